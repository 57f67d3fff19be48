"""Optics of the focused beam: Rayleigh length, weightings, transfer functions, range cells."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from cwlidar_sim.beam import (
    BeamOptics,
    cdf_exact,
    fourier_exact,
    rayleigh_length,
    transfer_exact,
    transfer_lorentzian,
    truncated_fraction_lorentzian,
    weight_exact,
    weight_lorentzian,
    weight_truncated,
)
from cwlidar_sim.beam.optics import TELESCOPE_RADIUS, WAVELENGTH

Z_AP = math.pi * TELESCOPE_RADIUS**2 / WAVELENGTH  # aperture Rayleigh range, 812 m


def eq3_physical(s, r):
    """Unnormalised 1/w(z)^2 written directly from the Gaussian-beam radius (module notes)."""
    return 1.0 / ((s / r) ** 2 + (r + s) ** 2 / Z_AP**2)


# -- Rayleigh length and parameters -----------------------------------------
def test_rayleigh_length_a2012():
    # A2012: z_R = 5.61 m at r = 67.5 m (quoted to 3 digits -> tolerance half a unit of the last digit)
    opt = BeamOptics(focus=67.5)
    assert abs(opt.rayleigh_length - 5.61) < 0.005
    assert rayleigh_length(67.5) == pytest.approx(opt.rayleigh_length, rel=1e-15)
    # PHYSICS: waist radius about 1.7 mm at 67.5 m
    assert abs(opt.waist_radius - 1.7e-3) < 0.05e-3
    assert opt.optical_wavenumber == pytest.approx(2 * math.pi / 1547.615e-9, rel=1e-15)
    # zR scales as r^2
    np.testing.assert_allclose(rayleigh_length(np.array([67.5, 135.0])), [opt.rayleigh_length, 4 * opt.rayleigh_length])


def test_optics_dict_roundtrip_and_validation():
    opt = BeamOptics(focus=100.0, radius=0.025)
    assert BeamOptics.from_dict(opt.as_dict()) == opt
    assert BeamOptics.from_dict({"focus": 50.0}).wavelength == WAVELENGTH
    with pytest.raises(ValueError, match="unknown key.*'zr'"):
        BeamOptics.from_dict({"focus": 50.0, "zr": 1.0})
    with pytest.raises(ValueError, match="focus"):
        BeamOptics(focus=-1.0)
    with pytest.raises(ValueError, match="radius"):
        BeamOptics(focus=10.0, radius=0.0)
    with pytest.raises(TypeError, match="wavelength"):
        BeamOptics(focus=10.0, wavelength="1.5um")
    with pytest.raises(ValueError, match="focus"):
        rayleigh_length([10.0, 0.0])
    with pytest.raises(ValueError, match="s contains non-finite"):
        weight_lorentzian([0.0, np.nan], 1.0)


# -- normalisation ---------------------------------------------------------------
def test_lorentzian_integrates_to_one():
    zR = 5.61
    total, err = quad(weight_lorentzian, -np.inf, np.inf, args=(zR,), epsabs=1e-13)
    assert abs(total - 1.0) < 1e-9


@pytest.mark.parametrize("r", [10.0, 67.5, 300.0, 1500.0])
def test_exact_integrates_to_one_over_physical_domain(r):
    s0 = -(r**3) / (r**2 + Z_AP**2)  # peak: quad needs a break point there
    a, _ = quad(weight_exact, -r, s0, args=(r,), epsabs=1e-13, limit=200)
    b, _ = quad(weight_exact, s0, np.inf, args=(r,), epsabs=1e-13, limit=200)
    assert abs(a + b - 1.0) < 1e-8
    assert weight_exact(-r - 1e-9, r) == 0.0
    assert cdf_exact(1e12, r) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("r", [10.0, 67.5, 300.0])
def test_exact_matches_gaussian_beam_formula(r):
    # weight_exact is a Cauchy re-expression; it must be proportional to 1/w(z)^2 for s > -r
    s = np.linspace(-r + 1e-3, 5 * r, 2001)
    ratio = weight_exact(s, r) / eq3_physical(s, r)
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)


# -- limits and asymmetry ------------------------------------------------------------
def test_exact_tends_to_lorentzian_for_short_range():
    # The exact form differs from Eq. 4 by a shift s0 ~ -r^3/z_ap^2 (first order in r/z_ap once
    # scaled by zR ~ r^2/z_ap) and by the cut weight arctan(r/z_ap)/pi.  Bound: max|f'| of a unit
    # Lorentzian is 3*sqrt(3)/8 = 0.65, so the peak-normalised error is <= 0.65 r/z_ap + r/(pi z_ap)
    # to first order, i.e. < r/z_ap.
    errs = []
    for r in (2.0, 4.0, 8.0, 16.0):
        zR = rayleigh_length(r)
        s = np.linspace(-20 * zR, 20 * zR, 4001)
        err = np.max(np.abs(weight_exact(s, r) - weight_lorentzian(s, zR))) * math.pi * zR
        assert err < r / Z_AP
        errs.append(err)
    ratios = np.array(errs[1:]) / np.array(errs[:-1])
    # first order in r: doubling r doubles the error (second-order terms are ~ r/z_ap ~ 2 % of it)
    np.testing.assert_allclose(ratios, 2.0, rtol=0.05)


def test_exact_asymmetry_at_long_range():
    r = 300.0
    zR = rayleigh_length(r)
    s = np.array([0.5, 1.0, 2.0]) * zR
    near, far = weight_exact(-s, r), weight_exact(s, r)
    assert np.all(near > far)  # more weight on the lidar side of the focus
    # ratio from the Gaussian-beam formula directly
    np.testing.assert_allclose(near / far, eq3_physical(-s, r) / eq3_physical(s, r), rtol=1e-12)
    assert near[1] / far[1] > 1.5
    # the peak sits at s* = -r^3/(r^2 + z_ap^2) (root of the derivative of the denominator)
    grid = np.linspace(-2 * zR, 2 * zR, 400001)
    s_peak = grid[np.argmax(weight_exact(grid, r))]
    assert abs(s_peak - (-(r**3) / (r**2 + Z_AP**2))) <= grid[1] - grid[0]
    # at short range the same ratio is 1 to within ~4 r/z_ap (shift of the centre by r zR/z_ap)
    r_short = 5.0
    zs = rayleigh_length(r_short)
    q = weight_exact(-zs, r_short) / weight_exact(zs, r_short)
    assert 1.0 < q < 1.0 + 4 * r_short / Z_AP


# -- transfer functions ----------------------------------------------------------------
def test_lorentzian_fourier_transform_is_exponential():
    zR = 5.61
    for k in (0.003, 0.03, 0.1, 0.3, 1.0):
        # phi is even: phi_hat(k) = 2 int_0^inf phi(s) cos(ks) ds, computed by QUADPACK QAWF
        half, _ = quad(weight_lorentzian, 0.0, np.inf, args=(zR,), weight="cos", wvar=k)
        assert abs(2 * half - math.exp(-k * zR)) < 1e-8
        assert transfer_lorentzian(k, zR) == pytest.approx((2 * half) ** 2, abs=1e-8)
    assert transfer_lorentzian(-0.1, zR) == transfer_lorentzian(0.1, zR)


@pytest.mark.parametrize("r", [67.5, 400.0])
def test_exact_fourier_transform_by_direct_quadrature(r):
    # independent route: integrate phi(s) exp(-iks) over s > -r without the Cauchy closed form
    s0 = -(r**3) / (r**2 + Z_AP**2)
    ks = np.array([0.0, 0.005, 0.05, 0.2])
    ph = fourier_exact(ks, r)
    for k, p in zip(ks, ph):
        if k == 0:
            assert p == 1.0
            continue
        re1, _ = quad(weight_exact, -r, s0, args=(r,), weight="cos", wvar=k, limit=400)
        im1, _ = quad(weight_exact, -r, s0, args=(r,), weight="sin", wvar=k, limit=400)
        re2, _ = quad(lambda v: weight_exact(s0 + v, r), 0, np.inf, weight="cos", wvar=k)
        im2, _ = quad(lambda v: weight_exact(s0 + v, r), 0, np.inf, weight="sin", wvar=k)
        direct = (re1 - 1j * im1) + np.exp(-1j * k * s0) * (re2 - 1j * im2)
        assert abs(p - direct) < 1e-7
    np.testing.assert_allclose(transfer_exact(-ks, r), np.abs(ph) ** 2, rtol=1e-12)


def test_exact_transfer_tends_to_lorentzian_for_short_range():
    r = 5.0
    zR = rayleigh_length(r)
    k = np.array([0.1, 1.0, 3.0]) / zR
    # differences are O(r/z_ap) = 0.6 % (normalisation and width) of the transfer value
    np.testing.assert_allclose(transfer_exact(k, r), transfer_lorentzian(k, zR), rtol=3 * r / Z_AP, atol=1e-6)


# -- range cells ------------------------------------------------------------------------
def test_truncated_lorentzian_cells():
    opt = BeamOptics(focus=67.5)
    zR = opt.rayleigh_length
    front = 0.5 + math.atan(opt.focus / zR) / math.pi  # Eq. 4's weight in front of the telescope
    for n in (2.0, 10.0):
        rc = weight_truncated(opt, "lorentzian", span=n, n_cells=101, renormalise=False)
        line = 1 - (2 / math.pi) * math.atan(n)  # Eq. 4 outside +-n z_R
        assert truncated_fraction_lorentzian(n * zR, zR) == pytest.approx(line, rel=1e-12)
        # the weighting is Eq. 4 cut at the telescope and renormalised over s > -r
        assert rc.truncated_fraction == pytest.approx(1 - (1 - line) / front, rel=1e-12)
        assert rc.weight_s.sum() == pytest.approx((1 - line) / front, rel=1e-12)
        # each cell weight is the integral of phi over the cell
        i = 37
        cell, _ = quad(weight_lorentzian, rc.edges[i], rc.edges[i + 1], args=(zR,), epsabs=1e-14)
        assert rc.weight_s[i] == pytest.approx(cell / front, rel=1e-10)
        rn = weight_truncated(opt, "lorentzian", span=n, n_cells=101, renormalise=True)
        assert rn.weight_s.sum() == pytest.approx(1.0, rel=1e-13)
        assert rn.truncated_fraction == rc.truncated_fraction
    # a span beyond the telescope is clipped at s = -r
    rc = weight_truncated(opt, "lorentzian", span=20.0, n_cells=50)
    assert rc.edges[0] == -67.5
    assert rc.truncated_fraction == pytest.approx(
        1 - (math.atan(20.0) + math.atan(67.5 / zR)) / math.pi / front, rel=1e-10
    )


def test_truncated_exact_cells():
    opt = BeamOptics(focus=300.0)
    rc = weight_truncated(opt, "exact", span=3.0, n_cells=60, renormalise=False)
    zR = opt.rayleigh_length
    assert rc.edges[0] == -opt.focus  # 3 zR = 332 m > r: clipped at the telescope
    kept, _ = quad(weight_exact, -300.0, 3 * zR, args=(300.0,), points=[-36.0], epsabs=1e-13, limit=200)
    assert rc.kept_fraction == pytest.approx(kept, rel=1e-9)
    assert rc.truncated_fraction == pytest.approx(1 - kept, rel=1e-8)
    assert rc.weight_s.sum() == pytest.approx(kept, rel=1e-12)


def test_weight_truncated_validation():
    opt = BeamOptics(focus=67.5)
    with pytest.raises(ValueError, match="weighting"):
        weight_truncated(opt, "gaussian")
    with pytest.raises(ValueError, match="span"):
        weight_truncated(opt, span=0.0)
    with pytest.raises(ValueError, match="n_cells"):
        weight_truncated(opt, n_cells=0)
    with pytest.raises(TypeError, match="optics"):
        weight_truncated(67.5)
