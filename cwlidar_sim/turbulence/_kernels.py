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
from numba import types
from numba.extending import intrinsic

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
def _in_region(s1, s2, n3, r1, r2, r3):
    return abs(s1) <= r1 and abs(s2) <= r2 and abs(n3) <= r3


# ---------------------------------------------------------------------------
# Box generator.
#
# Noise.  Normal number c of a box is a function of (seed, c) only.  The
# 64-bit word mix64(key + (c + 1) G) -- output c of SplitMix64 (Steele, Lea &
# Flood 2014) started at ``key`` -- feeds a 256-layer ziggurat (Marsaglia &
# Tsang 2000): 8 bits pick the layer, 1 the sign and 53 the position in the
# layer.  The few draws the ziggurat's first test does not accept (1.5 %)
# go on with a private SplitMix64 stream started at mix64(key_b + (c + 1)
# G), again a function of (key_b, c) only.  Mode m = (n1 N2 + n2)
# (N3//2 + 1) + n3 of the half spectrum takes normals 6 m .. 6 m + 5
# (component i: real part 6 m + 2 i, imaginary part 6 m + 2 i + 1), so any
# split of the modes over threads draws the same numbers.
#
# Amplitudes.  ``box_params`` is ``amplitude_params`` without calls to the
# C library's log, exp, pow and atan2, which cost more than the noise: the
# eddy lifetime comes from a table indexed by the bits of (|k| L)^2 (a shift
# and a mask instead of a log), linear between 2**_FB nodes per octave
# (relative error < 0.094 * 4**-_FB = 3.6e-7, from the curvature bound
# h^2 |f''| / 8 of f ~ t^(-1/2) .. t^(-1/3)); y^(-17/12), y = 1 + |k0|^2
# L^2 = m 2^e, as 2^(-17 e / 12) m^(-17/12) from two tables, m^(-17/12)
# linear between 2**_PB nodes on [1, 2) (relative error < 0.43 * 4**-_PB =
# 1.0e-7, the same bound with (17/12)(29/12) / 8); atan2 by a polynomial
# (relative error < 1e-12).  Generator, stencil and
# expected spectra all use it, so the box has exactly the statistics
# ``expected_box_covariance`` reports.
# ---------------------------------------------------------------------------
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_U1 = np.uint64(1)
_U8 = np.uint64(8)
_U11 = np.uint64(11)
_U27 = np.uint64(27)
_U30 = np.uint64(30)
_U31 = np.uint64(31)
_U52 = np.uint64(52)
_U63 = np.uint64(63)
_LOW8 = np.uint64(0xFF)
_TWO_M53 = 2.0**-53

#: Edge of the base layer of a 256-layer ziggurat for exp(-x^2/2)
#: (Marsaglia & Tsang 2000).
ZIG_R = 3.6541528853610088


def ziggurat_tables(n=256, r=ZIG_R, bits=53):
    """Layer tables of the ziggurat for f(x) = exp(-x^2/2), x >= 0.

    Layer 0 is the base strip [0, r] x [0, f(r)] plus the tail beyond r, of
    area v = r f(r) + integral_r^inf f; it is given the virtual width
    x_0 = v / f(r).  Layer i >= 1 is the rectangle [0, x_i] x [f(x_i),
    f(x_{i+1})] with x_1 = r, x_{i+1} = f^-1(f(x_i) + v / x_i) and
    x_n = 0: every layer has area v (the top one to 1e-13 relative with this
    r).

    Returns
    -------
    w : ndarray, float64 (n,)
        x_i 2^-bits: an integer u of ``bits`` bits gives x = u w[i], uniform
        on [0, x_i).
    k : ndarray, uint64 (n,)
        floor(2^bits x_{i+1} / x_i): u < k[i] lies under the curve for sure.
    f : ndarray, float64 (n + 1,)
        f(x_i), with f(x_n) = 1.
    """
    def fx(x):
        return math.exp(-0.5 * x * x)

    v = r * fx(r) + math.sqrt(0.5 * math.pi) * math.erfc(r / math.sqrt(2.0))
    x = [0.0] * (n + 1)
    x[0] = v / fx(r)
    x[1] = r
    for i in range(1, n - 1):
        x[i + 1] = math.sqrt(-2.0 * math.log(v / x[i] + fx(x[i])))
    w = np.array([xi * 2.0**-bits for xi in x[:n]])
    k = np.array([int(x[i + 1] / x[i] * 2.0**bits) for i in range(n)], dtype=np.uint64)
    f = np.array([fx(xi) for xi in x[:n]] + [1.0])
    return w, k, f


