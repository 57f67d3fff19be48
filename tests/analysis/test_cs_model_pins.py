"""CS's filter model pinned by independent quadrature: its default z_R (at the focus r = z / cos Phi), each
filter, each integral and both ratios, to far better than the 0.005 a user reads off the std ratio."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from reference import cs_model_quadrature, cs_scan_transfer_quadrature

from cwlidar_sim.analysis.cs_model import (
    ZR_COEFFICIENT,
    model_integrals,
    model_ratios,
    probe_transfer,
    scan_transfer,
)

PHI = math.radians(30.0)


@pytest.mark.parametrize("kind", ["boxcar", "rectified_sine", "rectified_cosine"])
def test_each_scan_filter_against_quadrature_of_its_weighting(kind):
    # CS Eqs. 5-7: the weighting's normalised Fourier transform squared, here by Gauss-Legendre in x
    length = 51.2
    k = np.concatenate([[0.0, 1e-5], np.linspace(0.01, 3.0, 301)])
    np.testing.assert_allclose(scan_transfer(k, length, kind), cs_scan_transfer_quadrature(k, length, kind),
                               rtol=1e-9, atol=1e-14)


def test_probe_filter_is_the_lorentzian_power_transfer():
    # CS Eq. 3: a Lorentzian weighting of half-width zR has the amplitude transfer exp(-zR |k|); power exp(-2 zR |k|)
    zr = 2.77
    for k in (0.05, 0.3, 1.0):
        # Fourier integral over the whole line (QAWF), of the unit-area Lorentzian
        amp = 2.0 * quad(lambda s: zr / math.pi / (zr**2 + s**2), 0.0, math.inf, weight="cos", wvar=k)[0]
        assert probe_transfer(k, zr) == pytest.approx(amp**2, rel=1e-7)
    assert probe_transfer(-0.3, zr) == probe_transfer(0.3, zr)


@pytest.mark.parametrize("z", [40.0, 100.0])
def test_default_probe_length_is_cs_coefficient_at_the_focus(z):
    # the series ZephIR's z_R = 0.0013 r^2 with r the focus distance z / cos Phi, not the height
    r = z / math.cos(PHI)
    m = model_integrals(z, 10.0, 1, n_k=400)
    assert ZR_COEFFICIENT == 0.0013
    assert m["rayleigh_length"] == pytest.approx(0.0013 * r * r, rel=1e-12)
    explicit = model_ratios(z, 10.0, 1, rayleigh_length=0.0013 * r * r, n_k=2000)
    assert model_ratios(z, 10.0, 1, n_k=2000) == explicit


@pytest.mark.parametrize("z, U, n", [(40.0, 10.0, 1), (40.0, 10.0, 3), (100.0, 6.0, 1)])
def test_model_integrals_and_ratios_against_independent_quadrature(z, U, n):
    zr = 0.0013 * (z / math.cos(PHI)) ** 2
    ref = cs_model_quadrature(z, U, n, zr)
    got = model_integrals(z, U, n)  # defaults: Kaimal, u* = 1, zR at the focus, 6000 points in ln k
    assert got["l_az"] == pytest.approx(ref["l_az"], rel=1e-12)
    for key in ("lidar_var_u", "hp_u", "hp_v", "hp_w"):
        assert got[key] == pytest.approx(ref[key], rel=1e-6), key
    # the ratios, assembled from the reference: std ratio over the Kaimal u variance 102/33 * 1.5, radial
    # variance with the azimuth-averaged projection sin^2 Phi / 2 (u, v) + cos^2 Phi (w)
    a = 5.0 / 3.0
    var = (102.0 / 33.0 * 1.5, 17.0 / 9.5 * 1.5, 2.1 * 5.3 ** (-1 / a) * (math.pi / a) / math.sin(math.pi / a))
    s2, c2 = math.sin(PHI) ** 2, math.cos(PHI) ** 2
    want_std = math.sqrt(ref["lidar_var_u"] / var[0])
    want_rv = (0.5 * s2 * (ref["hp_u"] + ref["hp_v"]) + c2 * ref["hp_w"]) / (0.5 * s2 * (var[0] + var[1]) + c2 * var[2])
    r = model_ratios(z, U, n)
    assert r["std_ratio"] == pytest.approx(want_std, abs=5e-4)
    assert r["radial_variance_ratio"] == pytest.approx(want_rv, rel=2e-3)


def test_each_component_has_its_own_filter():
    # the along-wind u is seen at the circle's up- and downwind ends (rectified sine), v at its sides (rectified
    # cosine), w everywhere (box-car): swapping any two moves its integral by well over the tolerance above
    z, U, n = 40.0, 10.0, 1
    zr = 0.0013 * (z / math.cos(PHI)) ** 2
    ref = cs_model_quadrature(z, U, n, zr)
    got = model_integrals(z, U, n)
    k = np.geomspace(1e-3, 3.0, 200)
    L = {kind: scan_transfer(k, ref["l_az"], kind) for kind in ("boxcar", "rectified_sine", "rectified_cosine")}
    assert np.max(np.abs(L["rectified_sine"] - L["rectified_cosine"])) > 0.1
    assert np.max(np.abs(L["boxcar"] - L["rectified_cosine"])) > 0.1
    assert got["hp_v"] == pytest.approx(ref["hp_v"], rel=1e-6) and got["hp_w"] == pytest.approx(ref["hp_w"], rel=1e-6)
