"""numba kernels of the Mann tensor and of the field generators.

Only the arithmetic lives here; validation, tables and memory management are
in the public wrappers (``tensor.py``, ``spectra.py``, ``box.py``, ...).

The amplitude matrix
--------------------
For a wave vector k the Mann (1994) tensor factorises as Phi = M M^T with the
real 3x3 matrix ``M = D(k) A_iso(k0)``::

    A_iso = s * [[0, k30, -k2], [-k30, 0, k1], [k2, -k1, 0]],
    s     = sqrt(E(|k0|) / (4 pi)) / |k0|^2
          = sqrt(alpha_eps / (4 pi)) L^(17/6) (1 + (|k0| L)^2)^(-17/12),
    D     = [[1, 0, zeta1], [0, 1, zeta2], [0, 0, |k0|^2 / |k|^2]].

The second form of ``s`` has no singularity at k0 = 0.  The arctangent of
Mann's C2 is the difference ``atan(k30/kh) - atan(k3/kh)`` (kh = |(k1, k2)|),
computed as one ``atan2`` of tangent-difference form; its magnitude is below
pi, so atan2 returns the right branch, and it stays accurate when beta*k1 is
tiny.  At k1 = 0 the limit is zeta1 = -beta (the lift-up of u by w), zeta2 = 0.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._config import NJIT

# Lifetime table: log f(x) on a uniform grid of log x, x = |k| L, where
# beta = Gamma * f(x).  Outside the table the asymptotes are exact to O(x^2)
# (small x, slope -1) and O(x^-2) (large x, slope -2/3).
LOG_X_LO = math.log(1e-4)
LOG_X_HI = math.log(1e4)


@numba.njit(**NJIT)
def lifetime_f(x, tab):
    """f(x) with beta = Gamma f(kL), interpolated linearly in log-log."""
    if x <= 0.0:
        return 0.0
    lx = math.log(x)
    n = tab.shape[0]
    h = (LOG_X_HI - LOG_X_LO) / (n - 1)
    if lx <= LOG_X_LO:
        return math.exp(tab[0] - (lx - LOG_X_LO))
    if lx >= LOG_X_HI:
        return math.exp(tab[n - 1] - (2.0 / 3.0) * (lx - LOG_X_HI))
    t = (lx - LOG_X_LO) / h
    i = int(t)
    if i >= n - 1:
        i = n - 2
    a = t - i
    return math.exp((1.0 - a) * tab[i] + a * tab[i + 1])


@numba.njit(**NJIT)
def amplitude_params(k1, k2, k3, L, gamma, tab, p):
    """Write (s, s zeta1, s zeta2, s k30, s q) of wave vector k into p[0:5].

    With these five numbers and (k1, k2) the amplitude matrix is

        M = [[s zeta1 k2, s k30 - s zeta1 k1, -s k2],
             [-s k30 + s zeta2 k2, -s zeta2 k1, s k1],
             [s q k2, -s q k1, 0]].

    All five are even in k2 except s zeta2, which is odd, so the mode
    (k1, -k2, k3) reuses them with s zeta2 negated.
    """
    kk = k1 * k1 + k2 * k2 + k3 * k3
    if kk == 0.0:
        for i in range(5):
            p[i] = 0.0
        return
    kabs = math.sqrt(kk)
    beta = gamma * lifetime_f(kabs * L, tab)
    k30 = k3 + beta * k1
    k0sq = k1 * k1 + k2 * k2 + k30 * k30
    s = (1.0 + k0sq * L * L) ** (-17.0 / 12.0)
    s12 = k1 * k1 + k2 * k2
    if k1 == 0.0:
        zeta1 = -beta
        zeta2 = 0.0
    else:
        c1 = beta * k1 * k1 * (k0sq - 2.0 * k30 * k30 + beta * k1 * k30) / (kk * s12)
        kh = math.sqrt(s12)
        ang = math.atan2(beta * k1 * kh, s12 + k30 * k3)
        c2 = k2 * k0sq / (s12 * kh) * ang
        r = k2 / k1
        zeta1 = c1 - r * c2
        zeta2 = r * c1 + c2
    p[0] = s
    p[1] = s * zeta1
    p[2] = s * zeta2
    p[3] = s * k30
    p[4] = s * k0sq / kk


@numba.njit(**NJIT)
def matrix_from_params(p0, p1, p2, p3, p4, k1, k2, out):
    """Assemble M from amplitude_params' five numbers (see there)."""
    out[0, 0] = p1 * k2
    out[0, 1] = p3 - p1 * k1
    out[0, 2] = -p0 * k2
    out[1, 0] = -p3 + p2 * k2
    out[1, 1] = -p2 * k1
    out[1, 2] = p0 * k1
    out[2, 0] = p4 * k2
    out[2, 1] = -p4 * k1
    out[2, 2] = 0.0


