"""The conical results' VAD quantities pinned to their physics: the sonic-side radial variance's projection
(a w-only field gives cos^2 Phi of its variance), TP's divisor n - 3, CS's 65 % selection at its boundary,
the ambiguity rate on the circle, and the probe-length fit's a0 ~ zR^-1/2."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.vad import ambiguity_rate, fit_rectified_cosine, period_statistics, sonic_radial_variance

PHI = math.radians(30.0)
AZ = 3.6 + 7.2 * np.arange(50)


def test_sonic_radial_variance_projects_each_component():
    # 40 revolutions of 50 equally spaced azimuths; each component constant within a revolution, so that over
    # a revolution <cos> = <sin> = <cos sin> = 0 and <cos^2> = 1/2 hold exactly
    rng = np.random.default_rng(3)
    n_rev = 40
    az = np.tile(AZ, n_rev)
    per_rev = rng.standard_normal((n_rev, 3)) * np.array([1.1, 0.8, 0.5])
    vel = np.repeat(per_rev, 50, axis=0) + np.array([10.0, 0.0, 0.0])
    var = per_rev.var(axis=0)
    for c, want in ((2, math.cos(PHI) ** 2 * var[2]), (0, 0.5 * math.sin(PHI) ** 2 * var[0]),
                    (1, 0.5 * math.sin(PHI) ** 2 * var[1])):
        only = np.zeros_like(vel)
        only[:, 0] = 10.0
        only[:, c] += vel[:, c] - (10.0 if c == 0 else 0.0)
        assert sonic_radial_variance(only, az, 30.0) == pytest.approx(want, rel=1e-12), c
    # all three together: sin^2 Phi / 2 (s_u^2 + s_v^2) + cos^2 Phi s_w^2 minus the (sample) cross terms, which
    # the per-revolution constancy makes sin 2 Phi <u'w'><cos> = 0 exactly
    want = 0.5 * math.sin(PHI) ** 2 * (var[0] + var[1]) + math.cos(PHI) ** 2 * var[2]
    assert sonic_radial_variance(vel, az, 30.0) == pytest.approx(want, rel=1e-12)
    # another cone: Phi enters as sin^2 / cos^2, not through the 30 deg default
    assert sonic_radial_variance(vel, az, 45.0) == pytest.approx(0.25 * (var[0] + var[1]) + 0.5 * var[2], rel=1e-12)


def test_residual_variance_is_unbiased_for_white_noise_with_divisor_n_minus_3():
    # no sign change on the circle (B > A + 8 sigma): the fit is ordinary least squares with 3 parameters and
    # sum r^2 / (n - 3) is unbiased; 1000 scans of 47 dof give a relative standard error sqrt(2 / 47000) = 0.65 %
    # (the divisor n would sit 6 % low, 9 of those)
    rng = np.random.default_rng(8)
    U, w, s = 4.0, 6.0, 0.2
    clean = U * math.sin(PHI) * np.cos(np.radians(AZ)) + w * math.cos(PHI)
    assert clean.min() > 8 * s
    y = clean[None, :] + s * rng.standard_normal((1000, 50))
    f = fit_rectified_cosine(np.broadcast_to(AZ, y.shape), y, 30.0, reference_deg=0.0)
    assert f.residual_var_p.mean() == pytest.approx(s * s, rel=4 * math.sqrt(2 / (1000 * 47)))
    # TP (CS Eq. 8): the rms residual over U, so (TP U)^2 is the radial variance
    np.testing.assert_allclose((f.tp_p * f.speed_p) ** 2, f.residual_var_p, rtol=1e-12)
    # U, w and the direction unbiased: means within 4 standard errors of the least-squares scatter
    # (var of a = 2 s^2 / n over 50 azimuths, of c = s^2 / n)
    assert f.speed_p.mean() == pytest.approx(U, abs=4 * s * math.sqrt(2 / 50) / math.sin(PHI) / math.sqrt(1000))
    assert f.w_p.mean() == pytest.approx(w, abs=4 * s / math.sqrt(50) / math.cos(PHI) / math.sqrt(1000))


def _scans_with_used_fraction(frac, n_scans=20, seed=0):
    rng = np.random.default_rng(seed)
    y = np.tile(np.abs(10.0 * math.sin(PHI) * np.cos(np.radians(AZ))), (n_scans, 1))
    n_keep = int(round(frac * 50))
    for row in y:
        row[rng.permutation(50)[n_keep:]] = np.nan
    return fit_rectified_cosine(np.broadcast_to(AZ, y.shape), y, 30.0, reference_deg=0.0)


@pytest.mark.parametrize("frac, selected", [(0.60, False), (0.64, False), (0.66, True), (0.70, True)])
def test_cs_selection_at_its_65_percent_boundary(frac, selected):
    f = _scans_with_used_fraction(frac)
    st = period_statistics(f)
    assert st["mean_points_used_fraction"] == pytest.approx(frac, abs=1e-12)
    assert st["selected"] is selected
    assert st["n_fitted"] == 20 and st["mean_speed"] == pytest.approx(10.0, rel=1e-12)


def test_selection_counts_failed_scans_as_unused():
    # half the scans lost altogether (fewer points than a fit needs), the other half complete: 50 % of the points
    # of the period were used, whatever the fitted scans alone say
    y = np.tile(np.abs(10.0 * math.sin(PHI) * np.cos(np.radians(AZ))), (10, 1))
    y[::2, 3:] = np.nan
    f = fit_rectified_cosine(np.broadcast_to(AZ, y.shape), y, 30.0, reference_deg=0.0)
    st = period_statistics(f)
    assert st["n_fitted"] == 5 and st["mean_points_used_fraction"] == pytest.approx(0.53, abs=1e-12)
    assert not st["selected"]
    assert period_statistics(f, min_used_fraction=0.5)["selected"]


def test_ambiguity_rate_compares_directions_on_the_circle():
    true = np.array([179.0, -179.0, 10.0, 0.0, 95.0, 30.0])
    got = np.array([-179.0, 179.0, -170.0, 91.0, -84.0, np.nan])
    # 2, 2, 180, 91 and 179 deg apart: three of the five fitted scans are on the wrong side
    assert ambiguity_rate(got, true) == pytest.approx(3 / 5)
    assert ambiguity_rate(true, true) == 0.0
    assert math.isnan(ambiguity_rate(np.full(3, np.nan), np.zeros(3)))


def test_probe_length_fit_propagates_its_uncertainty_as_a0_to_the_minus_half():
    from cwlidar_sim.analysis.estimator_theory import radius_of_rayleigh_length
    from cwlidar_sim.signal import PROTOTYPE_2003 as P

    lam, r = P.wavelength, P.focus
    # A2012 Eq. 1 inverted: the nominal instrument's zR gives back its radius
    a0, _ = radius_of_rayleigh_length(P.rayleigh_length, 0.0, wavelength=lam, focus=r)
    assert a0 == pytest.approx(P.telescope_radius, rel=1e-12)
    # the 1-sigma of a0 is the derivative times sigma_zR: a central difference of the radius itself
    zR, sig = 7.7, 0.3
    a, s = radius_of_rayleigh_length(zR, sig, wavelength=lam, focus=r)
    h = 1e-4 * zR
    up, _ = radius_of_rayleigh_length(zR + h, 0.0, wavelength=lam, focus=r)
    dn, _ = radius_of_rayleigh_length(zR - h, 0.0, wavelength=lam, focus=r)
    assert s == pytest.approx(abs(up - dn) / (2 * h) * sig, rel=1e-6)
    # and a0 scales as zR^-1/2: four times the probe length, half the radius
    assert radius_of_rayleigh_length(4 * zR, 0.0, wavelength=lam, focus=r)[0] == pytest.approx(0.5 * a, rel=1e-12)
