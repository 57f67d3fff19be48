"""Counter-based standard normals of the field generators.

Normal number c of a field is a function of (seed, c) only.  The
64-bit word mix64(key + (c + 1) G) -- output c of SplitMix64 (Steele, Lea &
Flood 2014) started at ``key`` -- feeds a 256-layer ziggurat (Marsaglia &
Tsang 2000): 8 bits pick the layer, 1 the sign and 53 the position in the
layer.  The few draws the ziggurat's first test does not accept (1.5 %)
go on with a private SplitMix64 stream started at mix64(key_b + (c + 1)
G), again a function of (key_b, c) only.

Counters are keyed by the wavenumber, not by the loop position: a mode with
signed indices (s1, s2, s3) -- the physical wavenumber k_i = 2 pi s_i / L_i at
a box size L_i = N_i d_i, signed as numpy's fftfreq signs them (index N/2 of
an even axis is -N/2), s3 >= 0 in the half spectrum -- takes normals
6 m .. 6 m + 5 (component i: real part 6 m + 2 i, imaginary part 6 m + 2 i + 1)
with m the offset-binary packing of its indices (``box_row_counter``,
``plane_row_counter``; a line's mode s >= 0 has m = s).  Two grids of one
physical size therefore draw the same numbers for every wavenumber they
share, and any split of the modes over threads draws the same numbers.
The packing holds shapes up to 2**25 x 2**18 x 2**18 for boxes
(``BOX_MAX_SHAPE``) and 2**32 x 2**29 for planes (``PLANE_MAX_SHAPE``); boxes, planes and lines of one seed use keys of
their own (see ``turbulence.box._noise_keys``).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from ..._config import NJIT

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




#: Bits of s1, s2, s3 in a box mode's counter index m (offset binary for the
#: signed s1, s2): 25 + 18 + 18 = 61, so 6 m + 5 < 2**64.
_BOX_B1 = 25
_BOX_B2 = 18
_BOX_B3 = 18
#: Largest box shape whose signed indices fit the packing.
BOX_MAX_SHAPE = (1 << _BOX_B1, 1 << _BOX_B2, 1 << _BOX_B3)
_BOX_OFF1 = 1 << (_BOX_B1 - 1)
_BOX_OFF2 = 1 << (_BOX_B2 - 1)
_BOX_SH1 = np.uint64(_BOX_B2 + _BOX_B3)
_BOX_SH2 = np.uint64(_BOX_B3)
#: Bits of s1 and s2 (>= 0) in a plane mode's counter index: 32 + 29 = 61.
_PLANE_B1 = 32
_PLANE_B2 = 29
PLANE_MAX_SHAPE = (1 << _PLANE_B1, 1 << _PLANE_B2)
_PLANE_OFF1 = 1 << (_PLANE_B1 - 1)
_PLANE_SH1 = np.uint64(_PLANE_B2)
_U6 = np.uint64(6)


@numba.njit(inline="always", **NJIT)
def box_row_counter(s1, s2):
    """First counter of the n3 row of box modes (s1, s2, 0 ..): 6 m with m packed from (s1, s2, 0).

    Mode (s1, s2, s3) of the row takes counters ``box_row_counter(s1, s2) + 6 s3 + j``, j = 0..5.
    """
    return _U6 * ((np.uint64(s1 + _BOX_OFF1) << _BOX_SH1) | (np.uint64(s2 + _BOX_OFF2) << _BOX_SH2))


@numba.njit(inline="always", **NJIT)
def plane_row_counter(s1):
    """First counter of the k2 row of plane modes (s1, 0 ..); mode (s1, s2) takes + 6 s2 + j."""
    return _U6 * (np.uint64(s1 + _PLANE_OFF1) << _PLANE_SH1)


@numba.njit(**NJIT)
def plane_noise_kernel(key, key_b, n1_lo, N1, out_xy32):
    """Normals of plane rows n1_lo .. n1_lo + len(out): out[r, s2, i, 0/1] is the real/imaginary
    normal of component i of mode (s1, s2), s1 the signed index of row n1_lo + r (see the notes)."""
    rows = out_xy32.shape[0]
    n = out_xy32.shape[1] * 6
    rej = np.empty(n, np.int64)
    for r in range(rows):
        n1 = n1_lo + r
        s1 = n1 if 2 * n1 < N1 else n1 - N1
        _row_normals(key, key_b, plane_row_counter(s1), out_xy32[r].reshape(n), rej)
