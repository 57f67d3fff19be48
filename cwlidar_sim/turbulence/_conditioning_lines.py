"""Conditioning on records along full lines in x: one solve per k1 (see ``conditioning.py``)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

COMPONENTS = ("u", "v", "w")
#: Relative tolerance on the field length against U times the record duration.
_LENGTH_RTOL = 1e-6
#: Eigenvalues below this fraction of a k1 row's largest are dropped (zero-noise duplicates).
_RCOND = 1e-12
#: Lateral modes per task of the per-k1 pass (about 12 MB of Phi per task).
_MODES_PER_TASK = 1 << 18
_C6 = np.array([[0, 4, 3], [4, 1, 5], [3, 5, 2]])


# ---------------------------------------------------------------------------
# the field's grid and the sensors' lateral weights
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Grid:
    kind: str
    shape: tuple
    origin: tuple  # x0, y0, z0 of the nodes (or the fixed y, z of a line/plane)
    spacing: tuple  # dx, dy, dz (1.0 where the field has no such axis)


def _axis(field, name):
    c = np.asarray(field[name].values, dtype=np.float64)
    d = np.diff(c)
    if c.ndim != 1 or c.size < 2 or not (d[0] > 0 and np.allclose(d, d[0], rtol=1e-6, atol=0.0)):
        raise ValueError(f"field coordinate {name!r} must be uniformly increasing with >= 2 points")
    return float(c[0]), float(d[0])


def _field_grid(field):
    import xarray as xr

    if not isinstance(field, xr.Dataset) or any(c not in field.data_vars for c in COMPONENTS):
        raise TypeError("field must be an xarray.Dataset with u, v, w (a generate_line/plane/box result)")
    dims = tuple(field["u"].dims)
    kind = {("x",): "line", ("x", "y"): "plane", ("x", "y", "z"): "box"}.get(dims)
    if kind is None:
        raise ValueError(f"field dims {dims} not allowed; allowed: ('x',), ('x', 'y'), ('x', 'y', 'z')")
    x0, dx = _axis(field, "x")
    y0, dy = _axis(field, "y") if kind != "line" else (float(field.attrs.get("y", 0.0)), 1.0)
    if kind == "box":
        z0, dz = _axis(field, "z")
    else:
        z0, dz = float(field.attrs.get("z", 0.0)), 1.0
    return _Grid(kind, tuple(field["u"].shape), (x0, y0, z0), (dx, dy, dz))


def _linear_corners(name, p, p0, h, n, periodic, label):
    """Nodes and weights of the linear interpolate at p along one axis."""
    f = (p - p0) / h
    if periodic:
        f = f % n
        i = int(math.floor(f))
        t = f - i
        return [(i % n, 1.0 - t), ((i + 1) % n, t)]
    tol = 1e-9 * max(1.0, n)
    if f < -tol or f > n - 1 + tol:
        raise ValueError(f"{label}: {name} = {p:.9g} m is outside the field's nodes "
                         f"[{p0:.9g}, {p0 + (n - 1) * h:.9g}] m")
    f = min(max(f, 0.0), n - 1.0)
    i = min(int(math.floor(f)), n - 2)
    t = f - i
    return [(i, 1.0 - t), (i + 1, t)]


def _fixed_coordinate(name, p, ref, label, tol=1e-6):
    if abs(p - ref) > tol:
        raise ValueError(f"{label}: {name} = {p:.9g} m but the field lies at {name} = {ref:.9g} m "
                         f"(allowed deviation {tol} m); use a plane or box for sensors off it")
    return [(0, 1.0)]


def _lateral(grid, y, z, label):
    """Corners (iy, iz, weight) of a sensor at (y, z) and its phase profiles wy (N2l,), wz (N3l,)."""
    if grid.kind == "line":
        _fixed_coordinate("y", y, grid.origin[1], label)
        _fixed_coordinate("z", z, grid.origin[2], label)
        return [(0, 0, 1.0)], np.ones(1, complex), np.ones(1, complex)
    N2 = grid.shape[1]
    cy = _linear_corners("y", y, grid.origin[1], grid.spacing[1], N2, False, label)
    j = np.arange(N2)
    wy_lat = sum(b * np.exp(2j * math.pi * j * i / N2) for i, b in cy)
    if grid.kind == "plane":
        _fixed_coordinate("z", z, grid.origin[2], label)
        # The plane's y axis is the kernels' j3 slot.
        return [(iy, 0, b) for iy, b in cy], np.ones(1, complex), wy_lat
    N3 = grid.shape[2]
    cz = _linear_corners("z", z, grid.origin[2], grid.spacing[2], N3, False, label)
    l3 = np.arange(N3)
    wz = sum(b * np.exp(2j * math.pi * l3 * i / N3) for i, b in cz)
    return [(iy, iz, by * bz) for iy, by in cy for iz, bz in cz], wy_lat, wz


def _sample_rows(arrays, grid, corners):
    """The field's rows along x at a sensor, (3, Nx), from its lateral corners."""
    out = np.zeros((3, grid.shape[0]))
    for iy, iz, b in corners:
        if b == 0.0:
            continue
        for c in range(3):
            a = arrays[c]
            row = a if grid.kind == "line" else (a[:, iy] if grid.kind == "plane" else a[:, iy, iz])
            out[c] += b * np.asarray(row, dtype=np.float64)
    return out


