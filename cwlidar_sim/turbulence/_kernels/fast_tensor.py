"""The box's amplitude parameters from tables (no C library log, exp, pow or atan2).

``box_params`` is ``amplitude_params`` without calls to the
C library's log, exp, pow and atan2, which cost more than the noise: the
eddy lifetime comes from a table indexed by the bits of (|k| L)^2 (a shift
and a mask instead of a log), linear between 2**_FB nodes per octave
(relative error < 0.094 * 4**-_FB = 3.6e-7, from the curvature bound
h^2 |f''| / 8 of f ~ t^(-1/2) .. t^(-1/3)); y^(-17/12), y = 1 + |k0|^2
L^2 = m 2^e, as 2^(-17 e / 12) m^(-17/12) from two tables, m^(-17/12)
linear between 2**_PB nodes on [1, 2) (relative error < 0.43 * 4**-_PB =
1.0e-7, the same bound with (17/12)(29/12) / 8); atan2 by a polynomial
(relative error < 1e-12).  Generator, stencil and
expected spectra all use it, so the box has exactly the statistics
``expected_box_covariance`` reports.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT
from .rng import _U52, _f64_bits
from .tensor import _phi6_of_params

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
