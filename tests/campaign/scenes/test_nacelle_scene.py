"""Nacelle scenes (campaign/scenes/nacelle.py, campaign/periods/nacelle.py): validation, round trip, a small run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cwlidar_sim.campaign import bundled_scene, loads_scene, read_results, run_scene
from cwlidar_sim.campaign.scenes.nacelle import NacelleScene

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
    # the std ratio and correlation of the paired series, and the general linear theory's beside them
    for v in ("lidar_std", "rotor_std", "std_ratio", "correlation", "lidar_std_theory", "rotor_std_theory",
              "std_ratio_theory", "correlation_theory"):
        assert "units" in back[v].attrs, v
    assert "continuum" in back.std_ratio_theory.attrs["theory"] and "cells" in back.std_ratio_theory.attrs["theory"]
    np.testing.assert_allclose(ds.std_ratio_theory.values, ds.lidar_std_theory.values / ds.rotor_std_theory.values)
    np.testing.assert_array_equal(ds.std_ratio.values[0, :, 0], ds.std_ratio.values[0, :, 1])
    # each estimate kind's ratio and the rotor std it stores come from the same paired samples
    assert ds.rotor_std.dims == ds.std_ratio.dims == ("period", "focus", "estimate")
    np.testing.assert_array_equal(ds.std_ratio.values, ds.lidar_std.values / ds.rotor_std.values)
    th_r, sim_r = ds.std_ratio_theory.values[0], ds.std_ratio.values[0, :, 0]
    th_c, sim_c = ds.correlation_theory.values[0], ds.correlation.values[0, :, 0]
    # one 60-s period: the ratio scatters by ~0.1, the correlation less; the smaller scan circle (40 m) sees more
    assert np.all(np.abs(sim_r / th_r - 1.0) < 0.3) and np.all(np.abs(sim_c - th_c) < 0.15) and th_r[0] > th_r[1]
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
    from cwlidar_sim.campaign.execution.sweep import estimate_task, expand, loads_campaign

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


COHERENCE = """
name = "nac_coherence"
kind = "nacelle"
seed = 7
duration = 1260.0
[scan]
focus_distances = [100.0]
half_angle_deg = 15.0
rotor_radius = 60.0
spacing = 4.0
segment_duration = 60.0
k_min = 0.006
k_max = 0.3
n_k = 12
theory_beams = 8
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.1
length_scale = 33.6
gamma = 3.9
[[period]]
name = "frozen"
mean_speed = 12.0
"""


def test_simulated_coherence_is_the_analytic_one_within_its_sampling_error():
    # the bundled geometry (60 m rotor, 15 deg scan focused at 100 m, 4 m box, span 5 z_R) at
    # tier 1, frozen, 20 segments of 60 s: each bin's estimate against the analytic coherence as
    # the estimate sees it (the segments' Hann kernels and the bins), Fisher's z with the effective
    # number of averages (n_dof) and its bias 1 / (2 (n - 1)); 4 standard errors per bin
    ds = run_scene(loads_scene(COHERENCE), progress=False)
    th = ds.coherence_theory.values[0, 0]
    coh = ds.coherence.values[0, 0, 0]
    n = ds.n_dof.values[0]
    use = np.isfinite(coh) & (th > 0.01)
    s = 1 / np.sqrt(2 * (n[use] - 1))
    z = (np.arctanh(np.sqrt(coh[use])) - s * s - np.arctanh(np.sqrt(th[use]))) / s
    assert use.sum() >= 5 and np.all(np.abs(z) < 4), z
    # informative: the theory falls from near 1 to near 0 over the bins used
    assert th[use].max() > 0.85 and th[use].min() < 0.1


PLATFORM = """
[platform]
period = 7.0
surge = 1.5
pitch_deg = 3.0
phase_deg = { pitch_deg = 90.0 }
correction = true
"""


def test_platform_table_round_trips_reaches_the_lidar_and_rejects_bad_keys(tmp_path):
    s = loads_scene(SMALL + PLATFORM)
    assert NacelleScene.from_dict(s.as_dict()) == s and s.platform.correction
    assert loads_scene(SMALL).platform is None and "platform" not in loads_scene(SMALL).as_dict()
    lid = s.sensor(s.periods[0])
    m = lid.motion
    assert lid.motion_correction and m.time[0] <= 0.0 and m.time[-1] >= 60.0
    w = 2 * math.pi / 7.0
    np.testing.assert_allclose(m.surge, 1.5 * np.sin(w * m.time), atol=1e-12)
    np.testing.assert_allclose(m.pitch_deg, 3.0 * np.cos(w * m.time), atol=1e-12)
    np.testing.assert_array_equal(m.sway, 0.0)
    bad = [("surge = 1.5", "surge = 1.5\nbogus = 1", "bogus"),
           ("pitch_deg = 3.0", "pitch_deg = 30.0", "platform.pitch_deg"),
           ("phase_deg = { pitch_deg = 90.0 }", "phase_deg = { pitch = 90.0 }", "pitch"),
           ("period = 7.0", "period = 0.1", "platform.period"),
           ("correction = true", "correction = 1", "platform.correction"),
           ("surge = 1.5", 'surge = 1.5\ncsv = "m.csv"', "not both")]
    for old, new, msg in bad:
        assert old in PLATFORM
        with pytest.raises((ValueError, TypeError), match=msg):
            loads_scene(SMALL + PLATFORM.replace(old, new))
    # a CSV time series, resolved relative to the scene file
    from cwlidar_sim.campaign import load_scene

    (tmp_path / "sub").mkdir()
    t = np.arange(0.0, 62.0, 0.05)
    np.savetxt(tmp_path / "sub" / "motion.csv", np.column_stack([t, 0.5 * np.sin(t), 2.0 * np.cos(0.3 * t)]),
               delimiter=",", header="time,heave,yaw_deg", comments="")
    (tmp_path / "sub" / "nac.toml").write_text(SMALL + '[platform]\ncsv = "motion.csv"\n')
    m = load_scene(tmp_path / "sub" / "nac.toml").sensor(loads_scene(SMALL).periods[0]).motion
    np.testing.assert_allclose(m.heave, 0.5 * np.sin(t)) and np.testing.assert_allclose(m.yaw_deg, 2 * np.cos(0.3 * t))
    np.testing.assert_array_equal(m.surge, 0.0)
    (tmp_path / "sub" / "bad.csv").write_text("time,bob\n0,1\n100,1\n")
    (tmp_path / "sub" / "bad.toml").write_text(SMALL + '[platform]\ncsv = "bad.csv"\n')
    with pytest.raises(ValueError, match="bob"):
        load_scene(tmp_path / "sub" / "bad.toml")
    (tmp_path / "sub" / "gone.toml").write_text(SMALL + '[platform]\ncsv = "gone.csv"\n')
    with pytest.raises(ValueError, match="gone.csv"):
        load_scene(tmp_path / "sub" / "gone.toml")


def test_platform_motion_is_corrected_alike_in_every_estimate():
    # tier 'los': the chain's estimate is the tier-1 line-of-sight speed, so the campaign's tier-1 and
    # main u series are one with the correction (added to both) and without it
    from cwlidar_sim.campaign.periods.nacelle import _u_series, period_records

    surge_only = PLATFORM.replace("pitch_deg = 3.0\n", "")
    out = {}
    for corr in ("true", "false"):
        s = loads_scene(SMALL + surge_only.replace("correction = true", f"correction = {corr}"))
        _, t_e, recs, _ = period_records(s, 0)
        out[corr] = [_u_series(recs[40.0], k) for k in ("tier1", "main")]
        np.testing.assert_allclose(out[corr][0], out[corr][1], rtol=0, atol=1e-9)
    # surge alone leaves the beams' directions: the correction adds n . d' / n_x = d'_x, the
    # platform's speed 1.5 w cos(w t); the motion's speeds are central differences of samples h = 0.01 s
    # apart (relative error (w h)^2 / 6), interpolated to the looks ((w h)^2 / 8), averaged over the
    # 20-ms dwell ((w dt)^2 / 24)
    w, h, dt = 2 * math.pi / 7.0, 0.01, 0.02
    tol = 1.5 * w * ((w * h) ** 2 / 6 + (w * h) ** 2 / 8 + (w * dt) ** 2 / 24)
    np.testing.assert_allclose(out["true"][0] - out["false"][0], 1.5 * w * np.cos(w * t_e), rtol=0, atol=tol)
