"""Line and plane fields against the spectra they are built from."""

import math

import numpy as np
import pytest

from cwlidar_sim.turbulence import (
    MannParameters,
    covariances,
    generate_line,
    generate_plane,
    line_spectra,
    one_point_spectra,
    plane_spectra,
)

P = MannParameters(alpha_eps=1.0, length_scale=33.6, gamma=3.9)
TINY = 1e-7  # a spacing whose grid holds every k2, k3 of interest


def _seed_moments(fields):
    """Per-field variances of u, v, w and u-w covariance, and their mean and standard error."""
    s = np.array([[f.u.values.var(), f.v.values.var(), f.w.values.var(), (f.u.values * f.w.values).mean()]
                  for f in fields])
    return s.mean(axis=0), s.std(axis=0, ddof=1) / math.sqrt(len(s))


def _mult(n):
    m = np.full(n // 2 + 1, 2.0)
    m[0] = 1.0
    if n % 2 == 0:
        m[-1] = 1.0
    return m


def test_line_spectra_sum_to_tensor_variance_without_lateral_truncation():
    n, dx = 4096, 2.0
    k, F = line_spectra(P, n, dx)
    dk = k[1]
    tot = (F * _mult(n)[:, None, None]).sum(axis=0) * dk
    ref = covariances(P, (dx, TINY, TINY))
    # The zero-mean line lacks the k1 cell around 0: integral of F over |k1| < dk/2.
    x = np.linspace(-dk / 2, dk / 2, 41)[1:-1]
    mean_cell = np.array(one_point_spectra(x, P)).mean(axis=1) * dk
    for i, (a, b) in enumerate([(tot[0, 0], ref.uu), (tot[1, 1], ref.vv), (tot[2, 2], ref.ww), (tot[0, 2], ref.uw)]):
        assert (a + mean_cell[i]) / b == pytest.approx(1.0, abs=5e-3)


def test_line_statistics_over_seeds():
    n, dx = 2048, 2.0
    k, F = line_spectra(P, n, dx)
    exp = (F * _mult(n)[:, None, None]).sum(axis=0) * k[1]
    mean, sem = _seed_moments(generate_line(P, n, dx, seed, dtype=np.float64) for seed in range(12))
    e = np.array([exp[0, 0], exp[1, 1], exp[2, 2], exp[0, 2]])
    # Four standard errors of the seed-to-seed scatter (Student t, 11 dof: p < 0.002).
    assert np.all(np.abs(mean - e) < 4 * sem), mean / e


def test_line_periodogram_matches_cross_spectra():
    n, dx = 1024, 1.0
    k, F = line_spectra(P, n, dx)
    per = []
    for seed in range(40):
        line = generate_line(P, n, dx, seed, dtype=np.float64)
        X = [np.fft.rfft(line[c].values) for c in "uvw"]
        per.append([np.abs(X[0]) ** 2, np.abs(X[2]) ** 2, (X[0] * X[2].conj()).real])
    per = np.array(per) / (n**2 * k[1])  # seed, quantity, k
    band = slice(20, 200)
    est = per[:, :, band].mean(axis=2)
    exp = np.array([F[band, 0, 0].mean(), F[band, 2, 2].mean(), F[band, 0, 2].mean()])
    mean, sem = est.mean(axis=0), est.std(axis=0, ddof=1) / math.sqrt(len(est))
    assert np.all(np.abs(mean - exp) < 4 * sem), mean / exp


def test_plane_spectra_sum_to_grid_resolved_without_vertical_truncation():
    shape, spacing = (256, 32), (2.0, 2.0)
    phi = plane_spectra(P, shape, spacing)
    dk = (2 * math.pi / (shape[0] * spacing[0])) * (2 * math.pi / (shape[1] * spacing[1]))
    tot = (phi * _mult(shape[1])[None, :, None, None]).sum(axis=(0, 1)) * dk
    ref = covariances(P, spacing + (TINY,))
    for a, b in [(tot[0, 0], ref.uu), (tot[1, 1], ref.vv), (tot[2, 2], ref.ww), (tot[0, 2], ref.uw)]:
        assert a / b == pytest.approx(1.0, abs=0.01)
    # Symmetric, positive semi-definite spectral matrices.
    flat = phi.reshape(-1, 3, 3)
    assert np.all(np.linalg.eigvalsh(flat).min(axis=1) >= -1e-9 * np.abs(flat).max())


def test_plane_statistics_over_seeds():
    shape, spacing = (256, 32), (2.0, 2.0)
    phi = plane_spectra(P, shape, spacing)
    dk = (2 * math.pi / (shape[0] * spacing[0])) * (2 * math.pi / (shape[1] * spacing[1]))
    mult = _mult(shape[1])[None, :]
    d = phi[..., [0, 1, 2, 0], [0, 1, 2, 2]]
    d[0, 0] = 0.0  # the plane's mean is zero
    exp = (d * mult[..., None]).sum(axis=(0, 1)) * dk
    mean, sem = _seed_moments(generate_plane(P, shape, spacing, seed, dtype=np.float64) for seed in range(10))
    assert np.all(np.abs(mean - exp) < 4 * sem), mean / exp


def test_same_seed_same_field_and_bad_input():
    a = generate_line(P, 100, 1.0, 5)
    assert np.array_equal(a.u.values, generate_line(P, 100, 1.0, 5).u.values)
    assert a.u.dims == ("x",) and a.u.dtype == np.float32
    b = generate_plane(P, (32, 8), (1.0, 1.0), 5, z=80.0)
    assert b.u.dims == ("x", "y") and b.attrs["z"] == 80.0
    assert np.array_equal(b.w.values, generate_plane(P, (32, 8), (1.0, 1.0), 5, z=80.0).w.values)
    with pytest.raises(ValueError, match="n"):
        generate_line(P, 1, 1.0, 0)
    with pytest.raises(ValueError, match="dx"):
        generate_line(P, 10, -1.0, 0)
    with pytest.raises(ValueError, match="spacing"):
        generate_plane(P, (8, 8), (1.0, 0.0), 0)
    with pytest.raises(ValueError, match="shape"):
        generate_plane(P, (8, 8, 8), (1.0, 1.0), 0)
