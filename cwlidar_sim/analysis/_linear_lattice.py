"""The lattice theory's trilinear interpolation (:func:`cwlidar_sim.analysis.linear_theory.lattice_spectra`).

Each box mode k reaches the looks through the sampler's linear interpolation
as the wavenumbers ``k + 2 pi m / d`` with amplitudes ``L(q) = sinc^2(q d /
2)`` per interpolated axis (``lattice_spectra``'s notes): the aliases m1
along x are lines of their own, those across (y, z) are summed in power.
"""

from __future__ import annotations

import math

import numpy as np

#: Alias terms (m != 0) whose gain L_x^2 L_y^2 L_z^2 is below this are skipped (their power is below it).
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


def interpolated_lines(df, rows, k1_r, g2, g3, spacing, interp, aliases, n_a, accumulate):
    """The lines ``|k1 + 2 pi m1 / dx|`` [rad/m] and their densities ``(n_lines, n_a, n_a)`` [m^3 s^-2].

    ``accumulate(q1, k2, k3, w, phi, out)`` adds ``2 sum_n w_n g^H phi_n g``
    of the functionals at ``(q1, k2_n, k3_n)`` to ``out``; ``interp`` holds
    ``"linear"`` or ``"none"`` per axis (x, y, z), ``aliases`` the largest
    ``|m|`` per interpolated axis.
    """
    dx, dy, dz = spacing
    n1 = df.n1
    on = [v == "linear" for v in interp]
    ms = [np.arange(-aliases, aliases + 1) if o else np.zeros(1, np.int64) for o in on]
    lines = {}
    for j, r in enumerate(rows):
        phi = _phi_row(df, int(r), g2.size)
        for m1 in ms[0]:
            q1 = float(k1_r[j]) + 2.0 * math.pi * m1 / dx
            gx = _gain(q1, dx, on[0])
            if q1 == 0.0 or gx == 0.0:
                continue
            acc = np.zeros((n_a, n_a), dtype=complex)
            for m2 in ms[1]:
                k2 = g2 + 2.0 * math.pi * m2 / dy
                gy = _gain(k2, dy, on[1])
                for m3 in ms[2]:
                    k3 = g3 + 2.0 * math.pi * m3 / dz
                    w = gx * gy * _gain(k3, dz, on[2]) * np.ones(g2.size)
                    keep = np.nonzero(w > (_ALIAS_TOL if (m1, m2, m3) != (0, 0, 0) else 0.0))[0]
                    if keep.size:
                        accumulate(q1, np.ascontiguousarray(k2[keep]), np.ascontiguousarray(k3[keep]),
                                   np.ascontiguousarray(w[keep]), np.ascontiguousarray(phi[keep]), acc)
            if 2 * r == n1:
                acc *= 0.5  # the Nyquist row: a single row
            key = int(round(abs(q1) / df.dk1))
            lines[key] = lines.get(key, 0.0) + (np.conj(acc) if q1 < 0 else acc)
    keys = sorted(lines)
    out = np.array([lines[k] for k in keys]).reshape(len(keys), n_a, n_a)
    return np.array(keys, dtype=float) * df.dk1, out / df.dk1
