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

Planes (``generate_plane``).  A plane's modes ``(k1, k2)`` carry the tensor
integrated over all k3 (``turbulence.plane_spectra``): for looks in the
plane (one height, horizontal directions) that is the box's sum with one
lateral index per k2 and ``k3 = 0`` (:class:`PlaneRows` gives the rows in the
box's layout, ``N3 = 1``).  Its bilinear reading across y is either summed
in power over the aliases as above (the expectation over the plane's
offset against the instrument), or, with the plane's placement known,
read exactly (:func:`plane_lines`): each look at ``y`` reads the nodes
``j0 dy`` and ``(j0 + 1) dy`` around it, ``(1 - f) exp(i k2 j0 dy) + f
exp(i k2 (j0 + 1) dy)`` with ``f = y / dy - j0`` (a Nyquist column's
``(-1)^j`` included, whatever its sign), in place of ``exp(i k2 y)``.  A
staring beam's weight lies within a few metres of its focus, which a
misalignment of 1.2 deg moves across y by a fraction of a cell: its looks
and a sonic at the focus read one fraction of a cell, not the average
over fractions.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_choice, check_int, check_real, check_tuple
from ..turbulence._discrete import plane_phi_rows

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


class PlaneRows:
    """A plane's discrete matrices in :func:`lattice_lines`' box layout ``(N1, Ny, 1)`` (its rows on demand)."""

    def __init__(self, params, shape, spacing):
        self.params, self.plane_shape, self.spacing = params, tuple(shape), tuple(spacing)
        self.shape = (self.plane_shape[0], self.plane_shape[1], 1)
        self.dk1 = 2.0 * math.pi / (shape[0] * spacing[0])

    def k1_of_rows(self, rows):
        r = np.asarray(rows)
        return self.dk1 * np.where(2 * r < self.shape[0], r, r - self.shape[0])

    def phi_rows(self, rows):
        return plane_phi_rows(self.params, self.plane_shape, self.spacing, rows)


def node_reader(dy, y0):
    """``read_y(y_l, k2)`` of a plane's bilinear reading across y (module notes): nodes at ``j dy - y0`` [m]."""
    def read(y_l, k2):
        u = (np.asarray(y_l, dtype=float) + y0) / dy
        j0 = np.floor(u)
        f = (u - j0)[:, None]
        e0 = np.exp(1j * np.multiply.outer(j0 * dy, k2))
        return e0 * ((1.0 - f) + f * np.exp(1j * k2 * dy)[None, :])
    return read


def plane_lines(df, rows, transfer, spacing, interp_x, aliases, n_a):
    """:func:`lattice_lines` of a plane read exactly across y: ``transfer(q1, k2) -> (n_a, n_modes, 3)``.

    ``transfer`` gives the functionals' transfer vectors at ``(q1, k2_n,
    k3 = 0)`` with each look's reading across y (:func:`node_reader`);
    ``interp_x`` ``"linear"`` or ``"none"`` as :func:`lattice_lines` (the
    aliases along x are lines of their own).
    """
    dx, dy = spacing
    n1, n2 = df.plane_shape
    k2 = 2.0 * math.pi * np.fft.fftfreq(n2, dy)
    on = interp_x == "linear"
    lines = {}
    for r, k1 in zip(rows, df.k1_of_rows(rows).astype(float)):
        r = int(r)
        phi = _phi_row(df, r, n2)
        for s1, w1, _p in _shifts(dx, aliases if on else 0, 2 * r == n1):
            q1 = float(k1) + s1
            gx = w1 * _gain(q1, dx, on)
            if q1 == 0.0 or gx == 0.0:
                continue
            g = transfer(q1, k2)
            acc = 2.0 * gx * np.einsum("ani,nij,bnj->ab", np.conj(g), phi, g)
            if 2 * r == n1:
                acc *= 0.5  # the Nyquist row: a single row
            key = int(round(abs(q1) / df.dk1))
            lines[key] = lines.get(key, 0.0) + (np.conj(acc) if q1 < 0 else acc)
    keys = sorted(lines)
    out = np.array([lines[k] for k in keys]).reshape(len(keys), n_a, n_a)
    return np.array(keys, dtype=float) * df.dk1, out / df.dk1


def plane_arguments(fs, shape, spacing, rows, correction, hf_compensation, interpolation, aliases, origin):
    """A plane's ``lattice_spectra`` arguments checked: ``(shape, spacing, rows, interp, aliases, origin)``.

    ``origin`` comes back None unless y is read exactly (given, y ``"linear"``).
    """
    shape = check_tuple("shape", shape, 2, lambda n, v: check_int(n, v, lo=2))
    spacing = check_tuple("spacing", spacing, 2, lambda n, v: check_real(n, v, lo=0.0, lo_open=True))
    if correction != "cell" or hf_compensation:
        raise ValueError(f"a plane has its own cell averages and no high-frequency compensation: correction='cell', "
                         f"hf_compensation=False (got {correction!r}, {hf_compensation!r})")
    interp = (interpolation,) * 2 if isinstance(interpolation, str) else tuple(interpolation)
    if len(interp) != 2:
        raise ValueError(f"interpolation of a plane must be 'none', 'linear' or a tuple of two of them, got "
                         f"{interpolation!r}")
    for a, v in zip("xy", interp):
        check_choice(f"interpolation ({a})", v, ("none", "linear"))
    aliases = check_int("aliases", aliases, lo=0)
    n1 = shape[0]
    rows = np.arange(1, n1 // 2 + 1) if rows is None else np.array(rows, dtype=np.int64, ndmin=1)
    if rows.ndim != 1 or np.any(rows < 1) or np.any(rows > n1 // 2):
        raise ValueError(f"rows must be row indices in 1 .. {n1 // 2} (N1 // 2)")
    exact = origin is not None and interp[1] == "linear"
    heights = np.concatenate([f.looks.point_lc[np.any(f.weight_olc != 0.0, axis=(0, 2)), 2] for f in fs])
    if np.ptp(heights) > 1e-9:
        raise ValueError(f"functionals: a plane holds looks at one height, got heights "
                         f"{np.unique(heights).tolist()} m")
    for i, f in enumerate(fs):
        used = np.nonzero(np.any(f.weight_olc != 0.0, axis=(0, 2)))[0]
        n = f.looks.direction_lc[used]
        if np.any(np.abs(n[:, 2]) > 1e-12):
            raise ValueError(f"functionals[{i}]: a plane holds looks with horizontal directions (n_z = 0), got "
                             f"|n_z| up to {np.max(np.abs(n[:, 2])):g}")
        if exact and any(f.looks.probe_l[j] is not None and abs(n[m, 1]) > 1e-12 for m, j in enumerate(used)):
            raise ValueError(f"functionals[{i}]: with origin given, a look read across y must be a point or along x "
                             f"(n_y = 0); expand a slanted beam's probe into point looks")
    if exact:
        origin = check_tuple("origin", origin, 2, lambda n, v: check_real(n, v))
    return shape, spacing, rows, interp, aliases, (origin if exact else None)
