"""Truncated-aperture beam: the pupil's defocus function against an independent integral, the
untruncated limit, normalisation, transfer function, effective Rayleigh lengths, bad input."""

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import erf, j0

from cwlidar_sim.beam import BeamOptics, fourier_exact, weight_exact
from cwlidar_sim.beam.aperture import (
    TruncatedAperture,
    effective_rayleigh_length,
    fourier_aperture,
    pupil_function,
    transfer_aperture,
    weight_aperture,
)

A2012 = BeamOptics(focus=67.5)
_GX, _GW = np.polynomial.legendre.leggauss(16)


def _composite(a, b, n):
    e = np.linspace(a, b, n + 1)
    h, c = 0.5 * np.diff(e), 0.5 * (e[:-1] + e[1:])
    return (c[:, None] + h[:, None] * _GX).ravel(), (h[:, None] * _GW).ravel()


def w_autocorrelation(M, T, n_xi=100, n_u=50):
    """W(M) of a clipped Gaussian pupil by Parseval: (2 pi)^-3 times the integral of |Gamma|^2 d^2 xi,
    Gamma the pupil's autocorrelation.  With the centre y of the two shifted pupils,
    |Gamma(xi)| = exp(-xi^2 / 2) |integral over the lens |y +- xi/2| <= T of exp(-2 |y|^2 + 2 i M xi y1)|;
    the y2 integral is sqrt(pi/2) erf(sqrt(2) h), h = sqrt(T^2 - (|y1| + xi/2)^2), and y1 = a (1 - u^2),
    a = T - xi/2, removes the square-root edge.  No Hankel transform, no J0: an independent route."""
    xi, wxi = _composite(0.0, 2 * T, n_xi)
    u, wu = _composite(0.0, 1.0, n_u)
    a = (T - xi / 2)[:, None]
    y = a * (1 - u**2)
    h = a * u * np.sqrt(np.clip(2 * T / a - u**2, 0, None))
    f = math.sqrt(math.pi / 2) * np.exp(-2 * y * y) * erf(math.sqrt(2) * h) * 2 * a * u
    G = 2 * np.sum(f * wu * np.cos(2 * M * xi[:, None] * y), axis=1)
    return np.sum(wxi * np.exp(-xi * xi) * G * G * xi) / (4 * math.pi**2)


@pytest.mark.parametrize("T", [0.5, 1.2])
def test_pupil_function_against_the_autocorrelation_integral(T):
    # Table points and points between them (spline), both signs of M, the blocks' edges.
    ap = TruncatedAperture(T)
    for M in (0.0, 0.35, -2.5, 3.3, -7.6, 10.0, -13.25, 19.7):
        ref = w_autocorrelation(M, T)
        # Required 1e-6 relative (measured <= 6e-7 over |M| <= 20; the reference with twice the
        # nodes agrees with itself to 1e-15).
        assert pupil_function(M, ap) == pytest.approx(ref, rel=1e-6), M


def test_pupil_function_tends_to_the_gaussian_as_the_aperture_opens():
    # Untruncated: W = 1 / (32 (1 + M^2)) (closed form).  Clipped at T the focal value loses
    # about the clipped amplitude e^-T^2 (a fraction ~ e^-T^2 of I at v = 0), and far from
    # focus geometric optics gives (1 - e^(-4 T^2)) / (32 M^2).
    M = np.array([0.0, 1.0, -3.0, 12.0])
    g = 1.0 / (32.0 * (1.0 + M * M))
    np.testing.assert_allclose(pupil_function(M, TruncatedAperture()), g, rtol=1e-14)
    dev = [np.abs(pupil_function(M, TruncatedAperture(T)) / g - 1).max() for T in (1.0, 1.5, 1.8)]
    assert dev[0] > dev[1] > dev[2]
    for T, d in zip((1.0, 1.5, 1.8), dev):
        assert d < 4.0 * math.exp(-T * T)
    # Beyond the table (|M| > 20) the continuation (G + c/|M|) / (32 (1 + M^2)): within 0.5 % of
    # the true W at |M| = 60 (stated 0.3 %), which itself approaches geometric optics.
    ref60 = w_autocorrelation(60.0, 1.0, 200, 100)
    assert pupil_function(-60.0, TruncatedAperture(1.0)) == pytest.approx(ref60, rel=5e-3)
    assert ref60 * 32 * 60.0**2 == pytest.approx(1 - math.exp(-4.0), rel=0.02)