def _profiles(items):
    """Deduplicate complex profile vectors: (table, index of each item)."""
    table, index = [], []
    for v in items:
        for i, t in enumerate(table):
            if t.shape == v.shape and np.array_equal(t, v):
                index.append(i)
                break
        else:
            table.append(v)
            index.append(len(table) - 1)
    return np.array(table), np.array(index, dtype=np.int64)


@dataclasses.dataclass
class _Positions:
    wy: np.ndarray  # (Py, N2l)
    wz: np.ndarray  # (Pz, N3l)
    py: np.ndarray
    pz: np.ndarray
    wzz: np.ndarray  # (Pz^2, N3l): wz[a] conj(wz[b]) for pair b = a * Pz + b
    pair: np.ndarray  # (P, P)
    corners: list


def _positions(grid, yz_list, labels):
    corners, wys, wzs = [], [], []
    for (y, z), lab in zip(yz_list, labels):
        c, wy, wz = _lateral(grid, y, z, lab)
        corners.append(c)
        wys.append(wy)
        wzs.append(wz)
    wy, py = _profiles(wys)
    wz, pz = _profiles(wzs)
    A = wz.shape[0]
    wzz = (wz[:, None, :] * np.conj(wz[None, :, :])).reshape(A * A, -1)
    pair = (pz[:, None] * A + pz[None, :]).astype(np.int64)
    return _Positions(np.ascontiguousarray(wy), np.ascontiguousarray(wz), py, pz, np.ascontiguousarray(wzz), pair,
                      corners)


# ---------------------------------------------------------------------------
# line records: one solve per k1
# ---------------------------------------------------------------------------
@dataclasses.dataclass
class _Channel:
    pos: int  # position index
    comp: int  # field component 0, 1, 2
    coef: np.ndarray  # (N1h,) record coefficient A(k1) of exp(i k1 x) on the active rows, 0 elsewhere
    active: np.ndarray  # (N1h,) bool
    var: float  # noise variance per coefficient [m^2 s^-2]
    H: np.ndarray  # (N1h,) response on exp(i k1 x)