@numba.njit(**NJIT)
def amplitude(k1, k2, k3, L, gamma, tab, out):
    """Write M (3x3, without the sqrt(alpha_eps/(4 pi)) L^(17/6) factor) into out."""
    p = np.empty(5)
    amplitude_params(k1, k2, k3, L, gamma, tab, p)
    matrix_from_params(p[0], p[1], p[2], p[3], p[4], k1, k2, out)


@numba.njit(**NJIT)
def amplitude_many(k1, k2, k3, L, gamma, tab, out):
    """M for arrays of wave vectors: out[n] = M(k1[n], k2[n], k3[n])."""
    for n in range(k1.shape[0]):
        amplitude(k1[n], k2[n], k3[n], L, gamma, tab, out[n])


@numba.njit(**NJIT)
def _accumulate_phi(m, w, acc):
    # acc gets w * (M M^T) for the 4 non-zero one-point components plus
    # the two that vanish only after integration over k2 (12 and 23).
    p11 = m[0, 0] * m[0, 0] + m[0, 1] * m[0, 1] + m[0, 2] * m[0, 2]
    p22 = m[1, 0] * m[1, 0] + m[1, 1] * m[1, 1] + m[1, 2] * m[1, 2]
    p33 = m[2, 0] * m[2, 0] + m[2, 1] * m[2, 1] + m[2, 2] * m[2, 2]
    p12 = m[0, 0] * m[1, 0] + m[0, 1] * m[1, 1] + m[0, 2] * m[1, 2]
    p13 = m[0, 0] * m[2, 0] + m[0, 1] * m[2, 1] + m[0, 2] * m[2, 2]
    p23 = m[1, 0] * m[2, 0] + m[1, 1] * m[2, 1] + m[1, 2] * m[2, 2]
    acc[0] += w * p11
    acc[1] += w * p22
    acc[2] += w * p33
    acc[3] += w * p13
    acc[4] += w * p12
    acc[5] += w * p23


@numba.njit(**NJIT)
def onepoint_kernel(k1_k, q2_kq, w2_kq, q3_kq, w3_kq, L, gamma, tab, out_k6):
    """Integrate Phi over (k2, k3) on tensor-product nodes, one row per k1.

    ``out_k6[k]`` receives (Phi11, Phi22, Phi33, Phi13, Phi12, Phi23)
    integrated, without the alpha_eps/(4 pi) L^(17/3) factor.
    """
    m = np.empty((3, 3))
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
                amplitude(k1_k[ik], q2_kq[ik, a], q3_kq[ik, b], L, gamma, tab, m)
                _accumulate_phi(m, wa * wb, acc)
        for c in range(6):
            out_k6[ik, c] = acc[c]


_MAX_DEPTH = 40
_STACK = 512


