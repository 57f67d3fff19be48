"""Nacelle scenes (campaign/nacelle_scene.py, campaign/nacelle.py): validation, round trip, a small run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cwlidar_sim.campaign import bundled_scene, loads_scene, read_results, run_scene
from cwlidar_sim.campaign.nacelle_scene import NacelleScene

SMALL = """
name = "nac_small"
kind = "nacelle"
seed = 3
duration = 60.0
[scan]
half_angle_deg = 15.0
focus_distances = [40.0, 80.0]
rotor_radius = 20.0
spacing = 8.0
segment_duration = 15.0
k_min = 0.04
k_max = 0.3
n_k = 5
theory_beams = 4
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.1
length_scale = 20.0
gamma = 3.9
[[period]]
name = "p0"
mean_speed = 10.0
"""


def test_scene_round_trip_and_named_errors():
    s = loads_scene(SMALL)
    assert isinstance(s, NacelleScene) and s.unit_names() == ["p0"]
    assert NacelleScene.from_dict(s.as_dict()) == s
    bad = [("half_angle_deg = 15.0", "half_angle_deg = 70.0", "half_angle_deg"),
           ("focus_distances = [40.0, 80.0]", "focus_distances = [40.0, 40.0]", "distinct"),
           ("mean_speed = 10.0", "mean_speed = 1.0", "mean_speed"),
           ("segment_duration = 15.0", "segment_duration = 30.0", "3 coherence segments"),
           ('tier = "los"', 'tier = "fast"', "lidar.tier"),
           ("n_k = 5", "n_k = 5\nbogus = 1", "bogus")]
    for old, new, msg in bad:
        assert old in SMALL
        with pytest.raises((ValueError, TypeError), match=msg):
            loads_scene(SMALL.replace(old, new))


def test_bundled_scene_is_listed_and_valid(capsys):
    from cwlidar_sim.cli import main

    s = bundled_scene("nacelle", quick=True)
    assert s.kind == "nacelle" and all(s.period_duration(p) == 300.0 for p in s.periods)
    assert main(["scenes"]) == 0
    assert "nacelle" in capsys.readouterr().out


def test_small_run_writes_units_and_physics(tmp_path):
    ds = run_scene(loads_scene(SMALL), tmp_path, progress=False)
    back = read_results(tmp_path / "nac_small.nc")
    assert back.coherence.dims == ("period", "focus", "estimate", "k")
    for v in ("coherence", "k_half", "preview_time", "coherence_theory", "wiener_gain", "rews_psd"):
        assert "units" in back[v].attrs, v
    np.testing.assert_allclose(back.preview_time.values[0], np.array([40.0, 80.0]) * math.cos(math.radians(15)) / 10)
    # tier 1 and the 'main' estimate are one thing at tier 'los'
    np.testing.assert_array_equal(ds.coherence.values[0, :, 0], ds.coherence.values[0, :, 1])
    coh = ds.coherence.values[0, :, 0]
    assert np.all(np.isfinite(coh)) and np.all((coh >= 0) & (coh <= 1))  # 1/15 Hz segments: k >= 0.042 rad/m
    th = ds.coherence_theory.values[0]
    # the preview decorrelates with k, more so from further away
    assert np.all(np.diff(th, axis=1) < 0) and np.all(th[1] < th[0])
    # the Wiener gain is |S_RL| / S_LL, i.e. sqrt(coherence S_RR / S_LL)
    np.testing.assert_allclose(ds.wiener_gain.values[0, :, 0],
                               np.sqrt(coh * ds.rews_psd.values[0] / ds.lidar_psd.values[0, :, 0]), rtol=1e-12)


def test_sweep_over_focus_half_angle_and_rotor_size_plans_tasks():
    """A campaign file sweeps a nacelle scene's keys like any scene's; each task is validated and estimated."""
    from cwlidar_sim.campaign.sweep import estimate_task, expand, loads_campaign

    spec = loads_campaign("""
name = "nac_sweep"
seed = 1
base = "nacelle"
[set]
duration = 300.0
[[sweep]]
"scan.focus_distances" = [[50.0], [150.0]]
[[sweep]]
"scan.half_angle_deg" = [10.0, 20.0]
[[sweep]]
"scan.rotor_radius" = [40.0, 80.0]
""")
    tasks = expand(spec)
    assert len(tasks) == 8 and all(t.scene.kind == "nacelle" for t in tasks)
    est = {(t.scene.scan.focus_distances[0], t.scene.scan.half_angle_deg, t.scene.scan.rotor_radius):
           estimate_task(t.scene) for t in tasks}
    assert all(e["seconds"] > 0 and e["memory_bytes"] > 1e8 for e in est.values())
    # a farther focus needs a longer box, a bigger rotor a wider one
    assert est[150.0, 10.0, 40.0]["memory_bytes"] > est[50.0, 10.0, 40.0]["memory_bytes"]
    assert est[50.0, 10.0, 80.0]["memory_bytes"] > est[50.0, 10.0, 40.0]["memory_bytes"]
