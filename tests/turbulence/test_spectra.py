"""Analytic one-point spectra and variances."""

import math

import numpy as np
import pytest
import reference

from cwlidar_sim.turbulence import MannParameters, covariances, isotropic_spectra, one_point_spectra

K1 = np.logspace(-4, 1.5, 23)


def test_gamma_zero_matches_von_karman_closed_forms():
    p0 = MannParameters(0.7, 25.0, 0.0)
    F11, F22, F33, F13 = one_point_spectra(K1, p0)
    a11, a22 = isotropic_spectra(K1, p0)
    np.testing.assert_allclose(F11, a11, rtol=1e-6)
    np.testing.assert_allclose(F22, a22, rtol=1e-6)
    np.testing.assert_allclose(F33, a22, rtol=1e-6)
    assert np.all(np.abs(F13) < 1e-12 * F11)


def test_gamma_zero_variance_is_two_thirds_of_tke_integral():
    p0 = MannParameters(0.7, 25.0, 0.0)
    c = covariances(p0)
    # (2/3) * integral of E(k) dk = (2/3) * B(5/2, 1/3)/2 * alpha_eps L^(2/3).
    expected = (2 / 3) * 0.5 * math.gamma(2.5) * math.gamma(1 / 3) / math.gamma(17 / 6) * 0.7 * 25.0 ** (2 / 3)
    for v in (c.uu, c.vv, c.ww):
        assert v == pytest.approx(expected, rel=1e-6)
    assert abs(c.uw) < 1e-9 * expected


def test_sheared_variance_ratios_and_negative_uw():
    """Variances of the sheared tensor against an independent quadrature of Mann (1994)'s tensor.

    The tensor is Mann (1994), J. Fluid Mech. 273, 141-168 (von Karman energy spectrum, eddy
    lifetime through 2F1, rapid-distortion shear); tests/reference.py integrates it in
    spherical coordinates with numpy only.  For Gamma = 3.9 the ratios come out
    1 : 0.508 : 0.271 (the quadrature agrees with itself on a 1.5x finer grid to 2e-4).
    """
    p = MannParameters(1.0, 33.6, 3.9)
    c = covariances(p)
    uu, vv, ww = reference.mann_variances(p.alpha_eps, p.length_scale, p.gamma)
    assert c.uu == pytest.approx(uu, rel=2e-3)
    assert c.vv == pytest.approx(vv, rel=2e-3)
    assert c.ww == pytest.approx(ww, rel=2e-3)
    assert c.vv / c.uu == pytest.approx(0.508, abs=0.002)
    assert c.ww / c.uu == pytest.approx(0.271, abs=0.002)
    assert c.uw < 0


def test_shear_redistributes_but_does_not_change_w_much_at_high_k():
    # Far in the inertial range the eddy lifetime -> 0: spectra become isotropic.
    p = MannParameters(1.0, 33.6, 3.9)
    k = np.array([30.0, 100.0])
    F11, F22, F33, _ = one_point_spectra(k, p)
    assert np.all(np.abs(F22 / F33 - 1) < 0.05)
    assert np.all(np.abs(F33 / F11 - 4 / 3) < 0.1)


def test_grid_resolved_less_than_full_and_consistent_with_spectra():
    p = MannParameters(1.0, 33.6, 3.9)
    full = covariances(p)
    grid = covariances(p, (2.0, 2.0, 2.0))
    for a, b in [(grid.uu, full.uu), (grid.vv, full.vv), (grid.ww, full.ww)]:
        assert a < b
    # Independent check of the k1 quadrature: trapezoid on a log-graded grid
    # (F33 rises steeply within 1e-3 rad/m of k1 = 0 because Phi33 ~ 1/|k|^2
    # at the origin, so a uniform grid converges only at first order).
    k = np.concatenate([[0.0], np.geomspace(1e-8, math.pi / 2.0, 600)])
    F11, _, F33, _ = one_point_spectra(k, p, k2_max=math.pi / 2, k3_max=math.pi / 2)
    # Trapezoid error ~ h^2/12 relative with h = ln(1.6e8)/600 = 0.031: ~1e-4.  One-sided spectra:
    # the variance is their integral over k1 >= 0.
    assert np.trapezoid(F33, k) == pytest.approx(grid.ww, rel=5e-4)
    assert np.trapezoid(F11, k) == pytest.approx(grid.uu, rel=5e-4)


def test_against_mannrs_analytic_spectra():
    mannrs = pytest.importorskip("mannrs", reason="peer generator mannrs not installed (test extra)")
    p = MannParameters(1.0, 33.6, 3.9)
    k = np.logspace(-3, 1, 9)
    ours = np.array(one_point_spectra(k, p))
    theirs = np.array(mannrs.mann_spectra(k, 1.0, 33.6, 3.9), dtype=float)  # two-sided
    ratio = 2.0 * theirs / ours
    # mannrs agrees in shape to 0.2 % and is offset by a constant ~0.5 %
    # (a normalisation constant of its own; our Gamma = 0 spectra match the
    # closed forms to 1e-6).
    assert np.all(np.abs(ratio - 1) < 0.01)
    assert np.ptp(ratio) < 0.003


