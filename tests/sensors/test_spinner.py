"""SpinnerLidar (sensors/spinner.py) and the disc fit (analysis/disc_fit.py): geometry against closed forms.

The rosette is checked against the closed form of two composed prism rotations, written here from the
geometry (``cos theta = cos d1 cos d2 - sin d1 sin d2 cos(phi1 - phi2)``), not from the sensor.  In tier 1
with a point weighting a linear wind field is sampled exactly (trilinear interpolation of a linear field),
so every line-of-sight speed equals ``n . (U + alpha z, beta z + kappa y..., 0)`` evaluated here from the
frame's definition, and the disc fit returns the field's parameters to round-off.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis.disc_fit import fit_disc
from cwlidar_sim.sensors import PlatformMotion
from cwlidar_sim.sensors.spinner import SpinnerLidar, measure_spinner, prism_directions, rosette_period
from cwlidar_sim.signal import Flag
from cwlidar_sim.signal.instrument import SPINNER_LIDAR
from cwlidar_sim.turbulence.cover import plan_box

U = 10.0


def linear_box(lid, duration, *, alpha=0.0, beta=0.0, kappa=0.0, d=4.0):
    """Fluctuations u = alpha z + kappa y, v = beta z, w = 0 (z, y from the lidar) on the lidar's box."""
    plan = plan_box(lid.box_region(d), U, duration, d, min_extent=0.0)
    (nx, ny, nz), (x0, y0, z0) = plan.shape, plan.origin
    y = y0 + d * np.arange(ny) - lid.position[1]
    z = z0 + d * np.arange(nz) - lid.position[2]
    Y, Z = np.meshgrid(y, z, indexing="ij")
    u = np.broadcast_to(alpha * Z + kappa * Y, (nx, ny, nz))
    v = np.broadcast_to(beta * Z, (nx, ny, nz))
    return xr.Dataset({"u": (("x", "y", "z"), np.array(u)), "v": (("x", "y", "z"), np.array(v)),
                       "w": (("x", "y", "z"), np.zeros((nx, ny, nz)))},
                      coords={"x": x0 + d * np.arange(nx), "y": y0 + d * np.arange(ny), "z": z0 + d * np.arange(nz)})


