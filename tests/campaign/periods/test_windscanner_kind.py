"""The windscanner scene kind end to end: the bundled scene found by name, run (quick) with figures, resumed,
its refusals named; a plugin's files and one line in BUILTIN_KINDS."""

import json

import numpy as np
import pytest

from cwlidar_sim._bundled import bundled_or_path
from cwlidar_sim.campaign import loads_scene, registry
from cwlidar_sim.cli import main
from kind_scenes import WINDSCANNER

SCENE = WINDSCANNER


def test_the_bundled_scene_is_found_by_name_and_is_a_windscanner():
    path = bundled_or_path("windscanner", "scene")
    with open(path, encoding="utf-8") as f:
        scene = loads_scene(f.read())
    kind = registry.kind_of(scene)
    assert kind.name == "windscanner" and registry.check_kind(kind, "windscanner") is kind
    assert "windscanner" in registry.kind_names()
    quick = kind.quick(scene)
    assert {quick.period_duration(p) for p in quick.periods} == {30.0}
    assert quick.scanner.segment_duration == 10.0 and quick.scanner == scene.scanner.__class__(
        **{**scene.scanner.__dict__, "segment_duration": 10.0})
    # the published layout: three beams at 56.5, 51.7 and 56.4 deg elevation, a mean range of 125 m
    ws = scene.sensor()
    n = ws.directions()[0]
    np.testing.assert_allclose(np.degrees(np.arcsin(n[:, 2])), [56.5, 51.7, 56.4], atol=1e-9)
    assert abs(ws.ranges().mean() - 125.0) < 1e-3


def test_run_quick_with_figures_and_resume(tmp_path, capsys):
    from cwlidar_sim.campaign import read_results

    path = tmp_path / "ws.toml"
    path.write_text(SCENE)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--figures", "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["periods_reused"] == []
    row = summary["windscanner"]["a"]
    assert row["condition_max"] == pytest.approx(2.654, abs=1e-3)
    ds = read_results(out / "ws.nc")
    assert ds.attrs["sensor"] == "windscanner" and ds.transfer_cross.dims == ("period", "estimate", "component", "k")
    assert (out / "windscanner_transfer_a.png").is_file()
    # the probe volumes (z_R ~ 19 m at 125 m) average the turbulence: every component's std below the sonic's
    j = list(ds.estimate.values).index("tier1")
    ratio = ds.wind_std.values[0, j] / ds.sonic_std.values[0]
    assert np.all((ratio > 0.2) & (ratio < 1.0)), ratio
    # the mean wind comes back; nothing ill-conditioned in the published layout
    np.testing.assert_allclose(ds.wind_mean.values[0, j], [8.0, 0.0, 0.0], atol=0.5)
    assert int(ds.n_ill_conditioned.values[0, j]) == 0 and float(ds.availability.values[0, j].min()) == 1.0
    assert np.isfinite(ds.transfer_cross.values[0, j]).any()
    # resume: the period reused, the same bits
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 0
    assert json.loads(capsys.readouterr().out)["periods_reused"] == ["a"]
    assert read_results(out / "ws.nc").wind_std.equals(ds.wind_std)


def test_a_lissajous_period_reconstructs_but_has_no_sonic_transfer():
    text = SCENE.replace("[scanner]", '[scanner]\npattern = "lissajous"\npoints_per_pattern = 64\namplitude = 5.0')
    scene = loads_scene(text)
    ds = registry.kind_of(scene).run_unit(scene, 0)
    assert np.all(np.isnan(ds.transfer_ratio.values)) and np.all(np.isnan(ds.wind_rmse.values))
    assert float(ds.availability.values.min()) == 1.0
    assert float(ds.condition_min.values[0]) < float(ds.condition_max.values[0])


@pytest.mark.parametrize("change, match", [
    (("[scanner]", "[scanner]\nunit_height = 200.0"), r"scanner.unit_height=200.0 m is not below the target"),
    (("[scanner]", "[scanner]\npositions = [[-50.0, 0.0, 113.067], [50.0, 0.0, 113.067], [0.0, 40.0, 113.067]]"),
     r"windscanner scene: scanner: positions: the three beams are coplanar"),
    (("[scanner]", "[scanner]\ntarget = [0.0, 0.0, 900.0]"), r"windscanner scene: scanner: target: .*never meet"),
    (("[scanner]", "[scanner]\nelevation_deg = [50.0, 50.0, 50.0]"), r"elevation_deg"),
    (("[scanner]", "[scanner]\npattern = \"lissajous\"\nlissajous_ratio = [3, 0]"), r"lissajous_ratio\[1\]"),
    (("[scanner]", "[scanner]\nmax_condition = 0.5"), r"scanner.max_condition"),
    (("duration = 30.0", "duration = 20.0"), r"period\[0\] \('a'\) lasts 20 s, shorter than 3 segments"),
])
def test_bad_scenes_are_refused_by_name(change, match):
    with pytest.raises((ValueError, TypeError), match=match):
        loads_scene(SCENE.replace(*change))
