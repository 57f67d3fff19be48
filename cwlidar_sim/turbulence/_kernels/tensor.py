"""The Mann tensor's amplitude matrix and eddy lifetime, exact (C library maths).

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

from ..._config import NJIT


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


@numba.njit(inline="always", **NJIT)
def _params_scalars(k1, k2, k3, L, gamma, tab):
    # amplitude_params' five numbers as scalars: the integration kernels call this per node, and an
    # array per call (amplitude's scratch) cost a third of their time.  One body, so both forms
    # give the same bits.
    kk = k1 * k1 + k2 * k2 + k3 * k3
    if kk == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
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
    return s, s * zeta1, s * zeta2, s * k30, s * k0sq / kk


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
    p[0], p[1], p[2], p[3], p[4] = _params_scalars(k1, k2, k3, L, gamma, tab)


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


@numba.njit(**NJIT)
def amplitude(k1, k2, k3, L, gamma, tab, out):
    """Write M (3x3, without the sqrt(alpha_eps/(4 pi)) L^(17/6) factor) into out."""
    p0, p1, p2, p3, p4 = _params_scalars(k1, k2, k3, L, gamma, tab)
    matrix_from_params(p0, p1, p2, p3, p4, k1, k2, out)


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



@numba.njit(inline="always", **NJIT)
def accumulate_phi_at(k1, k2, k3, L, gamma, tab, w, acc):
    """``acc += w * (M M^T)`` at wave vector k, in the order of :func:`_accumulate_phi`, without a matrix.

    The same products and sums as ``amplitude`` followed by ``_accumulate_phi``
    (:func:`_phi6_of_params`, which leaves out the terms of M_22 = 0: the same
    values), held in registers: the quadrature kernels' inner loop.
    """
    p0, p1, p2, p3, p4 = _params_scalars(k1, k2, k3, L, gamma, tab)
    a0, a1, a2, a3, a4, a5 = _phi6_of_params(p0, p1, p2, p3, p4, k1, k2)
    acc[0] += w * a0
    acc[1] += w * a1
    acc[2] += w * a2
    acc[3] += w * a3
    acc[4] += w * a4
    acc[5] += w * a5
