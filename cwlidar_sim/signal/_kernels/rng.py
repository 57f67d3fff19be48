"""Counter-based random numbers: splitmix64 streams and normal deviates."""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.special import ndtri

from ..._config import NJIT

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S32 = np.uint64(32)
_LO32 = np.uint64(0xFFFFFFFF)
_TWO_M32 = 2.0**-32
_TWOPI = 2.0 * math.pi
_DBL_MAX = float(np.finfo(np.float64).max)
_START_STREAM = np.uint64(1 << 62)

# ---------------------------------------------------------------------------
# counter-based random numbers
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def mix64(z):
    """splitmix64 finaliser (Steele, Lea & Flood 2014), a bijection of uint64."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


@numba.njit(**NJIT)
def stream_start(key, index):
    """Initial state of stream ``index`` under ``key`` (both uint64-convertible)."""
    return mix64(np.uint64(key) ^ mix64(np.uint64(index) * _GOLDEN + _GOLDEN))


# Inverse normal CDF: a table of ndtri on a uniform grid of 2**14 cells of
# (0, 1), linearly interpolated (absolute error < 1e-4 where used), and
# Acklam's rational approximation (relative error < 1.2e-9) in the outer
# 64 cells of each tail (|z| > 2.66), where the table would be too coarse.
_NT_BITS = 14
_NTAB = ndtri(np.arange(2**_NT_BITS + 1) / 2.0**_NT_BITS)
_NT_SHIFT = np.uint64(32 - _NT_BITS)
_NT_FRAC = np.uint64((1 << (32 - _NT_BITS)) - 1)
_NT_FSCALE = 1.0 / (1 << (32 - _NT_BITS))
_NT_LO = 64
_NT_HI = 2**_NT_BITS - 64
_A0, _A1, _A2, _A3, _A4, _A5 = (-3.969683028665376e01, 2.209460984245205e02, -2.759285104469687e02,
                                1.383577518672690e02, -3.066479806614716e01, 2.506628277459239e00)
_B0, _B1, _B2, _B3, _B4 = (-5.447609879822406e01, 1.615858368580409e02, -1.556989798598866e02,
                           6.680131188771972e01, -1.328068155288572e01)
_C0, _C1, _C2, _C3, _C4, _C5 = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e00,
                                -2.549732539343734e00, 4.374664141464968e00, 2.938163982698783e00)
_D0, _D1, _D2, _D3 = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e00, 3.754408661907416e00)


@numba.njit(**NJIT)
def acklam(p):
    """Inverse standard-normal CDF, Acklam's algorithm (relative error < 1.2e-9), 0 < p < 1."""
    if p < 0.02425 or p > 0.97575:
        q = math.sqrt(-2.0 * math.log(p if p < 0.5 else 1.0 - p))
        z = (((((_C0 * q + _C1) * q + _C2) * q + _C3) * q + _C4) * q + _C5) / (
            (((_D0 * q + _D1) * q + _D2) * q + _D3) * q + 1.0)
        return z if p < 0.5 else -z
    q = p - 0.5
    r = q * q
    return (((((_A0 * r + _A1) * r + _A2) * r + _A3) * r + _A4) * r + _A5) * q / (
        ((((_B0 * r + _B1) * r + _B2) * r + _B3) * r + _B4) * r + 1.0)


@numba.njit(**NJIT)
def normal_u32(u):
    """N(0, 1) number from a 32-bit unsigned integer ``u`` (uniform), by inverse CDF.

    The uniform is ``(u + 1/2) / 2**32``: |z| <= 6.3.
    """
    i = int(u >> _NT_SHIFT)
    if i < _NT_LO or i >= _NT_HI:
        return acklam((float(u) + 0.5) * _TWO_M32)
    f = float(u & _NT_FRAC) * _NT_FSCALE
    return _NTAB[i] + f * (_NTAB[i + 1] - _NTAB[i])


