"""numba kernels of the conditioned fields (see ``conditioning.py``).

Only the arithmetic lives here.  Spectral components are stored in the order
``(11, 22, 33, 13, 12, 23)`` of the generator's kernels.  A field's modes are
addressed as rows ``n1`` (k1 index, numpy's fftfreq order) times a lateral
grid ``(j2, j3)`` in FFT order; a line has the lateral grid (1, 1), a plane
(1, Ny) (its y axis in the ``j3`` slot, the halved one), a box (Ny, Nz).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._config import NJIT
from ._kernels import _box_params_row, _in_region, _row_constants, _signed_index, _wavenumber

#: (i, j) -> position of Phi_ij in the 6-vector (11, 22, 33, 13, 12, 23).
_C6 = np.array([[0, 4, 3], [4, 1, 5], [3, 5, 2]], dtype=np.int64)


@numba.njit(inline="always", **NJIT)
def _mode_phi(k1, k2, k3, s1, s2, s3, rc, L2, gamma, ftab, fbase, corr_33, r1, r2, r3):
    # M M^T (11, 22, 33, 13, 12, 23) of the wave vector (k1, k2, k3) with
    # signed indices (s1, s2, s3), M as fill_box_kernel makes it;
    # rc = _row_constants(k1, k2).
    if _in_region(s1, s2, s3, r1, r2, r3):
        c = corr_33[s1 + r1, s2 + r2, s3 + r3]
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = (c[0, 0], c[0, 1], c[0, 2], c[1, 0], c[1, 1], c[1, 2],
                                                       c[2, 0], c[2, 1], c[2, 2])
    else:
        p0, p1, p2, p3, p4 = _box_params_row(k1, k2, k3, rc[0], rc[1], rc[2], rc[3], rc[4], L2, gamma, ftab,
                                             fbase)
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = (p1 * k2, p3 - p1 * k1, -p0 * k2, -p3 + p2 * k2, -p2 * k1,
                                                       p0 * k1, p4 * k2, -p4 * k1, 0.0)
    return (m00 * m00 + m01 * m01 + m02 * m02, m10 * m10 + m11 * m11 + m12 * m12, m20 * m20 + m21 * m21 + m22 * m22,
            m00 * m20 + m01 * m21 + m02 * m22, m00 * m10 + m01 * m11 + m02 * m12, m10 * m20 + m11 * m21 + m12 * m22)


@numba.njit(**NJIT)
def box_phi_rows_kernel(rows, n_j3, N1, N2, N3, d1, d2, d3, L, gamma, ftab, fbase, corr_33, r1, r2, r3, keep_mean,
                        out_rqj6):
    """M M^T of every mode (n1, j2, j3), j3 < n_j3, as the box generator draws it.

    ``rows`` lists the n1 of the output's rows.  No prefactor, no gain.  The
    rules follow ``fill_box_kernel``: a mode with signed k3 index s3 > 0 is
    drawn with its own amplitude; one with s3 < 0 is the conjugate of the
    stored mode (-n1, -j2, -s3), so it carries that mode's matrix (they
    differ where n1 or j2 is a Nyquist index, which the fftfreq order puts
    at the negative wavenumber); in the planes s3 = 0 and (even Nz) the
    z-Nyquist, of each pair (n1, j2), (-n1, -j2) the member with the smaller
    flat index n1 Ny + j2 is drawn and both carry its matrix, the Nyquist
    plane holding the average of the tensor at k3 = +-pi/dz.  The k = 0 mode
    is zero unless ``keep_mean``.
    """
    L2 = L * L
    dz3 = 2.0 * math.pi / (N3 * d3)
    rc_d = np.empty(5)
    rc_p = np.empty(5)
    for r in range(rows.shape[0]):
        n1 = rows[r]
        m1 = (N1 - n1) % N1
        k1, k1p = _wavenumber(n1, N1, d1), _wavenumber(m1, N1, d1)
        s1, s1p = _signed_index(n1, N1), _signed_index(m1, N1)
        for j2 in range(N2):
            m2 = (N2 - j2) % N2
            k2, k2p = _wavenumber(j2, N2, d2), _wavenumber(m2, N2, d2)
            s2, s2p = _signed_index(j2, N2), _signed_index(m2, N2)
            rc_d[0], rc_d[1], rc_d[2], rc_d[3], rc_d[4] = _row_constants(k1, k2)
            rc_p[0], rc_p[1], rc_p[2], rc_p[3], rc_p[4] = _row_constants(k1p, k2p)
            first = n1 * N2 + j2 <= m1 * N2 + m2
            for j3 in range(n_j3):
                if j3 == 0 and n1 == 0 and j2 == 0 and not keep_mean:
                    for c in range(6):
                        out_rqj6[r, j2, j3, c] = 0.0
                    continue
                # Which stored mode carries this one, and at which k3 (two for the Nyquist average).
                nyq = 2 * j3 == N3
                if nyq or j3 == 0:
                    own = first
                    s3 = j3
                else:
                    own = 2 * j3 < N3
                    s3 = j3 if own else N3 - j3
                if own:
                    a = _mode_phi(k1, k2, dz3 * s3, s1, s2, s3, rc_d, L2, gamma, ftab, fbase, corr_33, r1, r2, r3)
                else:
                    a = _mode_phi(k1p, k2p, dz3 * s3, s1p, s2p, s3, rc_p, L2, gamma, ftab, fbase, corr_33, r1, r2, r3)
                if nyq:
                    if own:
                        b = _mode_phi(k1, k2, -dz3 * s3, s1, s2, -s3, rc_d, L2, gamma, ftab, fbase, corr_33, r1, r2,
                                      r3)
                    else:
                        b = _mode_phi(k1p, k2p, -dz3 * s3, s1p, s2p, -s3, rc_p, L2, gamma, ftab, fbase, corr_33, r1,
                                      r2, r3)
                    for c in range(6):
                        out_rqj6[r, j2, j3, c] = 0.5 * (a[c] + b[c])
                else:
                    for c in range(6):
                        out_rqj6[r, j2, j3, c] = a[c]


@numba.njit(**NJIT)
def lateral_cov_kernel(phi_rq6, wy_an, wzz_bn, pair_b, py, out_rpp6):
    """Sum over the lateral modes of Phi_c(q) w_p(q) conj(w_p'(q)), every row.

    ``w_p(j2, j3) = wy[py[p], j2] * wz[pz[p], j3]``; ``wzz_bn[b, j3]`` is the
    product ``wz[a, j3] conj(wz[a', j3])`` of the z-profile pair ``b =
    pair_b[p, p']``.  out has shape (rows, P, P, 6) (complex) and receives
    all ordered pairs.
    """
    R, N2, N3, _ = phi_rq6.shape
    P = py.shape[0]
    B = wzz_bn.shape[0]
    t = np.empty((B, 6), np.complex128)
    for r in range(R):
        for p in range(P):
            for q in range(P):
                for c in range(6):
                    out_rpp6[r, p, q, c] = 0.0
        for j2 in range(N2):
            for b in range(B):
                for c in range(6):
                    t[b, c] = 0.0
            for j3 in range(N3):
                f0 = phi_rq6[r, j2, j3, 0]
                f1 = phi_rq6[r, j2, j3, 1]
                f2 = phi_rq6[r, j2, j3, 2]
                f3 = phi_rq6[r, j2, j3, 3]
                f4 = phi_rq6[r, j2, j3, 4]
                f5 = phi_rq6[r, j2, j3, 5]
                for b in range(B):
                    z = wzz_bn[b, j3]
                    t[b, 0] += f0 * z
                    t[b, 1] += f1 * z
                    t[b, 2] += f2 * z
                    t[b, 3] += f3 * z
                    t[b, 4] += f4 * z
                    t[b, 5] += f5 * z
            for p in range(P):
                for q in range(P):
                    yy = wy_an[py[p], j2] * np.conj(wy_an[py[q], j2])
                    b = pair_b[p, q]
                    for c in range(6):
                        out_rpp6[r, p, q, c] += yy * t[b, c]


@numba.njit(inline="always", **NJIT)
def _phi_times(phi, r, j2, j3, h0, h1, h2):
    # Phi(mode) @ (h0, h1, h2) with Phi stored as (11, 22, 33, 13, 12, 23).
    f0 = phi[r, j2, j3, 0]
    f1 = phi[r, j2, j3, 1]
    f2 = phi[r, j2, j3, 2]
    f3 = phi[r, j2, j3, 3]
    f4 = phi[r, j2, j3, 4]
    f5 = phi[r, j2, j3, 5]
    return f0 * h0 + f4 * h1 + f3 * h2, f4 * h0 + f1 * h1 + f5 * h2, f3 * h0 + f5 * h1 + f2 * h2


@numba.njit(**NJIT)
def correction_kernel(phi_rq6, rows, wy_an, wz_an, py, pz, g_rp3, N1, mirror, spec_u, spec_v, spec_w):
    """Write Delta_i(q) = sum_c Phi_ic(q) sum_p conj(w_p(q)) g[r, p, c] into the half spectra.

    Row ``n1 = rows[r]`` gets the lateral modes j3 < NH (NH = spec.shape[2]);
    with ``mirror`` (rows 0 < n1 < N1/2 of a field whose half axis is
    lateral) the row N1 - n1 gets the conjugates of the mirrored modes, the
    field being real.  Every mode of the output that a row reaches is
    written by that row only.
    """
    R, N2, N3, _ = phi_rq6.shape
    P = py.shape[0]
    A = wz_an.shape[0]
    NH = spec_u.shape[2]
    y = np.empty((A, 3), np.complex128)
    h = np.empty(3, np.complex128)
    for r in range(R):
        n1 = rows[r]
        do_mirror = mirror and n1 != 0 and 2 * n1 != N1
        m1 = (N1 - n1) % N1
        for j2 in range(N2):
            for a in range(A):
                for c in range(3):
                    y[a, c] = 0.0
            for p in range(P):
                wc = np.conj(wy_an[py[p], j2])
                for c in range(3):
                    y[pz[p], c] += wc * g_rp3[r, p, c]
            m2 = (N2 - j2) % N2
            for j3 in range(N3):
                mj3 = (N3 - j3) % N3
                direct = j3 < NH
                mirrored = do_mirror and mj3 < NH
                if not (direct or mirrored):
                    continue
                for c in range(3):
                    h[c] = 0.0
                for a in range(A):
                    wc = np.conj(wz_an[a, j3])
                    for c in range(3):
                        h[c] += wc * y[a, c]
                du, dv, dw = _phi_times(phi_rq6, r, j2, j3, h[0], h[1], h[2])
                if direct:
                    spec_u[n1, j2, j3] = du
                    spec_v[n1, j2, j3] = dv
                    spec_w[n1, j2, j3] = dw
                if mirrored:
                    spec_u[m1, m2, mj3] = np.conj(du)
                    spec_v[m1, m2, mj3] = np.conj(dv)
                    spec_w[m1, m2, mj3] = np.conj(dw)


@numba.njit(**NJIT)
def point_correction_kernel(phi_rq6, rows, wx_pn, wy_pn, wz_pn, alpha_p3, spec_u, spec_v, spec_w):
    """Delta_i(k) = sum_c Phi_ic(k) sum_p conj(wx_p(n1) wy_p(j2) wz_p(j3)) alpha[p, c] on rows of a half spectrum.

    ``phi_rq6`` holds the rows' modes in the half spectrum's own layout
    (lateral (Ny, NH) for a box).  Cost: about 10 P complex operations per mode.
    """
    R, N2, NH, _ = phi_rq6.shape
    P = alpha_p3.shape[0]
    a = np.empty((P, 3), np.complex128)
    b = np.empty((P, 3), np.complex128)
    h = np.empty(3, np.complex128)
    for r in range(R):
        n1 = rows[r]
        for p in range(P):
            wx = np.conj(wx_pn[p, n1])
            for c in range(3):
                a[p, c] = wx * alpha_p3[p, c]
        for j2 in range(N2):
            for p in range(P):
                wy = np.conj(wy_pn[p, j2])
                for c in range(3):
                    b[p, c] = wy * a[p, c]
            for j3 in range(NH):
                for c in range(3):
                    h[c] = 0.0
                for p in range(P):
                    wz = np.conj(wz_pn[p, j3])
                    for c in range(3):
                        h[c] += wz * b[p, c]
                du, dv, dw = _phi_times(phi_rq6, r, j2, j3, h[0], h[1], h[2])
                spec_u[n1, j2, j3] = du
                spec_v[n1, j2, j3] = dv
                spec_w[n1, j2, j3] = dw
