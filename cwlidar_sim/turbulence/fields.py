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
from .box import _REGION, NOISE_LINE, NOISE_PLANE, _as_dataset, _check_noise_shape, _noise_keys
from .parameters import MannParameters
from .spectra import _one_point_two_sided, half_line_nodes
from .tensor import _check_params, _prefactor, lifetime_table

#: k1 cells nearest 0 whose spectra are cell-averaged (F33 rises steeply there).
_LINE_AVERAGED_CELLS = 16
#: Knots per decade of k1 of the line's local cubics in log-log.  Measured
#: relative error at the modes: <= 2.1e-5 at 20 per decade (L = 10 .. 60 m,
#: Gamma = 0 .. 5; a global spline gave 8e-6 but moves with the grid); it
#: falls like h^4.
_LINE_KNOTS_PER_DECADE = 20


def _sym_sqrt(phi_n33):
    lam, vec = np.linalg.eigh(phi_n33)
    return (vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]) @ np.swapaxes(vec, 1, 2)


def _line_grid(shape, spacing) -> tuple:
    """A line's (n, dx) from ``shape`` (Nx, or (Nx,)) and ``spacing`` (dx, or (dx,)), as a box's or a plane's."""
    if isinstance(shape, (tuple, list, np.ndarray)):
        if len(shape) != 1:
            raise ValueError(f"shape={tuple(shape)!r} has {len(shape)} entries; a line's shape is Nx (or (Nx,))")
        shape = shape[0]
    if isinstance(spacing, (tuple, list, np.ndarray)):
        if len(spacing) != 1:
            raise ValueError(f"spacing={tuple(spacing)!r} has {len(spacing)} entries; a line's spacing is dx "
                             f"(or (dx,)) [m]")
        spacing = spacing[0]
    return check_int("shape", shape, lo=2), check_real("spacing", spacing, lo=0.0, lo_open=True)


def line_spectra(params: MannParameters, shape, spacing):
    """Cross-spectral matrices a line of ``shape`` = n points at ``spacing`` = dx is built from.

    Parameters
    ----------
    params : MannParameters
    shape : int or (int,)
        Number of points n, >= 2.
    spacing : float or (float,)
        Spacing dx [m], > 0.

    Returns
    -------
    k1_k : ndarray
        Wavenumbers 0 .. of the rfft grid [rad/m].
    F_k33 : ndarray
        *One-sided* one-point cross-spectral matrices [m^3 s^-2], like
        :func:`one_point_spectra`'s (the line's variance is the sum of
        ``F_k33 dk1`` over k1 > 0, the Nyquist mode of an even n counted
        half); the line draws each mode at +-k1 from half of it, Mann's
        two-sided matrix.  Interpolated
        from :func:`one_point_spectra` at 20 knots per decade of k1 (on a
        lattice in log k1 shared by all n and dx of the same parameters;
        local cubics, :func:`lattice_pieces`, in log k1 of log F_ii and of
        the correlation coefficient F13 / sqrt(F11 F33); relative error
        < 1e-4, measured <= 2.1e-5), and averaged over each k1 cell for the
        16 cells nearest 0 (8-point Gauss-Legendre on the cubics);
        F_k33[0] = 0 (zero mean).  A mode's value depends on its wavenumber
        and the parameters only, not on n or dx, so lines of one length
        n dx share their spectra where their wavenumbers coincide.  A new
        array on each call (the two-sided tables behind it are cached).
    """
    _check_params(params)
    k, F = _line_spectra(params, *_line_grid(shape, spacing))
    return k, 2.0 * F


_line_knots_lock = threading.Lock()


@functools.lru_cache(maxsize=8)
def _line_knot_store(params):
    # F at knot j (k1 = exp(j h)) for these parameters, filled on demand.
    return {}


