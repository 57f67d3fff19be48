#!/usr/bin/env python3
"""The tail rule's effect, with the turbulence held fixed: staring T2 (A2012 period C) and the conical std ratio.

For each setting of the probe volume's tail -- what the weight beyond the simulated span sees
(``tail``: 'renormalise', the staring lidar's old rule; 'mean_wind', the one rule now, see
:mod:`cwlidar_sim.beam.cells`), the span and the cells' growth -- the same field is measured:

* **staring** (A2012 period C: 8.1 m/s, 1.2 deg off the beam, prototype at 67.5 m, sonic at the focus,
  the bundled a2012 scene's tensor): one plane sized for the longest span, the lidar through tier 'los'
  (the probe volume alone) and 'spectral' (the median estimator), T2 = Re(chi)^2 / F_vs^2 at chosen
  wavenumbers and the band RMS of log10(T2 / T2_reference), the reference being the longest span;
* **conical** (CS's ZephIR, 40 m and 100 m, 10 m/s, a neutral surface layer): one box sized for the
  longest span per height and seed, tier 'los', the lidar/cup 10-min standard-deviation ratio of 1 s
  and 3 s VAD scans.

Usage::

    python studies/tail_rule.py --quick            # 20-min staring records, 1 seed; conical 1 seed
    python studies/tail_rule.py --json results/tail_rule.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

STARING = [  # (label, tail, span [z_R], growth)
    ("renormalise, span 20 (old staring rule)", "renormalise", 20.0, 0.0),
    ("mean wind, span 20", "mean_wind", 20.0, 0.0),
    ("mean wind, span 60", "mean_wind", 60.0, 0.0),
    ("mean wind, span 200, growth 0.1", "mean_wind", 200.0, 0.1),
    ("mean wind, span 200 (reference)", "mean_wind", 200.0, 0.0),
]
K_REPORT = (0.003, 0.01, 0.03, 0.1, 0.28, 0.56)
BAND = (0.002, 0.6)


def staring(duration, seeds, tiers):
    from cwlidar_sim.analysis import log_bins, transfer_functions
    from cwlidar_sim.beam import direction_from_angles
    from convergence import a2012_sonic
    from cwlidar_sim.sensors import StaringLidar, block_average, measure_staring
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.turbulence import MannParameters, generate_plane

    p = MannParameters(alpha_eps=0.06224407174474577, length_scale=18.76, gamma=3.9)
    U, theta = 8.1, 1.2
    inst = PROTOTYPE_2003.replace(focus=67.5, estimator="median")
    n = direction_from_angles(180.0 + theta, 0.0)
    reach = max(s for _, _, s, _ in STARING) * inst.rayleigh_length
    dx = 0.5
    from scipy.fft import next_fast_len

    nx = next_fast_len(int(math.ceil((U * duration + 2 * (inst.focus + reach) + 8) / dx)), real=True)
    lat = (inst.focus + reach) * abs(n[1]) + 4 * p.length_scale
    ny = 1 << int(math.ceil(math.log2(lat / dx)))
    k_edges = log_bins(1e-3, 5.0, 10)
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        field = generate_plane(p, (nx, ny), (dx, dx), seed=seed)
        field.attrs["z"] = 0.0
        x0 = float(field.x.values[-1]) - (inst.focus + reach) * abs(n[0]) - 4.0
        pos = np.array([x0, float(field.y.values[ny // 2]) - inst.focus * n[1], 0.0])
        vs10, t50 = a2012_sonic(field, pos + inst.focus * n, n, duration, U)
        for tier in tiers:
            for label, tail, span, growth in STARING:
                lid = StaringLidar(instrument=inst, position=tuple(pos), azimuth_deg=180.0 + theta, tier=tier,
                                   span=span, cell_length=dx, cell_growth=growth, tail=tail,
                                   transverse_speed=1.0)
                t1 = time.perf_counter()
                rec = measure_staring(field, lid, t50, U, seed + 1)
                cost = time.perf_counter() - t1
                vr10 = block_average(rec.speed_e, 5)[0]
                tf = transfer_functions(vr10, vs10, fs=10.0, U=U, k_edges=k_edges, segment_duration=600.0,
                                        window="hann")
                rows.append({"seed": seed, "tier": tier, "label": label, "tail": tail, "span": span,
                             "growth": growth, "n_cells": rec.info["n_cells"], "cost_s": cost,
                             "k": tf.k_k.tolist(), "t2": tf.transfer_cross_k.tolist()})
        print(f"staring seed {seed}: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return rows


def summarise_staring(rows):
    out = []
    for tier in sorted({r["tier"] for r in rows}):
        ref = {r["seed"]: np.asarray(r["t2"]) for r in rows if r["tier"] == tier and "reference" in r["label"]}
        for label, tail, span, growth in STARING:
            sel = [r for r in rows if r["tier"] == tier and r["label"] == label]
            k = np.asarray(sel[0]["k"])
            band = (k >= BAND[0]) & (k <= BAND[1])
            t2 = np.array([r["t2"] for r in sel])
            d = np.array([np.log10(np.asarray(r["t2"])[band] / ref[r["seed"]][band]) for r in sel])
            at = {f"{kk:g}": float(np.nanmean(np.interp(np.log(kk), np.log(k), np.log10(t2).mean(axis=0))))
                  for kk in K_REPORT}
            out.append({"tier": tier, "label": label, "n_cells": sel[0]["n_cells"],
                        "cost_s": float(np.mean([r["cost_s"] for r in sel])),
                        "rms_log10_vs_reference": float(np.sqrt(np.nanmean(d**2))),
                        "mean_log10_vs_reference": float(np.nanmean(d)),
                        "log10_t2_at_k": at})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", default=os.path.join("results", "tail_rule.json"))
    ap.add_argument("--tiers", nargs="+", default=["los", "spectral"])
    args = ap.parse_args(argv)
    duration = 1200.0 if args.quick else 3600.0
    seeds = [1] if args.quick else [1, 2, 3]
    rows = staring(duration, seeds, args.tiers)
    summary = summarise_staring(rows)
    for s in summary:
        print(f"{s['tier']:9s} {s['label']:42s} cells {s['n_cells']:5d}  {s['cost_s']:6.1f} s  "
              f"mean log10(T2/ref) {s['mean_log10_vs_reference']:+.4f}  rms {s['rms_log10_vs_reference']:.4f}")
    os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    with open(args.json, "w") as fh:
        json.dump({"staring": summary, "staring_rows": rows, "duration": duration, "seeds": seeds}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