ZIG_W, ZIG_K, ZIG_F = ziggurat_tables()


@numba.njit(inline="always", **NJIT)
def mix64(z):
    """SplitMix64's finaliser, a bijection of uint64 with full avalanche."""
    z = (z ^ (z >> _U30)) * _MIX1
    z = (z ^ (z >> _U27)) * _MIX2
    return z ^ (z >> _U31)


@numba.njit(**NJIT)
def _uniform_open(z):
    # (0, 1) from the top 53 bits: never 0, so log() is safe.
    return (float(np.int64(z >> _U11)) + 0.5) * _TWO_M53


@intrinsic
def _bits_f64(typingctx, b):
    """The float64 whose bit pattern is the uint64 ``b`` (no conversion)."""
    sig = types.float64(types.uint64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float64))

    return sig, codegen


@intrinsic
def _f64_bits(typingctx, x):
    """The bit pattern of a float64 as a uint64 (no conversion)."""
    sig = types.uint64(types.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.uint64))

    return sig, codegen


@numba.njit(**NJIT)
def _normal_slow(w, t):
    """Finish a ziggurat draw whose word ``w`` failed the fast test.

    Further words are mix64(t + j G), j = 1, 2, ...
    """
    while True:
        i = int(w & _LOW8)
        u = w >> _U11
        x = float(np.int64(u)) * ZIG_W[i]
        sgn = float(1 - 2 * np.int64((w >> _U8) & _U1))
        if u < ZIG_K[i]:
            return sgn * x
        if i == 0:
            # Tail x > r (Marsaglia 1964): r + a, a ~ Exp(rate r), kept with
            # probability exp(-a^2 / 2).
            while True:
                t += _GOLDEN
                a = -math.log(_uniform_open(mix64(t))) / ZIG_R
                t += _GOLDEN
                b = -math.log(_uniform_open(mix64(t)))
                if b + b > a * a:
                    return sgn * (ZIG_R + a)
        t += _GOLDEN
        y = ZIG_F[i] + _uniform_open(mix64(t)) * (ZIG_F[i + 1] - ZIG_F[i])
        if y < math.exp(-0.5 * x * x):
            return sgn * x
        t += _GOLDEN
        w = mix64(t)


@numba.njit(**NJIT)
def normal_at(key, key_b, c):
    """Standard normal number ``c`` (uint64) of the stream keyed by (key, key_b)."""
    return _normal_slow(mix64(key + (c + _U1) * _GOLDEN), mix64(key_b + (c + _U1) * _GOLDEN))


@numba.njit(**NJIT)
def _row_normals(key, key_b, c0, z, rej):
    # z[j] = normal_at(key, key_b, c0 + j) for a whole n3 row of modes.  The
    # loop holds the ziggurat's fast path only (no call: the compiler keeps
    # it tight) and notes the 1.5 % of draws it does not accept in ``rej``
    # (scratch, len(z) integers); those are finished afterwards.
    s = key + (c0 + _U1) * _GOLDEN
    nrej = 0
    for j in range(z.shape[0]):
        w = mix64(s)
        i = int(w & _LOW8)
        u = w >> _U11
        # u < 2^53 converts exactly through int64, which x86 does in one
        # instruction (uint64 needs several); bit 8 of w becomes the sign bit
        # without a branch (it is a coin toss the CPU cannot predict).
        x = float(np.int64(u)) * ZIG_W[i]
        z[j] = _bits_f64(_f64_bits(x) ^ ((w >> _U8) << _U63))
        if u >= ZIG_K[i]:
            rej[nrej] = j
            nrej += 1
        s += _GOLDEN
    for q in range(nrej):
        z[rej[q]] = normal_at(key, key_b, c0 + np.uint64(rej[q]))