def _line_knots(params, x_lo, x_hi):
    """Knots j h around [x_lo, x_hi] (log k1) and (F11, F22, F33, F13) there.

    The knots lie on one lattice in log k1 whatever n and dx, from one below
    the piece holding x_lo to two above the piece holding x_hi (the local
    cubics use four knots), so the periods of a campaign (same parameters,
    new dx) reuse each other's integrals; a knot's value does not depend on
    which call computed it.  Returns (j0, h, F): the first knot's index, the
    lattice step and the values.
    """
    h = math.log(10.0) / _LINE_KNOTS_PER_DECADE
    j0 = math.floor(x_lo / h) - 1
    j1 = math.floor(x_hi / h) + 2
    j = np.arange(j0, j1 + 1)
    store = _line_knot_store(params)
    with _line_knots_lock:
        missing = [int(i) for i in j if int(i) not in store]
    if missing:
        # the quadrature runs on the package's threads (turbulence.spectra)
        vals = np.array(_one_point_two_sided(np.exp(np.array(missing) * h), params)).T
        with _line_knots_lock:
            store.update(zip(missing, vals))
    with _line_knots_lock:
        F = np.array([store[int(i)] for i in j])
    return j0, h, F


def lattice_pieces(v_j, h):
    """Local cubic pieces through the values v_j at the knots x_j = j h.

    Piece i spans [x_(i+1), x_(i+2)] and is the cubic through the four knots
    i .. i + 3 (Lagrange).  Returns the coefficients in scipy's PPoly layout,
    shape (4, len(v_j) - 3, ...), in t = x - x_(i+1): ``coef[0]`` multiplies
    t^3.  Each piece depends on its four knots only, so two tables on the
    same lattice agree wherever they overlap (a global spline's pieces move
    with the table's ends); interpolation error (9/384) h^4 max|f^(4)|, about
    twice a not-a-knot spline's.
    """
    fm, f0, f1, f2 = v_j[:-3], v_j[1:-2], v_j[2:-1], v_j[3:]
    a1 = -fm / 3.0 - f0 / 2.0 + f1 - f2 / 6.0
    a2 = fm / 2.0 - f0 + f1 / 2.0
    a3 = -fm / 6.0 + f0 / 2.0 - f1 / 2.0 + f2 / 6.0
    return np.stack([a3 / h**3, a2 / h**2, a1 / h, f0])


def _eval_pieces(coef, j0, h, x):
    # lattice_pieces of knots j0 .. evaluated at x: piece and t = x - j h come
    # from x and h alone, so any table holding x gives the same bits.
    j = np.floor(x / h).astype(np.int64)
    i = np.clip(j - (j0 + 1), 0, coef.shape[1] - 1)
    t = x - (i + j0 + 1) * h
    c = coef[:, i]
    tt = t.reshape(t.shape + (1,) * (c.ndim - 2))
    return ((c[0] * tt + c[1]) * tt + c[2]) * tt + c[3]


@functools.lru_cache(maxsize=8)
def _line_spectra(params, n, dx):
    """Two-sided :func:`line_spectra` (what the line's modes are drawn from): cached, read-only arrays."""
    dk = 2 * math.pi / (n * dx)
    nh = n // 2 + 1
    k = dk * np.arange(nh)
    F = np.zeros((nh, 3, 3))
    # Knots from the lower edge of the first cell to past the last mode.
    j0, h, Ft = _line_knots(params, math.log(0.5 * dk), math.log(k[-1]))  # 11, 22, 33, 13
    rho = Ft[:, 3] / np.sqrt(Ft[:, 0] * Ft[:, 2])
    coef = lattice_pieces(np.column_stack([np.log(Ft[:, :3]), rho]), h)

    def ev(kk):
        v = _eval_pieces(coef, j0, h, np.log(kk))
        d = np.exp(v[:, :3])
        return np.column_stack([d, v[:, 3] * np.sqrt(d[:, 0] * d[:, 2])])

    Fk = ev(k[1:])
    # Cell averages where the spectra change within a cell; the pieces are as
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


