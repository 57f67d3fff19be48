"""numba kernel of the general linear theory: ``sum_n w_n g_a^H Phi g_b`` over (k2, k3) nodes, fused.

Imported lazily by :mod:`cwlidar_sim.analysis.linear_theory` (compiles on
first use, then loads from numba's cache; importing the package compiles
nothing).  Per node it forms every look's phase ``exp(i (k.p_l - k1 U t_l))``,
its tabulated probe transform ``conj(phi_hat_l(k.n_l))`` (linear in ln|q|,
the ``_Table`` of the module), its time filter, the transfer vectors
``g_ac = sum_l W_alc e_l`` and adds ``w_n g_a^H Phi_n g_b``, without storing
the (looks x nodes) arrays of the plain numpy path (``linear_theory._accumulate``
with ``fused=False``, the reference the tests compare against to round-off).
Each parallel iteration sums one fixed block of nodes into its own row of
the output; the caller adds the rows in order, so the result does not depend
on the thread count.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._config import NJIT_PARALLEL


@numba.njit(**NJIT_PARALLEL)
def accumulate_kernel(k1, k2_n, k3_n, w_n, phi_n33, a_l, py_l, pz_l, nx_l, ny_l, nz_l, table_l, resp_l, nz_start_l,
                      nz_ac_j, nz_w_j, tab_re_tq, tab_im_tq, tab_lq0_t, tab_inv_t, tab_v0_t, block, out_bab):
    """``out_bab[b] = sum_{n in block b} w_n g_a(k_n)^H Phi_n g_b(k_n)`` (blocks of ``block`` nodes).

    ``a_l = k1 (p_lx - U t_l)``; ``table_l`` the row of the look's probe in
    the tables (-1: a point); ``resp_l`` the look's time filter at
    ``omega = -k1 U`` (complex, 1 when none); the estimator weights of every
    output (all functionals' outputs, looks concatenated) as look l's nonzero
    entries ``j in nz_start_l[l] .. nz_start_l[l + 1] - 1``: weight
    ``nz_w_j[j]`` of component ``nz_ac_j[j] % 3`` in output ``nz_ac_j[j] // 3``
    (in increasing ``a * 3 + c``, the order of the dense loop they replace).
    """
    n_nodes = k2_n.shape[0]
    n_l = a_l.shape[0]
    n_a = out_bab.shape[1]
    n_q = tab_re_tq.shape[1]
    n_blocks = out_bab.shape[0]
    for b in numba.prange(n_blocks):
        g = np.empty((n_a, 3), dtype=np.complex128)
        gf = g.reshape(n_a * 3)
        pg = np.empty((n_a, 3), dtype=np.complex128)
        acc = np.zeros((n_a, n_a), dtype=np.complex128)
        for n in range(b * block, min((b + 1) * block, n_nodes)):
            k2 = k2_n[n]
            k3 = k3_n[n]
            g[:, :] = 0.0
            for ll in range(n_l):
                ph = a_l[ll] + py_l[ll] * k2 + pz_l[ll] * k3
                er = math.cos(ph)
                ei = math.sin(ph)
                t = table_l[ll]
                if t >= 0:
                    q = k1 * nx_l[ll] + k2 * ny_l[ll] + k3 * nz_l[ll]
                    aq = abs(q)
                    u = (math.log(max(aq, 1e-300)) - tab_lq0_t[t]) * tab_inv_t[t]
                    if u < 0.0:
                        fr = tab_v0_t[t].real
                        fi = tab_v0_t[t].imag
                    elif u > n_q - 1:
                        fr = 0.0
                        fi = 0.0
                    else:
                        i = int(u)
                        if i > n_q - 2:
                            i = n_q - 2
                        f = min(max(u - i, 0.0), 1.0)
                        fr = tab_re_tq[t, i] + f * (tab_re_tq[t, i + 1] - tab_re_tq[t, i])
                        fi = tab_im_tq[t, i] + f * (tab_im_tq[t, i + 1] - tab_im_tq[t, i])
                    if q < 0.0:
                        fi = -fi
                    # e *= conj(phi_hat)
                    er, ei = er * fr + ei * fi, ei * fr - er * fi
                rr = resp_l[ll].real
                ri = resp_l[ll].imag
                er, ei = er * rr - ei * ri, er * ri + ei * rr
                e = complex(er, ei)
                for j in range(nz_start_l[ll], nz_start_l[ll + 1]):
                    gf[nz_ac_j[j]] += nz_w_j[j] * e
            for a in range(n_a):
                for c in range(3):
                    pg[a, c] = phi_n33[n, c, 0] * g[a, 0] + phi_n33[n, c, 1] * g[a, 1] + phi_n33[n, c, 2] * g[a, 2]
            wn = w_n[n]
            for a in range(n_a):
                for bb in range(n_a):
                    s = (g[a, 0].conjugate() * pg[bb, 0] + g[a, 1].conjugate() * pg[bb, 1]
                         + g[a, 2].conjugate() * pg[bb, 2])
                    acc[a, bb] += wn * s
        out_bab[b, :, :] = acc