def _x_reading(x_s, grid, n):
    """Phase reference and response of a record's reading along x.

    A record with as many samples as the grid (U / fs = dx) reads the
    linear interpolate between nodes, as ``beam.sample_los`` does: sample i
    is ``(1 - t) f(x_{j0 - i}) + t f(x_{j0 - i + 1})`` with ``x_s = x_{j0} + t
    dx``, the response ``(1 - t) + t exp(i k1 dx)`` on the mode exp(i k1 x)
    and the phase reference x_{j0}.  Any other record is read band-limited
    (its own Fourier series, shifted to x_s).  Returns (x_ref - x0, H(k1)).
    """
    n1 = grid.shape[0]
    dx = grid.spacing[0]
    k = 2.0 * math.pi * np.arange(n1 // 2 + 1) / (n1 * dx)
    f = (x_s - grid.origin[0]) / dx
    if n != n1:
        return x_s - grid.origin[0], np.ones(k.size, complex)
    j0 = math.floor(f + 1e-9)
    t = max(0.0, f - j0)
    H = (1.0 - t) + t * np.exp(1j * k * dx)
    return j0 * dx, H


def _record_coefficients(series, n1, x_ref, U, fs, rng, noise_var):
    """x-Fourier coefficients (of exp(i k1 (x - x0))) of a record, mean removed, minus a noise draw."""
    from .. import _fft

    n = series.size
    d = series - series.mean()
    if rng is not None and noise_var > 0:
        d = d - rng.normal(0.0, math.sqrt(noise_var), n)
    a = _fft.rfft_rows(d[None, :])[0] / n
    nh1 = n1 // 2 + 1
    J = min(n // 2, n1 // 2)
    active = np.zeros(nh1, bool)
    active[: J + 1] = True
    if n != n1:
        # A Nyquist bin of one length is not a mode of the other.
        if n % 2 == 0 and J == n // 2:
            active[J] = False
        if n1 % 2 == 0 and J == n1 // 2:
            active[J] = False
    k = 2.0 * math.pi * np.arange(nh1) * fs / (U * n)
    coef = np.zeros(nh1, complex)
    m = min(nh1, a.size)
    coef[:m] = np.conj(a[:m]) * np.exp(-1j * k[:m] * x_ref)
    if n1 % 2 == 0:
        # Sampled on the grid, the Nyquist mode has a cosine only.
        coef[-1] = coef[-1].real
    coef[~active] = 0.0
    return coef, active


def _channels(records, grid, df, U, rng, extra_yz=()):
    n1 = grid.shape[0]
    L_field = n1 * grid.spacing[0]
    labels = [r.name or f"records[{i}]" for i, r in enumerate(records)]
    for r, lab in zip(records, labels):
        span = U * r.duration
        if abs(span - L_field) > _LENGTH_RTOL * L_field:
            raise ValueError(f"{lab}: the record spans U T = {U:.6g} m/s x {r.duration:.6g} s = {span:.9g} m of x "
                             f"but the field is Nx dx = {L_field:.9g} m long; allowed: equal (dx = U T / Nx = "
                             f"{span / n1:.9g} m, see twin_spacing)")
    pos = _positions(grid, [r.position[1:] for r in records] + list(extra_yz),
                     labels + [f"targets[{i}]" for i in range(len(extra_yz))])
    k1 = df.k1_of_rows(df.rows_half)
    var_v = None
    chans = []
    for ir, r in enumerate(records):
        for c, series in r.values.items():
            nv = r.noise_std[c] ** 2
            H = np.ones(k1.size, complex)
            comp = COMPONENTS.index(c) if c != "speed" else 0
            if c == "speed":
                if var_v is None:
                    var_v = _variances(df)[1]
                Uc = float(series.mean())
                if not Uc > 0:
                    raise ValueError(f"{labels[ir]}: a cup's mean speed must be > 0, got {Uc:.3g} m/s")
                nv += var_v**2 / (2.0 * Uc * Uc)
                if r.distance_constant > 0:
                    H = 1.0 / (1.0 - 1j * k1 * r.distance_constant * U / Uc)
            x_ref, Hx = _x_reading(r.position[0], grid, series.size)
            H = H * Hx
            if n1 % 2 == 0:
                H[-1] = H[-1].real
            coef, active = _record_coefficients(series, n1, x_ref, U, r.sample_rate, rng, nv)
            chans.append(_Channel(ir, comp, coef, active, nv / series.size, H))
    return chans, pos


def _variances(df):
    """The discrete field's variances of u, v, w [m^2 s^-2] (sum of Phi_d over all modes)."""
    rows = df.rows_half
    mult = np.full(rows.size, 2.0)
    mult[0] = 1.0
    if df.n1 % 2 == 0:
        mult[-1] = 1.0
    tot = np.zeros(6)
    for lo in range(0, rows.size, 64):
        ph = df.phi_rows(rows[lo:lo + 64])
        tot += np.einsum("r,rabc->c", mult[lo:lo + 64], ph)
    return tot[:3]


def _row_tasks(df, n_rows):
    per = max(1, _MODES_PER_TASK // (df.lat[0] * df.lat[1]))
    return [(lo, min(n_rows, lo + per)) for lo in range(0, n_rows, per)]


def _lateral_sums(df, rows, pos):
    from ._conditioning_kernels import lateral_cov_kernel

    phi = df.phi_rows(rows, threaded=False)
    L = np.empty((rows.size, pos.py.size, pos.py.size, 6), complex)
    lateral_cov_kernel(phi, pos.wy, pos.wzz, pos.pair, pos.py, L)
    return phi, L


def _channel_cov(L, chans, r_idx):
    """C + N over channels for rows r_idx of a chunk, (R, m, m) complex."""
    m = len(chans)
    C = np.empty((L.shape[0], m, m), complex)
    for a, ca in enumerate(chans):
        for b, cb in enumerate(chans):
            C[:, a, b] = ca.H[r_idx] * np.conj(cb.H[r_idx]) * L[:, ca.pos, cb.pos, _C6[ca.comp, cb.comp]]
        C[:, a, a] += ca.var
    return C


def _solve(C, R, act):
    """(C + N)^-1 R on the active channels of each row (pseudo-inverse of tiny eigenvalues)."""
    G = np.zeros_like(R)
    keys = np.packbits(act, axis=1)
    groups = {}
    for i, k in enumerate(map(bytes, keys)):
        groups.setdefault(k, []).append(i)
    for idx in groups.values():
        idx = np.array(idx)
        a = np.nonzero(act[idx[0]])[0]
        if a.size == 0:
            continue
        Cs = C[np.ix_(idx, a, a)]
        Cs = 0.5 * (Cs + np.conj(np.swapaxes(Cs, 1, 2)))
        lam, V = np.linalg.eigh(Cs)
        tol = _RCOND * np.maximum(lam[:, -1:], 0.0)
        inv = np.where(lam > tol, 1.0 / np.where(lam > tol, lam, 1.0), 0.0)
        y = np.einsum("rji,rj->ri", np.conj(V), R[np.ix_(idx, a)])
        G[np.ix_(idx, a)] = np.einsum("rij,rj->ri", V, inv * y)
    return G


def _condition_lines(arrays, grid, df, records, U, rng, specs_views):
    """Add the per-k1 Hoffman-Ribak correction of line records into the half spectra."""
    from .. import _config, _fft
    from ._conditioning_kernels import correction_kernel

    chans, pos = _channels(records, grid, df, U, rng)
    n1 = grid.shape[0]
    nh1 = n1 // 2 + 1
    rows_all = df.rows_half
    # The field's coefficient at each sensor position: rfft of its interpolated rows.
    P = pos.py.size
    Af = np.empty((P, 3, nh1), complex)
    for p in range(P):
        Af[p] = _fft.rfft_rows(_sample_rows(arrays, grid, pos.corners[p]))[:, :nh1] / n1
    m = len(chans)
    R = np.zeros((nh1, m), complex)
    act = np.zeros((nh1, m), bool)
    for a, ch in enumerate(chans):
        act[:, a] = ch.active
        R[:, a] = np.where(ch.active, ch.coef - ch.H * Af[ch.pos, ch.comp], 0.0)
    if n1 % 2 == 0:
        R[-1] = R[-1].real
    R[0] = R[0].real
    mirror = df.kind != "line"

    def work(_w, t):
        lo, hi = t
        rows = rows_all[lo:hi]
        phi, L = _lateral_sums(df, rows, pos)
        G = _solve(_channel_cov(L, chans, slice(lo, hi)), R[lo:hi], act[lo:hi])
        g = np.zeros((rows.size, P, 3), complex)
        for a, ch in enumerate(chans):
            g[:, ch.pos, ch.comp] += np.conj(ch.H[lo:hi]) * G[:, a]
        correction_kernel(phi, rows, pos.wy, pos.wz, pos.py, pos.pz, g, n1, mirror, *specs_views)

    _config.run_static(_row_tasks(df, rows_all.size), work)
    return chans, pos


def line_variance(grid, df, records, U, targets_yz):
    """Prior and posterior spectra of u, v, w at lateral positions ``targets_yz`` given line records.

    Returns (k1 rows [rad/m], prior (N1h, T, 3), posterior (N1h, T, 3)), each the
    variance of the mode exp(i k1 x) of the target's line [m^2 s^-2].
    """
    from .. import _config

    chans, pos = _channels(records, grid, df, U, None, targets_yz)
    nh1 = grid.shape[0] // 2 + 1
    P0 = len(records)
    T = len(targets_yz)
    act = np.stack([ch.active for ch in chans], axis=1)
    prior = np.empty((nh1, T, 3))
    post = np.empty((nh1, T, 3))

    def work(_w, t):
        lo, hi = t
        rows = df.rows_half[lo:hi]
        _phi, L = _lateral_sums(df, rows, pos)
        C = _channel_cov(L, chans, slice(lo, hi))
        for it in range(T):
            for i in range(3):
                x = np.stack([ch.H[lo:hi] * L[:, ch.pos, P0 + it, _C6[ch.comp, i]] for ch in chans], axis=1)
                G = _solve(C, x, act[lo:hi])
                prior[lo:hi, it, i] = L[:, P0 + it, P0 + it, _C6[i, i]].real
                post[lo:hi, it, i] = prior[lo:hi, it, i] - np.einsum("ra,ra->r", np.conj(x), G).real

    _config.run_static(_row_tasks(df, nh1), work)
    return df.k1_of_rows(df.rows_half), prior, post