@numba.njit(**NJIT)
def normal_pair(state):
    """Two independent N(0, 1) numbers from one splitmix64 step; returns (state, z0, z1)."""
    state = state + _GOLDEN
    z = mix64(state)
    return state, normal_u32(z >> _S32), normal_u32(z & _LO32)


@numba.njit(**NJIT)
def normal_pair_polar(state):
    """Two independent N(0, 1) numbers by Marsaglia's polar method (no trigonometry)."""
    while True:
        state = state + _GOLDEN
        z = mix64(state)
        a = float(z >> _S32) * (2.0 * _TWO_M32) - 1.0
        b = float(z & _LO32) * (2.0 * _TWO_M32) - 1.0
        s = a * a + b * b
        if 0.0 < s < 1.0:
            f = math.sqrt(-2.0 * math.log(s) / s)
            return state, a * f, b * f


# The inverse-CDF table of normal_u32 as (value, slope) pairs, so that a draw
# reads one 16-byte entry; ``a + f * d`` with ``d`` precomputed is the same
# IEEE arithmetic as normal_u32's ``a + f * (b - a)``, so the two agree bit
# for bit.  Values from cells outside [_NT_LO, _NT_HI) are replaced (Acklam).
_NT_PAIR = np.ascontiguousarray(np.stack([_NTAB[:-1], _NTAB[1:] - _NTAB[:-1]], axis=1))
_U_NT_SHIFT = np.uint64(32 - _NT_BITS)
_U_NT_LO = np.uint64(_NT_LO)
_U_NT_SPAN = np.uint64(_NT_HI - _NT_LO)


