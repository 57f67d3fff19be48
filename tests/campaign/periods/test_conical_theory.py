"""The linear theory beside a conical scene's simulation and instead of it (campaign/periods/conical_theory.py)."""

import dataclasses
import json
import math

import numpy as np
import pytest

from cwlidar_sim.campaign.execution.reproduce import bundled_scene
from cwlidar_sim.campaign.periods import conical, conical_theory as ct
from cwlidar_sim.sensors import Cup


@pytest.fixture
def few_k1(monkeypatch):
    """A coarser grid: these tests compare the theory with itself, not its convergence (stated in the module)."""
    monkeypatch.setattr(ct, "N_START", 5)
    monkeypatch.setattr(ct, "TOL", 2e-2)


def _scene(theory, tier="los", duration=60.0, **lidar):
    cs = bundled_scene("cs")
    return cs.replace(scan=dataclasses.replace(cs.scan, heights=(40.0,), periods_per_height=(), theory=theory),
                      periods=cs.periods[:1], lidar=dataclasses.replace(cs.lidar, tier=tier, **lidar),
                      duration=duration)


def test_theory_only_equals_the_theory_beside_a_simulated_run(few_k1):
    """theory = 'only' writes, in the simulated variables' places, the *_theory of a simulated tier-los run of the same
    scene (a theory that does not depend on the box's cells or seed), and its attributes say it is the theory's."""
    alone = conical.summarise(conical.run_unit(_scene("only"), 0))
    sim = conical.summarise(conical.run_unit(_scene("continuum"), 0))
    np.testing.assert_allclose(alone.std_ratio.values, sim.std_ratio_theory.values, rtol=1e-12)
    np.testing.assert_allclose(alone.std_ratio_theory.values, sim.std_ratio_theory.values, rtol=1e-12)
    np.testing.assert_allclose(alone.cup_std_unit.values, sim.cup_std_theory_unit.values, rtol=1e-12)
    assert "theory" in alone.attrs["answer"] and "answer" not in sim.attrs
    assert np.all(np.isnan(alone.std_ratio_sigma.values)) and np.all(np.isnan(alone.tp.values))
    a = sim.std_ratio_theory.attrs
    assert a["theory_box"].startswith("continuum") and a["theory_weighting"] == "exact"
    assert json.loads(a["theory_tensor"])["length_scale"] == pytest.approx(0.59 * 40.0)
    # the simulation itself: a 60-s period of tier los about the theory (one period's scatter is ~0.05-0.1)
    assert abs(float(sim.std_ratio[0, 0]) - float(sim.std_ratio_theory[0, 0])) < 0.25
    assert 0.6 < float(sim.std_ratio_theory[0, 0]) < 0.95


def test_cup_response_and_mean_removal_enter_the_theory(few_k1):
    """Physics: a slower cup (distance constant 20 m against 2.3 m) reads a smaller sigma and raises the ratio; a
    shorter period removes more of the low wavenumbers with its own mean, lowering both sigmas; the 3-revolution scan
    averages three 1-revolution fits, lowering the lidar's sigma."""
    scene = _scene("continuum")
    lidar, z = ct.scene_lidar(scene, 0, 2.0)
    params = scene.turbulence.params(z, 8.0)

    def run(T, dc):
        return ct.unit_theory(lidar, z, 8.0, T, params, (1, 3), Cup(position=(0.0, 0.0, z), distance_constant=dc))

    fast, slow, short = run(600.0, 2.3), run(600.0, 20.0), run(60.0, 2.3)
    assert slow["cup_std"] < 0.97 * fast["cup_std"]
    assert slow["scans"][1]["std_ratio"] > 1.03 * fast["scans"][1]["std_ratio"]
    assert short["cup_std"] < 0.9 * fast["cup_std"] and short["scans"][1]["lidar_std"] < 0.9 * fast["scans"][1]["lidar_std"]
    assert fast["scans"][3]["lidar_std"] < fast["scans"][1]["lidar_std"]


def test_theory_only_refuses_what_it_cannot_answer():
    with pytest.raises(ValueError, match=r"scan.theory = 'only'.*lidar.tier = 'spectral'"):
        _scene("only", tier="spectral")
    with pytest.raises(ValueError, match=r"lidar.variants"):
        _scene("only", variants=({"name": "raise10", "threshold_raise_percent": 10.0},))
    with pytest.raises(ValueError, match=r"scan.theory"):
        _scene("box")


