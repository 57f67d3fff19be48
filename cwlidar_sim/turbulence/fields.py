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

import functools
import math

import numpy as np

from .. import _config
from .._validation import check_int, check_memory, check_real, check_seed, check_tuple
from .box import _REGION, _GAUSS_POINTS, _as_dataset
from .parameters import MannParameters
from .spectra import half_line_nodes, one_point_spectra
from .tensor import _check_params, _prefactor, lifetime_table

#: k1 cells nearest 0 whose spectra are cell-averaged (F33 rises steeply there).
_LINE_AVERAGED_CELLS = 16
_LINE_TABLE = 160


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
        Two-sided one-point cross-spectral matrices [m^3 s^-2], averaged over
        each k1 cell for the cells nearest 0 and interpolated (cubic in
        log-log, relative error < 1e-4) elsewhere; F_k33[0] = 0 (zero mean).
        Cached: read-only arrays, shared between calls.
    """
    _check_params(params)
    return _line_spectra(params, check_int("n", n, lo=2), check_real("dx", dx, lo=0.0, lo_open=True))


@functools.lru_cache(maxsize=8)
def _line_spectra(params, n, dx):
    from scipy.interpolate import CubicSpline

    dk = 2 * math.pi / (n * dx)
    nh = n // 2 + 1
    k = dk * np.arange(nh)
    F = np.zeros((nh, 3, 3))
    kt = np.geomspace(0.5 * dk, k[-1] * 1.001, _LINE_TABLE)
    Ft = np.array(one_point_spectra(kt, params)).T  # 11, 22, 33, 13
    rho = Ft[:, 3] / np.sqrt(Ft[:, 0] * Ft[:, 2])
    logs = CubicSpline(np.log(kt), np.log(Ft[:, :3]), axis=0)
    rs = CubicSpline(np.log(kt), rho)
    lk = np.log(k[1:])
    d = np.exp(logs(lk))
    r = rs(lk)
    F[1:, 0, 0], F[1:, 1, 1], F[1:, 2, 2] = d[:, 0], d[:, 1], d[:, 2]
    F[1:, 0, 2] = F[1:, 2, 0] = r * np.sqrt(d[:, 0] * d[:, 2])
    # Cell averages where the spectra change within a cell.
    m = min(_LINE_AVERAGED_CELLS, nh - 1)
    if m > 0:
        gx, gw = np.polynomial.legendre.leggauss(8)
        kk = (k[1 : m + 1, None] + 0.5 * dk * gx[None, :]).ravel()
        Fa = np.array(one_point_spectra(kk, params)).reshape(4, m, 8)
        Fa = (Fa * gw / 2.0).sum(axis=2)
        F[1 : m + 1, 0, 0], F[1 : m + 1, 1, 1], F[1 : m + 1, 2, 2] = Fa[0], Fa[1], Fa[2]
        F[1 : m + 1, 0, 2] = F[1 : m + 1, 2, 0] = Fa[3]
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
        singular origin) and taken at the mode elsewhere.  Cached, read-only.
    """
    _check_params(params)
    shape = check_tuple("shape", shape, 2, lambda nm, v: check_int(nm, v, lo=2))
    spacing = check_tuple("spacing", spacing, 2, lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    return _plane_spectra(params, shape, spacing)


@functools.lru_cache(maxsize=4)
def _plane_spectra(params, shape, spacing):
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
    dmax = max(dk1, dk2)
    r1 = int(min((N1 - 1) // 2, math.floor(_REGION * dmax / dk1 + 1e-9)))
    r2 = int(min((N2 - 1) // 2, math.floor(_REGION * dmax / dk2 + 1e-9)))
    gx, gw = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
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
    phi.setflags(write=False)
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

    Returns
    -------
    plane : xarray.Dataset
        u, v, w [m/s] on dims ("x", "y"), periodic, zero mean.  Its modes
        carry the tensor integrated over all k3, so the plane has no
        vertical truncation: its expected variances are the tensor
        integrated over |k1| <= pi/dx, |k2| <= pi/dy (less the mean cell).
    """
    _check_params(params)
    shape = check_tuple("shape", shape, 2, lambda nm, v: check_int(nm, v, lo=2))
    spacing = check_tuple("spacing", spacing, 2, lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    seed = check_seed("seed", seed)
    z = check_real("z", z)
    dt = _check_dtype(dtype)
    N1, N2 = shape
    check_memory(f"a plane of shape {shape}", N1 * (N2 // 2 + 1) * (9 * 8 + 3 * 16))
    phi = plane_spectra(params, shape, spacing)
    M = _sym_sqrt(phi.reshape(-1, 3, 3)).reshape(phi.shape)
    dk = (2 * math.pi / (N1 * spacing[0])) * (2 * math.pi / (N2 * spacing[1]))
    rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence(seed)))
    zn = rng.standard_normal(phi.shape[:2] + (3, 2))
    c = (zn[..., 0] + 1j * zn[..., 1]) / math.sqrt(2.0)
    spec = math.sqrt(dk) * np.einsum("xyij,xyj->xyi", M, c)
    spec[0, 0] = 0.0
    from ._kernels import hermitian_plane_kernel

    out = []
    for i in range(3):
        s = np.ascontiguousarray(spec[:, :, i])[:, None, :]
        hermitian_plane_kernel(s, 0)
        if N2 % 2 == 0:
            hermitian_plane_kernel(s, N2 // 2)
        out.append((np.fft.irfft2(s[:, 0, :], s=shape) * (N1 * N2)).astype(dt))
    attrs = dict(params.as_dict(), seed=seed, dx=spacing[0], dy=spacing[1], z=z,
                 generator="cwlidar_sim.turbulence.generate_plane")
    return _as_dataset(out, spacing, attrs)


def _check_dtype(dtype):
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise TypeError(f"dtype must be float32 or float64, got {dt}")
    return dt
