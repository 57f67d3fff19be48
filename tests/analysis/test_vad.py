"""Rectified-cosine fit: exact recovery of uniform flow at any direction, ambiguity, flagged points, TP."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.vad import (
    VadFlag,
    fit_rectified_cosine,
    period_statistics,
    scan_arrays,
    sonic_radial_variance,
)

PHI = math.radians(30.0)
AZ = 3.6 + 7.2 * np.arange(50)


def folded(U, d, w, az=AZ):
    return np.abs(U * math.sin(PHI) * np.cos(np.radians(az - d)) + w * math.cos(PHI))


@pytest.mark.parametrize("d", [0.0, 37.0, 90.0, 135.0, 180.0, -90.0, -163.0, 3.6, 93.6])
@pytest.mark.parametrize("w", [0.0, 0.4, -1.5])
def test_uniform_flow_recovered_exactly_at_any_direction(d, w):
    U = 8.0
    f = fit_rectified_cosine(AZ, folded(U, d, w), 30.0, reference_deg=d + 60.0)
    assert f.speed_p[0] == pytest.approx(U, rel=1e-12)
    assert ((f.direction_p[0] - d + 180.0) % 360.0 - 180.0) == pytest.approx(0.0, abs=1e-9)
    assert f.w_p[0] == pytest.approx(w, abs=1e-12)
    assert f.residual_var_p[0] < 1e-24 and f.n_used_p[0] == 50 and f.flags_p[0] == 0
    # without a reference: one of the two equivalent solutions, flagged
    g = fit_rectified_cosine(AZ, folded(U, d, w), 30.0)
    assert g.flags_p[0] & VadFlag.UNRESOLVED
    alt = ((g.direction_p[0] - d) % 360.0)
    assert min(alt, 360 - alt) == pytest.approx(0.0, abs=1e-9) or alt == pytest.approx(180.0, abs=1e-9)
    assert g.w_p[0] == pytest.approx(w if min(alt, 360 - alt) < 1 else -w, abs=1e-12)
    assert abs(g.direction_p[0]) <= 90.0


def test_vertical_dominated_and_weak_wind():
    # |B| > A: no sign change at all on the circle
    f = fit_rectified_cosine(AZ, folded(0.5, 200.0, 3.0), 30.0, reference_deg=-160.0)
    assert f.speed_p[0] == pytest.approx(0.5, rel=1e-10) and f.w_p[0] == pytest.approx(3.0, rel=1e-12)
    assert f.direction_p[0] == pytest.approx(-160.0, abs=1e-8)


def test_flagged_and_nan_points_left_out_and_3s_scans():
    rng = np.random.default_rng(1)
    az3 = 3.6 + 7.2 * np.arange(150)
    y = folded(10.0, 20.0, 0.3, az3)
    y[[5, 6, 7]] = np.nan
    bad = np.ones(150, dtype=bool)
    idx = rng.choice(150, 40, replace=False)
    y2 = y.copy()
    y2[idx] = 50.0  # garbage, but marked invalid
    bad[idx] = False
    f = fit_rectified_cosine(az3, y2, 30.0, valid=bad, reference_deg=0.0)
    assert f.speed_p[0] == pytest.approx(10.0, rel=1e-12) and f.direction_p[0] == pytest.approx(20.0, abs=1e-9)
    assert f.n_used_p[0] == 150 - len(set(idx) | {5, 6, 7}) and f.n_points == 150
    # too few points: failed, NaN, counted
    few = np.full(50, np.nan)
    few[:4] = 1.0
    g = fit_rectified_cosine(AZ, few, 30.0, min_points=6)
    assert g.flags_p[0] == VadFlag.FAILED and np.isnan(g.speed_p[0]) and g.availability == 0.0


def test_ambiguity_resolved_by_previous_scan_and_perpendicular_reference():
    dirs = [10.0, 25.0, 40.0, 170.0]
    y = np.stack([folded(6.0, d, 0.2) for d in dirs])
    ref = np.array([0.0, np.nan, np.nan, np.nan])
    f = fit_rectified_cosine(np.broadcast_to(AZ, y.shape), y, 30.0, reference_deg=ref)
    np.testing.assert_allclose(f.direction_p[:3], dirs[:3], atol=1e-9)
    assert list(f.flags_p[:3]) == [0, VadFlag.FROM_PREVIOUS, VadFlag.FROM_PREVIOUS]
    # 170 deg is 130 deg from the previous 40 deg: the previous picks 170 - 180 = -10 deg (and -w)
    assert f.direction_p[3] == pytest.approx(-10.0, abs=1e-9) and f.w_p[3] == pytest.approx(-0.2, abs=1e-12)
    g = fit_rectified_cosine(AZ, folded(6.0, 90.0, 0.2), 30.0, reference_deg=2.0)
    assert g.flags_p[0] & VadFlag.UNRESOLVED


def test_tp_of_white_noise_is_its_std_over_U():
    rng = np.random.default_rng(5)
    s = 0.1
    n_scans = 400
    y = folded(10.0, 0.0, 0.0)[None, :] + s * rng.standard_normal((n_scans, 50))
    f = fit_rectified_cosine(np.broadcast_to(AZ, y.shape), np.abs(y), 30.0, reference_deg=0.0)
    # residual variance with n - 3 dof is unbiased for the noise variance (points far from the zero crossing
    # dominate; the few near |v| ~ s are folded, a small bias)
    rv = f.residual_var_p.mean()
    assert rv == pytest.approx(s * s, rel=4 * math.sqrt(2 / (n_scans * 47)) + 0.02)
    assert np.mean(f.tp_p) == pytest.approx(s / 10.0, rel=0.03)
    st = period_statistics(f)
    assert st["selected"] and st["mean_points_used_fraction"] == 1.0
    assert st["radial_variance"] == pytest.approx(rv)


def test_scan_arrays_and_sonic_radial_variance():
    rev = np.repeat(np.arange(7), 50)
    x = np.arange(350.0)
    a = scan_arrays(x, rev, 3)
    assert a.shape == (2, 150) and a[1, 0] == 150.0
    with pytest.raises(ValueError, match="n_rev=0"):
        scan_arrays(x, rev, 0)
    # a steady u' = 1 seen by the rotating beam: projected variance sin^2 Phi <cos^2> = 1/8 about the mean 0
    az = 3.6 + 7.2 * np.arange(500)
    vel = np.zeros((500, 3))
    vel[:, 0] = 10.0 + np.where(np.arange(500) % 2 == 0, 1.0, -1.0)
    # alternating u' of unit variance, projected: sin^2 Phi * E[cos^2] = 0.25 * 0.5
    assert sonic_radial_variance(vel, az, 30.0) == pytest.approx(0.125, rel=0.02)
    vel[:, 0] = 10.0
    assert sonic_radial_variance(vel, az, 30.0, scan=True, revolution_e=np.repeat(np.arange(10), 50)) < 1e-24