def test_spherical_aberration_symmetry_and_reference_quadrature():
    # Conjugating the pupil maps (M, W040) to (-M, -W040) and leaves |I| unchanged.
    a, b = TruncatedAperture(1.2, 0.3), TruncatedAperture(1.2, -0.3)
    M = np.array([0.0, 0.8, -2.2, 6.1])
    np.testing.assert_allclose(pupil_function(M, a), pupil_function(-M, b), rtol=1e-9)
    # Aberration breaks W(M) = W(-M) (which holds without it).
    assert abs(pupil_function(2.0, a) / pupil_function(-2.0, a) - 1) > 1e-3
    # W at one M by nested adaptive quadrature of the Hankel integral (QUADPACK, no table).
    T, w040, M0 = 1.2, 0.3, 1.5

    def I2(v):
        def part(x, imag):
            z = np.exp(-x * x + 1j * (M0 * x * x + 2 * math.pi * w040 * (x / T) ** 4)) * x * j0(v * x)
            return z.imag if imag else z.real

        re = quad(part, 0, T, args=(False,), limit=200, epsabs=1e-13, epsrel=1e-10)[0]
        im = quad(part, 0, T, args=(True,), limit=200, epsabs=1e-13, epsrel=1e-10)[0]
        return re * re + im * im

    ref = quad(lambda v: I2(v) ** 2 * v, 0, 80, limit=400, epsabs=0, epsrel=1e-7)[0]
    assert pupil_function(M0, a) == pytest.approx(ref, rel=1e-5)


def test_untruncated_weight_and_transfer_are_the_exact_gaussian_ones():
    ap = TruncatedAperture()
    for r in (40.0, 67.5, 150.0):
        opt = BeamOptics(focus=r)
        s = np.linspace(-r + 0.01, 40 * opt.rayleigh_length, 3001)
        np.testing.assert_allclose(weight_aperture(s, opt, ap), weight_exact(s, r), rtol=1e-12)
    k = np.array([0.0, 0.01, 0.05, 0.2, 0.6, -0.3])
    np.testing.assert_allclose(fourier_aperture(k, A2012, ap), fourier_exact(k, 67.5), rtol=0, atol=1e-8)
    assert weight_aperture(-67.6, A2012, ap) == 0.0


