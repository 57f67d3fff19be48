"""The lattice theory's lines (:func:`cwlidar_sim.analysis.linear_theory.lattice_spectra`).

Each box mode k reaches the looks at its own wavenumber or, through the
sampler's linear interpolation, as the wavenumbers ``k + 2 pi m / d``.
Linear interpolation along an axis of spacing d turns a mode's node values
``exp(i k x_j)`` into the piecewise-linear function ::

    sum_m L(k + 2 pi m / d) exp(i (k + 2 pi m / d) x),   L(q) = sinc^2(q d / 2)

(the Fourier series of the tent-function interpolant; its value at ``x =
x_j + f d`` is ``((1 - f) + f exp(i k d)) exp(i k x_j)``, the sampler's).
Trilinear interpolation is the product over the axes, so each box mode k
reaches the functionals as the continuum's wavenumbers ``k + 2 pi m / d``
with amplitudes ``L_x L_y L_z``.  Along x the advected box sweeps the looks
across the nodes, so the aliases m1 are lines of their own at ``k1 + 2 pi
m1 / dx`` (exact, each on the box's line grid, conjugated where negative).
Across (y, z) each look's reading depends on where it sits in its cell: the
aliases (m2, m3) interfere through ``exp(2 pi i m.p / d)``.  They are summed
in power, ``sum_m L^2 g^H Phi_d g`` at ``k + 2 pi m / d``: exact in
expectation over the box's lateral offset against the instrument (uniform
over a cell: the cross terms of two aliases carry ``exp(2 pi i (m - m').
offset / d)`` and average to zero); a scan whose looks sweep across many
cells averages them the same way, a point on a node does not (leave its
axes ``"none"``).

Nyquist indices (index ``N / 2`` of an even axis).  The generator draws such a
mode at ``-pi / d`` (numpy's fftfreq sign) and writes its Hermitian partner,
whose matrix it shares, at the same grid index: on the nodes ``+pi / d`` and
``-pi / d`` are one wavenumber, and a real field's Nyquist pattern ``(-1)^j``
holds both.  Its linear interpolant (the tent series of ``(-1)^j``) has the
lines ``(2 m + 1) pi / d`` for every integer m, symmetric about 0 with equal
gains, so the index is taken here as standing for both ``+-pi / d``, half the
weight at each, with m aliases about each: without interpolation the two
signs, with ``aliases`` a the lines ``-(2 a + 1) .. (2 a + 1) pi / d``, the
two outermost at half weight (the exact series' truncation, symmetric; the
earlier ``-pi / d``-only rule dropped ``+(2 a + 1) pi / d`` and, across y and
z without interpolation, paired the partner's matrix at ``+pi / d`` with the
transfer at ``-pi / d``).  The sum does not depend on the generator's sign
convention.
"""

from __future__ import annotations

import math

import numpy as np

#: Alias terms (beyond the principal ones) whose gain L_x^2 L_y^2 L_z^2 is below this are skipped.
_ALIAS_TOL = 1e-12


def _phi_row(df, r, n):
    """The discrete spectral matrices ``(n, 3, 3)`` of one row r of a ``DiscreteField``."""
    p6 = df.phi_rows(np.array([r]))[0].reshape(-1, 6)
    phi = np.empty((n, 3, 3))
    for c, (a, b) in enumerate(((0, 0), (1, 1), (2, 2), (0, 2), (0, 1), (1, 2))):
        phi[:, a, b] = phi[:, b, a] = p6[:, c]
    return phi


def _gain(q, d, on):
    """``L(q)^2 = sinc^4(q d / 2)`` [-] on an interpolated axis, else 1."""
    return np.sinc(q * d / (2.0 * math.pi)) ** 4 if on else 1.0


def _shifts(d, aliases, nyquist):
    """``(shift [rad/m], weight, principal)`` of one index's terms along an axis of spacing d (module notes).

    ``aliases`` is the largest ``|m|`` (0 without interpolation); a Nyquist
    index, named ``-pi / d``, takes ``m = -a .. a + 1`` with the two outermost
    at half weight (``+-pi / d`` at half weight each when ``a = 0``).
    """
    step = 2.0 * math.pi / d
    if not nyquist:
        return [(step * m, 1.0, m == 0) for m in range(-aliases, aliases + 1)]
    ms = range(-aliases, aliases + 2)
    return [(step * m, 0.5 if m in (-aliases, aliases + 1) else 1.0, m in (0, 1)) for m in ms]


def lattice_lines(df, rows, g2, g3, spacing, interp, aliases, n_a, accumulate):
    """The lines ``|k1 + 2 pi m1 / dx|`` [rad/m] and their densities ``(n_lines, n_a, n_a)`` [m^3 s^-2].

    ``accumulate(q1, k2, k3, w, phi, out)`` adds ``2 sum_n w_n g^H phi_n g``
    of the functionals at ``(q1, k2_n, k3_n)`` to ``out``; ``g2, g3`` are the
    box's lateral modes (numpy's fftfreq order, y major); ``interp`` holds
    ``"linear"`` or ``"none"`` per axis (x, y, z), ``aliases`` the largest
    ``|m|`` per interpolated axis.  Rows are ``1 .. N1 // 2``; the Nyquist
    row of an even N1 is a single row (its modes pair within it).
    """
    dx, dy, dz = spacing
    n1, n2, n3 = df.shape
    on = [v == "linear" for v in interp]
    al = [aliases if o else 0 for o in on]
    j2, j3 = (a.ravel() for a in np.meshgrid(np.arange(n2), np.arange(n3), indexing="ij"))
    ny2, ny3 = 2 * j2 == n2, 2 * j3 == n3
    groups = [(a, b, np.nonzero((ny2 == a) & (ny3 == b))[0]) for a in (False, True) for b in (False, True)]
    groups = [(a, b, i) for a, b, i in groups if i.size]
    k1_r = df.k1_of_rows(rows).astype(float)
    lines = {}
    for r, k1 in zip(rows, k1_r):
        r = int(r)
        phi = _phi_row(df, r, g2.size)
        for s1, w1, p1 in _shifts(dx, al[0], 2 * r == n1):
            q1 = float(k1) + s1
            gx = w1 * _gain(q1, dx, on[0])
            if q1 == 0.0 or gx == 0.0:
                continue
            acc = np.zeros((n_a, n_a), dtype=complex)
            for a2, a3, idx in groups:
                for s2, w2, p2 in _shifts(dy, al[1], a2):
                    k2 = g2[idx] + s2
                    gy = w2 * _gain(k2, dy, on[1])
                    for s3, w3, p3 in _shifts(dz, al[2], a3):
                        k3 = g3[idx] + s3
                        w = gx * gy * w3 * _gain(k3, dz, on[2]) * np.ones(idx.size)
                        keep = np.nonzero(w > (0.0 if (p1 and p2 and p3) else _ALIAS_TOL))[0]
                        if keep.size:
                            accumulate(q1, np.ascontiguousarray(k2[keep]), np.ascontiguousarray(k3[keep]),
                                       np.ascontiguousarray(w[keep]), np.ascontiguousarray(phi[idx[keep]]), acc)
            if 2 * r == n1:
                acc *= 0.5  # the Nyquist row: a single row
            key = int(round(abs(q1) / df.dk1))
            lines[key] = lines.get(key, 0.0) + (np.conj(acc) if q1 < 0 else acc)
    keys = sorted(lines)
    out = np.array([lines[k] for k in keys]).reshape(len(keys), n_a, n_a)
    return np.array(keys, dtype=float) * df.dk1, out / df.dk1
