"""Line and plane fields against the spectra they are built from."""

import math

import numpy as np
import pytest

import reference
from cwlidar_sim import _config
from cwlidar_sim.turbulence import fields
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


def _one_sided(n):
    """Weights of a one-sided spectrum's rfft bins in a variance: 1, the k = 0 and Nyquist bins 1/2."""
    return _mult(n) / 2.0


def test_line_spectra_sum_to_tensor_variance_without_lateral_truncation():
    n, dx = 4096, 2.0
    k, F = line_spectra(P, n, dx)  # one-sided: the variance is their integral over k1 >= 0
    dk = k[1]
    tot = (F * _one_sided(n)[:, None, None]).sum(axis=0) * dk
    ref = covariances(P, (dx, TINY, TINY))
    # The zero-mean line lacks the k1 cell around 0: integral of the one-sided F over 0 <= k1 < dk/2.
    x = np.linspace(-dk / 2, dk / 2, 41)[1:-1]
    mean_cell = np.array(one_point_spectra(x, P)).mean(axis=1) * dk / 2.0
    for i, (a, b) in enumerate([(tot[0, 0], ref.uu), (tot[1, 1], ref.vv), (tot[2, 2], ref.ww), (tot[0, 2], ref.uw)]):
        assert (a + mean_cell[i]) / b == pytest.approx(1.0, abs=5e-3)


def test_line_statistics_over_seeds():
    n, dx = 2048, 2.0
    k, F = line_spectra(P, n, dx)
    exp = (F * _one_sided(n)[:, None, None]).sum(axis=0) * k[1]
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
    per = 2.0 * np.array(per) / (n**2 * k[1])  # one-sided periodogram: seed, quantity, k
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
    with pytest.raises(ValueError, match="shape=1 is out of range"):
        generate_line(P, 1, 1.0, 0)
    with pytest.raises(ValueError, match="spacing=-1.0 is out of range"):
        generate_line(P, 10, -1.0, 0)
    with pytest.raises(ValueError, match="a line's shape is Nx"):
        generate_line(P, (8, 8), 1.0, 0)
    with pytest.raises(ValueError, match="spacing"):
        generate_plane(P, (8, 8), (1.0, 0.0), 0)
    with pytest.raises(ValueError, match="shape"):
        generate_plane(P, (8, 8, 8), (1.0, 1.0), 0)


def _rel_err(a_xy33, b_xy33):
    """Per-component error of a against b, relative to sqrt(b_ii b_jj)."""
    d = np.sqrt(np.einsum("...ii->...i", b_xy33))
    return np.abs(a_xy33 - b_xy33) / (d[..., :, None] * d[..., None, :])


@pytest.mark.parametrize("params, shape, spacing", [
    (MannParameters(0.1, 20.0, 3.9), (2048, 16), (0.5, 2.0)),
    (MannParameters(1.0, 10.0, 5.0), (1024, 32), (0.25, 0.5)),
])
def test_plane_spectra_table_matches_direct_integration(params, shape, spacing):
    fast = plane_spectra(params, shape, spacing)
    # The direct path integrates every mode, k1 < 0 included, so this also
    # checks the symmetry Phi2(-k1, k2) = S Phi2(k1, k2) S the tables rely on.
    direct = fields._plane_spectra_direct(params, shape, spacing)
    t = fields._plane_table(params, shape, spacing)
    # Both splines are in use: point values beyond the directly computed
    # |k1| <= 16 dk1, and cell averages of the region beyond it.
    assert t.near.shape[0] == 17 and t.coef.shape[1] > 3 and t.r1 > 16 and t.rcoef.shape[1] > 3
    # Required accuracy of the interpolation: 1e-4 relative (the spline's
    # own error is a few 1e-6 at 32 knots per decade; the direct cell
    # averages agree with 8-point quadrature to 2e-7).
    assert _rel_err(fast, direct).max() < 1e-4