@numba.njit(**NJIT)
def _gl_block(lo, hi, gx, gw, L, gamma, tab, m, acc):
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
                amplitude(c0 + h0 * gx[a], c1 + h1 * gx[b], c2 + h2 * gx[c], L, gamma, tab, m)
                _accumulate_phi(m, h0 * h1 * h2 * gw[a] * gw[b] * gw[c], acc)


@numba.njit(**NJIT)
def cell_integral(lo0, hi0, gx, gw, L, gamma, tab, acc):
    """Integral of Phi over an axis-aligned box, refined toward k = 0.

    The sheared tensor is bounded but direction-dependent at k = 0 and Phi33
    grows like 1/|k|^2 there (beta -> infinity), so boxes closer to the
    origin than their own size are bisected along their long sides until
    they are not (or are negligibly small).  Elsewhere one product
    Gauss-Legendre block per box suffices: Phi varies on scales >= |k|.
    """
    m = np.empty((3, 3))
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
            _gl_block(lo, hi, gx, gw, L, gamma, tab, m, acc)
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
def box_amplitude(n1, n2, n3, N1, N2, N3, d1, d2, d3, L, gamma, tab, corr_33, r1, r2, r3, m):
    """Amplitude matrix of mode (n1, n2, n3) of the box, corrected or not.

    ``n3`` is a signed index here (the half spectrum stores n3 >= 0; the
    expected-spectrum kernel also needs n3 < 0).  Modes with
    |signed n_i| <= r_i take the precomputed ``corr_33`` matrix.
    """
    s1 = _signed_index(n1, N1)
    s2 = _signed_index(n2, N2)
    if abs(s1) <= r1 and abs(s2) <= r2 and abs(n3) <= r3:
        for i in range(3):
            for j in range(3):
                m[i, j] = corr_33[s1 + r1, s2 + r2, n3 + r3, i, j]
        return
    k1 = _wavenumber(n1, N1, d1)
    k2 = _wavenumber(n2, N2, d2)
    k3 = 2.0 * math.pi * n3 / (N3 * d3)
    amplitude(k1, k2, k3, L, gamma, tab, m)


@numba.njit(**NJIT)
def _in_region(s1, s2, n3, r1, r2, r3):
    return abs(s1) <= r1 and abs(s2) <= r2 and abs(n3) <= r3


@numba.njit(**NJIT)
def _mix(m, noise, r, n2, n3, g0, g1, g2, spec_u, spec_v, spec_w, n1):
    a0 = noise[r, n2, n3, 0, 0]
    b0 = noise[r, n2, n3, 0, 1]
    a1 = noise[r, n2, n3, 1, 0]
    b1 = noise[r, n2, n3, 1, 1]
    a2 = noise[r, n2, n3, 2, 0]
    b2 = noise[r, n2, n3, 2, 1]
    spec_u[n1, n2, n3] = g0 * complex(m[0, 0] * a0 + m[0, 1] * a1 + m[0, 2] * a2,
                                      m[0, 0] * b0 + m[0, 1] * b1 + m[0, 2] * b2)
    spec_v[n1, n2, n3] = g1 * complex(m[1, 0] * a0 + m[1, 1] * a1 + m[1, 2] * a2,
                                      m[1, 0] * b0 + m[1, 1] * b1 + m[1, 2] * b2)
    spec_w[n1, n2, n3] = g2 * complex(m[2, 0] * a0 + m[2, 1] * a1 + m[2, 2] * a2,
                                      m[2, 0] * b0 + m[2, 1] * b1 + m[2, 2] * b2)


@numba.njit(**NJIT)
def stencil_kernel(n1_lo, n1_hi, N1, N2, N3, d1, d2, d3, L, gamma, tab, out_x5):
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
                amplitude_params(k1, k2, 2.0 * math.pi * n3 / (N3 * d3), L, gamma, tab, p)
                for c in range(5):
                    out_x5[n1 - n1_lo, n2, n3, c] = p[c]


