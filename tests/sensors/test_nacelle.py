"""Nacelle lidar (sensors/nacelle.py): geometry against closed forms, the platform, blockage, the chain's tiers.

Uniform wind is exact for tier 1: every look's line-of-sight speed is ``n . (U, 0, 0)`` (minus the
lidar's own velocity along n), written here from the frame's definition, not from the sensor; a
revolution's least-squares fit then returns the wind in the nacelle frame,
``(U cos gamma, -U sin gamma, 0)``.  Tiers 2 and 3 return it to the estimator's scatter and bias.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis.rews import fit_uvw
from cwlidar_sim.sensors import NacelleLidar, PlatformMotion, measure_nacelle
from cwlidar_sim.turbulence.cover import plan_box
from cwlidar_sim.signal import Flag

U = 10.0


def calm_box(lid, duration, d=4.0):
    plan = plan_box(lid.box_region(d), U, duration, d, min_extent=0.0)
    (nx, ny, nz), (x0, y0, z0) = plan.shape, plan.origin
    z = np.zeros((nx, ny, nz), dtype=np.float32)
    return xr.Dataset({c: (("x", "y", "z"), z) for c in "uvw"},
                      coords={"x": x0 + d * np.arange(nx), "y": y0 + d * np.arange(ny), "z": z0 + d * np.arange(nz)})


def beam(a_deg, phi_deg, gamma_deg=0.0):
    """The beam in the field frame from the frame's definition: Rz(gamma) (-cos a, sin a cos phi, sin a sin phi)."""
    a, phi, g = math.radians(a_deg), np.radians(phi_deg), math.radians(gamma_deg)
    m = np.stack([-math.cos(a) * np.ones_like(phi), math.sin(a) * np.cos(phi), math.sin(a) * np.sin(phi)], -1)
    rz = np.array([[math.cos(g), -math.sin(g), 0.0], [math.sin(g), math.cos(g), 0.0], [0.0, 0.0, 1.0]])
    return m @ rz.T


def look_azimuths(lid, rec):
    off = ((np.arange(lid.sub_dwells) + 0.5) / lid.sub_dwells - 0.5) * 360.0 / lid.estimates_per_rev
    return rec.azimuth_e[:, None] + off[None, :]


def per_revolution_fit(rec, lid, los=None):
    los = rec.los_e if los is None else los
    key = rec.revolution_e * 100 + rec.focus_index_e
    return fit_uvw(los, rec.direction_ec, key)[1]


@pytest.mark.parametrize("gamma", [0.0, 12.0])
def test_uniform_wind_tier1_is_exact_yawed_or_not(gamma):
    lid = NacelleLidar(focus_distances=(50.0, 120.0), half_angle_deg=15.0, yaw_misalignment_deg=gamma,
                       refocus_time=0.3, revs_per_focus=2, azimuth0_deg=7.0)
    rec = measure_nacelle(calm_box(lid, 8.0), lid, 8.0, U)
    # two blocks of 2 revolutions per focus in 4 x 2 s + 3 x 0.3 s ... 8 s hold 3 blocks (6.9 s)
    assert rec.time_e.size == 3 * 100 and np.count_nonzero(rec.focus_index_e == 1) == 100
    want = (beam(15.0, look_azimuths(lid, rec), gamma) @ np.array([U, 0.0, 0.0])).mean(axis=1)
    np.testing.assert_allclose(rec.vlos_e, want, rtol=0, atol=1e-12)
    assert np.all(rec.flags_e == 0)
    np.testing.assert_array_equal(rec.speed_e, np.abs(rec.vlos_e))
    g = math.radians(gamma)
    np.testing.assert_allclose(per_revolution_fit(rec, lid), [[U * math.cos(g), -U * math.sin(g), 0.0]] * 6,
                               atol=1e-10)
    # the rotor-axis estimate (v = w = 0 assumed) averaged over a revolution is U cos gamma
    u_b = rec.los_e / rec.direction_ec[:, 0]
    for r in range(2):
        np.testing.assert_allclose(u_b[rec.revolution_e == r].mean(), U * math.cos(g), rtol=1e-12)