@numba.njit(**NJIT)
def normals_kernel(key, key_b, c0, out):
    """out[j] = normal_at(key, key_b, c0 + j), by the generator's own row loop."""
    _row_normals(key, key_b, c0, out, np.empty(out.shape[0], np.int64))


#: Lifetime table nodes per octave of (|k| L)^2, and mantissa nodes of
#: y^(-17/12): 2**_FB and 2**_PB.
_FB = 9
_PB = 11
_FSHIFT = np.uint64(52 - _FB)
_FMASK = np.uint64((1 << (52 - _FB)) - 1)
_FSCALE = 2.0 ** -(52 - _FB)
_PSHIFT = np.uint64(52 - _PB)
_PMASK = np.uint64((1 << _PB) - 1)
_PLOW = np.uint64((1 << (52 - _PB)) - 1)
_PSCALE = 2.0 ** -(52 - _PB)
_POW_E = np.array([2.0 ** (-17.0 * e / 12.0) for e in range(1024)])
_POW_M = np.array([(1.0 + j / 2.0**_PB) ** (-17.0 / 12.0) for j in range((1 << _PB) + 1)])


def lifetime_bits_nodes(t_lo, t_hi):
    """Nodes t_j of the bit-indexed lifetime table covering [t_lo, t_hi].

    2**_FB nodes per octave, uniform in t within an octave, starting at the
    power of two at or below t_lo.  Returns (t_j, base) with ``base`` the
    value of ``bits(t_0) >> (52 - _FB)``.
    """
    base = int(np.array(t_lo, dtype=np.float64).view(np.uint64)) >> (52 - _FB)
    base &= ~((1 << _FB) - 1)  # start at a power of two
    top = (int(np.array(t_hi, dtype=np.float64).view(np.uint64)) >> (52 - _FB)) + 2
    codes = (np.arange(base, top, dtype=np.uint64) << np.uint64(52 - _FB))
    return codes.view(np.float64), base


@numba.njit(**NJIT)
def box_lifetime(t, ftab, fbase):
    """f at (|k| L)^2 = t from the bit-indexed table (see lifetime_bits_nodes)."""
    b = _f64_bits(t)
    i = int(b >> _FSHIFT) - fbase
    a = float(np.int64(b & _FMASK)) * _FSCALE
    if i < 0:
        i = 0
        a = 0.0
    elif i > ftab.shape[0] - 2:
        i = ftab.shape[0] - 2
        a = 1.0
    return ftab[i] + a * (ftab[i + 1] - ftab[i])


@numba.njit(**NJIT)
def pow_m17_12(y):
    """y^(-17/12) for 1 <= y < 2^1024, relative error < 1.0e-7 (see the section notes)."""
    b = _f64_bits(y)
    e = int(b >> _U52) - 1023
    j = int((b >> _PSHIFT) & _PMASK)
    a = float(np.int64(b & _PLOW)) * _PSCALE
    return _POW_E[e] * (_POW_M[j] + a * (_POW_M[j + 1] - _POW_M[j]))


def _atan_poly(deg=7):
    """Coefficients c_j of atan(t) = t sum_j c_j t^(2j) on |t| <= tan(pi/8).

    Chebyshev interpolation of atan(sqrt(u)) / sqrt(u) in u = t^2 (analytic
    but for the branch point u = -1, far outside [0, 0.17]: the error falls
    by a factor of 25 per degree) converted to powers of u; relative error
    below 1e-12 at degree 7 (tested against math.atan2), far inside the
    3.6e-7 of the lifetime table it works with.
    """
    from numpy.polynomial import chebyshev, polynomial

    umax = math.tan(math.pi / 8.0) ** 2
    n = deg + 1
    xc = np.cos((2.0 * np.arange(n) + 1.0) * np.pi / (2.0 * n))
    u = 0.5 * umax * (xc + 1.0)
    cx = chebyshev.cheb2poly(chebyshev.chebfit(xc, np.arctan(np.sqrt(u)) / np.sqrt(u), deg))
    cu = np.zeros(n)
    for j, c in enumerate(cx):  # x = 2 u / umax - 1
        cu[: j + 1] += c * polynomial.polypow([-1.0, 2.0 / umax], j)
    return cu