def generate_line(params: MannParameters, shape, spacing, seed: int, *, dtype=np.float32):
    """Generate u, v, w on a line along x.

    The arguments are a box's and a plane's (:func:`generate_box`,
    :func:`generate_plane`) with one axis.

    Parameters
    ----------
    params : MannParameters
    shape : int or (int,)
        Number of points Nx, >= 2.
    spacing : float or (float,)
        Spacing dx [m], > 0.
    seed : int
        Seed, 0 <= seed < 2**63.
    dtype : float32 or float64

    Returns
    -------
    line : xarray.Dataset
        u, v, w [m/s] on dim "x" (x = i dx [m]), periodic, zero mean; their
        expected one-sided one-point spectra are :func:`one_point_spectra`'s
        F_ij(k1) at every k1 the line holds (no lateral truncation at all).

    Notes
    -----
    Grid-consistent: the Fourier coefficient of wavenumber 2 pi s / (n dx)
    depends on the seed, the parameters and that wavenumber only, so two
    lines of one length n dx and one seed agree at every wavenumber they
    share but the Nyquist one (|s| < n / 2 of the shorter; the Nyquist
    mode of an even line holds sqrt(2) times the real part of the draw
    the finer line uses there, see :func:`generate_box`).
    """
    _check_params(params)
    n, dx = _line_grid(shape, spacing)
    seed = check_seed("seed", seed)
    dt = _check_dtype(dtype)
    check_memory(f"a line of {n} points", 3 * (n + 2) * 16)
    from ._kernels import normals_kernel

    k, F = _line_spectra(params, n, dx)
    M = _sym_sqrt(F)
    dk = 2 * math.pi / (n * dx)
    # Mode s >= 0 takes the normals 6 s .. 6 s + 5 of the line's stream: keyed
    # by the wavenumber s dk, the same on every line of length n dx.
    z = np.empty(6 * len(k))
    normals_kernel(*_noise_keys(seed, NOISE_LINE), np.uint64(0), z)
    z = z.reshape(len(k), 3, 2)
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
    cell averages by adaptive 6-point Gauss-Legendre) for |k1| <= 16 dk1.
    Beyond, it is interpolated, separately for each k2 column, by local
    cubics (:func:`lattice_pieces`) in log|k1| on a fixed lattice of 32
    knots per decade of log Phi2_ii and of the correlation coefficients
    Phi2_ij / sqrt(Phi2_ii Phi2_jj): relative error below 1e-4 (measured
    < 5e-6) per component, off-diagonals relative to sqrt(Phi2_ii Phi2_jj).
    The cell averages of the region beyond |k1| = 16 dk1 are interpolated
    the same way along each k2 strip.  Which way a mode is computed, and
    the lattice, depend on the wavenumber spacing only, so planes of one
    physical size get the same matrices at the modes they share.  Only k1 >= 0 is tabulated:
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
        plane_phi_kernel(lo, N1, t.dk1, t.near, t.r1, t.r2, t.j0, t.h, t.coef, t.rj0, t.rh, t.rcoef,
                         scale, phi[lo:hi])

    _config.run_static(tasks, work)
    return phi


#: Knots per decade of |k1| of the plane's tables.  Measured error of a
#: global spline (L = 20 m, Gamma = 3.9, k2 = 0 .. 3 rad/m, k1 over 4.5
#: decades): 2e-5 at 20 per decade, 4e-6 at 30; the local cubics used now,
#: 4.6e-6 at 32 (tests' cases); it falls like h^4.
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
#: Modes per task of the plane generator (any value gives the same plane).
_PLANE_MODES_PER_CHUNK = 1 << 15