@numba.njit(**NJIT)
def fill_box_kernel(spec_u, spec_v, spec_w, n1_lo, noise, N3, d1, d2, d3, L, gamma, tab,
                    corr_33, r1, r2, r3, gain_x3, scale, keep_mean, stencil, use_stencil):
    """Fill rows n1_lo .. n1_lo + len(noise) of the three half spectra.

    noise has shape (rows, N2, N3//2+1, 3, 2): standard normals, the last
    axis being real and imaginary parts.  Each mode gets
    ``scale * gain[n1, i] * sum_j M_ij (a_j + i b_j) / sqrt(2)`` so that
    E|c_i|^2 = scale^2 gain^2 (M M^T)_ii.  M comes from ``corr_33`` in the
    corrected region, else from ``stencil`` (rows n1 - n1_lo, when
    use_stencil) or is computed here; either way the amplitude parameters of
    n2 and of its mirror -n2 are shared.
    """
    N1 = spec_u.shape[0]
    N2 = spec_u.shape[1]
    NH = spec_u.shape[2]
    m = np.empty((3, 3))
    p = np.empty(5)
    inv_sqrt2 = 1.0 / math.sqrt(2.0)
    for r in range(noise.shape[0]):
        n1 = n1_lo + r
        s1 = _signed_index(n1, N1)
        k1 = _wavenumber(n1, N1, d1)
        g0 = gain_x3[n1, 0] * scale * inv_sqrt2
        g1 = gain_x3[n1, 1] * scale * inv_sqrt2
        g2 = gain_x3[n1, 2] * scale * inv_sqrt2
        for n2 in range(N2 // 2 + 1):
            k2 = _wavenumber(n2, N2, d2)
            s2 = _signed_index(n2, N2)
            m2 = (N2 - n2) % N2
            for n3 in range(NH):
                if use_stencil:
                    for c in range(5):
                        p[c] = stencil[r, n2, n3, c]
                else:
                    amplitude_params(k1, k2, 2.0 * math.pi * n3 / (N3 * d3), L, gamma, tab, p)
                if _in_region(s1, s2, n3, r1, r2, r3):
                    for i in range(3):
                        for j in range(3):
                            m[i, j] = corr_33[s1 + r1, s2 + r2, n3 + r3, i, j]
                else:
                    matrix_from_params(p[0], p[1], p[2], p[3], p[4], k1, k2, m)
                _mix(m, noise, r, n2, n3, g0, g1, g2, spec_u, spec_v, spec_w, n1)
                if m2 != n2:
                    if _in_region(s1, -s2, n3, r1, r2, r3):
                        for i in range(3):
                            for j in range(3):
                                m[i, j] = corr_33[s1 + r1, -s2 + r2, n3 + r3, i, j]
                    else:
                        matrix_from_params(p[0], p[1], -p[2], p[3], p[4], k1, -k2, m)
                    _mix(m, noise, r, m2, n3, g0, g1, g2, spec_u, spec_v, spec_w, n1)
    if n1_lo == 0 and noise.shape[0] > 0 and not keep_mean:
        # The box mean (k = 0) is set to zero: see generate_box's notes.
        spec_u[0, 0, 0] = 0.0
        spec_v[0, 0, 0] = 0.0
        spec_w[0, 0, 0] = 0.0


@numba.njit(**NJIT)
def box_spectrum_kernel(n1_lo, n1_hi, N1, N2, N3, d1, d2, d3, L, gamma, tab, corr_33, r1, r2, r3, out_x6):
    """Expected one-point spectra of the box: sum over all (n2, n3) of M M^T.

    Sums over the full (signed) n3 range, i.e. over every mode of the real
    field, for rows n1_lo..n1_hi-1; the k = 0 mode is excluded as in the
    generator.  Components as in onepoint_kernel, without any scale factor.
    """
    m = np.empty((3, 3))
    for n1 in range(n1_lo, n1_hi):
        acc = np.zeros(6)
        for n2 in range(N2):
            for j3 in range(N3):
                n3 = _signed_index(j3, N3)
                if n1 == 0 and n2 == 0 and n3 == 0:
                    continue
                box_amplitude(n1, n2, n3, N1, N2, N3, d1, d2, d3, L, gamma, tab, corr_33, r1, r2, r3, m)
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


@numba.njit(**NJIT)
def plane_kernel(k1_m, k2_m, q3, w3, L, gamma, tab, out_m6):
    """Phi integrated over k3 on the nodes q3 (scaled per mode), per (k1, k2).

    q3/w3 are normalised nodes on [0, inf) for unit scale; for each mode
    they are stretched by the mode's scale and used for both signs of k3.
    """
    m = np.empty((3, 3))
    for n in range(k1_m.shape[0]):
        k1 = k1_m[n]
        k2 = k2_m[n]
        kh = math.sqrt(k1 * k1 + k2 * k2)
        sc = kh if 0.0 < kh < 1.0 / L else 1.0 / L
        acc = np.zeros(6)
        for j in range(q3.shape[0]):
            x = q3[j] * sc
            w = w3[j] * sc
            amplitude(k1, k2, x, L, gamma, tab, m)
            _accumulate_phi(m, w, acc)
            amplitude(k1, k2, -x, L, gamma, tab, m)
            _accumulate_phi(m, w, acc)
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


@numba.njit(**NJIT)
def _spline6(coef, x0, h, col, x, out):
    # Cubic pieces (scipy's PPoly layout: coef[0] multiplies t^3) of
    # (log Phi11, log Phi22, log Phi33, rho13, rho12, rho23) on the uniform
    # knots x0 + i h; converted back to the six spectral components.
    nseg = coef.shape[1]
    i = int(math.floor((x - x0) / h))
    if i < 0:
        i = 0
    elif i > nseg - 1:
        i = nseg - 1
    t = x - (x0 + i * h)
    for c in range(6):
        out[c] = ((coef[0, i, col, c] * t + coef[1, i, col, c]) * t + coef[2, i, col, c]) * t + coef[3, i, col, c]
    d0 = math.exp(out[0])
    d1 = math.exp(out[1])
    d2 = math.exp(out[2])
    out[0] = d0
    out[1] = d1
    out[2] = d2
    out[3] *= math.sqrt(d0 * d2)
    out[4] *= math.sqrt(d0 * d1)
    out[5] *= math.sqrt(d1 * d2)


@numba.njit(**NJIT)
def plane_mode(s1, s2, dk1, near, r1, r2, x0, h, coef, rx0, rh, rcoef, out):
    """The six k3-integrated components of plane mode (s1 dk1, s2 dk2), s2 >= 0.

    ``near[|s1|, s2]`` holds directly computed values for |s1| < len(near);
    beyond, the cell averages of the region |s1| <= r1, s2 <= r2 come from
    the spline ``rcoef`` (strip s2) and all other modes from ``coef``
    (column s2), both in log|k1|.
    """
    a1 = abs(s1)
    if a1 < near.shape[0]:
        for c in range(6):
            out[c] = near[a1, s2, c]
    else:
        x = math.log(a1 * dk1)
        if s2 <= r2 and a1 <= r1:
            _spline6(rcoef, rx0, rh, s2, x, out)
        else:
            _spline6(coef, x0, h, s2, x, out)
    if s1 < 0:
        out[4] = -out[4]
        out[5] = -out[5]


@numba.njit(**NJIT)
def plane_phi_kernel(n1_lo, N1, dk1, near, r1, r2, x0, h, coef, rx0, rh, rcoef, scale, out_xy33):
    """Spectral matrices of rows n1_lo .. n1_lo + len(out) (times ``scale``)."""
    p = np.empty(6)
    for r in range(out_xy33.shape[0]):
        s1 = _signed_index(n1_lo + r, N1)
        for s2 in range(out_xy33.shape[1]):
            plane_mode(s1, s2, dk1, near, r1, r2, x0, h, coef, rx0, rh, rcoef, p)
            o = out_xy33[r, s2]
            o[0, 0] = scale * p[0]
            o[1, 1] = scale * p[1]
            o[2, 2] = scale * p[2]
            o[0, 2] = o[2, 0] = scale * p[3]
            o[0, 1] = o[1, 0] = scale * p[4]
            o[1, 2] = o[2, 1] = scale * p[5]


@numba.njit(**NJIT)
def chol3(p, m):
    """Lower Cholesky factor m of the symmetric matrix held in p (six components).

    Positive semi-definite input is allowed: a pivot <= 0 gives a zero column
    (a tiny negative pivot can come from interpolation error), so m m^T = P
    wherever P is positive definite and the nearest such factor otherwise.
    """
    a11 = p[0]
    l11 = math.sqrt(a11) if a11 > 0.0 else 0.0
    l21 = p[4] / l11 if l11 > 0.0 else 0.0
    l31 = p[3] / l11 if l11 > 0.0 else 0.0
    a22 = p[1] - l21 * l21
    l22 = math.sqrt(a22) if a22 > 0.0 else 0.0
    l32 = (p[5] - l31 * l21) / l22 if l22 > 0.0 else 0.0
    a33 = p[2] - l31 * l31 - l32 * l32
    l33 = math.sqrt(a33) if a33 > 0.0 else 0.0
    m[0, 0] = l11
    m[0, 1] = 0.0
    m[0, 2] = 0.0
    m[1, 0] = l21
    m[1, 1] = l22
    m[1, 2] = 0.0
    m[2, 0] = l31
    m[2, 1] = l32
    m[2, 2] = l33


@numba.njit(**NJIT)
def fill_plane_kernel(spec_u, spec_v, spec_w, n1_lo, noise, dk1, near, r1, r2, x0, h, coef,
                      rx0, rh, rcoef, scale):
    """Fill rows n1_lo .. n1_lo + len(noise) of the plane's three half spectra.

    noise has shape (rows, Ny//2 + 1, 3, 2) (standard normals, real and
    imaginary parts).  Mode (s1, s2) gets ``scale * sum_j C_ij (a_j + i b_j)``
    with C the Cholesky factor of Phi2(s1 dk1, s2 dk2) as the tables hold it
    (without the alpha_eps/(4 pi) L^(17/3) factor), so that
    E[c c^H] = 2 scale^2 Phi2.  Any factor with C C^T = Phi2 gives the same
    Gaussian statistics; Cholesky is the cheapest.
    """
    N1 = spec_u.shape[0]
    p = np.empty(6)
    m = np.empty((3, 3))
    for r in range(noise.shape[0]):
        n1 = n1_lo + r
        s1 = _signed_index(n1, N1)
        for s2 in range(noise.shape[1]):
            plane_mode(s1, s2, dk1, near, r1, r2, x0, h, coef, rx0, rh, rcoef, p)
            chol3(p, m)
            a0 = noise[r, s2, 0, 0]
            b0 = noise[r, s2, 0, 1]
            a1 = noise[r, s2, 1, 0]
            b1 = noise[r, s2, 1, 1]
            a2 = noise[r, s2, 2, 0]
            b2 = noise[r, s2, 2, 1]
            spec_u[n1, s2] = scale * complex(m[0, 0] * a0, m[0, 0] * b0)
            spec_v[n1, s2] = scale * complex(m[1, 0] * a0 + m[1, 1] * a1, m[1, 0] * b0 + m[1, 1] * b1)
            spec_w[n1, s2] = scale * complex(m[2, 0] * a0 + m[2, 1] * a1 + m[2, 2] * a2,
                                             m[2, 0] * b0 + m[2, 1] * b1 + m[2, 2] * b2)
