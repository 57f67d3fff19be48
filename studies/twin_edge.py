"""How far into a period the periodic reading of a record reaches: var(twin - truth) against time from the edge.

Usage::

    python studies/twin_edge.py [--quick] [--pairs M] [--json PATH]

The per-k1 conditioning reads a record of length T as one whole period of a field of length U T:
its first and last seconds meet.  A real mast's record is a window of a longer flow.  Here the
truth is a horizontal Mann plane (the surface layer's tensor at 40 m, U = 10 m/s, 2 m spacing,
128 m wide) three times the record's length; a sonic at y = 0 records the middle third (0.05 m/s of
white noise, one sample per node).  Each twin is a plane of length U T conditioned on that record
alone (:func:`cwlidar_sim.turbulence.conditioning.condition_field`).  At points offset from the
mast by (dx, dy) -- the conical lidar's circle at 40 m has a radius of 23 m -- the benchmark
measures over M (truth, twin) pairs the variance of twin minus truth of u at each instant of the
record, and divides it by the theory away from the ends: twice the conditional variance
sigma^2 (1 - gamma^2) at that point (truth and twin are both draws given the record;
:func:`cwlidar_sim.turbulence.conditioning.conditional_variance`).

Reported per offset: the ratio in 1-s bins from each end, its mean over the middle half of the
period (1 if the twin's periodic model held there; above 1 where the truth holds scales longer
than the record, which the twin cannot), and the reach: the time from each end beyond which every
bin is within 3 standard errors of that middle level (the ratio's standard error per bin is
sqrt(2 / (M samples per bin)), the chi-square scatter).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import log, machine, write_json  # noqa: E402

HEIGHT, U, DX, NY, NOISE = 40.0, 10.0, 2.0, 64, 0.05
#: Offsets (along, across the wind) from the mast [m], on the 2 m nodes (the theory is taken at the very points).
OFFSETS = ((0.0, 0.0), (24.0, 0.0), (-24.0, 0.0), (0.0, 12.0), (0.0, 24.0), (16.0, 16.0))


def run(M, T, seed0=31):
    from cwlidar_sim.turbulence import generate_plane
    from cwlidar_sim.turbulence.conditioning import LineRecord, condition_field, conditional_variance
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    params = surface_layer_parameters(HEIGHT, U)[0]
    n = int(round(U * T / DX))
    fs = U / DX
    i = np.arange(n)
    y_mast = 0.5 * NY * DX  # a node in the middle of the plane's width
    sq = np.zeros((len(OFFSETS), n))
    theory = None
    t0 = time.perf_counter()
    for m in range(M):
        ss = np.random.SeedSequence([seed0, m]).generate_state(3, np.uint64) >> np.uint64(1)
        truth = generate_plane(params, (3 * n, NY), (DX, DX), int(ss[0]), dtype=np.float64)
        tu = {c: truth[c].values for c in "uvw"}
        # the sonic at node x = 2n dx of the truth: sample i sees node 2n - i (the record covers nodes n+1 .. 2n)
        rng = np.random.default_rng(int(ss[1]))
        iy0 = int(round(y_mast / DX))
        vals = {c: tu[c][2 * n - i, iy0] + rng.normal(0.0, NOISE, n) for c in "uvw"}
        rec = LineRecord((0.0, y_mast, 0.0), fs, vals, noise_std=NOISE, name="mast")
        prior_field = generate_plane(params, (n, NY), (DX, DX), int(ss[2]), dtype=np.float64)
        if theory is None:
            tg = [(dx, y_mast + dy, 0.0) for dx, dy in OFFSETS]
            cv = conditional_variance(prior_field, rec, tg, U=U, params=params)
            theory = 2.0 * np.asarray(cv.posterior)[:, 0]
            prior = np.asarray(cv.prior)[:, 0]
        twin = condition_field(prior_field, rec, seed=int(ss[2]), U=U, params=params)
        wu = twin["u"].values
        for o, (dx, dy) in enumerate(OFFSETS):
            jx, jy = int(dx / DX), iy0 + int(dy / DX)
            a = wu[(jx - i) % n, jy]            # twin: periodic, the record's node at x = 0
            # truth: the same offset from the mast, unmeasured air past the ends; the twin's mean wind is the
            # record's mean (U + mean u), so the truth's fluctuation is taken about it
            b = tu["u"][2 * n + jx - i, jy] - vals["u"].mean()
            sq[o] += (a - b) ** 2
        if (m + 1) % 20 == 0:
            log(f"pair {m + 1}/{M} ({time.perf_counter() - t0:.0f} s)")
    return params, n, sq / M, theory, prior


def analyse(var_t, theory, M, n, fs):
    per = int(round(fs))
    out = []
    se = math.sqrt(2.0 / (M * per))
    for o, (dx, dy) in enumerate(OFFSETS):
        r = var_t[o] / theory[o]
        bins = r[: n // per * per].reshape(-1, per).mean(axis=1)
        nb = bins.size
        from_start, from_end = bins[: nb // 2], bins[::-1][: nb // 2]

        mid = bins[nb // 4: 3 * nb // 4]
        level = float(mid.mean())

        def reach(b):
            # the run of bins from the edge that stands out of the period's own level (3 consecutive within
            # 3 standard errors end it; isolated bins further in are chance)
            k = 0
            while k < b.size and np.any(np.abs(b[k:k + 3] - level) > 3 * se * level):
                k += 1
            return float(k)

        rs, re = reach(from_start), reach(from_end)
        out.append({"offset_m": [dx, dy], "theory_var_m2_s2": float(theory[o]),
                    "ratio_first_10_s": [float(x) for x in from_start[:10]],
                    "ratio_last_10_s": [float(x) for x in from_end[:10]],
                    "ratio_middle_mean": level, "reach_start_s": rs, "reach_end_s": re,
                    "bin_standard_error": se})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="40 pairs")
    ap.add_argument("--pairs", type=int, default=None)
    ap.add_argument("--duration", type=float, default=120.0, help="record length T [s] (default 120)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    M = a.pairs or (40 if a.quick else 400)
    t0 = time.perf_counter()
    params, n, var_t, theory, prior = run(M, a.duration)
    res = analyse(var_t, theory, M, n, U / DX)
    rep = {"machine": machine(), "height_m": HEIGHT, "mean_speed_m_s": U, "spacing_m": DX, "width_m": NY * DX,
           "noise_m_s": NOISE, "duration_s": a.duration, "pairs": M, "params": params.as_dict(),
           "prior_var_u_m2_s2": [float(p) for p in prior], "offsets": res, "wall_s": time.perf_counter() - t0}
    for r in res:
        log(f"offset {r['offset_m']} m: 2 sigma^2 (1 - gamma^2) = {r['theory_var_m2_s2']:.4f} m2/s2, middle ratio "
            f"{r['ratio_middle_mean']:.3f}, reach {r['reach_start_s']:.0f} s (start) / {r['reach_end_s']:.0f} s (end); "
            f"first s {np.round(r['ratio_first_10_s'][:4], 2).tolist()}, last s "
            f"{np.round(r['ratio_last_10_s'][:4], 2).tolist()}")
    if a.json:
        write_json(a.json, rep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
