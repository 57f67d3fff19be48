"""Conical scenes in the campaign layer: validation, units, resume, per-height results, CLI."""

import json

import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene, read_results, run_scene
from cwlidar_sim.campaign.scenes.conical import ConicalScene
from cwlidar_sim.cli import main

TEXT = """
name = "cone"
kind = "conical"
seed = 4
duration = 120.0
[scan]
heights = [40.0]
scan_revs = [1, 3]
[lidar]
tier = "los"
[[period]]
name = "a"
mean_speed = 8.0
[[period]]
name = "b"
mean_speed = 9.0
"""


def test_scene_validation_and_round_trip():
    sc = loads_scene(TEXT)
    assert isinstance(sc, ConicalScene) and sc.unit_names() == ["a_z40", "b_z40"]
    assert ConicalScene.from_dict(sc.as_dict()) == sc
    assert loads_scene(TEXT.replace("heights = [40.0]", "heights = [40.0, 60.0]")).unit_names() == \
        ["a_z40", "a_z60", "b_z40", "b_z60"]
    for bad, match in [
        (TEXT.replace("scan_revs = [1, 3]", "scan_revs = [1, 3]\nfoo = 1"), r"unknown key\(s\) in scan: \['foo'\]"),
        (TEXT.replace("tier = \"los\"", "tier = \"los\"\nfoo = 1"), r"unknown key\(s\) in lidar: \['foo'\]"),
        (TEXT.replace("tier = \"los\"", "tier = \"los\"\ncnr_db = 500.0"), r"lidar.cnr_db=500.0 is out of range"),
        (TEXT.replace("scan_revs = [1, 3]", "scan_revs = [1, 3]\ntier = \"los\""), r"scan.lidar and scan.tier moved"),
        (TEXT.replace("seed = 4", "seed = 4\ncolour = 1"), r"unknown key\(s\) in conical scene: \['colour'\]"),
        (TEXT.replace("heights = [40.0]", "heights = [5.0]"), r"heights\[0\]=5.0 m needs focus"),
        (TEXT.replace("scan_revs = [1, 3]", "scan_revs = [0]"), r"scan.scan_revs\[0\]"),
        (TEXT.replace("[scan]", "[scan]\nhalf_angle_deg = 80.0"), "half_angle_deg"),
        (TEXT.replace('kind = "conical"', 'kind = "orbital"'), "kind"),
        (TEXT.replace("duration = 120.0", "duration = 5.0"), "duration"),
    ]:
        with pytest.raises(ValueError, match=match):
            loads_scene(bad)


@pytest.fixture(scope="module")
def cone(tmp_path_factory):
    out = tmp_path_factory.mktemp("cone")
    return run_scene(loads_scene(TEXT), out, progress=False), out


def test_per_height_results_are_the_selected_periods_mean(cone):
    ds, out = cone
    assert ds.std_ratio.dims == ("height", "scan_s") and list(ds.height.values) == [40.0]
    for var in ("std_ratio", "std_ratio_model", "radial_variance_ratio", "radial_variance_ratio_model",
                "mean_speed_bias", "scan_availability"):
        assert ds[var].attrs["units"] == "1", var
    units = ds.std_ratio_unit.values  # (period, scan_s)
    keep = ds.selected_unit.values > 0.5
    for j in range(2):
        x = units[keep[:, j], j]
        assert ds.std_ratio.values[0, j] == pytest.approx(x.mean(), rel=1e-12)
        if x.size > 1:
            assert ds.std_ratio_sigma.values[0, j] == pytest.approx(x.std(ddof=1) / np.sqrt(x.size), rel=1e-12)
    # a period that fails CS's selection (points used < 65 %) leaves the height's mean
    from cwlidar_sim.campaign.periods.conical import summarise

    raw = ds[[v for v in ds.data_vars if v.endswith("_unit")]]
    raw = raw.rename({v: v[:-5] for v in raw.data_vars}).drop_dims(["height"], errors="ignore")
    sel = raw.selected.values.copy()
    sel[1, 0] = 0.0
    again = summarise(raw.assign(selected=(("period", "scan_s"), sel)))
    assert again.std_ratio.values[0, 0] == units[0, 0] and again.n_selected.values[0, 0] == 1
    assert again.std_ratio.values[0, 1] == pytest.approx(units[:, 1].mean(), rel=1e-12)
    # each unit's ratio is its lidar std over its cup std
    np.testing.assert_allclose(units, ds.lidar_std_unit.values / ds.cup_std_unit.values[:, None], rtol=1e-12)
    assert ds.n_periods.values[0] == 2