_ATAN_C = _atan_poly()
_TAN_PI8 = math.tan(math.pi / 8.0)


@numba.njit(inline="always", **NJIT)
def atan2_poly(y, x):
    """atan2(y, x) by reduction to |t| <= tan(pi/8) and a polynomial.

    Faster than the C library's, which is built for the last ulp: one or
    two divisions and a degree-7 polynomial in t^2 evaluated by Estrin's
    scheme (short dependency chains).  Relative error below 1e-12.
    """
    ax = abs(x)
    ay = abs(y)
    swap = ay > ax
    if swap:
        t = ax / ay
    elif ax > 0.0:
        t = ay / ax
    else:
        t = 0.0
    off = 0.0
    if t > _TAN_PI8:
        t = (t - 1.0) / (t + 1.0)
        off = 0.25 * math.pi
    u = t * t
    u2 = u * u
    c = _ATAN_C
    q = ((c[0] + c[1] * u) + u2 * (c[2] + c[3] * u)) + (u2 * u2) * ((c[4] + c[5] * u) + u2 * (c[6] + c[7] * u))
    r = off + t * q
    if swap:
        r = 0.5 * math.pi - r
    if x < 0.0:
        r = math.pi - r
    return math.copysign(r, y)


@numba.njit(inline="always", **NJIT)
def _box_params_row(k1, k2, k3, s12, kh, r21, inv_s12, inv_s12kh, L2, gamma, ftab, fbase):
    # box_params with the quantities fixed along an n3 row passed in:
    # s12 = k1^2 + k2^2, kh = sqrt(s12), r21 = k2 / k1, inv_s12 = 1 / s12,
    # inv_s12kh = 1 / (s12 kh) (unused where k1 = 0).
    kk = s12 + k3 * k3
    if kk == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    beta = gamma * box_lifetime(kk * L2, ftab, fbase)
    k30 = k3 + beta * k1
    k0sq = s12 + k30 * k30
    s = pow_m17_12(1.0 + k0sq * L2)
    inv_kk = 1.0 / kk
    if k1 == 0.0:
        zeta1 = -beta
        zeta2 = 0.0
    else:
        c1 = beta * k1 * k1 * (k0sq - 2.0 * k30 * k30 + beta * k1 * k30) * inv_kk * inv_s12
        ang = atan2_poly(beta * k1 * kh, s12 + k30 * k3)
        c2 = k2 * k0sq * inv_s12kh * ang
        zeta1 = c1 - r21 * c2
        zeta2 = r21 * c1 + c2
    return s, s * zeta1, s * zeta2, s * k30, s * k0sq * inv_kk


@numba.njit(inline="always", **NJIT)
def _row_constants(k1, k2):
    s12 = k1 * k1 + k2 * k2
    kh = math.sqrt(s12)
    return s12, kh, k2 / k1, 1.0 / s12, 1.0 / (s12 * kh)


@numba.njit(**NJIT)
def box_params(k1, k2, k3, L, gamma, ftab, fbase, p):
    """``amplitude_params`` (same five numbers) with tabulated lifetime and power, and atan2_poly."""
    s12, kh, r21, inv_s12, inv_s12kh = _row_constants(k1, k2)
    p[0], p[1], p[2], p[3], p[4] = _box_params_row(k1, k2, k3, s12, kh, r21, inv_s12, inv_s12kh, L * L, gamma,
                                                   ftab, fbase)


@numba.njit(**NJIT)
def box_params_many(k1, k2, k3, L, gamma, ftab, fbase, out_n5):
    """box_params for arrays of wave vectors (for tests)."""
    for n in range(k1.shape[0]):
        box_params(k1[n], k2[n], k3[n], L, gamma, ftab, fbase, out_n5[n])


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


@numba.njit(inline="always", **NJIT)
def _phi6_of_params(p0, p1, p2, p3, p4, k1, k2):
    # (Phi11, Phi22, Phi33, Phi13, Phi12, Phi23) of M from amplitude
    # parameters (M as in matrix_from_params; M_22 = 0).
    m00 = p1 * k2
    m01 = p3 - p1 * k1
    m02 = -p0 * k2
    m10 = -p3 + p2 * k2
    m11 = -p2 * k1
    m12 = p0 * k1
    m20 = p4 * k2
    m21 = -p4 * k1
    return (m00 * m00 + m01 * m01 + m02 * m02, m10 * m10 + m11 * m11 + m12 * m12, m20 * m20 + m21 * m21,
            m00 * m20 + m01 * m21, m00 * m10 + m01 * m11 + m02 * m12, m10 * m20 + m11 * m21)


