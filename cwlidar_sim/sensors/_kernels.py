"""numba kernels of the virtual sensors (imported lazily; compile on first use).

Every parallel loop runs over estimates and writes only that estimate's
outputs; sums over range cells run in a fixed order inside one iteration, so
results do not depend on the thread count.  Plain-Python references are in
``tests/reference.py``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._config import NJIT, NJIT_PARALLEL
from ..beam._kernels import los_point
from ..signal._kernels import cell_cosines_row

@numba.njit(**NJIT_PARALLEL)
def los_cells_kernel(u, v, w, grid, wrap_y, wrap_z, origin, n3, range_s, weight_s, time_e, U, add_mean,
                     vlos_es, vlos_e):
    """Line-of-sight speed of every range cell and their weighted sum, field advected at U along +x.

    ``vlos_es[e, s] = n . vel(origin + range_s[s] n, time_e[e])`` and
    ``vlos_e[e] = sum_s weight_s[s] vlos_es[e, s]``, summed in cell order with
    the arithmetic of :func:`cwlidar_sim.beam._kernels.los_weighted_kernel`
    (so ``vlos_e`` equals :func:`cwlidar_sim.beam.los_average` bit for bit).
    """
    nx, ny, nz = u.shape
    ne = time_e.shape[0]
    ns = range_s.shape[0]
    ex = n3[0]
    ey = n3[1]
    ez = n3[2]
    for it in numba.prange(ne):
        shift = U * time_e[it]
        acc = 0.0
        for js in range(ns):
            vl = los_point(u, v, w, grid, nx, ny, nz, wrap_y, wrap_z, origin, range_s[js], ex, ey, ez, shift, U,
                           add_mean)
            acc += weight_s[js] * vl
            vlos_es[it, js] = vl
        vlos_e[it] = acc


@numba.njit(**NJIT)
def _lag_one(x_s, amp_s, a_d, out_d):
    """One estimate of :func:`lag_sequence_kernel`: the cells' cosine sums, then the fold."""
    n = out_d.shape[0]
    cd = np.empty(n)
    cell_cosines_row(x_s, amp_s, n, n, cd)
    out_d[0] = a_d[0] * cd[0]
    for d in range(1, n):
        out_d[d] = a_d[d] * cd[d] + a_d[n - d] * cd[n - d]


@numba.njit(**NJIT_PARALLEL)
def lag_sequence_kernel(x_es, amp_s, a_d, out_ed):
    """Folded lag sequence of the expected signal spectrum (see :mod:`cwlidar_sim.sensors.lidar`).

    For each estimate e, with ``theta_s = 2 pi x_s / N`` (``x_s`` the cell's
    Doppler frequency in bins, signed, any size: aliasing is the periodicity
    of the cosine),

    ``C(d) = 2 sum_s amp_s cos(theta_s d)``, d = 0..N-1, by the Chebyshev
    recurrence ``y_{d+1} = 2 cos(theta) y_d - y_{d-1}`` started from
    ``y_0 = amp``, ``y_1 = amp cos(theta)`` (exact up to rounding that grows
    at most like ``d^2 eps``), the cells updated together (a vectorisable
    loop) and summed in 8 fixed partial sums (cell 8 b + j into sum j) and a
    fixed tree;

    ``out[e, 0] = a_0 C(0)``, ``out[e, d] = a_d C(d) + a_{N-d} C(N-d)``:
    the lags d and d - N coincide on integer bins, so the real DFT of ``out``
    gives ``S(k) = sum_{|d|<N} a_d C(d) exp(i 2 pi k d / N)``.
    """
    ne = out_ed.shape[0]
    for e in numba.prange(ne):
        _lag_one(x_es[e], amp_s, a_d, out_ed[e])