def test_plane_quadrant_cross_spectra_over_seeds():
    # Phi2_12 and Phi2_23 are odd in k1: the generator must give them
    # opposite signs in the quadrants k1 > 0 and k1 < 0 (a variance test
    # cannot see this, the two quadrants cancel).
    shape, spacing = (256, 32), (2.0, 2.0)
    N1, N2 = shape
    phi = plane_spectra(P, shape, spacing)
    dk = (2 * math.pi / (N1 * spacing[0])) * (2 * math.pi / (N2 * spacing[1]))
    quads = [slice(1, N1 // 2), slice(N1 // 2 + 1, N1)]
    q2 = slice(1, N2 // 2)
    pairs = [(0, 1), (1, 2)]
    exp = np.array([phi[q, q2, i, j].sum() * dk for i, j in pairs for q in quads])
    est = []
    for seed in range(12):
        f = generate_plane(P, shape, spacing, seed, dtype=np.float64)
        X = [np.fft.rfft2(f[c].values) / (N1 * N2) for c in "uvw"]
        est.append([(X[i][q, q2] * X[j][q, q2].conj()).real.sum() for i, j in pairs for q in quads])
    est = np.array(est)
    mean, sem = est.mean(axis=0), est.std(axis=0, ddof=1) / math.sqrt(len(est))
    assert np.all(np.sign(exp[[0, 2]]) == -np.sign(exp[[1, 3]]))
    assert np.all(np.abs(exp) > 6 * sem)  # the test can see the sign
    # Four standard errors of the seed-to-seed scatter (Student t, 11 dof: p < 0.002).
    assert np.all(np.abs(mean - exp) < 4 * sem), (mean, exp)


def test_plane_fill_kernel_against_reference():
    from cwlidar_sim.turbulence._kernels import fill_plane_kernel

    shape, spacing = (1024, 8), (0.5, 2.0)
    N1, n2h = shape[0], shape[1] // 2 + 1
    t = fields._plane_table(P, shape, spacing)
    # The reference gets the matrices plane_spectra reports (prefactor taken
    # out again); the kernel evaluates the tables itself.  Rows with k1 > 0
    # and k1 < 0 crossing |s1| = r1 = 96, so both splines are used.
    phi = plane_spectra(P, shape, spacing) / fields._prefactor(P) ** 2
    assert t.r1 == 96 and t.coef.shape[1] > 3
    rng = np.random.default_rng(3)
    specs = [np.zeros((N1, n2h), complex) for _ in range(3)]
    for lo in (80, N1 - 110):
        noise = rng.standard_normal((32, n2h, 3, 2)).astype(np.float32)
        fill_plane_kernel(*specs, lo, noise, t.dk1, t.near, t.r1, t.r2, t.j0, t.h, t.coef, t.rj0, t.rh,
                          t.rcoef, 0.7)
        ref = reference.turbulence_fill_plane(phi, noise, lo, 0.7)
        got = np.array([s[lo : lo + 32] for s in specs])
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_chol3_semidefinite():
    from cwlidar_sim.turbulence._kernels import chol3

    rng = np.random.default_rng(0)
    m = np.empty((3, 3))
    for rank in (3, 2, 1):
        a = rng.standard_normal((3, rank))
        p33 = a @ a.T
        p = np.array([p33[0, 0], p33[1, 1], p33[2, 2], p33[0, 2], p33[0, 1], p33[1, 2]])
        chol3(p, m)
        assert np.all(np.triu(m, 1) == 0.0)
        # Rank-deficient matrices (pivots at rounding level) keep m m^T = P.
        np.testing.assert_allclose(m @ m.T, p33, atol=1e-7 * np.abs(p33).max())


def test_plane_and_line_independent_of_thread_count():
    params = MannParameters(0.5, 25.0, 3.0)
    shape, spacing = (8192, 16), (0.5, 2.0)  # several noise chunks
    before = _config.get_num_threads()
    res = []
    try:
        for nt in (1, 2):
            _config.set_num_threads(nt)
            fields._plane_table.cache_clear()
            fields._line_spectra.cache_clear()
            fields._line_knot_store.cache_clear()
            p = generate_plane(params, shape, spacing, 11)
            ln = generate_line(params, 4096, 0.7, 11)
            res.append([p.u.values, p.v.values, p.w.values, ln.u.values, ln.w.values])
    finally:
        _config.set_num_threads(before)
    for a, b in zip(*res):
        assert np.array_equal(a, b)


def test_line_spectra_spline_matches_direct_integration():
    params = MannParameters(1.0, 10.0, 5.0)
    n, dx = 8192, 1.0
    k, F = line_spectra(params, n, dx)
    idx = np.unique(np.geomspace(17, n // 2, 30).astype(int))
    Fd = np.array(one_point_spectra(k[idx], params))
    # Cell averages of the 16 cells nearest 0 (8-point Gauss-Legendre).
    gx, gw = np.polynomial.legendre.leggauss(8)
    kk = (k[1:17, None] + 0.5 * k[1] * gx).ravel()
    Fc = (np.array(one_point_spectra(kk, params)).reshape(4, 16, 8) * gw / 2).sum(axis=2)
    for got, ref in [(F[idx], Fd), (F[1:17], Fc)]:
        err = np.abs([got[:, 0, 0] / ref[0] - 1, got[:, 1, 1] / ref[1] - 1, got[:, 2, 2] / ref[2] - 1,
                      (got[:, 0, 2] - ref[3]) / np.sqrt(ref[0] * ref[2])])
        # Required: 1e-4 relative (measured <= 8e-6 at 20 knots per decade).
        assert err.max() < 1e-4


def test_line_plane_and_box_take_the_same_arguments():
    """One signature for the three fields: (params, shape, spacing, seed), by position or by keyword."""
    import inspect

    from cwlidar_sim.turbulence import generate_box, line_spectra, plane_spectra
    from cwlidar_sim.turbulence.conditioning import conditioned_line, conditioned_plane

    for fn in (generate_line, generate_plane, generate_box, conditioned_line, conditioned_plane):
        assert list(inspect.signature(fn).parameters)[:4] == ["params", "shape", "spacing", "seed"], fn.__name__
    assert list(inspect.signature(line_spectra).parameters) == list(inspect.signature(plane_spectra).parameters)
    a = generate_line(params=P, shape=64, spacing=2.0, seed=3)
    assert np.array_equal(a.u.values, generate_line(P, (64,), (2.0,), 3).u.values)
    assert a.sizes["x"] == 64 and float(a.x[1] - a.x[0]) == 2.0
