"""CS's filter model: scan filters on a synthetic field, closed forms vs quadrature, Kaimal integrals."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.cs_model import (
    kaimal_spectra,
    mann_spectra_one_sided,
    model_integrals,
    radial_variance_ratio,
    scan_length,
    scan_transfer,
    std_ratio,
)
from cwlidar_sim.turbulence import MannParameters, isotropic_spectra

SHAPES = {"boxcar": lambda x, l: np.ones_like(x), "rectified_sine": lambda x, l: np.abs(np.sin(np.pi * x / l)),
          "rectified_cosine": lambda x, l: np.abs(np.cos(np.pi * x / l))}


@pytest.mark.parametrize("kind", list(SHAPES))
def test_scan_filter_on_a_synthetic_field(kind):
    # a white random field on a fine periodic grid, averaged with the weighting over |x| <= l/2 (circular
    # convolution): the spectrum ratio filtered/unfiltered is the analytic power transfer function
    rng = np.random.default_rng(0)
    dx, n, length = 0.05, 2**16, 40.0
    field = rng.standard_normal(n)
    m = int(round(length / dx)) | 1
    x = (np.arange(m) - m // 2) * dx
    wts = SHAPES[kind](x, m * dx)
    wts /= wts.sum()
    kern = np.zeros(n)
    kern[np.arange(m) - m // 2] = wts
    filt = np.fft.irfft(np.fft.rfft(field) * np.fft.rfft(kern), n)
    k = 2 * np.pi * np.fft.rfftfreq(n, dx)
    ratio = np.abs(np.fft.rfft(filt)) ** 2 / np.abs(np.fft.rfft(field)) ** 2
    sel = (k > 0) & (k < 30.0 / length)  # many lobes, k dx << 1
    want = scan_transfer(k[sel], m * dx, kind)
    # discretisation of the weighting on the grid: relative O((k dx)^2) plus an absolute floor on the lobes
    np.testing.assert_allclose(ratio[sel], want, rtol=2e-3, atol=2e-6)
    # the filtered variance is the white variance times sum w^2, within 4 sigma of a variance estimated
    # from n / m_eff independent averages (m_eff = 1 / sum w^2)
    g = np.sum(wts**2)
    assert np.var(filt) / np.var(field) == pytest.approx(g, rel=4 * math.sqrt(2 / (n * g)))


@pytest.mark.parametrize("kind", ["rectified_sine", "rectified_cosine"])
def test_closed_forms_against_quadrature(kind):
    length = 55.0
    k = np.array([0.0, 1e-4, 0.3 * np.pi / length, np.pi / length, 2 * np.pi / length, 3.7, 12.0])
    x, w = np.polynomial.legendre.leggauss(600)
    x = 0.25 * length * (x + 1.0)
    w = 0.25 * length * w
    f = SHAPES[kind](x, length)
    ft = np.cos(np.multiply.outer(k, x)) @ (w * f) / np.dot(w, f)
    np.testing.assert_allclose(scan_transfer(k, length, kind), ft**2, rtol=1e-9, atol=1e-15)
    assert scan_transfer(-k, length, kind) == pytest.approx(scan_transfer(k, length, kind))


def test_kaimal_integrals_and_scan_length():
    z = 60.0
    m = model_integrals(z, 10.0, 1, k_lo=1e-9, k_max=1e6, n_k=20000)
    assert m["var_u"] == pytest.approx(102.0 / 33.0 * 1.5, rel=2e-3)
    assert m["var_v"] == pytest.approx(17.0 / 9.5 * 1.5, rel=2e-3)
    a = 5.0 / 3.0
    assert m["var_w"] == pytest.approx(2.1 * 5.3 ** (-1 / a) * (math.pi / a) / math.sin(math.pi / a), rel=2e-3)
    Fu, _, _ = kaimal_spectra(np.array([0.0]), z, 0.5)
    assert Fu[0] == pytest.approx(0.25 * 102.0 * z / (2 * math.pi))
    assert scan_length(z, 10.0, 3) == pytest.approx(2 * z * math.tan(math.radians(30)) + 25.0)
    with pytest.raises(ValueError, match="n_rev=0"):
        scan_length(z, 10.0, 0)


def test_model_trends_and_mann_spectra():
    # CS's qualitative findings hold in the model: ratio below 1, falling with height, 1 s above 3 s
    r = {(z, n): std_ratio(z, 10.0, n, n_k=2000) for z in (40.0, 100.0) for n in (1, 3)}
    assert 0.7 < r[(100.0, 3)] < r[(40.0, 3)] < r[(40.0, 1)] < 1.0 and r[(100.0, 3)] < r[(100.0, 1)]
    assert 0 < radial_variance_ratio(100.0, 10.0, 1, n_k=2000) < radial_variance_ratio(40.0, 10.0, 1, n_k=2000) < 1
    # isotropic Mann (Gamma = 0): the von Karman closed forms, one-sided both
    p = MannParameters(alpha_eps=0.1, length_scale=30.0, gamma=0.0)
    k = np.array([0.003, 0.05, 0.8])
    got = mann_spectra_one_sided(k, p)
    ref = isotropic_spectra(k, p)
    for g, f in zip(got, ref[:3]):
        np.testing.assert_allclose(g, f, rtol=1e-5)
    mm = model_integrals(60.0, 10.0, 1, spectrum="mann", params=p, n_k=2000)
    assert mm["var_u"] == pytest.approx(p.isotropic_variance, rel=0.01)