@numba.njit(inline="always", **NJIT)
def _chol3_scalars(a11, a22, a33, a13, a12, a23):
    # chol3 on scalars: returns (l11, l21, l31, l22, l32, l33).
    l11 = math.sqrt(a11) if a11 > 0.0 else 0.0
    l21 = a12 / l11 if l11 > 0.0 else 0.0
    l31 = a13 / l11 if l11 > 0.0 else 0.0
    d22 = a22 - l21 * l21
    l22 = math.sqrt(d22) if d22 > 0.0 else 0.0
    l32 = (a23 - l31 * l21) / l22 if l22 > 0.0 else 0.0
    d33 = a33 - l31 * l31 - l32 * l32
    l33 = math.sqrt(d33) if d33 > 0.0 else 0.0
    return l11, l21, l31, l22, l32, l33


@numba.njit(inline="always", **NJIT)
def _nyquist_row(k1, k2, kz, s12, kh, r21, inv_s12, inv_s12kh, L2, gamma, ftab, fbase):
    # Lower factor (l11, l21, l31, l22, l32, l33), as chol3 makes it, of
    # (Phi(k1, k2, kz) + Phi(k1, k2, -kz)) / 2 without the prefactor.  The
    # z-Nyquist plane of the half spectrum stands for both k3 = +pi/dz and
    # -pi/dz (its cell straddles them), and the Hermitian constraint
    # c(-k1, -k2) = c(k1, k2)* forces equal variances on the two modes of a
    # pair; with shear Phi(k1, k2, kz) != Phi(k1, k2, -kz), so only the
    # average -- which is even in (k1, k2) -- serves both.
    q0, q1, q2, q3, q4 = _box_params_row(k1, k2, kz, s12, kh, r21, inv_s12, inv_s12kh, L2, gamma, ftab, fbase)
    a0, a1, a2, a3, a4, a5 = _phi6_of_params(q0, q1, q2, q3, q4, k1, k2)
    q0, q1, q2, q3, q4 = _box_params_row(k1, k2, -kz, s12, kh, r21, inv_s12, inv_s12kh, L2, gamma, ftab, fbase)
    b0, b1, b2, b3, b4, b5 = _phi6_of_params(q0, q1, q2, q3, q4, k1, k2)
    return _chol3_scalars(0.5 * (a0 + b0), 0.5 * (a1 + b1), 0.5 * (a2 + b2), 0.5 * (a3 + b3), 0.5 * (a4 + b4),
                          0.5 * (a5 + b5))


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
    with a_j, b_j its six standard normals (see the section notes: they
    depend on (key, key_b) and the mode's index only), so that
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
    self-conjugate mode becomes sqrt(2) times its real part.
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
            # The normals of the n3 rows (n1, n2) and (n1, m2): counters
            # 6 m .. 6 m + 6 NH - 1 from their first modes' index m.
            _row_normals(key, key_b, np.uint64(6 * ((n1 * N2 + n2) * NH)), za, rej)
            if m2 != n2:
                _row_normals(key, key_b, np.uint64(6 * ((n1 * N2 + m2) * NH)), zb, rej)
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


# ---------------------------------------------------------------------------
# Plane: k3-integrated spectra Phi2(k1, k2) from tables, and the generator.
#
# Six numbers per mode, in the order of _accumulate_phi:
# (Phi11, Phi22, Phi33, Phi13, Phi12, Phi23).  The tables hold them for
# k1 >= 0 only: y -> -y is a symmetry of the sheared flow and k -> -k one of
# every real field, so Phi2(-k1, k2) = S Phi2(k1, k2) S with S = diag(1, -1, 1),
# i.e. Phi12 and Phi23 change sign with k1 and the rest are even in k1.
# ---------------------------------------------------------------------------


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