def test_fixed_beams_take_turns_and_are_exact():
    lid = NacelleLidar(focus_distances=(80.0,), beam_azimuths_deg=(45.0, 135.0, 225.0, 315.0), half_angle_deg=20.0,
                       estimates_per_rev=40, yaw_misalignment_deg=-8.0)
    rec = measure_nacelle(calm_box(lid, 2.0), lid, 2.0, U)
    np.testing.assert_array_equal(rec.azimuth_e[:8], [45.0, 135.0, 225.0, 315.0] * 2)
    want = beam(20.0, rec.azimuth_e, -8.0) @ np.array([U, 0.0, 0.0])
    np.testing.assert_allclose(rec.vlos_e, want, atol=1e-12)
    g = math.radians(-8.0)
    np.testing.assert_allclose(fit_uvw(rec.los_e, rec.direction_ec)[1][0], [U * math.cos(g), -U * math.sin(g), 0],
                               atol=1e-10)


def _motion(duration):
    t = np.linspace(-1.0, duration + 1.0, 801)
    w = 2 * math.pi / 7.0  # a 7 s platform period
    return PlatformMotion(time=t, surge=1.5 * np.sin(w * t), sway=0.4 * np.cos(w * t), heave=0.5 * np.sin(w * t + 1),
                          roll_deg=1.0 * np.sin(w * t), pitch_deg=3.0 * np.sin(w * t + 0.5), yaw_deg=0.5 * np.cos(w * t))


def test_platform_motion_los_and_its_correction():
    gamma, dur = 6.0, 4.0
    motion = _motion(dur)
    still = NacelleLidar(focus_distances=(60.0,), yaw_misalignment_deg=gamma, sub_dwells=2)
    moving = still.replace(motion=motion)
    corrected = still.replace(motion=motion, motion_correction=True)
    box = calm_box(moving, dur)
    r0, r1, r2 = (measure_nacelle(box, lid, dur, U) for lid in (still, moving, corrected))
    # the Doppler shift of the wind relative to the moving lidar, written out here look by look
    az = look_azimuths(moving, r1)
    t_l = r1.time_e[:, None] + ((np.arange(2) + 0.5) / 2 - 0.5) * moving.dwell_time
    a = math.radians(15.0)
    m = np.stack([-math.cos(a) * np.ones_like(az), math.sin(a) * np.cos(np.radians(az)),
                  math.sin(a) * np.sin(np.radians(az))], -1)
    ang = [np.radians(np.interp(t_l, motion.time, getattr(motion, k))) for k in ("roll_deg", "pitch_deg", "yaw_deg")]
    vel = np.stack([np.interp(t_l, motion.time, np.gradient(getattr(motion, k), motion.time))
                    for k in ("surge", "sway", "heave")], -1)
    n = np.empty_like(m)
    for i in np.ndindex(az.shape):
        r, p, y = (x[i] for x in ang)
        y = y + math.radians(gamma)
        Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
        Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
        Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
        n[i] = Rz @ Ry @ Rx @ m[i]
    want = np.einsum("elc,elc->el", n, np.array([U, 0, 0]) - vel).mean(axis=1)
    np.testing.assert_allclose(r1.vlos_e, want, atol=1e-12)
    assert np.max(np.abs(r1.vlos_e - r0.vlos_e)) > 0.5  # the surge alone moves it by up to 1.35 m/s
    # corrected: the wind as without motion, exactly; uncorrected: off by the platform's speed
    f0, f1, f2 = (per_revolution_fit(r, lid) for r, lid in ((r0, still), (r1, moving), (r2, corrected)))
    np.testing.assert_allclose(f2, f0, atol=1e-9)
    assert np.max(np.abs(f1 - f0)) > 0.3
    # tier 2's spectra see the same relative speed (bounds as in the tier 2-3 test below)
    r3 = measure_nacelle(box, moving.replace(tier="spectral", cell_length=4.0), dur, U, seed=3)
    assert np.max(np.abs(r3.speed_e - np.abs(r3.vlos_e))) < 0.02 + 4 * 0.0128


