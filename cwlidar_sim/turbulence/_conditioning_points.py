"""Conditioning on scattered point values: the dense Hoffman-Ribak update (see ``conditioning.py``)."""

from __future__ import annotations

import math

import numpy as np

from ._conditioning_lines import _C6, _RCOND, COMPONENTS, _fixed_coordinate, _linear_corners


def _point_corners(grid, positions, label):
    """Per point the separable linear weights along x, y, z: three lists of (index, weight)."""
    out = []
    for i, (x, y, z) in enumerate(positions):
        lab = f"{label}[{i}]"
        cx = _linear_corners("x", x, grid.origin[0], grid.spacing[0], grid.shape[0], True, lab)
        if grid.kind == "line":
            cy = _fixed_coordinate("y", y, grid.origin[1], lab)
            cz = _fixed_coordinate("z", z, grid.origin[2], lab)
        else:
            cy = _linear_corners("y", y, grid.origin[1], grid.spacing[1], grid.shape[1], False, lab)
            if grid.kind == "plane":
                cz = _fixed_coordinate("z", z, grid.origin[2], lab)
            else:
                cz = _linear_corners("z", z, grid.origin[2], grid.spacing[2], grid.shape[2], False, lab)
        out.append((cx, cy, cz))
    return out


def _nodes(corners):
    """(P, 8, 3) node indices and (P, 8) weights of the trilinear interpolates."""
    P = len(corners)
    idx = np.zeros((P, 8, 3), np.int64)
    w = np.zeros((P, 8))
    for p, (cx, cy, cz) in enumerate(corners):
        k = 0
        for ix, bx in cx:
            for iy, by in cy:
                for iz, bz in cz:
                    idx[p, k] = (ix, iy, iz)
                    w[p, k] = bx * by * bz
                    k += 1
    return idx, w


def _shape3(grid):
    s = tuple(grid.shape)
    return s + (1,) * (3 - len(s))


def _cross_cov(Cf, shape3, idx_a, w_a, idx_b, w_b, c6):
    """sum over nodes of w_a w_b C_c6(node_a - node_b), (Pa, Pb)."""
    out = np.zeros((idx_a.shape[0], idx_b.shape[0]))
    N = np.array(shape3)
    for k in range(idx_a.shape[1]):
        lag = (idx_a[:, k, None, None, :] - idx_b[None, :, :, :]) % N  # (Pa, Pb, 8, 3)
        vals = Cf[c6][lag[..., 0], lag[..., 1], lag[..., 2]]
        out += w_a[:, k, None] * np.einsum("pqk,qk->pq", vals, w_b)
    return out


def _kxx(Cf, shape3, idx, w, comps):
    m = len(comps)
    P = idx.shape[0]
    K = np.empty((m * P, m * P))
    for a, ca in enumerate(comps):
        for b, cb in enumerate(comps):
            K[a * P:(a + 1) * P, b * P:(b + 1) * P] = _cross_cov(Cf, shape3, idx, w, idx, w, _C6[ca, cb])
    return K


def _pinv_solve(K, rhs):
    K = 0.5 * (K + K.T)
    lam, V = np.linalg.eigh(K)
    tol = _RCOND * max(lam[-1], 0.0)
    inv = np.where(lam > tol, 1.0 / np.where(lam > tol, lam, 1.0), 0.0)
    return V @ (inv[:, None] * (V.T @ rhs)) if rhs.ndim == 2 else V @ (inv * (V.T @ rhs))


