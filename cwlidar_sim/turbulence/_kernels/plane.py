"""Plane generator kernels: the k3-integrated spectra Phi2(k1, k2) from their tables, and the fill.

Six numbers per mode, in the order of _accumulate_phi:
(Phi11, Phi22, Phi33, Phi13, Phi12, Phi23).  The tables hold them for
k1 >= 0 only: y -> -y is a symmetry of the sheared flow and k -> -k one of
every real field, so Phi2(-k1, k2) = S Phi2(k1, k2) S with S = diag(1, -1, 1),
i.e. Phi12 and Phi23 change sign with k1 and the rest are even in k1.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT
from .box import _signed_index


@numba.njit(**NJIT)
def _spline6(coef, j0, h, col, x, out):
    # Cubic pieces (scipy's PPoly layout: coef[0] multiplies t^3) of
    # (log Phi11, log Phi22, log Phi33, rho13, rho12, rho23) on the lattice
    # x_j = j h, piece i spanning [x_(j0 + i), x_(j0 + i + 1)]; converted back
    # to the six spectral components.  The piece and t = x - j h depend on x
    # and the lattice only, not on where the table starts (j0), so two grids'
    # tables give the same bits at a shared wavenumber.
    nseg = coef.shape[1]
    j = int(math.floor(x / h))
    i = j - j0
    if i < 0:
        i = 0
    elif i > nseg - 1:
        i = nseg - 1
    t = x - (j0 + i) * h
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
def plane_mode(s1, s2, dk1, near, r1, r2, j0, h, coef, rj0, rh, rcoef, out):
    """The six k3-integrated components of plane mode (s1 dk1, s2 dk2), s2 >= 0.

    ``near[|s1|, s2]`` holds directly computed values for |s1| < len(near);
    beyond, the cell averages of the region |s1| <= r1, s2 <= r2 come from
    the pieces ``rcoef`` (strip s2) and all other modes from ``coef``
    (column s2), both local cubics in log|k1| on the lattice j h.
    """
    a1 = abs(s1)
    if a1 < near.shape[0]:
        for c in range(6):
            out[c] = near[a1, s2, c]
    else:
        x = math.log(a1 * dk1)
        if s2 <= r2 and a1 <= r1:
            _spline6(rcoef, rj0, rh, s2, x, out)
        else:
            _spline6(coef, j0, h, s2, x, out)
    if s1 < 0:
        out[4] = -out[4]
        out[5] = -out[5]


@numba.njit(**NJIT)
def plane_phi_kernel(n1_lo, N1, dk1, near, r1, r2, j0, h, coef, rj0, rh, rcoef, scale, out_xy33):
    """Spectral matrices of rows n1_lo .. n1_lo + len(out) (times ``scale``)."""
    p = np.empty(6)
    for r in range(out_xy33.shape[0]):
        s1 = _signed_index(n1_lo + r, N1)
        for s2 in range(out_xy33.shape[1]):
            plane_mode(s1, s2, dk1, near, r1, r2, j0, h, coef, rj0, rh, rcoef, p)
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
def fill_plane_kernel(spec_u, spec_v, spec_w, n1_lo, noise, dk1, near, r1, r2, j0, h, coef,
                      rj0, rh, rcoef, scale):
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
            plane_mode(s1, s2, dk1, near, r1, r2, j0, h, coef, rj0, rh, rcoef, p)
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