def test_theory_none_is_spelled_and_needs_no_dwell():
    """``theory = "none"`` (a TOML file cannot write None) is the default's behaviour: accepted in cycle mode, where
    the theory is refused."""
    from cwlidar_sim.campaign.scenes.conical import ScanSpec

    assert ScanSpec(heights=(40.0, 60.0), cycle=True, revs_per_height=3, theory="none").theory == "none"
    with pytest.raises(ValueError, match=r"scan.theory = 'continuum' needs scan.cycle = false"):
        ScanSpec(heights=(40.0, 60.0), cycle=True, revs_per_height=3, theory="continuum")
    with pytest.raises(ValueError, match=r"scan.theory"):
        ScanSpec(theory="off")


def _speeds_scene(speeds, theory=None, duration=60.0, **scan):
    """The CS scene at 40 m, tier los, one period per speed (direction 0)."""
    from cwlidar_sim.campaign.scenes.conical import ConicalPeriodSpec

    cs = bundled_scene("cs")
    periods = tuple(ConicalPeriodSpec(name=f"u{i}", mean_speed=float(u)) for i, u in enumerate(speeds))
    return cs.replace(scan=dataclasses.replace(cs.scan, heights=(40.0,), periods_per_height=(), theory=theory, **scan),
                      periods=periods, lidar=dataclasses.replace(cs.lidar, tier="los"), duration=duration)


def test_theory_is_on_by_default_and_the_lattice_asked_for():
    """A scene that names no theory carries the continuum (not the lattice, ~20 s more per unit: theory = 'lattice');
    a cycling scene, which the theory cannot take, carries none; the old spellings still parse."""
    from cwlidar_sim.campaign.scenes.conical import ScanSpec

    assert ScanSpec().theory is None and ScanSpec().theory_mode() == "continuum"
    assert ScanSpec(heights=(40.0, 60.0), cycle=True, revs_per_height=3).theory_mode() == "none"
    for spelled in ("none", "continuum", "lattice", "only"):
        assert ScanSpec(theory=spelled).theory_mode() == spelled
    calls = []
    import cwlidar_sim.campaign.periods.lattice_theory as lat

    real_c, real_l = ct.add_theory, lat.add_lattice_theory
    try:
        ct.add_theory = lambda *a, **k: calls.append("continuum")
        lat.add_lattice_theory = lambda *a, **k: calls.append("lattice")
        for theory, want in ((None, ["continuum"]), ("continuum", ["continuum"]), ("lattice", ["continuum", "lattice"]),
                             ("none", [])):
            calls.clear()
            conical.run_unit(_scene(theory), 0)
            assert calls == want, theory
    finally:
        ct.add_theory, lat.add_lattice_theory = real_c, real_l


def test_units_share_an_interpolant_in_u_only_where_a_group_has_many_speeds():
    """Units of one height, direction, duration and tensor shape share the interpolant where they have more distinct
    speeds than nodes (the CS scene's four per height are computed each); another direction or duration is another
    group."""
    assert all(v is None for v in ct.speed_ranges(bundled_scene("cs")).values())
    few = _speeds_scene(np.linspace(5.0, 12.0, ct.U_NODES))
    assert all(v is None for v in ct.speed_ranges(few).values())
    many = _speeds_scene(np.linspace(5.0, 12.0, ct.U_NODES + 1))
    assert set(ct.speed_ranges(many).values()) == {(5.0, 12.0)}
    from cwlidar_sim.campaign.scenes.conical import ConicalPeriodSpec

    turned = many.replace(periods=many.periods[:-1] + (ConicalPeriodSpec(name="t", mean_speed=12.0,
                                                                         wind_direction_deg=30.0),))
    assert all(v is None for v in ct.speed_ranges(turned).values())
    # wider than U_SPAN: pieces equally wide in ln U, each unit interpolated over its own
    wide = _speeds_scene(np.geomspace(3.0, 24.0, 2 * ct.U_NODES + 2))
    ranges = ct.speed_ranges(wide)
    cut = math.sqrt(3.0 * 24.0)
    for i, p in enumerate(wide.periods):
        lo, hi = ranges[i]
        assert lo <= p.mean_speed <= hi and hi / lo <= ct.U_SPAN * (1 + 1e-12)
        assert (lo, hi) == pytest.approx((3.0, cut) if p.mean_speed < cut else (cut, 24.0))