def test_blade_blockage_flags_the_estimates_it_covers():
    lid = NacelleLidar(focus_distances=(80.0,), rotor_rpm=12.0, n_blades=3, blade_chord=1.0,
                       rotor_plane_distance=4.0, blade_azimuth0_deg=30.0, sub_dwells=4, blockage_fraction=0.25)
    rec = measure_nacelle(calm_box(lid, 6.0), lid, 6.0, U)
    # brute force: where each look's ray crosses the rotor plane 4 m upwind, against the blades' strips
    az = look_azimuths(lid, rec)
    t_l = rec.time_e[:, None] + ((np.arange(4) + 0.5) / 4 - 0.5) * lid.dwell_time
    n = beam(15.0, az)
    p = n * (4.0 / -n[..., :1])  # (x = -4, y, z) on the ray
    blocked = np.zeros(az.shape, dtype=bool)
    for k in range(3):
        psi = math.radians(30.0) + 2 * math.pi * 12.0 / 60.0 * t_l + 2 * math.pi * k / 3
        e = np.stack([np.cos(psi), np.sin(psi)], -1)
        along = np.sum(p[..., 1:] * e, -1)
        across = p[..., 1] * e[..., 1] - p[..., 2] * e[..., 0]
        blocked |= (along > 0) & (np.abs(across) < 0.5)
    frac = blocked.mean(axis=1)
    np.testing.assert_array_equal(rec.blocked_e, frac)
    lost = frac > 0.25
    assert 10 < lost.sum() < rec.time_e.size // 2
    assert np.all(np.isnan(rec.speed_e[lost])) and np.all(rec.flags_e[lost] & Flag.BLOCKED)
    assert np.all(np.isfinite(rec.speed_e[~lost])) and not np.any(rec.flags_e[~lost] & Flag.BLOCKED)
    assert rec.info["n_blocked"] == lost.sum() == rec.info["flag_counts"]["BLOCKED"]
    assert rec.availability == pytest.approx(1 - lost.mean())


def test_yawed_cone_edge_meets_the_homodyne_blind_zone():
    # a + gamma = 90 deg: the beam at phi = 180 deg is across the wind, |v_los| -> 0
    lid = NacelleLidar(focus_distances=(40.0,), half_angle_deg=45.0, yaw_misalignment_deg=45.0, sub_dwells=1)
    rec = measure_nacelle(calm_box(lid, 2.0), lid, 2.0, U)
    inst = lid.instrument
    speed = np.abs(rec.vlos_e)
    np.testing.assert_array_equal(np.isnan(rec.speed_e), speed < inst.blind_zone_speed)
    near = speed < inst.blind_zone_speed + inst.edge_guard_speed
    assert near.any() and np.all(rec.flags_e[near] & Flag.NEAR_ZERO)
    assert not np.any(rec.flags_e[~near] & (Flag.NEAR_ZERO | Flag.NO_SIGNAL))


# Tier 2 (centroid of CS's instrument, thousands of speckle looks per estimate) and tier 3 (its signal; a
# 0.5 s revolution of 10 dwells keeps it to 10 estimates): scatter about the tier-1 ideal measured on seeds
# 0-5 (tier 2, 4 s) and 0-2 (tier 3): 0.0128 and 0.0055 m/s per estimate, means within 2e-4 of 0; the
# centroid's bias allowance is 0.02 m/s (test_conical).  Bounds: the allowance plus 4 sd.
@pytest.mark.parametrize("tier, duration, sd, kw", [
    ("spectral", 4.0, 0.0128, {}),
    ("signal", 0.5, 0.0055, {"revolution_time": 0.5, "estimates_per_rev": 10})])