def condition_points(arrays, grid, df, pv, rng, specs_views):
    """Add the dense correction of ``pv`` (a PointValues) into the half spectra; returns the solved weights."""
    from .. import _config
    from ._conditioning_kernels import point_correction_kernel

    corners = _point_corners(grid, pv.positions, "PointValues.positions")
    idx, w = _nodes(corners)
    shape3 = _shape3(grid)
    comps = [COMPONENTS.index(c) for c in pv.components]
    Cf = df.covariance_functions().reshape((6,) + shape3)
    K = _kxx(Cf, shape3, idx, w, comps)
    P = idx.shape[0]
    arr3 = [np.asarray(a, dtype=np.float64).reshape(shape3) for a in arrays]
    resid = np.empty(len(comps) * P)
    noise = np.empty(len(comps) * P)
    for a, (c, name) in enumerate(zip(comps, pv.components)):
        fx = np.einsum("pk,pk->p", w, arr3[c][idx[..., 0], idx[..., 1], idx[..., 2]])
        s = pv.noise_std[name]
        e = rng.normal(0.0, s, P) if (rng is not None and s > 0) else 0.0
        resid[a * P:(a + 1) * P] = pv.values[name] - e - fx
        noise[a * P:(a + 1) * P] = s * s
    alpha = _pinv_solve(K + np.diag(noise), resid)
    alpha_p3 = np.zeros((P, 3), complex)
    for a, c in enumerate(comps):
        alpha_p3[:, c] = alpha[a * P:(a + 1) * P]
    # Phase profiles of the interpolation weights, in the kernels' layout.
    N1 = grid.shape[0]
    rows = df.rows_half if grid.kind == "line" else np.arange(N1)
    n = np.arange(N1)
    wx = np.array([sum(b * np.exp(2j * math.pi * n * i / N1) for i, b in cx) for cx, _, _ in corners])
    if grid.kind == "box":
        N2, N3 = grid.shape[1:]
        j2, j3 = np.arange(N2), np.arange(N3 // 2 + 1)
        wy = np.array([sum(b * np.exp(2j * math.pi * j2 * i / N2) for i, b in cy) for _, cy, _ in corners])
        wz = np.array([sum(b * np.exp(2j * math.pi * j3 * i / N3) for i, b in cz) for _, _, cz in corners])
    elif grid.kind == "plane":
        N2 = grid.shape[1]
        j = np.arange(N2 // 2 + 1)
        wy = np.ones((P, 1), complex)
        wz = np.array([sum(b * np.exp(2j * math.pi * j * i / N2) for i, b in cy) for _, cy, _ in corners])
    else:
        wy = np.ones((P, 1), complex)
        wz = np.ones((P, 1), complex)
    lat = df.lat[0] * df.half_lat
    per = max(1, (1 << 16) // max(1, lat * max(1, P // 8)))
    tasks = [(lo, min(rows.size, lo + per)) for lo in range(0, rows.size, per)]

    def work(_w, t):
        r = rows[t[0]:t[1]]
        phi = df.phi_rows(r, half=True, threaded=False)
        point_correction_kernel(phi, r, wx, wy, wz, alpha_p3, *specs_views)

    _config.run_static(tasks, work)
    return alpha


def point_variance(grid, df, pv, targets, label="targets"):
    """Prior and posterior variances of u, v, w at target points given ``pv``: two (T, 3) arrays."""
    corners = _point_corners(grid, pv.positions, "PointValues.positions")
    idx, w = _nodes(corners)
    tidx, tw = _nodes(_point_corners(grid, targets, label))
    shape3 = _shape3(grid)
    comps = [COMPONENTS.index(c) for c in pv.components]
    Cf = df.covariance_functions().reshape((6,) + shape3)
    K = _kxx(Cf, shape3, idx, w, comps)
    K += np.diag(np.concatenate([np.full(idx.shape[0], pv.noise_std[c] ** 2) for c in pv.components]))
    T = tidx.shape[0]
    prior = np.empty((T, 3))
    post = np.empty((T, 3))
    for i in range(3):
        prior[:, i] = np.diag(_cross_cov(Cf, shape3, tidx, tw, tidx, tw, _C6[i, i]))
        X = np.concatenate([_cross_cov(Cf, shape3, idx, w, tidx, tw, _C6[c, i]) for c in comps], axis=0)
        post[:, i] = prior[:, i] - np.einsum("mt,mt->t", X, _pinv_solve(K, X))
    return prior, post
