"""Box generator kernels: the half spectra filled mode by mode with their noise, the
expected one-point spectra, the Hermitian planes."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT
from .fast_tensor import _box_params_row, _nyquist_row, _row_constants, box_params
from .rng import _row_normals, box_row_counter
from .tensor import _accumulate_phi, matrix_from_params


@numba.njit(**NJIT)
def _wavenumber(n, N, d):
    # numpy.fft.fftfreq convention: index N/2 (even N) is the negative Nyquist.
    if 2 * n < N:
        return 2.0 * math.pi * n / (N * d)
    return 2.0 * math.pi * (n - N) / (N * d)


@numba.njit(**NJIT)
def _signed_index(n, N):
    if 2 * n < N:
        return n
    return n - N


@numba.njit(**NJIT)
def _in_region(s1, s2, n3, r1, r2, r3):
    return abs(s1) <= r1 and abs(s2) <= r2 and abs(n3) <= r3


@numba.njit(**NJIT)
def box_amplitude(n1, n2, n3, N1, N2, N3, d1, d2, d3, L, gamma, ftab, fbase, corr_33, r1, r2, r3, m):
    """Amplitude matrix of mode (n1, n2, n3) of the box, corrected or not.

    ``n3`` is a signed index here (the half spectrum stores n3 >= 0; the
    expected-spectrum kernel also needs n3 < 0).  Modes with
    |signed n_i| <= r_i take the precomputed ``corr_33`` matrix.
    """
    s1 = _signed_index(n1, N1)
    s2 = _signed_index(n2, N2)
    if _in_region(s1, s2, n3, r1, r2, r3):
        for i in range(3):
            for j in range(3):
                m[i, j] = corr_33[s1 + r1, s2 + r2, n3 + r3, i, j]
        return
    k1 = _wavenumber(n1, N1, d1)
    k2 = _wavenumber(n2, N2, d2)
    k3 = 2.0 * math.pi * n3 / (N3 * d3)
    s12, kh, r21, inv_s12, inv_s12kh = _row_constants(k1, k2)
    p0, p1, p2, p3, p4 = _box_params_row(k1, k2, k3, s12, kh, r21, inv_s12, inv_s12kh, L * L, gamma, ftab, fbase)
    matrix_from_params(p0, p1, p2, p3, p4, k1, k2, m)


@numba.njit(inline="always", **NJIT)
def _mode_out(m00, m01, m02, m10, m11, m12, m20, m21, m22, z, j, g0, g1, g2, spec_u, spec_v, spec_w, n1, n2, n3):
    # Store g_i sum_j M_ij (a_j + i b_j) with (a_0, b_0, .., b_2) = z[j:j + 6].
    a0 = z[j]
    b0 = z[j + 1]
    a1 = z[j + 2]
    b1 = z[j + 3]
    a2 = z[j + 4]
    b2 = z[j + 5]
    spec_u[n1, n2, n3] = complex(g0 * (m00 * a0 + m01 * a1 + m02 * a2), g0 * (m00 * b0 + m01 * b1 + m02 * b2))
    spec_v[n1, n2, n3] = complex(g1 * (m10 * a0 + m11 * a1 + m12 * a2), g1 * (m10 * b0 + m11 * b1 + m12 * b2))
    spec_w[n1, n2, n3] = complex(g2 * (m20 * a0 + m21 * a1 + m22 * a2), g2 * (m20 * b0 + m21 * b1 + m22 * b2))


@numba.njit(**NJIT)
def stencil_kernel(n1_lo, n1_hi, N1, N2, N3, d1, d2, d3, L, gamma, ftab, fbase, out_x5):
    """Amplitude parameters of rows n1_lo..n1_hi-1 for n2 = 0..N2/2, all n3 >= 0.

    out has shape (rows, N2//2 + 1, N3//2 + 1, 5), float32 is enough: the
    parameters only scale Gaussian noise.
    """
    p = np.empty(5)
    for n1 in range(n1_lo, n1_hi):
        k1 = _wavenumber(n1, N1, d1)
        for n2 in range(N2 // 2 + 1):
            k2 = _wavenumber(n2, N2, d2)
            for n3 in range(N3 // 2 + 1):
                box_params(k1, k2, 2.0 * math.pi * n3 / (N3 * d3), L, gamma, ftab, fbase, p)
                for c in range(5):
                    out_x5[n1 - n1_lo, n2, n3, c] = p[c]


_SQRT2 = math.sqrt(2.0)


@numba.njit(inline="always", **NJIT)
def _hermitian_partner(spec_u, spec_v, spec_w, n1, n2, n3, q1, q2):
    # In a plane n3 = 0 or Nyquist, after mode (n1, n2) is written: its
    # partner (q1, q2) = (-n1, -n2) gets the conjugate, or, if it is the mode
    # itself, the mode becomes sqrt(2) times its real part (all the
    # variance in one real number).  Same arithmetic as hermitian_plane_kernel.
    if q1 == n1 and q2 == n2:
        spec_u[n1, n2, n3] = _SQRT2 * spec_u[n1, n2, n3].real
        spec_v[n1, n2, n3] = _SQRT2 * spec_v[n1, n2, n3].real
        spec_w[n1, n2, n3] = _SQRT2 * spec_w[n1, n2, n3].real
    else:
        spec_u[q1, q2, n3] = spec_u[n1, n2, n3].conjugate()
        spec_v[q1, q2, n3] = spec_v[n1, n2, n3].conjugate()
        spec_w[q1, q2, n3] = spec_w[n1, n2, n3].conjugate()


@numba.njit(**NJIT)
def fill_box_kernel(spec_u, spec_v, spec_w, n1_lo, n1_hi, N3, d1, d2, d3, L, gamma, ftab, fbase,
                    corr_33, r1, r2, r3, gain_x3, scale, keep_mean, stencil, use_stencil, key, key_b):
    """Fill rows n1_lo .. n1_hi - 1 of the three half spectra, noise included.

    Each mode gets ``scale * gain[n1, i] * sum_j M_ij (a_j + i b_j) / sqrt(2)``
    with a_j, b_j its six standard normals (see ``rng``: they depend on
    (key, key_b) and the mode's signed wavenumber indices only), so that
    E|c_i|^2 = scale^2 gain^2 (M M^T)_ii.  M comes from ``corr_33`` in the
    corrected region, else from ``stencil`` (row n1 - n1_lo, when
    use_stencil) or from ``box_params``; either way the amplitude parameters
    of n2 and of its mirror -n2 are shared.  In the z-Nyquist plane (even
    N3) M is the factor of _nyquist_row (a Cholesky factor: any C with
    C C^T = Phi gives the same Gaussian statistics).  The planes n3 = 0
    and Nyquist come out Hermitian in (n1, n2), as hermitian_plane_kernel
    would make them: of each pair (k, -k) the mode with the smaller index
    n1 N2 + n2 is drawn and its conjugate written to the other (which may
    lie in another task's rows: no other task writes it), and a
    self-conjugate mode becomes sqrt(2) times its real part.  Away from the
    Nyquist indices that is the mode with s1 > 0, or s1 = 0 and s2 > 0: a
    rule of the signed wavenumber indices, the same on every grid of one
    physical size.
    """
    N1 = spec_u.shape[0]
    N2 = spec_u.shape[1]
    NH = spec_u.shape[2]
    L2 = L * L
    inv_sqrt2 = 1.0 / math.sqrt(2.0)
    dz3 = 2.0 * math.pi / (N3 * d3)
    za = np.empty(6 * NH)
    zb = np.empty(6 * NH)
    rej = np.empty(6 * NH, np.int64)
    n_nyq = NH - 1 if N3 % 2 == 0 else -1
    for n1 in range(n1_lo, n1_hi):
        s1 = _signed_index(n1, N1)
        k1 = _wavenumber(n1, N1, d1)
        g0 = gain_x3[n1, 0] * scale * inv_sqrt2
        g1 = gain_x3[n1, 1] * scale * inv_sqrt2
        g2 = gain_x3[n1, 2] * scale * inv_sqrt2
        for n2 in range(N2 // 2 + 1):
            k2 = _wavenumber(n2, N2, d2)
            s2 = _signed_index(n2, N2)
            m2 = (N2 - n2) % N2
            # The normals of the n3 rows (s1, s2) and (s1, -s2), keyed by the
            # signed indices (the wavenumber at a fixed box size), not by n1, n2.
            _row_normals(key, key_b, box_row_counter(s1, s2), za, rej)
            if m2 != n2:
                _row_normals(key, key_b, box_row_counter(s1, _signed_index(m2, N2)), zb, rej)
            s12, kh, r21, inv_s12, inv_s12kh = _row_constants(k1, k2)
            # In the planes n3 = 0 and Nyquist, of each pair (k, -k) the mode
            # with the larger flat index is written as its partner's
            # conjugate: skip those here.
            m1 = (N1 - n1) % N1
            keep_a = n1 * N2 + n2 <= m1 * N2 + m2
            keep_b = n1 * N2 + m2 <= m1 * N2 + n2
            for n3 in range(NH):
                if n3 == n_nyq:
                    # The mirror's factor is S C S (S = diag(1, -1, 1)): y -> -y
                    # maps the averaged tensor to S Phi S.
                    if keep_a or (keep_b and m2 != n2):
                        l11, l21, l31, l22, l32, l33 = _nyquist_row(k1, k2, dz3 * n3, s12, kh, r21, inv_s12,
                                                                    inv_s12kh, L2, gamma, ftab, fbase)
                        if keep_a:
                            _mode_out(l11, 0.0, 0.0, l21, l22, 0.0, l31, l32, l33, za, 6 * n3, g0, g1, g2,
                                      spec_u, spec_v, spec_w, n1, n2, n3)
                            _hermitian_partner(spec_u, spec_v, spec_w, n1, n2, n3, m1, m2)
                        if keep_b and m2 != n2:
                            _mode_out(l11, 0.0, 0.0, -l21, l22, 0.0, l31, -l32, l33, zb, 6 * n3, g0, g1, g2,
                                      spec_u, spec_v, spec_w, n1, m2, n3)
                            _hermitian_partner(spec_u, spec_v, spec_w, n1, m2, n3, m1, n2)
                    continue
                if n3 == 0 and not keep_a and (m2 == n2 or not keep_b):
                    continue
                if use_stencil:
                    st = stencil[n1 - n1_lo, n2, n3]
                    p0 = float(st[0])
                    p1 = float(st[1])
                    p2 = float(st[2])
                    p3 = float(st[3])
                    p4 = float(st[4])
                else:
                    p0, p1, p2, p3, p4 = _box_params_row(k1, k2, dz3 * n3, s12, kh, r21, inv_s12, inv_s12kh, L2,
                                                         gamma, ftab, fbase)
                # M as in matrix_from_params; its mirror (-k2) negates k2 and p2.
                if _in_region(s1, s2, n3, r1, r2, r3):
                    c = corr_33[s1 + r1, s2 + r2, n3 + r3]
                    m00, m01, m02, m10, m11, m12, m20, m21, m22 = (c[0, 0], c[0, 1], c[0, 2], c[1, 0], c[1, 1],
                                                                   c[1, 2], c[2, 0], c[2, 1], c[2, 2])
                else:
                    m00, m01, m02, m10, m11, m12, m20, m21, m22 = (p1 * k2, p3 - p1 * k1, -p0 * k2, -p3 + p2 * k2,
                                                                   -p2 * k1, p0 * k1, p4 * k2, -p4 * k1, 0.0)
                if n3 > 0 or keep_a:
                    _mode_out(m00, m01, m02, m10, m11, m12, m20, m21, m22, za, 6 * n3, g0, g1, g2, spec_u, spec_v,
                              spec_w, n1, n2, n3)
                    if n3 == 0:
                        _hermitian_partner(spec_u, spec_v, spec_w, n1, n2, n3, m1, m2)
                if m2 != n2 and (n3 > 0 or keep_b):
                    if _in_region(s1, -s2, n3, r1, r2, r3):
                        c = corr_33[s1 + r1, -s2 + r2, n3 + r3]
                        m00, m01, m02, m10, m11, m12, m20, m21, m22 = (
                            c[0, 0], c[0, 1], c[0, 2], c[1, 0], c[1, 1], c[1, 2], c[2, 0], c[2, 1], c[2, 2])
                    else:
                        m00, m01, m02, m10, m11, m12, m20, m21, m22 = (-p1 * k2, p3 - p1 * k1, p0 * k2,
                                                                       -p3 + p2 * k2, p2 * k1, p0 * k1, -p4 * k2,
                                                                       -p4 * k1, 0.0)
                    _mode_out(m00, m01, m02, m10, m11, m12, m20, m21, m22, zb, 6 * n3, g0, g1, g2, spec_u, spec_v,
                              spec_w, n1, m2, n3)
                    if n3 == 0:
                        _hermitian_partner(spec_u, spec_v, spec_w, n1, m2, n3, m1, n2)
    if n1_lo == 0 and n1_hi > 0 and not keep_mean:
        # The box mean (k = 0) is set to zero: see generate_box's notes.
        spec_u[0, 0, 0] = 0.0
        spec_v[0, 0, 0] = 0.0
        spec_w[0, 0, 0] = 0.0


@numba.njit(**NJIT)
def box_spectrum_kernel(n1_lo, n1_hi, N1, N2, N3, d1, d2, d3, L, gamma, ftab, fbase, corr_33, r1, r2, r3,
                        out_x6):
    """Expected one-point spectra of the box: sum over all (n2, n3) of M M^T.

    Sums over the full (signed) n3 range, i.e. over every mode of the real
    field, for rows n1_lo..n1_hi-1; the k = 0 mode is excluded as in the
    generator, and the z-Nyquist plane (even N3) holds the average of the
    tensor at k3 = +-pi/dz, as in the generator (see _nyquist_row).
    Components as in onepoint_kernel, without any scale factor.
    """
    m = np.empty((3, 3))
    for n1 in range(n1_lo, n1_hi):
        acc = np.zeros(6)
        for n2 in range(N2):
            for j3 in range(N3):
                n3 = _signed_index(j3, N3)
                if n1 == 0 and n2 == 0 and n3 == 0:
                    continue
                if 2 * j3 == N3:
                    for sg in (-1, 1):
                        box_amplitude(n1, n2, sg * n3, N1, N2, N3, d1, d2, d3, L, gamma, ftab, fbase, corr_33,
                                      r1, r2, r3, m)
                        _accumulate_phi(m, 0.5, acc)
                    continue
                box_amplitude(n1, n2, n3, N1, N2, N3, d1, d2, d3, L, gamma, ftab, fbase, corr_33, r1, r2, r3, m)
                _accumulate_phi(m, 1.0, acc)
        for c in range(6):
            out_x6[n1 - n1_lo, c] = acc[c]


@numba.njit(**NJIT)
def hermitian_plane_kernel(spec, n3):
    """Make plane n3 (0 or N3/2) of a half spectrum Hermitian in (n1, n2).

    Of each pair (k, -k) the coefficient with the larger flat index is
    replaced by the conjugate of its mirror; self-conjugate modes keep
    sqrt(2) times their real part, which has the full variance of the mode.
    """
    N1 = spec.shape[0]
    N2 = spec.shape[1]
    sq2 = math.sqrt(2.0)
    for n1 in range(N1):
        m1 = (N1 - n1) % N1
        for n2 in range(N2):
            m2 = (N2 - n2) % N2
            if m1 == n1 and m2 == n2:
                spec[n1, n2, n3] = sq2 * spec[n1, n2, n3].real
            elif n1 * N2 + n2 > m1 * N2 + m2:
                spec[n1, n2, n3] = spec[m1, m2, n3].conjugate()