def test_bad_input():
    p = MannParameters(1.0, 33.6, 3.9)
    with pytest.raises(ValueError, match="k1"):
        one_point_spectra([0.1, np.nan], p)
    with pytest.raises(ValueError, match="spacing"):
        covariances(p, (1.0, 0.0, 1.0))
    with pytest.raises(TypeError, match="params"):
        one_point_spectra([0.1], dict(alpha_eps=1))


def test_one_point_quadrature_is_shared_across_alpha_eps_and_split_free():
    """The kept quadrature (L, Gamma only) times alpha_eps is the quadrature itself, at any split or thread count."""
    from cwlidar_sim import _config
    from cwlidar_sim.turbulence import spectra as S

    k1 = np.concatenate([[0.0], np.logspace(-3, 1, 37)])  # 38 rows: tasks of 16, 16 and 6
    p = MannParameters(0.31, 29.0, 3.2)
    q = MannParameters(0.047, 29.0, 3.2)  # other alpha_eps: the same kept quadrature
    S._onepoint_cached.cache_clear()
    Fp = np.array(one_point_spectra(k1, p))
    Fq = np.array(one_point_spectra(k1, q))
    assert S._onepoint_cached.cache_info().hits == 1
    # another L or Gamma is another quadrature, not a kept one
    for other in (MannParameters(0.31, 30.0, 3.2), MannParameters(0.31, 29.0, 3.0)):
        F = np.array(one_point_spectra(k1, other))
        assert np.max(np.abs(F[0, 1:] / Fp[0, 1:] - 1)) > 1e-2
    assert S._onepoint_cached.cache_info().hits == 1
    # uncached, one row at a time and on one thread: every row is computed alone, so the bits agree
    n0 = _config.get_num_threads()
    try:
        _config.set_num_threads(1)
        rows = np.concatenate([S._onepoint_unscaled(k1[i:i + 1], 29.0, 3.2, math.inf, math.inf) for i in range(k1.size)])
    finally:
        _config.set_num_threads(n0)
    for par, F in ((p, Fp), (q, Fq)):
        pre = par.alpha_eps / (4.0 * math.pi) * par.length_scale ** (17.0 / 3.0)
        assert np.array_equal(F, 2.0 * (rows[:, :4] * pre).T)  # one-sided: twice Mann's two-sided quadrature
    # and F scales with alpha_eps (the reason the quadrature may be shared)
    np.testing.assert_allclose(Fq, Fp * (q.alpha_eps / p.alpha_eps), rtol=1e-14)
    # a kept result is read-only: a caller cannot change what the next call gets
    assert not S._onepoint_cached(k1.tobytes(), 29.0, 3.2, math.inf, math.inf).flags.writeable


@pytest.mark.parametrize("gamma, kl", [(3.9, 0.03), (3.9, 3.0), (8.0, 0.03), (8.0, 0.3), (8.0, 1.0)])
def test_sheared_one_point_spectra_against_an_independent_quadrature(gamma, kl):
    """The shear peak (k3 + beta k1 = 0) resolved: within 1e-6 of tests/reference.py's quadrature.

    The reference is numpy only (the tensor with scipy's hyp2f1, a trapezoid rule
    on sinh-mapped axes centred on the peak; converged to 2e-9 here).  The panels
    without the extra edges about the peak were off by up to 1.4e-4 at Gamma = 8.
    """
    L = 18.76
    k1 = kl / L
    ref = reference.mann_one_point(k1, 1.0, L, gamma)  # two-sided
    got = one_point_spectra(np.array([k1]), MannParameters(1.0, L, gamma))[:3]
    for g, r in zip(got, ref):
        assert g[0] == pytest.approx(2.0 * r, rel=1e-6)


@pytest.mark.parametrize("gamma, kl", [(0.0, 0.3), (3.9, 0.03), (8.0, 0.3), (8.0, 1.0)])
def test_coarse_rule_is_within_its_stated_accuracy(gamma, kl):
    L = 18.76
    k1 = kl / L
    ref = reference.mann_one_point(k1, 1.0, L, gamma)  # two-sided
    got = one_point_spectra(np.array([k1]), MannParameters(1.0, L, gamma), rule="coarse")[:3]
    for g, r in zip(got, ref):
        assert g[0] == pytest.approx(2.0 * r, rel=2.5e-4)
    with pytest.raises(ValueError, match="rule"):
        one_point_spectra(np.array([k1]), MannParameters(1.0, L, gamma), rule="fast")