def test_tiers_2_and_3_return_the_uniform_wind_to_the_estimators_bias(tier, duration, sd, kw):
    lid = NacelleLidar(focus_distances=(80.0,), tier=tier, yaw_misalignment_deg=10.0, cell_length=4.0, **kw)
    box = calm_box(lid, duration)
    rec = measure_nacelle(box, lid, duration, U, seed=5)
    if tier == "spectral":
        again = measure_nacelle(box, lid, duration, U, seed=5)
        np.testing.assert_array_equal(rec.speed_e, again.speed_e)
    assert np.all(rec.flags_e == 0)
    err = rec.speed_e - np.abs(rec.vlos_e)
    assert np.max(np.abs(err)) < 0.02 + 4 * sd, (np.mean(err), np.std(err))
    g = math.radians(10.0)
    fit = per_revolution_fit(rec, lid)
    n = lid.estimates_per_rev
    # the fit's u is the mean of the revolution's u_b: the allowance plus 4 sd / sqrt(n) (u_b = los / n_x)
    np.testing.assert_allclose(fit[:, 0], U * math.cos(g), atol=(0.02 + 4 * sd / math.sqrt(n)) / math.cos(
        math.radians(15.0)))
    # v from the revolution's cos phi harmonic: each estimate's error enters with weight 2 cos(phi) / (n sin a)
    sa = math.sin(math.radians(15.0))
    np.testing.assert_allclose(fit[:, 1], -U * math.sin(g), atol=(0.02 + 4 * sd * math.sqrt(2 / n)) / sa)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="half_angle_deg"):
        NacelleLidar(half_angle_deg=60.0)
    with pytest.raises(ValueError, match="focus_distances\\[1\\]"):
        NacelleLidar(focus_distances=(50.0, 5.0))
    with pytest.raises(ValueError, match="distinct"):
        NacelleLidar(focus_distances=(50.0, 50.0))
    with pytest.raises(ValueError, match="multiple"):
        NacelleLidar(beam_azimuths_deg=(0.0, 120.0, 240.0), estimates_per_rev=50)
    with pytest.raises(ValueError, match="yaw_misalignment_deg"):
        NacelleLidar(yaw_misalignment_deg=50.0)
    with pytest.raises(ValueError, match="half_angle_deg > 0"):
        NacelleLidar(half_angle_deg=0.0)
    with pytest.raises(ValueError, match="motion.pitch_deg"):
        PlatformMotion(time=[0.0, 1.0], pitch_deg=[0.0, 50.0])
    with pytest.raises(ValueError, match="motion.time"):
        PlatformMotion(time=[1.0, 0.0])
    lid = NacelleLidar(motion=PlatformMotion(time=[0.0, 1.0]))
    with pytest.raises(ValueError, match="motion covers"):
        measure_nacelle(calm_box(lid, 2.0), lid, 2.0, U)
    with pytest.raises(ValueError, match="unknown"):
        NacelleLidar.from_dict({"focus": 3.0})
    d = NacelleLidar(motion=PlatformMotion(time=[0.0, 5.0], surge=[0.0, 1.0])).as_dict()
    assert NacelleLidar.from_dict(d).motion.surge.tolist() == [0.0, 1.0]


def test_calibration_clock_sets_the_pauses_like_the_other_lidars():
    """``calibration_time`` puts the record on the background-calibration clock: estimates inside a pause are lost."""
    lid = NacelleLidar(focus_distances=(60.0,), background_pause=True)
    inst = lid.instrument
    field = calm_box(lid, 2.0)
    # the record's t = 1 s is the start of a calibration pause: from there on every estimate is paused
    rec = measure_nacelle(field, lid, 2.0, U, calibration_time=inst.background_interval - 1.0)
    paused = (rec.flags_e & np.uint8(Flag.PAUSED)) > 0
    np.testing.assert_array_equal(paused, rec.time_e >= 1.0)
    assert np.all(np.isnan(rec.speed_e[paused])) and np.all(np.isfinite(rec.speed_e[~paused]))


def test_a_cloud_is_refused_at_construction_not_ignored():
    with pytest.raises(ValueError, match=r"cloud_base=1500.0: the nacelle lidar does not model a cloud layer"):
        NacelleLidar(cloud_base=1500.0, cloud_strength=1e4)