def rot(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def expected_looks(lid, rec):
    """The looks' field-frame directions from the definitions: prism azimuths, tilt, yaw (no motion)."""
    off = ((np.arange(lid.sub_dwells) + 0.5) / lid.sub_dwells - 0.5) * lid.dwell_time
    t = rec.time_e[:, None] + off[None, :]
    psi = lid.rotor_azimuth0_deg + 6.0 * lid.rotor_rpm * t
    p1 = lid.prism_phase_deg[0] + 360.0 * lid.prism_rate_hz[0] * t + psi
    p2 = lid.prism_phase_deg[1] + 360.0 * lid.prism_rate_hz[1] * t + psi
    m = prism_directions(p1.ravel(), p2.ravel(), lid.prism_deflection_deg).reshape(t.shape + (3,))
    known = m @ rot("y", lid.tilt_deg).T
    return known @ rot("z", lid.yaw_misalignment_deg).T, known


def test_preset_is_the_published_instrument():
    s = SPINNER_LIDAR
    assert s.n_fft // 2 == 256 and s.sample_rate / 2 == 50e6
    assert s.wavelength * s.sample_rate / s.n_fft / 2 == pytest.approx(0.152, abs=5e-4)  # m/s per bin
    assert s.estimate_rate == 492.0
    assert s.blocks_per_estimate * s.n_fft / s.sample_rate <= 1.0 / 492.0


def test_rosette_closes_after_2_s_with_984_estimates_and_reaches_30_4_deg():
    lid = SpinnerLidar(sub_dwells=1)
    assert lid.rosette_time == pytest.approx(2.0, rel=1e-15)
    assert lid.estimates_per_rosette == 984 and 1.0 / lid.dwell_time == pytest.approx(492.0)
    t = np.linspace(0.0, 2.0, 20001)
    m = lid.rotor_direction(t)
    np.testing.assert_allclose(lid.rotor_direction(t + 2.0), m, atol=1e-12)
    # not closed earlier: no shorter period among the candidates 2/k
    for k in range(2, 14):
        assert np.abs(lid.rotor_direction(t + 2.0 / k) - m).max() > 0.1
    theta = np.degrees(np.arccos(-m[:, 0]))
    assert theta.max() == pytest.approx(30.4, abs=1e-3) and theta.min() < 0.01
    # the closed form of the composed rotations
    d = math.radians(15.2)
    p1, p2 = (np.radians(p) for p in lid.prism_azimuths(t))
    np.testing.assert_allclose(-m[:, 0], math.cos(d) ** 2 - math.sin(d) ** 2 * np.cos(p1 - p2), atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(m, axis=1), 1.0, atol=1e-14)
    # the small-angle sum of two rotating vectors has the same extremes, and differs by < 1.5 % in between
    small = np.degrees(np.abs(d * (np.exp(1j * p1) + np.exp(1j * p2))))
    assert np.abs(small - theta).max() < 0.015 * 30.4
    # a record: 3 rosettes in 6.5 s, 984 each
    rec = measure_spinner(linear_box(lid, 6.5), lid, 6.5, U)
    assert rec.time_e.size == 3 * 984 and np.array_equal(np.bincount(rec.rosette_e), [984] * 3)
    np.testing.assert_allclose(np.diff(rec.time_e), 1.0 / 492.0, rtol=1e-12)


def test_different_prisms_and_rates():
    assert rosette_period((3.5, -6.5)) == 2.0 and rosette_period((3.5, 6.5)) == 2.0
    assert rosette_period((2.0, 0.0)) == 0.5 and rosette_period((1.25, 2.0)) == 4.0
    m = prism_directions([40.0], [40.0 + 180.0], (15.0, 10.0))
    assert math.degrees(math.acos(-m[0, 0])) == pytest.approx(5.0, abs=1e-12)
    m = prism_directions([40.0], [40.0], (15.0, 10.0))
    assert math.degrees(math.acos(-m[0, 0])) == pytest.approx(25.0, abs=1e-12)
    assert math.degrees(math.atan2(m[0, 2], m[0, 1])) == pytest.approx(40.0, abs=1e-12)


CASES = [dict(), dict(yaw_misalignment_deg=12.0), dict(tilt_deg=6.0, rotor_rpm=14.0, rotor_azimuth0_deg=33.0),
         dict(yaw_misalignment_deg=-20.0, tilt_deg=-4.0, rotor_rpm=9.0, rotor_azimuth0_deg=200.0, sub_dwells=3),
         dict(prism_phase_deg=(10.0, 70.0), rotor_rpm=22.0, rotor_azimuth0_deg=-95.0, focus_distance=50.0)]


@pytest.mark.parametrize("case", CASES, ids=[str(c) for c in CASES])
def test_uniform_wind_is_exact_and_the_fit_returns_it(case):
    lid = SpinnerLidar(weighting="point", **{"sub_dwells": 1, **case})
    rec = measure_spinner(linear_box(lid, 4.0), lid, 4.0, U)
    n_elc, known = expected_looks(lid, rec)
    np.testing.assert_allclose(rec.vlos_e, (n_elc @ np.array([U, 0.0, 0.0])).mean(axis=1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.direction_elc, known, atol=1e-14)
    assert np.all(rec.flags_e == 0) and np.array_equal(rec.los_e, -rec.speed_e)
    fit = fit_disc(rec.los_e, rec.direction_elc, lid.focus_distance, rec.rosette_e)
    g = math.radians(lid.yaw_misalignment_deg)
    np.testing.assert_allclose(fit.params_gp, [[U * math.cos(g), 0, 0, -U * math.sin(g), 0, 0]] * 2, atol=1e-9)
    np.testing.assert_allclose(fit.uvw_gc, [[U * math.cos(g), -U * math.sin(g), 0]] * 2, atol=1e-10)
    np.testing.assert_allclose(fit.yaw_misalignment_g, lid.yaw_misalignment_deg, atol=1e-9)
    np.testing.assert_allclose(fit.rews_g, U * math.cos(g), atol=1e-10)
    np.testing.assert_allclose(fit.residual_rms_g, 0.0, atol=1e-10)


@pytest.mark.parametrize("case", CASES, ids=[str(c) for c in CASES])
def test_shear_and_veer_are_exact(case):
    alpha, beta = 0.04, 0.012  # du/dz [1/s], dv/dz [1/s]: veer beta / U rad/m
    lid = SpinnerLidar(weighting="point", **{"sub_dwells": 1, **case})
    rec = measure_spinner(linear_box(lid, 2.0, alpha=alpha, beta=beta), lid, 2.0, U)
    n_elc, known = expected_looks(lid, rec)
    c = lid.cells()  # the probe volume's first moment: where a linear field's average is taken
    r = lid.focus_distance + np.sum(np.repeat(c.weight_s, np.diff(c.ptr_s)) * c.fraction_j * c.sub_j)
    assert r == pytest.approx(lid.probe_centre, abs=1e-12) and abs(r - lid.focus_distance) < 1.0
    z_el = r * n_elc[..., 2]  # the probe's height above the lidar (the field frame's z)
    want = (n_elc[..., 0] * (U + alpha * z_el) + n_elc[..., 1] * beta * z_el).mean(axis=1)
    np.testing.assert_allclose(rec.vlos_e, want, rtol=0, atol=1e-11)
    fit = fit_disc(rec.los_e, rec.direction_elc, rec.info["probe_centre"], rec.rosette_e)
    g = math.radians(lid.yaw_misalignment_deg)
    cg, sg = math.cos(g), math.sin(g)
    # the field's (U + alpha z, beta z) in the yawed nacelle frame: Rz(-gamma)
    want_p = [U * cg, 0.0, alpha * cg + beta * sg, -U * sg, -alpha * sg + beta * cg, 0.0]
    np.testing.assert_allclose(fit.params_gp[0], want_p, atol=1e-9)
    assert fit.vertical_shear_g[0] == pytest.approx(alpha, abs=1e-10)
    assert fit.veer_g[0] == pytest.approx(math.degrees(beta / U), abs=1e-9)
    assert fit.yaw_misalignment_g[0] == pytest.approx(lid.yaw_misalignment_deg, abs=1e-8)
    assert fit.speed_g[0] == pytest.approx(U, abs=1e-10) and fit.rews_g[0] == pytest.approx(U * cg, abs=1e-10)


def test_horizontal_shear_is_exact_and_w_zero_fits_five():
    kappa = -0.03
    lid = SpinnerLidar(weighting="point", sub_dwells=2, tilt_deg=5.0, rotor_rpm=15.0)
    rec = measure_spinner(linear_box(lid, 2.0, kappa=kappa), lid, 2.0, U)
    for w_zero in (False, True):
        fit = fit_disc(rec.los_e, rec.direction_elc, lid.probe_centre, w_zero=w_zero)
        np.testing.assert_allclose(fit.params_gp[0], [U, kappa, 0, 0, 0, 0], atol=1e-9)
        assert fit.horizontal_shear_g[0] == pytest.approx(kappa, abs=1e-10)
    assert 10.0 < fit.condition_g[0] < 1e4


def test_blade_blockage_is_the_strip_rule_and_repeats_every_rosette():
    lid = SpinnerLidar(n_blades=3, sub_dwells=1, rotor_rpm=12.0, blade_chord=1.0, blade_plane_distance=2.0,
                       hub_radius=0.8)
    rec = measure_spinner(linear_box(lid, 4.0), lid, 4.0, U)
    t = rec.time_e
    m = prism_directions(*lid.prism_azimuths(t), lid.prism_deflection_deg)
    rho = 2.0 * np.tan(np.arccos(-m[:, 0]))
    phi = np.arctan2(m[:, 2], m[:, 1])
    hit = np.zeros(t.size, bool)
    for k in range(3):
        d = phi - np.radians(lid.rotor_azimuth(t) + 120.0 * k)
        hit |= (np.cos(d) > 0) & (rho * np.abs(np.sin(d)) < 0.5)
    hit &= rho >= 0.8
    assert 0.1 < hit.mean() < 0.5
    np.testing.assert_array_equal(rec.blocked_e == 1.0, hit)
    assert np.all(np.isnan(rec.speed_e[hit])) and np.all(rec.flags_e[hit] & Flag.BLOCKED)
    assert np.all(np.isfinite(rec.speed_e[~hit])) and rec.info["n_blocked"] == hit.sum()
    # the blades turn with the prisms: the same estimates of every rosette, whatever the rotor speed
    np.testing.assert_array_equal(hit[:984], hit[984:])
    lid0 = SpinnerLidar(n_blades=3, sub_dwells=1, rotor_rpm=0.0)
    np.testing.assert_array_equal(lid0.blocked(t), hit)
    # the fit over the unblocked estimates is still exact
    fit = fit_disc(rec.los_e, rec.direction_elc, lid.focus_distance, rec.rosette_e)
    np.testing.assert_allclose(fit.rews_g, U, atol=1e-9)
    assert np.array_equal(fit.n_used_g, [984 - hit[:984].sum()] * 2)


def test_platform_motion_and_its_correction():
    t = np.linspace(-1.0, 4.0, 501)
    motion = PlatformMotion(time=t, surge=0.8 * np.sin(2 * np.pi * t / 3.0), pitch_deg=2.0 * np.sin(2 * np.pi * t / 4.0))
    lid = SpinnerLidar(weighting="point", sub_dwells=1, motion=motion, motion_correction=True)
    rec = measure_spinner(linear_box(lid, 2.0), lid, 2.0, U)
    fit = fit_disc(rec.los_e, rec.direction_elc, lid.focus_distance)
    np.testing.assert_allclose(fit.params_gp[0], [U, 0, 0, 0, 0, 0], atol=1e-6)
    raw = SpinnerLidar(weighting="point", sub_dwells=1, motion=motion)
    rec2 = measure_spinner(linear_box(raw, 2.0), raw, 2.0, U)
    assert np.abs(rec2.los_e - rec.los_e).max() > 0.1


def test_spectral_tier_runs_through_the_chain():
    lid = SpinnerLidar(tier="spectral", cnr_db=0.0, sub_dwells=4)
    rec = measure_spinner(linear_box(lid, 2.0), lid, 2.0, U, seed=5)
    ok = np.isfinite(rec.speed_e)
    assert ok.mean() > 0.9
    assert np.abs(rec.speed_e[ok] - np.abs(rec.vlos_e[ok])).mean() < 0.2
    fit = fit_disc(rec.los_e, rec.direction_elc, lid.focus_distance, w_zero=True)
    assert fit.rews_g[0] == pytest.approx(U, abs=0.05)


@pytest.mark.parametrize("kw,match", [
    (dict(prism_rate_hz=(3.5, math.pi)), r"prism_rate_hz\[1\]=3.14.*never close"),
    (dict(prism_rate_hz=(0.001, 1.0)), r"prism_rate_hz=.*1000 s"),
    (dict(prism_rate_hz=(0.0, 0.0)), r"prism_rate_hz.*at rest"),
    (dict(prism_rate_hz=(3.5, 60.0)), r"prism_rate_hz\[1\]"),
    (dict(prism_deflection_deg=(15.2, 0.0)), r"prism_deflection_deg\[1\]"),
    (dict(prism_deflection_deg=(25.0, 25.0)), r"prism_deflection_deg=.*45"),
    (dict(focus_distance=5.0), r"focus_distance"),
    (dict(focus_distance=12.0, blade_plane_distance=11.0), r"focus_distance=12 m .*behind the blades"),
    (dict(tilt_deg=20.0), r"tilt_deg"),
    (dict(yaw_misalignment_deg=50.0), r"yaw_misalignment_deg"),
    (dict(n_blades=7), r"n_blades"),
    (dict(estimates_per_rosette=2), r"estimates_per_rosette"),
    (dict(estimates_per_rosette=2000), r"blocks_per_estimate=396 does not fit"),
    (dict(cloud_base=1000.0, cloud_strength=1e3), r"cloud_base"),
])
def test_refusals_by_name(kw, match):
    with pytest.raises(ValueError, match=match):
        SpinnerLidar(**kw)


def test_duration_without_a_rosette_is_refused():
    lid = SpinnerLidar()
    with pytest.raises(ValueError, match=r"duration=1.5 s holds no rosette"):
        measure_spinner(linear_box(lid, 2.0), lid, 1.5, U)


def test_a_probe_volume_sees_a_linear_field_at_its_first_moment():
    """The exact (asymmetric) weighting with the renormalised tail: the fit at probe_centre is still exact."""
    alpha, beta = 0.05, -0.01
    lid = SpinnerLidar(weighting="exact", tail="renormalise", span=3.0, cell_length=1.0, sub_dwells=2,
                       focus_distance=120.0, yaw_misalignment_deg=8.0)
    assert lid.focus_distance - lid.probe_centre > 1.0  # the exact weighting is asymmetric: it leans toward the lidar
    rec = measure_spinner(linear_box(lid, 2.0, alpha=alpha, beta=beta), lid, 2.0, U)
    fit = fit_disc(rec.los_e, rec.direction_elc, lid.probe_centre)
    assert fit.vertical_shear_g[0] == pytest.approx(alpha, abs=1e-9)
    assert fit.veer_g[0] == pytest.approx(math.degrees(beta / U), abs=1e-8)
    assert fit.yaw_misalignment_g[0] == pytest.approx(8.0, abs=1e-7)
    off = fit_disc(rec.los_e, rec.direction_elc, lid.focus_distance)  # the nominal focus is not where it looks
    assert abs(off.vertical_shear_g[0] - alpha) > 1e-5


@pytest.mark.parametrize("kw", [{}, {"tilt_deg": 5.0, "yaw_misalignment_deg": 10.0, "rotor_rpm": 16.0}])
def test_evolving_planes_age_by_the_preview(kw):
    """The probe's plane of evolving turbulence lies at its mean upwind distance over a rosette (the preview's),
    not at the focus distance on the axis: off the axis (up to 30.4 deg) the rosette looks 69-80 m upwind."""
    lid = SpinnerLidar(**kw)
    rec = measure_spinner(linear_box(lid, 2.0), lid, 2.0, U)
    # the field-frame upwind distance of the probe's first moment (the period's preview without yaw)
    upwind = -float(rec.field_direction_ec[:, 0].mean()) * rec.info["probe_centre"]
    assert 80.0 * math.cos(math.radians(40.4)) < upwind < 79.0
    x_rotor, x_probe = lid.box_planes()
    assert x_rotor == lid.position[0]
    assert lid.position[0] - x_probe == pytest.approx(upwind, rel=2e-3)