def test_interpolated_unit_says_so(few_k1):
    """A unit whose theory is interpolated in U carries theory_u_nodes = U_NODES, its values those of
    interpolated_theory over its group's speeds, and the attributes state the scheme and its error."""
    scene = _speeds_scene(np.linspace(5.0, 12.0, ct.U_NODES + 1), theory="only")
    ds = conical.run_unit(scene, 2)
    lidar, z = ct.scene_lidar(scene, 2, 1.0)
    want = ct.interpolated_theory(lidar, z, float(scene.periods[2].mean_speed), 60.0,
                                  scene.turbulence.params(z, float(scene.periods[2].mean_speed)), (1, 3),
                                  Cup(position=(0.0, 0.0, z)), (5.0, 12.0))
    assert int(ds.theory_u_nodes[0]) == ct.U_NODES
    np.testing.assert_allclose(ds.std_ratio_theory.values[0], [want["scans"][n]["std_ratio"] for n in (1, 3)],
                               rtol=1e-12)
    assert "Chebyshev-Lobatto" in ds.theory_u_nodes.attrs["theory_u"]
    assert json.loads(ds.std_ratio_theory.attrs["theory_u"].split(": ", 1)[1])["max_error_std_ratio"] > 0
    direct = conical.run_unit(_speeds_scene([5.0, 8.0], theory="only"), 0)
    assert int(direct.theory_u_nodes[0]) == 0


def test_interpolation_in_u_moves_the_ratios_less_than_stated():
    """The production numerics: the interpolant over 5-13 m/s at 100 m against the theory computed at off-node
    speeds (the widest gaps, mid-range) and at the ends (nodes: exact), for the 1- and 3-revolution scans."""
    cs = bundled_scene("cs")
    i = next(k for k, (p, z) in enumerate(cs.units()) if z == 100.0 and p.toward_deg == 0.0)
    lidar, z = ct.scene_lidar(cs, i, 1.0)
    cup = Cup(position=(0.0, 0.0, z))
    nodes = ct.u_nodes(5.0, 13.0)
    assert nodes[0] == pytest.approx(5.0) and nodes[-1] == pytest.approx(13.0)
    mid = ct.U_NODES // 2
    bound = ct.U_INTERPOLATION["max_error_std_ratio"]
    assert bound < 1e-3
    for U in (math.sqrt(nodes[mid - 1] * nodes[mid]), math.sqrt(nodes[mid] * nodes[mid + 1])):
        params = cs.turbulence.params(z, U)
        direct = ct.unit_theory(lidar, z, U, 600.0, params, (1, 3), cup)
        got = ct.interpolated_theory(lidar, z, U, 600.0, params, (1, 3), cup, (5.0, 13.0))
        for n in (1, 3):
            assert abs(got["scans"][n]["std_ratio"] - direct["scans"][n]["std_ratio"]) < bound, (U, n)
        assert got["cup_std"] == pytest.approx(direct["cup_std"], rel=1e-3)


def test_auto_answers_a_tier_los_scene_by_the_theory_and_says_why(few_k1):
    """``theory = "auto"``: a tier-los scene without variants is answered by the theory alone, the results saying
    so (``answer``) and why (``auto_choice``); a scene asking for the estimator or variants is simulated with the
    theory beside it; a cycling one has none."""
    from cwlidar_sim.campaign import run_scene
    from cwlidar_sim.campaign.scenes.conical import ScanSpec

    ds = run_scene(_scene("auto"), None, progress=False)
    assert "theory" in ds.attrs["answer"]
    why = json.loads(ds.attrs["auto_choice"])["scan.theory"]
    assert why.startswith("only: ") and "tier los" in why
    assert np.all(np.isfinite(ds.std_ratio.values)) and np.all(ds.std_ratio.values == ds.std_ratio_theory.values)
    choice, why = _scene("auto", tier="spectral").resolve_theory()
    assert choice == "continuum" and "lidar.tier = 'spectral'" in why
    choice, why = _scene("auto", variants=({"name": "raise10", "threshold_raise_percent": 10.0},)).resolve_theory()
    assert choice == "continuum" and "lidar.variants" in why
    cyc = _scene(None).replace(scan=ScanSpec(heights=(40.0, 60.0), cycle=True, revs_per_height=3, theory="auto"))
    assert cyc.resolve_theory()[0] == "none"
    assert _scene("continuum").resolve_theory() == ("continuum", "")