@numba.njit(inline="always", **NJIT)
def _table_normals(state0, noise_std, words_w, tails_n, out_n):
    """The part :func:`block_normals` and :func:`block_normals_tab2` share: the stream's words, every
    sample from the central table, and the indices of the ``cnt`` samples in its tails (returned)."""
    nn = out_n.shape[0]
    nw = (nn + 1) // 2
    # counter-based words: no carried dependence, the loop vectorises
    for w in range(nw):
        words_w[w] = mix64(state0 + np.uint64(w + 1) * _GOLDEN)
    # table part (every 18-bit cell index is a valid row); samples in the Acklam
    # tails are listed without a branch and recomputed after
    cnt = np.uint64(0)
    for w in range(nn // 2):
        z = words_w[w]
        u = z >> _S32
        i = u >> _U_NT_SHIFT
        f = float(np.int64(u & _NT_FRAC)) * _NT_FSCALE
        out_n[2 * w] = noise_std * (_NT_PAIR[i, 0] + f * _NT_PAIR[i, 1])
        tails_n[cnt] = 2 * w
        cnt += np.uint64((i - _U_NT_LO) >= _U_NT_SPAN)
        u = z & _LO32
        i = u >> _U_NT_SHIFT
        f = float(np.int64(u & _NT_FRAC)) * _NT_FSCALE
        out_n[2 * w + 1] = noise_std * (_NT_PAIR[i, 0] + f * _NT_PAIR[i, 1])
        tails_n[cnt] = 2 * w + 1
        cnt += np.uint64((i - _U_NT_LO) >= _U_NT_SPAN)
    if nn % 2 == 1:
        out_n[nn - 1] = noise_std * normal_u32(words_w[nw - 1] >> _S32)
    return int(cnt)


@numba.njit(**NJIT)
def block_normals(state0, noise_std, words_w, tails_n, out_n):
    """``out_n[:] = noise_std * z`` with z the normals of stream ``state0`` (normal_pair order).

    Word w of the stream is ``mix64(state0 + (w + 1) * golden)`` (what
    ``normal_pair`` steps through); sample 2w comes from its high 32 bits and
    sample 2w + 1 from its low 32 bits, both by :func:`normal_u32` (an odd
    length drops the last low half).  ``words_w`` (>= ceil(n / 2)) and
    ``tails_n`` (>= n) are scratch.
    """
    cnt = _table_normals(state0, noise_std, words_w, tails_n, out_n)
    for c in range(cnt):
        n = tails_n[c]
        z = words_w[n // 2]
        u = (z >> _S32) if n % 2 == 0 else (z & _LO32)
        out_n[n] = noise_std * acklam((float(u) + 0.5) * _TWO_M32)


# Second-level tables for the tails of tier 3's shot noise (:func:`block_normals_tab2`): in
# each tail of the table above (u < 2**24, u >= 2**32 - 2**24: the cells where normal_u32
# calls Acklam, |z| > 2.66) a table of ndtri on 2**14 cells of width 2**-22 (rows 0.. the
# lower tail, rows 2**14.. the upper one, by symmetry), linearly interpolated: |error| < 1e-5.
# Their outer 64 cells (u < 2**16, u >= 2**32 - 2**16: |z| > 3.8, probability 3e-5) are
# still Acklam's.
_T2_CELL = 2.0**-22
_T2_LOWER = ndtri(np.arange(2**_NT_BITS + 1) * _T2_CELL)
_T2_LOWER[0] = _T2_LOWER[1]  # the -inf node: its cell is Acklam's
_T2_UPPER = -ndtri(2.0**-8 - np.arange(2**_NT_BITS + 1) * _T2_CELL)
_T2_UPPER[-1] = _T2_UPPER[-2]  # the +inf node: its cell is Acklam's
_NT_TAIL2 = np.ascontiguousarray(np.concatenate([
    np.stack([t[:-1], t[1:] - t[:-1]], axis=1) for t in (_T2_LOWER, _T2_UPPER)]))
_U_TAIL = np.uint64(1 << 24)
_U_UPPER = np.uint64((1 << 32) - (1 << 24))
_U_FAR = np.uint64(1 << 16)
_U_FAR_SPAN = np.uint64((1 << 32) - (1 << 17))
_S10 = np.uint64(10)
_LO10 = np.uint64(1023)
_ROW_UPPER = np.uint64(2**_NT_BITS)


@numba.njit(**NJIT)
def tail_normal(u):
    """N(0, 1) number of a 32-bit uniform ``u`` in a tail of the table (``u < 2**24`` or ``u >= 2**32 - 2**24``).

    The second-level table (|error| < 1e-5); Acklam's formula for ``u <
    2**16`` and ``u >= 2**32 - 2**16``.
    """
    if (u - _U_FAR) >= _U_FAR_SPAN:
        return acklam((float(u) + 0.5) * _TWO_M32)
    row = (u >> _S10) if u < _U_TAIL else (_ROW_UPPER + ((u - _U_UPPER) >> _S10))
    f = float(np.int64(u & _LO10)) * (1.0 / 1024.0)
    return _NT_TAIL2[row, 0] + f * _NT_TAIL2[row, 1]


@numba.njit(**NJIT)
def block_normals_tab2(state0, noise_std, words_w, tails_n, out_n):
    """:func:`block_normals` with its tails from second-level tables (:func:`tail_normal`) instead of Acklam's formula.

    The same words, halves and central table, so the numbers with |z| <
    2.66 (99.2 %) are block_normals', bit for bit; the 0.8 % beyond come
    from the tails' tables (|error| < 1e-5 against ndtri, where the central
    table's is 1e-4; Acklam's formula, and its logarithm, only beyond |z| =
    3.8).  Tier 3's shot noise; tier 2 keeps block_normals.  Scratch as
    block_normals'.
    """
    cnt = _table_normals(state0, noise_std, words_w, tails_n, out_n)
    for c in range(cnt):
        n = tails_n[c]
        z = words_w[n // 2]
        u = (z >> _S32) if n % 2 == 0 else (z & _LO32)
        out_n[n] = noise_std * tail_normal(u)
