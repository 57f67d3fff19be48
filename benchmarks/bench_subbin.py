"""Tier 2's per-cell spectral synthesis against sub-bin gridding: error and time (issue 17's note).

    python benchmarks/bench_subbin.py [--quick] [--json PATH] [--estimates N]

Tier 2's exact cost is the cells' cosine sums ``C(tau) = 2 sum_s amp_s cos(2 pi x_s tau / N)``
for every lag the line shape needs (``O(cells x t_max)`` per estimate; the A2012 period:
360 cells of 0.5 m over +-20 zR, t_max = 484 lags).  Depositing the cells' weights on a
sub-bin grid and transforming once is ``O(cells + M log M)``.  Measured here, on the A2012
staring scene's probe volume (Mann line of A2012's tensor at 0.125 m, frozen and advected
at 8 m/s, 0.16 m per estimate; CNR -10 dB; the sub-cell spread of 0.5 m cells; transit
time at 0.9 m/s):

* ``linear Q``: each cell's amplitude shared linearly between the two nearest points of a
  grid of Q points per bin (the note's proposal), one real FFT of length N Q, no
  correction;
* ``gaussian w``: the cells spread by a Gaussian over 2 w + 1 points of a grid of about
  4 t_max angles and the Gaussian divided out after one FFT (a type-1 non-uniform FFT,
  Greengard & Lee 2004: ``continuum_moments(method='gridded')`` is w = 14);

then the same fold, FFT and moments as the exact path (``spectral._lag_moments``).  For each
method: the largest error of the expected signal spectrum ``S_k`` (relative to the
estimate's peak), of each bin's mean and variance (relative), and of the estimates drawn
from the same normals (``sample_moments`` with one key, median estimator): the fraction of
estimates that change, the rms and largest change [m/s], against the chain's own scatter:
the per-bin relative standard deviation ``sqrt(var) / mean`` at the line (the noise of
one drawn spectrum) and the standard deviation of the estimates about the probe-volume
speed (the estimate noise).  The adoption criterion of the note: an error at least 100
times below that scatter.  Time: the wall time of each method's lag sequences and of the
whole ``continuum_moments`` (one thread, minimum of 3), and ``realtime`` = simulated
seconds (50 Hz) per wall second of the lag step.  One process (not the shared protocol's
fresh children): an accuracy study with timings beside it; ``run_all.py`` keeps its
timings (the gridded path against the exact one, measured in the same run).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _protocol import machine, write_json  # noqa: E402  (also puts this checkout on sys.path)

import numpy as np  # noqa: E402


def _scene(ne):
    from cwlidar_sim.sensors import StaringLidar
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.turbulence import MannParameters, generate_line, subcell_variance

    p = MannParameters(0.06224407174474577, 18.76, 3.9)
    inst = PROTOTYPE_2003.replace(focus=67.5)
    cells = StaringLidar(instrument=inst, cell_length=0.5, span=20.0, weighting="exact").cells()
    dx = 0.125
    n = 1 << int(math.ceil(math.log2((cells.s_s.max() - cells.s_s.min() + 0.16 * ne + 50.0) / dx)))
    fld = generate_line(p, n, dx, 2012)
    x, u = fld["x"].values, fld["u"].values
    period = x[-1] + dx
    pos = inst.focus + cells.s_s[None, :] + 40.0 + 0.16 * np.arange(ne)[:, None]
    v = 8.0 + np.interp(np.mod(pos, period), x, u, period=period)
    return inst, v, cells.weight_s, math.sqrt(subcell_variance(p, 0.5)), inst.speckle_time(0.9)


def _cos_linear(x_s, amp_s, n, q, t_used):
    m = n * q
    u = np.mod(x_s, n) * q
    g0 = np.floor(u).astype(np.int64)
    f = u - g0
    w = np.zeros(m)
    np.add.at(w, g0 % m, amp_s * (1.0 - f))
    np.add.at(w, (g0 + 1) % m, amp_s * f)
    return 2.0 * np.fft.rfft(w).real[:t_used]


def _cos_gauss(x_s, amp_s, n, t_used, half):
    from scipy.fft import next_fast_len

    k = 2 * t_used
    m = int(next_fast_len(2 * k, real=True))
    r = m / k
    tau = math.pi * half / (k * k * r * (r - 0.5))
    h = 2.0 * math.pi / m
    th = 2.0 * math.pi * np.mod(x_s, n) / n
    m0 = np.floor(th / h + 0.5).astype(np.int64)
    grid = np.zeros(m)
    for j in range(-half, half + 1):
        d = (m0 + j) * h - th
        np.add.at(grid, (m0 + j) % m, amp_s * np.exp(-d * d / (4.0 * tau)))
    f = np.fft.rfft(grid)[:t_used]
    return 2.0 * f.real * math.sqrt(math.pi / tau) * np.exp(np.arange(t_used) ** 2 * tau) / m


def _lags_from(cos_rows, g, r_d, n, n_j):
    from cwlidar_sim.signal import _kernels as K

    ne = cos_rows.shape[0]
    lags = np.empty((ne, n_j + 1, n))
    c = np.zeros((n_j + 2) * n)
    for e in range(ne):
        c[:] = 0.0
        c[:cos_rows.shape[1]] = cos_rows[e]
        K.fold_block_lags(c, g, r_d, n, lags[e])
    return lags


def _best(fn, repeats=3):
    best = math.inf
    out = None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="512 estimates (default 4096)")
    ap.add_argument("--estimates", type=int, default=None)
    ap.add_argument("--json", default=None, metavar="PATH")
    a = ap.parse_args(argv)
    from cwlidar_sim import _config
    from cwlidar_sim.signal import estimate, noise_floor
    from cwlidar_sim.signal import spectral as S

    _config.set_num_threads(1)
    ne = a.estimates or (512 if a.quick else 4096)
    inst, v, w, spread, tau = _scene(ne)
    cnr_db = -10.0
    n = inst.n_fft
    t_max, n_j, g, r_d = S._continuum_setup(inst, spread, tau)
    t_used = min(t_max, (n_j + 1) * n)
    x = v / inst.bin_speed
    amp = 0.5 * 10.0 ** (cnr_db / 10.0) * w
    noise = noise_floor(inst)
    key = np.uint64(20121)
    S.continuum_moments(inst, v[:8], w, cnr_db, spread, correlation_time=tau)  # warm-up (JIT cache)
    S.continuum_moments(inst, v[:8], w, cnr_db, spread, correlation_time=tau, method="gridded")
    t_exact, (mean0, var0, _) = _best(lambda: S.continuum_moments(inst, v, w, cnr_db, spread, correlation_time=tau))
    t_grid, _ = _best(lambda: S.continuum_moments(inst, v, w, cnr_db, spread, correlation_time=tau,
                                                    method="gridded"))
    est0 = estimate(S.sample_moments(mean0, var0, key), inst)
    sig0 = mean0 - noise
    ok0 = np.isfinite(est0.speed_e)
    vlos = v @ w
    peak = sig0 > 2.0 * noise
    scatter_bin = float(np.median(np.sqrt(var0[peak]) / mean0[peak]))
    scatter_est = float(np.std(est0.speed_e[ok0] - np.abs(vlos[ok0]), ddof=1))
    # the exact path's own rounding: its cosine sums against cos() of every lag
    t = np.arange(t_used)
    sub = slice(0, ne, max(1, ne // 32))
    c_ex = np.array([2.0 * (amp[None, :] * np.cos(np.outer(t, 2 * np.pi * np.mod(xe, n) / n))).sum(1)
                     for xe in x[sub]])
    lags_ex = _lags_from(c_ex, g, r_d, n, n_j)
    m_ex, _, _ = S._lag_moments(inst, lags_ex)
    rows = [{"method": "exact (Chebyshev, the default)", "lags_s": t_exact, "moments_s": t_exact,
             "mean_rel_err_vs_cos": float(np.max(np.abs(mean0[sub] / m_ex - 1.0)))}]

    def record(name, cos_fn, lag_time=None, moments_time=None):
        t0 = time.perf_counter()
        c = np.array([cos_fn(x[e]) for e in range(ne)])
        lags = _lags_from(c, g, r_d, n, n_j)
        py_time = time.perf_counter() - t0
        mean, var, _ = S._lag_moments(inst, lags)
        sig = mean - noise
        est = estimate(S.sample_moments(mean, var, key), inst)
        ok = np.isfinite(est.speed_e) & ok0
        d = est.speed_e[ok] - est0.speed_e[ok]
        changed = np.count_nonzero(d != 0.0) + np.count_nonzero(np.isfinite(est.speed_e) != ok0)
        r = {"method": name,
             "signal_err_over_peak": float(np.max(np.abs(sig - sig0).max(1) / sig0.max(1))),
             "mean_rel_err": float(np.max(np.abs(mean / mean0 - 1.0))),
             "var_rel_err": float(np.max(np.abs(var / var0 - 1.0))),
             "estimates_changed": changed / ne,
             "speed_rms_change": float(np.sqrt(np.mean(d * d))) if d.size else 0.0,
             "speed_max_change": float(np.max(np.abs(d))) if d.size else 0.0,
             "lags_s_numpy_prototype": py_time}
        if lag_time is not None:
            r["lags_s"] = lag_time
            r["moments_s"] = moments_time
        r["margin_mean_vs_bin_scatter"] = scatter_bin / max(r["mean_rel_err"], 1e-300)
        r["margin_speed_vs_estimate_scatter"] = scatter_est / max(r["speed_rms_change"], 1e-300)
        rows.append(r)
        print(json.dumps(r), flush=True)

    for q in ([4, 16, 64] if a.quick else [4, 16, 64, 256]):
        record(f"linear Q={q}", lambda xe, q=q: _cos_linear(xe, amp, n, q, t_used))
    for half in ([6, 14] if a.quick else [6, 10, 12, 14]):
        record(f"gaussian w={half}", lambda xe, h=half: _cos_gauss(xe, amp, n, t_used, h),
               lag_time=t_grid if half == S.GRID_HALF_WIDTH else None,
               moments_time=t_grid if half == S.GRID_HALF_WIDTH else None)
    # the package's gridded path itself (numba kernels), against the exact one
    mean_g, var_g, _ = S.continuum_moments(inst, v, w, cnr_db, spread, correlation_time=tau, method="gridded")
    est_g = estimate(S.sample_moments(mean_g, var_g, key), inst)
    same = np.array_equal(est_g.speed_e, est0.speed_e, equal_nan=True)
    pkg = {"method": f"continuum_moments(method='gridded'), w={S.GRID_HALF_WIDTH}", "moments_s": t_grid,
           "mean_rel_err": float(np.max(np.abs(mean_g / mean0 - 1.0))),
           "var_rel_err": float(np.max(np.abs(var_g / var0 - 1.0))),
           "estimates_identical": bool(same),
           "estimates_changed": float(np.mean(est_g.speed_e != est0.speed_e)),
           "speedup_of_continuum_moments": t_exact / t_grid}
    rows.append(pkg)
    rep = {"machine": machine(), "estimates": ne, "cells": int(w.size), "t_max": int(t_max), "block_lags": int(n_j),
           "speed_spread": spread, "correlation_time": tau, "cnr_db": cnr_db,
           "scatter_per_bin_relative": scatter_bin, "scatter_estimates_m_s": scatter_est,
           "realtime_exact": ne / 50.0 / t_exact, "realtime_gridded": ne / 50.0 / t_grid, "rows": rows}
    print(f"A2012 probe volume: {w.size} cells, t_max {t_max}, {ne} estimates; chain's scatter: per bin "
          f"{scatter_bin:.3g} (relative), estimates {scatter_est:.3g} m/s")
    print(f"{'method':44s} {'S err/peak':>10s} {'mean err':>9s} {'var err':>9s} {'changed':>8s} {'rms dv':>9s} "
          f"{'margin':>9s} {'time s':>7s}")
    for r in rows:
        print(f"{r['method']:44s} {r.get('signal_err_over_peak', float('nan')):10.2e} "
              f"{r.get('mean_rel_err', r.get('mean_rel_err_vs_cos', float('nan'))):9.2e} "
              f"{r.get('var_rel_err', float('nan')):9.2e} {r.get('estimates_changed', 0.0):8.4f} "
              f"{r.get('speed_rms_change', float('nan')):9.2e} {r.get('margin_mean_vs_bin_scatter', float('nan')):9.2e} "
              f"{r.get('moments_s', float('nan')):7.3f}")
    print(f"continuum_moments: exact {t_exact:.3f} s, gridded {t_grid:.3f} s ({t_exact / t_grid:.2f}x) for {ne} "
          f"estimates, one thread")
    if a.json:
        write_json(a.json, rep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
