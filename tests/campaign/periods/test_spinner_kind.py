"""The spinner scene kind (campaign/kinds/spinner.py): the bundled scene, its checks, `run` end to end, resume."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene, read_results
from cwlidar_sim.campaign import registry
from cwlidar_sim.campaign.execution.reproduce import bundled_scene, bundled_text
from cwlidar_sim.campaign.scenes.spec import RESULTS_VERSION
from cwlidar_sim.campaign.scenes.spinner import SpinnerScene
from cwlidar_sim.cli import main


def small_text(**edits):
    """The bundled scene made small: 6 s periods (3 rosettes), a coarse box, tier 1."""
    text = bundled_text("spinner")
    text = text.replace("duration = 600.0", "duration = 6.0").replace('tier = "spectral"', 'tier = "los"')
    text = text.replace("spacing = 4.0", "spacing = 8.0")
    for old, new in edits.items():
        assert old in text
        text = text.replace(old, new)
    return text


def test_the_bundled_scene_is_the_published_instrument_and_its_kind_is_registered():
    scene = bundled_scene("spinner")
    kind = registry.kind_of(scene)
    assert kind.name == "spinner" and "spinner" in registry.kind_names() and isinstance(scene, SpinnerScene)
    lid = scene.sensor(scene.periods[0])
    assert lid.rosette_time == 2.0 and lid.estimates_per_rosette == 984 and lid.max_off_axis_deg == pytest.approx(30.4)
    assert lid.instrument.name == "dtu-spinnerlidar" and lid.rotor_rpm == 16.0 and lid.tilt_deg == 5.0
    quick = kind.quick(scene)
    assert quick.duration == 20.0 and all(p.duration is None for p in quick.periods)
    assert bundled_scene("spinner", quick=True) == quick
    assert loads_scene(bundled_text("spinner")).as_dict() == scene.as_dict()
    assert scene.with_values({"scan.focus_distance": 120.0}).sensor(scene.periods[0]).focus_distance == 120.0


@pytest.mark.parametrize("old,new,match", [
    ("prism_rate_hz = [3.5, -6.5]", "prism_rate_hz = [3.5, -6.4999]", r"scan\.prism_rate_hz\[1\]=-6.4999"),
    ("focus_distance = 80.0", "focus_distance = 2.0", r"scan\.focus_distance"),
    ("blade_plane_distance = 2.0", "blade_plane_distance = 15.0\nhub_radius_x = 1", r"unknown key.*hub_radius_x"),
    ("rotor_rpm = 16.0\n\n[[period]]\nname = \"yawed\"", "rotor_rpm = 160.0\n\n[[period]]\nname = \"yawed\"",
     r"period\[0\] \('aligned'\).*rotor_rpm"),
    ("duration = 6.0", "duration = 1.0", r"duration"),
])
def test_bad_scenes_are_refused_by_name(old, new, match):
    with pytest.raises((ValueError, TypeError), match=match):
        loads_scene(small_text(**{old: new}))


def test_focus_behind_the_blades_is_refused_by_name():
    text = small_text(**{"focus_distance = 80.0": "focus_distance = 12.0",
                         "blade_plane_distance = 2.0": "blade_plane_distance = 11.0"})
    with pytest.raises(ValueError, match=r"SpinnerLidar of period\[0\] \('aligned'\): scan\.focus_distance=12 m .*"
                                         r"behind the blades"):
        loads_scene(text)


def test_run_end_to_end_with_figures_and_resume(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(small_text())
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--figures", "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["periods_reused"] == [] and set(summary["per_period"]) == {"aligned", "yawed", "evolving"}
    ds = read_results(out / "spinner.nc")
    assert ds.attrs["sensor"] == "spinner" and ds.rews.dims == ("period", "estimate", "rosette")
    assert ds.rosette.size == 3 and list(ds.estimate.values) == ["tier1", "main", "median"]
    # the blades block the same share in every period (they turn with the prisms), as the sensor says
    lid = bundled_scene("spinner").sensor(bundled_scene("spinner").periods[0])
    t = (np.arange(984) + 0.5) * lid.dwell_time
    off = ((np.arange(4) + 0.5) / 4 - 0.5) * lid.dwell_time
    frac = lid.blocked(t[:, None] + off).mean(axis=1)
    assert np.all(ds.n_blocked.values == 3 * np.count_nonzero(frac > 0.5))
    # tier 1 in Mann turbulence: the REWS estimate follows the rotor's within a fraction of a m/s (frozen periods)
    j = list(ds.estimate.values).index("tier1")
    assert np.all(ds.rews_rmse.values[:2, j] < 0.3) and np.all(np.isfinite(ds.horizontal_shear.values[:, j]))
    # the yaw estimate follows the rotor's yaw from the disc-averaged wind (the set yaw less the turbulent
    # wind's direction), within several degrees per rosette (the wind is not linear over the disc, and a yawed
    # rosette's air passes ~14 m beside the hub)
    err = ds.yaw_estimate.values[:2, j] - ds.yaw_rotor.values[:2]
    assert np.abs(err).mean() < 5.0 and np.abs(err).max() < 12.0
    assert np.all(ds.condition.values[:, 0] < 3.0) and np.all(ds.condition.values[:, 1] > 20.0)
    assert all((out / f"spinner_{n}_period{i}.png").is_file() for n in ("rews", "inflow") for i in range(3))
    # resume: every period reused, the same bits
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["periods_reused"] == ["aligned", "yawed", "evolving"]
    assert read_results(out / "spinner.nc").rews.equals(ds.rews)
    # the bundled scene by name, as `run nacelle` finds its own
    assert registry.get_kind("spinner").estimate_unit(bundled_scene("spinner"), 0)["seconds"] > 0
    assert math.isfinite(registry.get_kind("spinner").estimate_bytes(bundled_scene("spinner")))


def test_run_finds_the_bundled_scene_by_name(tmp_path, capsys, monkeypatch):
    """`run spinner` resolves the bundled file (its quick form is too slow for here: a stub unit answers)."""
    import xarray as xr

    from cwlidar_sim.campaign.periods import spinner as periods

    seen = []

    def fake(scene, index, params=None, *, status=None):
        seen.append((scene.name, scene.periods[index].name, scene.duration))
        return xr.Dataset({"rews_rmse": (("period", "estimate"), [[0.1]]), "rews_bias": (("period", "estimate"), [[0.0]]),
                           **{k: (("period", "estimate", "rosette"), [[[0.0]]]) for k in ("yaw_estimate",
                                                                                         "vertical_shear", "veer")}},
                          coords={"period": [scene.periods[index].name], "estimate": ["tier1"], "rosette": [0]},
                          attrs={"sensor": "spinner", "scene": json.dumps(scene.as_dict()), "results_version": RESULTS_VERSION,
                                 "period_index": index})

    monkeypatch.setattr(periods, "run_unit", fake)
    assert main(["run", "spinner", "--out", str(tmp_path / "b"), "--no-progress"]) == 0
    assert [s[1] for s in seen] == ["aligned", "yawed", "evolving"] and seen[0][2] == 600.0
    capsys.readouterr()


def test_calm_air_the_rosettes_return_the_rotors_rews_and_the_yaw(tmp_path):
    """Turbulence all but off: every period's tier-1 REWS is the rotor's ``U cos gamma`` and the yaw its own."""
    from cwlidar_sim.campaign.periods.spinner import run_unit

    scene = loads_scene(small_text(**{"alpha_eps = 0.1": "alpha_eps = 1e-12"}))
    for i, p in enumerate(scene.periods):
        ds = run_unit(scene, i)
        j = list(ds.estimate.values).index("tier1")
        g = math.radians(p.yaw_misalignment_deg)
        np.testing.assert_allclose(ds.rews_rotor.values[0], p.mean_speed * math.cos(g), atol=1e-4)
        np.testing.assert_allclose(ds.rews.values[0, j], p.mean_speed * math.cos(g), atol=1e-4)
        np.testing.assert_allclose(ds.yaw_estimate.values[0, j], p.yaw_misalignment_deg, atol=1e-3)
        np.testing.assert_allclose(ds.yaw_rotor.values[0], p.yaw_misalignment_deg, atol=1e-3)
        np.testing.assert_allclose(ds.vertical_shear.values[0, j], 0.0, atol=1e-5)
        assert abs(float(ds.rews_bias.values[0, j])) < 1e-4
        # the preview: the probe's mean upwind distance (80 m at 0-30.4 deg off the axis) over U
        assert 80.0 * math.cos(math.radians(30.4)) / p.mean_speed < float(ds.preview_time.values[0]) < 8.0
