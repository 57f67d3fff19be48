"""Numba kernels of the beam stage: trilinear sampling of a periodic field along beams.

Imported lazily by :mod:`cwlidar_sim.beam.sampling`; importing it compiles
(or loads from cache) the kernels.  Every parallel loop runs over time samples
and writes only that sample's outputs; sums over range cells run serially in
index order inside one iteration, so results do not depend on the thread
count.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._config import NJIT, NJIT_PARALLEL


@numba.njit(**NJIT)
def _index_periodic(f, n):
    """Lower node and fraction of fractional index ``f`` on a periodic axis of ``n`` nodes."""
    f = f - math.floor(f / n) * n
    i = int(math.floor(f))
    t = f - i
    if i >= n:  # f rounded up to n
        i -= n
    i1 = i + 1
    if i1 == n:
        i1 = 0
    return i, i1, t


@numba.njit(**NJIT)
def _index_bounded(f, n):
    """Lower node and fraction on a non-periodic axis; ``f`` was checked to lie in [0, n-1]."""
    if n == 1:
        return 0, 0, 0.0
    i = int(math.floor(f))
    if i < 0:
        i = 0
    if i > n - 2:
        i = n - 2
    t = f - i
    if t < 0.0:
        t = 0.0
    if t > 1.0:
        t = 1.0
    return i, i + 1, t


@numba.njit(**NJIT)
def _interp3(a, i0, i1, j0, j1, k0, k1, tx, ty, tz):
    """Trilinear interpolation of ``a`` between the 8 nodes (i0|i1, j0|j1, k0|k1)."""
    c00 = a[i0, j0, k0] * (1.0 - tx) + a[i1, j0, k0] * tx
    c10 = a[i0, j1, k0] * (1.0 - tx) + a[i1, j1, k0] * tx
    c01 = a[i0, j0, k1] * (1.0 - tx) + a[i1, j0, k1] * tx
    c11 = a[i0, j1, k1] * (1.0 - tx) + a[i1, j1, k1] * tx
    c0 = c00 * (1.0 - ty) + c10 * ty
    c1 = c01 * (1.0 - ty) + c11 * ty
    return c0 * (1.0 - tz) + c1 * tz


@numba.njit(**NJIT)
def _locate(px, py, pz, grid, nx, ny, nz, wrap_y, wrap_z):
    """Nodes and fractions of a point; ``grid`` = (x0, y0, z0, dx, dy, dz)."""
    i0, i1, tx = _index_periodic((px - grid[0]) / grid[3], nx)
    fy = (py - grid[1]) / grid[4]
    if wrap_y and ny > 1:
        j0, j1, ty = _index_periodic(fy, ny)
    else:
        j0, j1, ty = _index_bounded(fy, ny)
    fz = (pz - grid[2]) / grid[5]
    if wrap_z and nz > 1:
        k0, k1, tz = _index_periodic(fz, nz)
    else:
        k0, k1, tz = _index_bounded(fz, nz)
    return i0, i1, j0, j1, k0, k1, tx, ty, tz


@numba.njit(**NJIT_PARALLEL)
def sample_points_kernel(u, v, w, grid, wrap_y, wrap_z, origin, n_tc, range_s, time_t, U, add_mean, vel_tsc, vlos_ts):
    """Velocity at ``origin + range * n(t)`` and time t, field advected at U along +x.

    Writes ``vel_tsc[t, s, :]`` (u, v, w) [m/s] and ``vlos_ts[t, s] = n(t) . vel``.
    """
    nx, ny, nz = u.shape
    n_t = time_t.shape[0]
    n_s = range_s.shape[0]
    for it in numba.prange(n_t):
        ex = n_tc[it, 0]
        ey = n_tc[it, 1]
        ez = n_tc[it, 2]
        shift = U * time_t[it]
        for js in range(n_s):
            a, b, c = vel_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, range_s[js], ex, ey, ez, shift,
                                U, add_mean)
            vel_tsc[it, js, 0] = a
            vel_tsc[it, js, 1] = b
            vel_tsc[it, js, 2] = c
            vlos_ts[it, js] = ex * a + ey * b + ez * c


@numba.njit(inline="always", **NJIT)
def vel_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, r, ex, ey, ez, shift, U, add_mean):
    """(u, v, w) at range ``r`` along the beam, the field shifted by ``shift`` = U t along x."""
    px = origin[0] + r * ex - shift
    py = origin[1] + r * ey
    pz = origin[2] + r * ez
    i0, i1, j0, j1, k0, k1, tx, ty, tz = _locate(px, py, pz, grid, nx, ny, nz, wrap_y, wrap_z)
    a = _interp3(u, i0, i1, j0, j1, k0, k1, tx, ty, tz)
    b = _interp3(v, i0, i1, j0, j1, k0, k1, tx, ty, tz)
    c = _interp3(w, i0, i1, j0, j1, k0, k1, tx, ty, tz)
    if add_mean:
        a += U
    return a, b, c


@numba.njit(inline="always", **NJIT)
def los_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, r, ex, ey, ez, shift, U, add_mean):
    """``n . vel`` at range ``r`` along the beam (see :func:`vel_point`)."""
    a, b, c = vel_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, r, ex, ey, ez, shift, U, add_mean)
    return ex * a + ey * b + ez * c


@numba.njit(**NJIT_PARALLEL)
def los_cells_kernel(u, v, w, grid, wrap_y, wrap_z, origin, n_lc, range_j, fraction_j, ptr_s, weight_s, tail_weight,
                     time_l, U, add_mean, store, vlos_ls, vlos_l):
    """Line-of-sight speed of every range cell of every look, and their weighted sum: every sensor's sampler.

    For look ``l`` (direction ``n_lc[l]``, time ``time_l[l]``, the field
    advected at U along +x) and cell ``s`` with sub-points
    ``j = ptr_s[s] .. ptr_s[s + 1] - 1`` at ranges ``range_j[j]``:
    ``vlos_ls[l, s] = sum_j fraction_j[j] n . vel(origin + range_j[j] n)``
    (:func:`los_point`); with ``tail_weight > 0`` one more column
    ``vlos_ls[l, n_s] = n . (U, 0, 0)`` (``0`` without ``add_mean``: the mean
    wind seen by the weight beyond the span,
    :mod:`cwlidar_sim.beam.cells`).  ``vlos_l[l] = sum_s weight_s[s]
    vlos_ls[l, s] + tail_weight vlos_ls[l, n_s]``, summed in cell order.
    ``store = False`` skips writing ``vlos_ls`` (any shape).
    """
    nx, ny, nz = u.shape
    n_l = time_l.shape[0]
    n_s = weight_s.shape[0]
    for il in numba.prange(n_l):
        ex = n_lc[il, 0]
        ey = n_lc[il, 1]
        ez = n_lc[il, 2]
        shift = U * time_l[il]
        acc = 0.0
        for js in range(n_s):
            vc = 0.0
            for jp in range(ptr_s[js], ptr_s[js + 1]):
                vc += fraction_j[jp] * los_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, range_j[jp],
                                                 ex, ey, ez, shift, U, add_mean)
            acc += weight_s[js] * vc
            if store:
                vlos_ls[il, js] = vc
        if tail_weight > 0.0:
            vt = U * ex if add_mean else 0.0
            acc += tail_weight * vt
            if store:
                vlos_ls[il, n_s] = vt
        vlos_l[il] = acc


def empty_outputs(n_t: int, n_s: int):
    """float64 outputs of :func:`sample_points_kernel`."""
    return np.empty((n_t, n_s, 3)), np.empty((n_t, n_s))
