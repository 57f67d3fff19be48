"""The linear theory beside a conical scene's simulation and instead of it (campaign/periods/conical_theory.py)."""

import dataclasses
import json

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
        _scene("lattice")


def test_theory_none_is_spelled_and_needs_no_dwell():
    """``theory = "none"`` (a TOML file cannot write None) is the default's behaviour: accepted in cycle mode, where
    the theory is refused."""
    from cwlidar_sim.campaign.scenes.conical import ScanSpec

    assert ScanSpec(heights=(40.0, 60.0), cycle=True, revs_per_height=3, theory="none").theory == "none"
    with pytest.raises(ValueError, match=r"scan.theory = 'continuum' needs scan.cycle = false"):
        ScanSpec(heights=(40.0, 60.0), cycle=True, revs_per_height=3, theory="continuum")
    with pytest.raises(ValueError, match=r"scan.theory"):
        ScanSpec(theory="off")