@dataclasses.dataclass(frozen=True, eq=False)
class _PlaneTable:
    """Compact tables from which every mode's Phi2 is evaluated (see plane_mode)."""

    dk1: float
    dk2: float
    r1: int
    r2: int
    near: np.ndarray  # (A + 1, Ny//2 + 1, 6), |s1| <= A, direct
    j0: int  # lattice index of the first piece's left knot (x_j = j h, x = log|k1|)
    h: float
    coef: np.ndarray  # (4, pieces, Ny//2 + 1, 6), point values
    rj0: int
    rh: float
    rcoef: np.ndarray  # (4, pieces, r2 + 1, 6), cell averages of the region


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
    kz = _plane_kz(params, dk1, dk2)
    # Direct values up to |s1| = A, local cubics on the lattice beyond: which
    # way a mode is computed depends on its wavenumber only (grid-consistent).
    A = min(a_max, _PLANE_NEAR)
    s1_g, s2_g = np.meshgrid(np.arange(A + 1), np.arange(n2h), indexing="ij")
    cell = (s1_g <= r1) & (s2_g <= r2)
    near = np.empty((A + 1, n2h, 6))
    near[cell] = _direct_cells(params, s1_g[cell] * dk1, s2_g[cell] * dk2, dk1, dk2, kz)
    near[~cell] = _direct_points(params, s1_g[~cell] * dk1, s2_g[~cell] * dk2)
    coef = rcoef = np.zeros((4, 1, 1, 6))
    j0 = rj0 = 0
    h = math.log(10.0) / _PLANE_KNOTS_PER_DECADE
    if A < a_max:
        jk, xk = _lattice_knots((A + 1) * dk1, a_max * dk1, h)
        kk1, kk2 = np.meshgrid(np.exp(xk), dk2 * np.arange(n2h), indexing="ij")
        v = _direct_points(params, kk1.ravel(), kk2.ravel()).reshape(xk.size, n2h, 6)
        coef, j0 = _lattice_coef(v, h), jk + 1
        if r1 > A:
            jk, xk = _lattice_knots((A + 1) * dk1, r1 * dk1, h)
            kk1, kk2 = np.meshgrid(np.exp(xk), dk2 * np.arange(r2 + 1), indexing="ij")
            v = _direct_cells(params, kk1.ravel(), kk2.ravel(), dk1, dk2, kz).reshape(xk.size, r2 + 1, 6)
            rcoef, rj0 = _lattice_coef(v, h), jk + 1
    for a in (near, coef, rcoef):
        a.setflags(write=False)
    return _PlaneTable(dk1, dk2, r1, r2, near, j0, h, coef, rj0, h, rcoef)


def _plane_kz(params, dk1, dk2):
    # |k3| limit of the cell averages: 1e5 times the largest scale of the
    # averaged region (|k_i| <= 3 max(dk)), where Phi's k3 tail is below
    # 1e-20 of the integral; from the wavenumber spacing only, so grids of
    # one physical size average their cells alike.
    return 1e5 * max(1.0 / params.length_scale, _REGION * max(dk1, dk2))


def _lattice_knots(k_lo, k_hi, h):
    """Lattice indices j0 .. j1 (x_j = j h) whose pieces cover log k in [log k_lo, log k_hi]."""
    j0 = math.floor(math.log(k_lo) / h) - 1
    j1 = math.floor(math.log(k_hi) / h) + 2
    return j0, h * np.arange(j0, j1 + 1)


def _lattice_coef(v_jc6, h):
    return np.ascontiguousarray(lattice_pieces(_to_spline_values(v_jc6), h))


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
    kz = _plane_kz(params, dk1, dk2)
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
    Gaussian noise drawn from counters keyed by the mode's signed wavenumber
    indices (see :func:`generate_box`), so the result is the same for any
    thread count, and two planes of one physical size N dx x N dy and one
    seed agree at every wavenumber they share (not at the Nyquist modes:
    the columns k2 = 0 and Nyquist are made Hermitian in k1, the mode with
    s1 > 0 drawn and its mirror its conjugate).
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
    from ._kernels import PLANE_MAX_SHAPE, fill_plane_kernel, hermitian_plane_kernel, plane_noise_kernel

    _check_noise_shape("a plane", shape, PLANE_MAX_SHAPE)

    t = _plane_table(params, shape, spacing)
    scale = _prefactor(params) * math.sqrt(t.dk1 * t.dk2 / 2.0)
    specs = [_fft.empty_halfspectrum(shape, dt) for _ in range(3)]
    key, key_b = _noise_keys(seed, NOISE_PLANE)

    def fill(_w, task):
        lo, hi = task
        # Drawn from counters keyed by the signed wavenumber indices (see
        # _kernels.rng): a mode's noise depends on the seed and its
        # wavenumber only, not on the chunk or the grid.
        noise = np.empty((hi - lo, n2h, 3, 2))
        plane_noise_kernel(key, key_b, lo, N1, noise)
        fill_plane_kernel(specs[0], specs[1], specs[2], lo, noise, t.dk1, t.near, t.r1, t.r2, t.j0, t.h,
                          t.coef, t.rj0, t.rh, t.rcoef, scale)

    _config.run_static(_row_chunks(N1, n2h), fill)
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
