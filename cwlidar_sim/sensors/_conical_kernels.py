"""numba kernels of the conically scanning lidar (imported lazily; compile on first use).

Every parallel loop runs over looks (sub-dwell directions) and writes only
that look's outputs; the sum over range cells runs in cell order inside one
iteration, so results do not depend on the thread count.  The plain-Python
reference is ``tests/reference.py::conical_scan_cells``.
"""

from __future__ import annotations

import numba

from .._config import NJIT_PARALLEL
from ..beam._kernels import los_point


@numba.njit(**NJIT_PARALLEL)
def scan_cells_kernel(u, v, w, grid, wrap_y, wrap_z, origin, n_tc, range_s, weight_s, tail_weight, time_t, U,
                      vlos_ts, vlos_t):
    """Line-of-sight speed of every range cell of every look, and their weighted sum.

    For look ``t`` (direction ``n_tc[t]``, time ``time_t[t]``) and cell ``s``:
    ``vlos_ts[t, s] = n . (U + u, v, w)`` at ``origin + range_s[s] n``, the
    field advected at U along +x (:func:`cwlidar_sim.beam._kernels.los_point`);
    the last column ``vlos_ts[t, ns]`` is the tail cell, ``n . (U, 0, 0)``
    (the mean wind seen by the weight outside the span).  ``vlos_t[t]`` is
    ``sum_s weight_s[s] vlos_ts[t, s] + tail_weight * vlos_ts[t, ns]``, summed
    in cell order.
    """
    nx, ny, nz = u.shape
    nt = time_t.shape[0]
    ns = range_s.shape[0]
    for it in numba.prange(nt):
        ex = n_tc[it, 0]
        ey = n_tc[it, 1]
        ez = n_tc[it, 2]
        shift = U * time_t[it]
        acc = 0.0
        for js in range(ns):
            vl = los_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, range_s[js], ex, ey, ez, shift, U,
                           True)
            acc += weight_s[js] * vl
            vlos_ts[it, js] = vl
        vt = U * ex
        vlos_ts[it, ns] = vt
        acc += tail_weight * vt
        vlos_t[it] = acc
