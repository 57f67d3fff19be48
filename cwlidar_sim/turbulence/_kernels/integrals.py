"""Integrals of the tensor: one-point spectra on tensor-product nodes, adaptive cell averages
refined toward the singular origin, and the k3 integrals of the plane's spectra."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT
from .tensor import accumulate_phi_at


@numba.njit(**NJIT)
def onepoint_kernel(k1_k, q2_kq, w2_kq, q3_kq, w3_kq, L, gamma, tab, out_k6):
    """Integrate Phi over (k2, k3) on tensor-product nodes, one row per k1.

    ``out_k6[k]`` receives (Phi11, Phi22, Phi33, Phi13, Phi12, Phi23)
    integrated, without the alpha_eps/(4 pi) L^(17/3) factor.
    """
    for ik in range(k1_k.shape[0]):
        acc = np.zeros(6)
        for a in range(q2_kq.shape[1]):
            wa = w2_kq[ik, a]
            if wa == 0.0:
                continue
            for b in range(q3_kq.shape[1]):
                wb = w3_kq[ik, b]
                if wb == 0.0:
                    continue
                accumulate_phi_at(k1_k[ik], q2_kq[ik, a], q3_kq[ik, b], L, gamma, tab, wa * wb, acc)
        for c in range(6):
            out_k6[ik, c] = acc[c]


_MAX_DEPTH = 40
_STACK = 512


@numba.njit(**NJIT)
def _gl_block(lo, hi, gx, gw, L, gamma, tab, acc):
    # Product Gauss-Legendre over one box; acc gets the integral of Phi.
    h0 = 0.5 * (hi[0] - lo[0])
    h1 = 0.5 * (hi[1] - lo[1])
    h2 = 0.5 * (hi[2] - lo[2])
    c0 = 0.5 * (hi[0] + lo[0])
    c1 = 0.5 * (hi[1] + lo[1])
    c2 = 0.5 * (hi[2] + lo[2])
    for a in range(gx.shape[0]):
        for b in range(gx.shape[0]):
            for c in range(gx.shape[0]):
                accumulate_phi_at(c0 + h0 * gx[a], c1 + h1 * gx[b], c2 + h2 * gx[c], L, gamma, tab,
                                  h0 * h1 * h2 * gw[a] * gw[b] * gw[c], acc)


@numba.njit(**NJIT)
def cell_integral(lo0, hi0, gx, gw, L, gamma, tab, acc):
    """Integral of Phi over an axis-aligned box, refined toward k = 0.

    The sheared tensor is bounded but direction-dependent at k = 0 and Phi33
    grows like 1/|k|^2 there (beta -> infinity), so boxes closer to the
    origin than their own size are bisected along their long sides until
    they are not (or are negligibly small).  Elsewhere one product
    Gauss-Legendre block per box suffices: Phi varies on scales >= |k|.
    """
    st_lo = np.empty((_STACK, 3))
    st_hi = np.empty((_STACK, 3))
    st_d = np.empty(_STACK, np.int64)
    st_lo[0, :] = lo0
    st_hi[0, :] = hi0
    st_d[0] = 0
    top = 1
    lo = np.empty(3)
    hi = np.empty(3)
    while top > 0:
        top -= 1
        lo[:] = st_lo[top]
        hi[:] = st_hi[top]
        depth = st_d[top]
        emax = 0.0
        dist2 = 0.0
        for i in range(3):
            e = hi[i] - lo[i]
            if e > emax:
                emax = e
            if lo[i] > 0.0:
                dist2 += lo[i] * lo[i]
            elif hi[i] < 0.0:
                dist2 += hi[i] * hi[i]
        if dist2 >= emax * emax or depth >= _MAX_DEPTH or top + 8 > _STACK:
            _gl_block(lo, hi, gx, gw, L, gamma, tab, acc)
            continue
        # Bisect every side longer than half the longest one.
        nsplit = 0
        split = np.zeros(3, np.bool_)
        for i in range(3):
            if hi[i] - lo[i] > 0.5 * emax:
                split[i] = True
                nsplit += 1
        for child in range(1 << nsplit):
            bit = 0
            for i in range(3):
                if split[i]:
                    mid = 0.5 * (lo[i] + hi[i])
                    if (child >> bit) & 1:
                        st_lo[top, i] = mid
                        st_hi[top, i] = hi[i]
                    else:
                        st_lo[top, i] = lo[i]
                        st_hi[top, i] = mid
                    bit += 1
                else:
                    st_lo[top, i] = lo[i]
                    st_hi[top, i] = hi[i]
            st_d[top] = depth + 1
            top += 1


@numba.njit(**NJIT)
def cell_average_kernel(kc_n3, half_3, gx, gw, L, gamma, tab, out_n33):
    """Phi averaged over the cells centred at kc_n3 with half-widths half_3."""
    lo = np.empty(3)
    hi = np.empty(3)
    for n in range(kc_n3.shape[0]):
        acc = np.zeros(6)
        vol = 1.0
        for i in range(3):
            lo[i] = kc_n3[n, i] - half_3[i]
            hi[i] = kc_n3[n, i] + half_3[i]
            vol *= 2.0 * half_3[i]
        cell_integral(lo, hi, gx, gw, L, gamma, tab, acc)
        for c in range(6):
            acc[c] /= vol
        out_n33[n, 0, 0] = acc[0]
        out_n33[n, 1, 1] = acc[1]
        out_n33[n, 2, 2] = acc[2]
        out_n33[n, 0, 2] = acc[3]
        out_n33[n, 2, 0] = acc[3]
        out_n33[n, 0, 1] = acc[4]
        out_n33[n, 1, 0] = acc[4]
        out_n33[n, 1, 2] = acc[5]
        out_n33[n, 2, 1] = acc[5]


@numba.njit(**NJIT)
def plane_kernel(k1_m, k2_m, q3, w3, L, gamma, tab, out_m6):
    """Phi integrated over k3 on the nodes q3 (scaled per mode), per (k1, k2).

    q3/w3 are normalised nodes on [0, inf) for unit scale; for each mode
    they are stretched by the mode's scale and used for both signs of k3.
    """
    for n in range(k1_m.shape[0]):
        k1 = k1_m[n]
        k2 = k2_m[n]
        kh = math.sqrt(k1 * k1 + k2 * k2)
        sc = kh if 0.0 < kh < 1.0 / L else 1.0 / L
        acc = np.zeros(6)
        for j in range(q3.shape[0]):
            x = q3[j] * sc
            w = w3[j] * sc
            accumulate_phi_at(k1, k2, x, L, gamma, tab, w, acc)
            accumulate_phi_at(k1, k2, -x, L, gamma, tab, w, acc)
        for c in range(6):
            out_m6[n, c] = acc[c]


@numba.njit(**NJIT)
def plane_rows_kernel(k1_m, k2_m, row_m, q3_rj, w3_rj, L, gamma, tab, out_m6):
    """Phi integrated over k3 per (k1, k2) node, on the k3 nodes of the node's row.

    Row ``r = row_m[n]`` of ``q3_rj``, ``w3_rj`` holds absolute k3 nodes
    [rad/m] over the whole line and their weights (zero weights pad a row and
    are skipped), e.g. the one-point quadrature's with its edges about the
    shear peak (:func:`cwlidar_sim.turbulence.spectra._onepoint_nodes`).
    Without the alpha_eps/(4 pi) L^(17/3) factor.
    """
    acc = np.empty(6)
    for n in range(k1_m.shape[0]):
        k1 = k1_m[n]
        k2 = k2_m[n]
        r = row_m[n]
        for c in range(6):
            acc[c] = 0.0
        for j in range(q3_rj.shape[1]):
            w = w3_rj[r, j]
            if w == 0.0:
                continue
            accumulate_phi_at(k1, k2, q3_rj[r, j], L, gamma, tab, w, acc)
        for c in range(6):
            out_m6[n, c] = acc[c]


@numba.njit(**NJIT)
def plane_cells_kernel(k1c_n, k2c_n, dk1, dk2, kz, gx, gw, L, gamma, tab, out_n6):
    """Phi integrated over |k3| <= kz and averaged over (k1, k2) cells.

    Cell n is centred at (k1c_n[n], k2c_n[n]) with widths (dk1, dk2); the
    adaptive ``cell_integral`` does the work.  Without the
    alpha_eps/(4 pi) L^(17/3) factor.
    """
    lo = np.empty(3)
    hi = np.empty(3)
    acc = np.empty(6)
    for n in range(k1c_n.shape[0]):
        lo[0] = k1c_n[n] - 0.5 * dk1
        hi[0] = k1c_n[n] + 0.5 * dk1
        lo[1] = k2c_n[n] - 0.5 * dk2
        hi[1] = k2c_n[n] + 0.5 * dk2
        lo[2] = -kz
        hi[2] = kz
        acc[:] = 0.0
        cell_integral(lo, hi, gx, gw, L, gamma, tab, acc)
        for c in range(6):
            out_n6[n, c] = acc[c] / (dk1 * dk2)