def test_truncated_weight_integrates_to_one_and_transforms_to_one_at_k0():
    opt = A2012
    ap = TruncatedAperture(1.2)
    r, zR = opt.focus, opt.rayleigh_length

    def phi(x):
        return weight_aperture(x, opt, ap)

    pieces = [(-r, -10 * zR), (-10 * zR, 10 * zR), (10 * zR, 200 * zR)]
    total = sum(quad(phi, a, b, limit=400, epsabs=0, epsrel=1e-11)[0] for a, b in pieces)
    total += quad(phi, 200 * zR, np.inf, limit=400)[0]
    assert total == pytest.approx(1.0, abs=1e-8)
    # The transform's far tail keeps z^-2 and z^-3 beyond 201 r; the dropped z^-4 term is about
    # (2 r / z)^2 of a tail holding 1e-4 of the weight: 3e-8.
    assert abs(fourier_aperture(0.0, opt, ap) - 1.0) < 3e-8
    # The transform against QUADPACK's cosine and sine integrals of the same weighting.
    kk = 0.15
    re = sum(quad(phi, a, b, weight="cos", wvar=kk, limit=400)[0] for a, b in pieces[:2])
    re += quad(lambda x: phi(x + 10 * zR), 0, np.inf, weight="cos", wvar=kk, limlst=200)[0] * math.cos(kk * 10 * zR)
    re -= quad(lambda x: phi(x + 10 * zR), 0, np.inf, weight="sin", wvar=kk, limlst=200)[0] * math.sin(kk * 10 * zR)
    im = -sum(quad(phi, a, b, weight="sin", wvar=kk, limit=400)[0] for a, b in pieces[:2])
    im -= quad(lambda x: phi(x + 10 * zR), 0, np.inf, weight="sin", wvar=kk, limlst=200)[0] * math.cos(kk * 10 * zR)
    im -= quad(lambda x: phi(x + 10 * zR), 0, np.inf, weight="cos", wvar=kk, limlst=200)[0] * math.sin(kk * 10 * zR)
    got = fourier_aperture(kk, opt, ap)
    assert abs(got - complex(re, im)) < 1e-7
    assert transfer_aperture(kk, opt, ap) == pytest.approx(abs(complex(re, im)) ** 2, abs=2e-7)


def test_effective_rayleigh_lengths():
    # Untruncated: the Cauchy density of centre -r^3 / (r^2 + z_ap^2) and half-width
    # r^2 z_ap / (r^2 + z_ap^2) (optics module notes); cutting it at the telescope rescales it only.
    r, zap = A2012.focus, A2012.aperture_rayleigh_length
    e = effective_rayleigh_length(A2012, TruncatedAperture())
    assert e.peak == pytest.approx(-(r**3) / (r * r + zap * zap), abs=1e-6)
    assert e.hwhm == pytest.approx(r * r * zap / (r * r + zap * zap), rel=1e-8)
    assert e.core == pytest.approx(e.hwhm, rel=1e-5)
    # A clipped pupil diffracts: a longer probe volume, the peak pulled toward the lidar, and a
    # transfer function no longer exponential in k.
    e15 = effective_rayleigh_length(A2012, TruncatedAperture(1.5))
    e12 = effective_rayleigh_length(A2012, TruncatedAperture(1.2))
    for f in ("hwhm", "core", "transfer"):
        assert getattr(e12, f) > getattr(e15, f) > 1.1 * getattr(e, f)
    assert e12.peak < e15.peak < e.peak
    assert e15.transfer_rms > 2 * e.transfer_rms


def test_aperture_parameters_and_bad_input():
    ap = TruncatedAperture(1.3, 0.1)
    assert TruncatedAperture.from_dict(ap.as_dict()) == ap
    assert TruncatedAperture.from_dict({}).truncation == math.inf
    assert TruncatedAperture(1.0).transmitted_fraction == pytest.approx(1 - math.exp(-2.0))
    with pytest.raises(ValueError, match="unknown key.*'radius'"):
        TruncatedAperture.from_dict({"radius": 0.02})
    with pytest.raises(ValueError, match="truncation"):
        TruncatedAperture(0.1)
    with pytest.raises(ValueError, match="truncation"):
        TruncatedAperture(7.0)
    with pytest.raises(ValueError, match="spherical_waves"):
        TruncatedAperture(spherical_waves=0.2)
    with pytest.raises(ValueError, match="spherical_waves"):
        TruncatedAperture(1.0, 5.0)
    with pytest.raises(TypeError, match="truncation"):
        TruncatedAperture("wide")
    with pytest.raises(TypeError, match="optics"):
        weight_aperture(0.0, 67.5, ap)
    with pytest.raises(TypeError, match="aperture"):
        weight_aperture(0.0, A2012, 1.3)
    with pytest.raises(ValueError, match="s contains non-finite"):
        weight_aperture([0.0, np.nan], A2012, TruncatedAperture())
    with pytest.raises(ValueError, match="m_max"):
        pupil_function(0.0, ap, m_max=1.0)
