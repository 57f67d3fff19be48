"""Cheaper fields than a box: a line along x and a horizontal plane.

A scene whose sensors all lie on one line along the mean wind (a staring
lidar aimed along the wind and a sonic on its beam) needs only u, v, w on that
line; one whose sensors lie in one horizontal plane (a horizontally
misaligned beam) needs only that plane.  Both are generated from spectra of
the tensor integrated over the wavenumbers the field does not resolve, so
neither has the lateral/vertical truncation of a box:

* line: F_ij(k1) = double integral of Phi_ij dk2 dk3 (one-point cross-spectral
  matrix), exact;
* plane: Phi2_ij(k1, k2) = integral of Phi_ij dk3 over all k3.

Both are periodic in their directions, zero-mean, and seeded like boxes.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import threading

import numpy as np

from .. import _config
from .._validation import check_int, check_memory, check_real, check_seed, check_tuple
from .box import _REGION, _as_dataset
from .parameters import MannParameters
from .spectra import half_line_nodes, one_point_spectra
from .tensor import _check_params, _prefactor, lifetime_table

#: k1 cells nearest 0 whose spectra are cell-averaged (F33 rises steeply there).
_LINE_AVERAGED_CELLS = 16
#: Knots per decade of k1 of the line's spline in log-log.  Measured relative
#: error at the modes: <= 8e-6 at 20 per decade (L = 10 .. 60 m, Gamma = 0 ..
#: 5); it falls like h^4.
_LINE_KNOTS_PER_DECADE = 20


def _sym_sqrt(phi_n33):
    lam, vec = np.linalg.eigh(phi_n33)
    return (vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]) @ np.swapaxes(vec, 1, 2)


def line_spectra(params: MannParameters, n: int, dx: float):
    """Cross-spectral matrices a line of n points at spacing dx is built from.

    Returns
    -------
    k1_k : ndarray
        Wavenumbers 0 .. of the rfft grid [rad/m].
    F_k33 : ndarray
        Two-sided one-point cross-spectral matrices [m^3 s^-2]: interpolated
        from :func:`one_point_spectra` at 20 knots per decade of k1 (on a
        lattice in log k1 shared by all n and dx of the same parameters; cubic
        spline in log k1 of log F_ii and of the correlation coefficient
        F13 / sqrt(F11 F33); relative error < 1e-4, about 1e-5 at worst),
        and averaged over each k1 cell for the 16 cells nearest 0 (8-point
        Gauss-Legendre on the spline); F_k33[0] = 0 (zero mean).  Cached:
        read-only arrays, shared between calls.
    """
    _check_params(params)
    return _line_spectra(params, check_int("n", n, lo=2), check_real("dx", dx, lo=0.0, lo_open=True))


def _one_point_parallel(k1_k, params):
    """one_point_spectra in chunks on the configured threads (its kernel releases the GIL)."""
    out = np.empty((4, k1_k.size))
    step = max(1, -(-k1_k.size // 8))

    def work(_w, t):
        lo, hi = t
        out[:, lo:hi] = one_point_spectra(k1_k[lo:hi], params)

    _config.run_static([(i, min(k1_k.size, i + step)) for i in range(0, k1_k.size, step)], work)
    return out


_line_knots_lock = threading.Lock()


@functools.lru_cache(maxsize=8)
def _line_knot_store(params):
    # F at knot j (k1 = exp(j h)) for these parameters, filled on demand.
    return {}


def _line_knots(params, x_lo, x_hi):
    """Knots j h covering [x_lo, x_hi] (log k1) and (F11, F22, F33, F13) there.

    The knots lie on one lattice in log k1 whatever n and dx, so the
    periods of a campaign (same parameters, new dx) reuse each other's
    integrals; a knot's value does not depend on which call computed it.
    """
    h = math.log(10.0) / _LINE_KNOTS_PER_DECADE
    j0 = math.floor(x_lo / h)
    j1 = max(math.ceil(x_hi / h), j0 + 7)
    j = np.arange(j0, j1 + 1)
    store = _line_knot_store(params)
    with _line_knots_lock:
        missing = [int(i) for i in j if int(i) not in store]
    if missing:
        vals = _one_point_parallel(np.exp(np.array(missing) * h), params).T
        with _line_knots_lock:
            store.update(zip(missing, vals))
    with _line_knots_lock:
        F = np.array([store[int(i)] for i in j])
    return j * h, F


@functools.lru_cache(maxsize=8)
def _line_spectra(params, n, dx):
    from scipy.interpolate import CubicSpline

    dk = 2 * math.pi / (n * dx)
    nh = n // 2 + 1
    k = dk * np.arange(nh)
    F = np.zeros((nh, 3, 3))
    # Knots from the lower edge of the first cell to past the last mode.
    xt, Ft = _line_knots(params, math.log(0.5 * dk), math.log(k[-1]))  # 11, 22, 33, 13
    rho = Ft[:, 3] / np.sqrt(Ft[:, 0] * Ft[:, 2])
    spl = CubicSpline(xt, np.column_stack([np.log(Ft[:, :3]), rho]), axis=0)

    def ev(kk):
        v = spl(np.log(kk))
        d = np.exp(v[:, :3])
        return np.column_stack([d, v[:, 3] * np.sqrt(d[:, 0] * d[:, 2])])

    Fk = ev(k[1:])
    # Cell averages where the spectra change within a cell; the spline is as
    # good inside the cells as at the modes (F is smooth in log-log).
    m = min(_LINE_AVERAGED_CELLS, nh - 1)
    if m > 0:
        gx, gw = np.polynomial.legendre.leggauss(8)
        kk = (k[1 : m + 1, None] + 0.5 * dk * gx[None, :]).ravel()
        Fk[:m] = (ev(kk).reshape(m, 8, 4) * (gw / 2.0)[None, :, None]).sum(axis=1)
    F[1:, 0, 0], F[1:, 1, 1], F[1:, 2, 2] = Fk[:, 0], Fk[:, 1], Fk[:, 2]
    F[1:, 0, 2] = F[1:, 2, 0] = Fk[:, 3]
    k.setflags(write=False)
    F.setflags(write=False)
    return k, F


def generate_line(params: MannParameters, n: int, dx: float, seed: int, *, dtype=np.float32):
    """Generate u, v, w on a line along x.

    Parameters
    ----------
    params : MannParameters
    n : int
        Number of points, >= 2.
    dx : float
        Spacing [m], > 0.
    seed : int
        Seed, 0 <= seed < 2**63.
    dtype : float32 or float64

    Returns
    -------
    line : xarray.Dataset
        u, v, w [m/s] on dim "x" (x = i dx [m]), periodic, zero mean; their
        expected two-sided one-point spectra are the tensor's F_ij(k1) at
        every k1 the line holds (no lateral truncation at all).
    """
    _check_params(params)
    n = check_int("n", n, lo=2)
    dx = check_real("dx", dx, lo=0.0, lo_open=True)
    seed = check_seed("seed", seed)
    dt = _check_dtype(dtype)
    check_memory(f"a line of {n} points", 3 * (n + 2) * 16)
    k, F = line_spectra(params, n, dx)
    M = _sym_sqrt(F)
    dk = 2 * math.pi / (n * dx)
    rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence(seed)))
    z = rng.standard_normal((len(k), 3, 2))
    c = (z[..., 0] + 1j * z[..., 1]) / math.sqrt(2.0)
    spec = math.sqrt(dk) * np.einsum("kij,kj->ki", M, c)
    spec[0] = 0.0
    if n % 2 == 0:
        spec[-1] = math.sqrt(2.0) * spec[-1].real
    out = [np.fft.irfft(spec[:, i], n=n) * n for i in range(3)]
    out = [a.astype(dt) for a in out]
    attrs = dict(params.as_dict(), seed=seed, dx=dx, generator="cwlidar_sim.turbulence.generate_line")
    return _as_dataset(out, (dx,), attrs)


def plane_spectra(params: MannParameters, shape, spacing):
    """Spectral matrices Phi2(k1, k2) = integral of Phi dk3 of a plane's modes.

    Returns
    -------
    phi_xy33 : ndarray, shape (Nx, Ny//2 + 1, 3, 3)
        Two-dimensional spectral density [m^4 s^-2] at the modes of the
        half spectrum (k1 by numpy's fftfreq convention, k2 >= 0), averaged
        over the (k1, k2) cell for |k_i| <= 3 max(dk) (adaptive, toward the
        singular origin) and taken at the mode elsewhere; the density is
        two-sided in both k1 and k2 (the variance is its sum over all
        (k1, k2), both signs, times dk1 dk2).  Exactly the matrices
        :func:`generate_plane` draws from.  A new array on each call (the
        compact tables behind it are cached).

    Notes
    -----
    Phi2 is computed directly (Phi integrated over k3 on geometric panels;
    cell averages by adaptive 6-point Gauss-Legendre) for |k1| <= 16 dk1,
    or for every k1 of a short grid.  Elsewhere it is interpolated,
    separately for each k2 column, by a cubic spline in log|k1| on 32 knots
    per decade of log Phi2_ii and of the correlation coefficients
    Phi2_ij / sqrt(Phi2_ii Phi2_jj): relative error below 1e-4 (measured
    < 1e-5) per component, off-diagonals relative to sqrt(Phi2_ii Phi2_jj).
    The cell averages of the region beyond |k1| = 16 dk1 are interpolated
    the same way along each k2 strip.  Only k1 >= 0 is tabulated:
    Phi2(-k1, k2) = S Phi2(k1, k2) S with S = diag(1, -1, 1) (mirror
    symmetry in y of the sheared flow and k -> -k symmetry).
    """
    _check_params(params)
    shape = check_tuple("shape", shape, 2, lambda nm, v: check_int(nm, v, lo=2))
    spacing = check_tuple("spacing", spacing, 2, lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    N1, N2 = shape
    check_memory(f"plane spectra of shape {shape}", N1 * (N2 // 2 + 1) * 9 * 8)
    from ._kernels import plane_phi_kernel

    t = _plane_table(params, shape, spacing)
    phi = np.empty((N1, N2 // 2 + 1, 3, 3))
    scale = _prefactor(params) ** 2
    tasks = _row_chunks(N1, N2 // 2 + 1)

    def work(_w, task):
        lo, hi = task
        plane_phi_kernel(lo, N1, t.dk1, t.near, t.r1, t.r2, t.x0, t.h, t.coef, t.rx0, t.rh, t.rcoef,
                         scale, phi[lo:hi])

    _config.run_static(tasks, work)
    return phi


#: Knots per decade of |k1| of the plane's spline tables.  Measured error of
#: the spline (L = 20 m, Gamma = 3.9, k2 = 0 .. 3 rad/m, k1 over 4.5
#: decades): 2e-5 at 20 per decade, 4e-6 at 30; it falls like h^4.
_PLANE_KNOTS_PER_DECADE = 32
#: Modes with |s1| <= this (k1 = s1 dk1) are computed directly, cells of the
#: averaged region included (the spectra of the thin k1 cells nearest
#: k1 = 0 change fastest there).
_PLANE_NEAR = 16
#: Gauss-Legendre points per axis of the plane's adaptive cell averages.  With
#: the box's 4 the averages jump by up to 5e-5 (relative) where the adaptive
#: subdivision changes from one cell to the next; with 6 they agree with 8
#: points to 2e-7.
_PLANE_GAUSS_POINTS = 6
#: Modes per task of the plane generator: fixes the chunking, hence the
#: random streams, independently of the thread count.
_PLANE_MODES_PER_CHUNK = 1 << 15


@dataclasses.dataclass(frozen=True, eq=False)
class _PlaneTable:
    """Compact tables from which every mode's Phi2 is evaluated (see plane_mode)."""

    dk1: float
    dk2: float
    r1: int
    r2: int
    near: np.ndarray  # (A + 1, Ny//2 + 1, 6), |s1| <= A, direct
    x0: float
    h: float
    coef: np.ndarray  # (4, knots - 1, Ny//2 + 1, 6), point values
    rx0: float
    rh: float
    rcoef: np.ndarray  # (4, knots - 1, r2 + 1, 6), cell averages of the region


def _row_chunks(n_rows, per_row):
    step = max(1, _PLANE_MODES_PER_CHUNK // per_row)
    return [(lo, min(n_rows, lo + step)) for lo in range(0, n_rows, step)]


def _region(shape, dk):
    dmax = max(dk)
    return tuple(int(min((n - 1) // 2, math.floor(_REGION * dmax / d + 1e-9))) for n, d in zip(shape, dk))


def _to_spline_values(v_n6):
    # log of the positive diagonal, and correlation coefficients: both smooth
    # in log|k1|, and the coefficients' error is the error relative to
    # sqrt(Phi_ii Phi_jj) asked of the off-diagonals.
    d = v_n6[..., :3]
    out = np.empty_like(v_n6)
    out[..., :3] = np.log(d)
    out[..., 3] = v_n6[..., 3] / np.sqrt(d[..., 0] * d[..., 2])
    out[..., 4] = v_n6[..., 4] / np.sqrt(d[..., 0] * d[..., 1])
    out[..., 5] = v_n6[..., 5] / np.sqrt(d[..., 1] * d[..., 2])
    return out


def _log_knots(a_lo, a_hi, dk1):
    """Uniform knots in log k1 over [a_lo dk1, a_hi dk1], at least 4."""
    x_lo, x_hi = math.log(a_lo * dk1), math.log(a_hi * dk1)
    n = max(4, int(math.ceil((x_hi - x_lo) / math.log(10.0) * _PLANE_KNOTS_PER_DECADE)) + 1)
    h = (x_hi - x_lo) / (n - 1)
    return x_lo, h, x_lo + h * np.arange(n)


def _spline_coef(x_j, v_jc6):
    from scipy.interpolate import CubicSpline

    return np.ascontiguousarray(CubicSpline(x_j, _to_spline_values(v_jc6), axis=0).c)


def _direct_points(params, k1_n, k2_n):
    """Phi integrated over all k3 at points (k1, k2), without the prefactor."""
    from ._kernels import plane_kernel

    q, w = half_line_nodes(1.0, math.inf)
    tab = lifetime_table()
    out = np.empty((k1_n.size, 6))
    k1_n, k2_n = np.ascontiguousarray(k1_n, float), np.ascontiguousarray(k2_n, float)

    def work(_w, t):
        lo, hi = t
        plane_kernel(k1_n[lo:hi], k2_n[lo:hi], q, w, params.length_scale, params.gamma, tab, out[lo:hi])

    _config.run_static([(i, min(k1_n.size, i + 256)) for i in range(0, k1_n.size, 256)], work)
    return out


def _direct_cells(params, k1c_n, k2c_n, dk1, dk2, kz):
    """Phi integrated over k3 and averaged over (dk1, dk2) cells, without the prefactor."""
    from ._kernels import plane_cells_kernel

    gx, gw = np.polynomial.legendre.leggauss(_PLANE_GAUSS_POINTS)
    tab = lifetime_table()
    out = np.empty((k1c_n.size, 6))
    k1c_n, k2c_n = np.ascontiguousarray(k1c_n, float), np.ascontiguousarray(k2c_n, float)

    def work(_w, t):
        lo, hi = t
        plane_cells_kernel(k1c_n[lo:hi], k2c_n[lo:hi], dk1, dk2, kz, gx, gw, params.length_scale,
                           params.gamma, tab, out[lo:hi])

    _config.run_static([(i, min(k1c_n.size, i + 8)) for i in range(0, k1c_n.size, 8)], work)
    return out


@functools.lru_cache(maxsize=8)
def _plane_table(params, shape, spacing):
    N1, N2 = shape
    d1, d2 = spacing
    dk1, dk2 = 2 * math.pi / (N1 * d1), 2 * math.pi / (N2 * d2)
    n2h = N2 // 2 + 1
    a_max = N1 // 2  # largest |s1| of the grid
    r1, r2 = _region(shape, (dk1, dk2))
    kz = 1e5 * max(1.0 / params.length_scale, math.pi / d1, math.pi / d2)
    # Direct values up to |s1| = A; all of them where a spline would cost more.
    x0, h, xk = _log_knots(_PLANE_NEAR, a_max, dk1) if a_max > _PLANE_NEAR else (0.0, 1.0, np.zeros(0))
    A = a_max if a_max <= _PLANE_NEAR + xk.size else _PLANE_NEAR
    s1_g, s2_g = np.meshgrid(np.arange(A + 1), np.arange(n2h), indexing="ij")
    cell = (s1_g <= r1) & (s2_g <= r2)
    near = np.empty((A + 1, n2h, 6))
    near[cell] = _direct_cells(params, s1_g[cell] * dk1, s2_g[cell] * dk2, dk1, dk2, kz)
    near[~cell] = _direct_points(params, s1_g[~cell] * dk1, s2_g[~cell] * dk2)
    coef = rcoef = np.zeros((4, 1, 1, 6))
    rx0, rh = 0.0, 1.0
    if A < a_max:
        kk1, kk2 = np.meshgrid(np.exp(xk), dk2 * np.arange(n2h), indexing="ij")
        v = _direct_points(params, kk1.ravel(), kk2.ravel()).reshape(xk.size, n2h, 6)
        coef = _spline_coef(xk, v)
        if r1 > A:
            rx0, rh, rk = _log_knots(A, r1, dk1)
            kk1, kk2 = np.meshgrid(np.exp(rk), dk2 * np.arange(r2 + 1), indexing="ij")
            v = _direct_cells(params, kk1.ravel(), kk2.ravel(), dk1, dk2, kz).reshape(rk.size, r2 + 1, 6)
            rcoef = _spline_coef(rk, v)
    for a in (near, coef, rcoef):
        a.setflags(write=False)
    return _PlaneTable(dk1, dk2, r1, r2, near, x0, h, coef, rx0, rh, rcoef)


def _plane_spectra_direct(params, shape, spacing):
    """Reference for :func:`plane_spectra`: every mode integrated directly (slow).

    Each of the Nx (Ny//2 + 1) modes costs one integral over k3 (tens of
    microseconds); kept for tests of the tabulated path.
    """
    from ._kernels import cell_integral, plane_kernel

    N1, N2 = shape
    d1, d2 = spacing
    dk1, dk2 = 2 * math.pi / (N1 * d1), 2 * math.pi / (N2 * d2)
    k1 = 2 * math.pi * np.fft.fftfreq(N1, d1)
    k2 = dk2 * np.arange(N2 // 2 + 1)
    K1, K2 = np.meshgrid(k1, k2, indexing="ij")
    L = params.length_scale
    tab = lifetime_table()
    # Normalised k3 nodes: from 1e-3 to 1e5 x the larger scale of the mode.
    q, w = half_line_nodes(1.0, math.inf)
    flat1, flat2 = K1.ravel().copy(), K2.ravel().copy()
    out = np.empty((flat1.size, 6))
    tasks = [(i, min(flat1.size, i + 4096)) for i in range(0, flat1.size, 4096)]

    def work(_w, t):
        lo, hi = t
        plane_kernel(flat1[lo:hi], flat2[lo:hi], q, w, L, params.gamma, tab, out[lo:hi])

    _config.run_static(tasks, work)
    phi = np.empty((flat1.size, 3, 3))
    phi[:, 0, 0], phi[:, 1, 1], phi[:, 2, 2] = out[:, 0], out[:, 1], out[:, 2]
    phi[:, 0, 2] = phi[:, 2, 0] = out[:, 3]
    phi[:, 0, 1] = phi[:, 1, 0] = out[:, 4]
    phi[:, 1, 2] = phi[:, 2, 1] = out[:, 5]
    phi = phi.reshape(K1.shape + (3, 3))
    # Cell averages near the origin (Phi33 ~ 1/|k|^2 there).
    r1, r2 = _region(shape, (dk1, dk2))
    gx, gw = np.polynomial.legendre.leggauss(_PLANE_GAUSS_POINTS)
    kz = 1e5 * max(1.0 / L, math.pi / d1, math.pi / d2)
    for s1 in range(-r1, r1 + 1):
        for s2 in range(0, r2 + 1):
            acc = np.zeros(6)
            lo = np.array([s1 * dk1 - dk1 / 2, s2 * dk2 - dk2 / 2, -kz])
            hi = np.array([s1 * dk1 + dk1 / 2, s2 * dk2 + dk2 / 2, kz])
            cell_integral(lo, hi, gx, gw, L, params.gamma, tab, acc)
            acc /= dk1 * dk2
            m = np.array([[acc[0], acc[4], acc[3]], [acc[4], acc[1], acc[5]], [acc[3], acc[5], acc[2]]])
            phi[s1 % N1, s2] = m
    phi *= _prefactor(params) ** 2
    return phi


def generate_plane(params: MannParameters, shape, spacing, seed: int, *, z: float = 0.0, dtype=np.float32):
    """Generate u, v, w on a horizontal plane (x, y).

    Parameters
    ----------
    params : MannParameters
    shape : (int, int)
        Points (Nx, Ny), each >= 2.
    spacing : (float, float)
        (dx, dy) [m], > 0.
    seed : int
    z : float
        Nominal height of the plane [m] (stored as an attribute; the tensor
        is homogeneous, so it does not change the statistics).
    dtype : float32 or float64
        Also the precision of the spectra and of the FFT.

    Returns
    -------
    plane : xarray.Dataset
        u, v, w [m/s] on dims ("x", "y"), periodic, zero mean.  Its modes
        carry the tensor integrated over all k3 (:func:`plane_spectra`), so
        the plane has no vertical truncation: its expected variances are
        the tensor integrated over |k1| <= pi/dx, |k2| <= pi/dy (less the
        mean cell).  The arrays are views of the in-place FFT buffers (rows
        padded by two values), so the peak memory is about the output's.

    Notes
    -----
    Each mode gets the Cholesky factor of its spectral matrix times complex
    Gaussian noise; the noise comes in chunks of rows, each from its own
    stream of ``seed``, so the result is the same for any thread count.
    """
    _check_params(params)
    shape = check_tuple("shape", shape, 2, lambda nm, v: check_int(nm, v, lo=2))
    spacing = check_tuple("spacing", spacing, 2, lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    seed = check_seed("seed", seed)
    z = check_real("z", z)
    dt = _check_dtype(dtype)
    N1, N2 = shape
    n2h = N2 // 2 + 1
    check_memory(f"a plane of shape {shape}", 3 * N1 * n2h * 2 * dt.itemsize)
    from .. import _fft
    from ._kernels import fill_plane_kernel, hermitian_plane_kernel

    t = _plane_table(params, shape, spacing)
    scale = _prefactor(params) * math.sqrt(t.dk1 * t.dk2 / 2.0)
    specs = [_fft.empty_halfspectrum(shape, dt) for _ in range(3)]
    ss = np.random.SeedSequence(seed)

    def fill(_w, task):
        ci, (lo, hi) = task
        # One stream per chunk of rows: a mode's noise depends on the seed
        # and the mode only.
        rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence(ss.entropy, spawn_key=(ci,))))
        noise = rng.standard_normal((hi - lo, n2h, 3, 2), dtype=np.float32)
        fill_plane_kernel(specs[0], specs[1], specs[2], lo, noise, t.dk1, t.near, t.r1, t.r2, t.x0, t.h,
                          t.coef, t.rx0, t.rh, t.rcoef, scale)

    _config.run_static(list(enumerate(_row_chunks(N1, n2h))), fill)
    out = []
    for spec in specs:
        spec[0, 0] = 0.0
        # Columns k2 = 0 (and Nyquist) must be Hermitian in k1 for the c2r transform.
        s = spec[:, None, :]
        hermitian_plane_kernel(s, 0)
        if N2 % 2 == 0:
            hermitian_plane_kernel(s, N2 // 2)
        out.append(_fft.irfftn_inplace(spec, N2))
    attrs = dict(params.as_dict(), seed=seed, dx=spacing[0], dy=spacing[1], z=z,
                 generator="cwlidar_sim.turbulence.generate_plane")
    return _as_dataset(out, spacing, attrs)


def _check_dtype(dtype):
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise TypeError(f"dtype must be float32 or float64, got {dt}")
    return dt