def test_conical_units_resume_and_same_bits(cone, monkeypatch):
    ds, out = cone
    from cwlidar_sim.campaign.periods import conical

    calls = []
    real = conical.run_unit
    monkeypatch.setattr(conical, "run_unit", lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    again = run_scene(loads_scene(TEXT), out, progress=False)
    assert calls == [] and json.loads(again.attrs["periods_reused"]) == ["a_z40", "b_z40"]
    fresh = run_scene(loads_scene(TEXT), None, progress=False)
    assert calls == [0, 1]
    np.testing.assert_array_equal(fresh.std_ratio.values, ds.std_ratio.values)
    np.testing.assert_array_equal(fresh.tp_unit.values, ds.tp_unit.values)


def test_cli_runs_a_conical_scene_file(tmp_path, capsys):
    f = tmp_path / "cone.toml"
    f.write_text(TEXT.replace('[[period]]\nname = "b"\nmean_speed = 9.0\n', ""))
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--no-progress", "--figures"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["results"].endswith("cone.nc") and summary["scan_s"] == [1.0, 3.0]
    # the scene's wind (default: toward the lidar's +x, east) in the meteorological convention: a westerly
    assert summary["wind_from_deg"] == {"a": 270.0}
    assert {p.rsplit("/", 1)[-1] for p in summary["figures"]} == {
        "cs_std_ratio.png", "cs_std_scatter.png", "cs_mean_speed.png", "cs_radial_variance.png"}
    ds = read_results(out / "cone.nc")
    assert ds.attrs["sensor"] == "conical" and "std_ratio" in ds


def test_turbulence_the_wind_cannot_carry_is_refused():
    """sigma_u / U <= 0.5: a fixed tensor per period; the surface layer's c kappa / ln(z / z0) per height."""
    from cwlidar_sim.turbulence.limits import longitudinal_std
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    rough = TEXT.replace("[lidar]", "[turbulence]\nz0 = 2.0\n[lidar]")
    # 14 m over z0 = 2 m: 2.4 x 0.4 / ln 7 = 0.49, accepted; 12 m: 0.54, refused
    assert loads_scene(rough.replace("heights = [40.0]", "heights = [14.0]")).scan.heights == (14.0,)
    with pytest.raises(ValueError, match=r"scan.heights: 12 m over turbulence.z0 = 2 m .* sigma_u/U = 0.54"):
        loads_scene(rough.replace("heights = [40.0]", "heights = [12.0, 40.0]"))
    # the closed form is the tensors' own: IEC's target, and Mann's fit below it
    for source, bound in (("iec", 1.0), ("mann1994", 2.24 / 2.4)):
        p, su, _ = surface_layer_parameters(12.0, 8.0, z0=2.0, source=source)
        assert su / 8.0 == pytest.approx(bound * 2.4 * 0.4 / np.log(6.0), rel=2e-3)
    assert longitudinal_std(surface_layer_parameters(12.0, 8.0, z0=2.0)[0]) / 8.0 < 0.5
    fixed = TEXT.replace("[lidar]", "[turbulence]\nsource = 'fixed'\nalpha_eps = 0.5\nlength_scale = 20.0\n"
                                    "gamma = 3.9\n[lidar]")  # sigma_u = 2.86 m/s
    loads_scene(fixed.replace("mean_speed = 8.0", "mean_speed = 6.0"))  # 0.48
    with pytest.raises(ValueError, match=r"period\[0\] \('a'\): the tensor alpha_eps=0.5 .* sigma_u/U = 0.57"):
        loads_scene(fixed.replace("mean_speed = 8.0", "mean_speed = 5.0"))


def test_a_run_stored_before_the_theory_default_is_computed_again(tmp_path, monkeypatch):
    """Results version 8 stored a conical period without the theory (then off by default; and 'continuum' carried the
    lattice): resuming such a run with this version must not reuse its periods beside new ones that carry the
    theory (the combined file would mix units with and without *_theory); they are computed again, all alike."""
    from cwlidar_sim.campaign.execution import store
    from cwlidar_sim.campaign.periods import conical, conical_theory

    monkeypatch.setattr(conical_theory, "N_START", 5)  # the theory's plumbing, not its convergence
    monkeypatch.setattr(conical_theory, "TOL", 2e-2)
    text = TEXT.replace("duration = 120.0", "duration = 60.0")
    real = conical.run_unit

    def as_version_8(*a, **k):  # a period as results version 8 wrote it: no theory variables
        ds = real(*a, **k)
        return ds.drop_vars([v for v in ds.data_vars if "theory" in v]).assign_attrs(results_version=8)

    with monkeypatch.context() as m:
        m.setattr(store, "RESULTS_VERSION", 8)
        m.setattr(conical, "run_unit", as_version_8)
        old = run_scene(loads_scene(text), tmp_path, progress=False)
    assert "std_ratio_theory_unit" not in old
    (tmp_path / "cone.periods" / "001_b_z40.nc").unlink()  # interrupted after its first period
    calls = []
    monkeypatch.setattr(conical, "run_unit", lambda *a, **k: calls.append(a[1]) or real(*a, **k))
    ds = run_scene(loads_scene(text), tmp_path, progress=False)
    assert calls == [0, 1] and json.loads(ds.attrs.get("periods_reused", "[]")) == []
    assert np.all(np.isfinite(ds.std_ratio_theory_unit.values)) and ds.attrs["results_version"] != 8
