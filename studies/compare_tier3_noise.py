"""Tier 3 with RIN and the 0 Hz reflection: this checkout's coloured shot noise against an older checkout's AR(1) streams.

    python studies/compare_tier3_noise.py --before DIR [--n N] [--json PATH]

(``DIR``: e.g. ``git archive <rev> | tar -x -C DIR``.)  Since the noise above shot noise became
a colouring of the shot-noise normals (heterodyne.noise_filter) the random draws of tier 3
with RIN differ from the earlier separate AR(1) streams; the law is meant to be the same.
Each checkout runs, in a fresh interpreter (the shared protocol's ``spawn``), the prototype
preset (RIN 10 dB at 300 kHz, reflection 30 dB at 30 kHz) at several speeds, 8 cells over
1 m/s, CNR -15 dB, speckle time at 1 m/s, ``n`` estimates each (one seed per checkout, so the
two samples are independent), and reports per speed: the mean averaged periodogram in
bins 0..40 (where RIN and reflection live), the availability, the mean and the standard
deviation of the median estimates.  The comparison: two-sample z of every statistic with
its standard error from the samples' own scatter (spectrum: per-bin sd / sqrt(n);
availability: binomial; mean speed: sd / sqrt(n); sd: sd sqrt(1 / (2 (n - 1))) per sample).
Not a timing benchmark.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
import _protocol  # noqa: E402
from _protocol import child_main, machine, write_json  # noqa: E402

SPEEDS = (0.8, 1.5, 3.0, 8.0)
BINS = 41


def _child(task):
    import numpy as np

    import cwlidar_sim
    from cwlidar_sim.signal import PROTOTYPE_2003, estimate, simulate_signal_spectra

    inst = PROTOTYPE_2003
    tau = inst.speckle_time(1.0)
    w = np.full(8, 1 / 8)
    out = {"cwlidar_sim": os.path.dirname(os.path.abspath(cwlidar_sim.__file__)), "speeds": {}}
    for i, v0 in enumerate(task["speeds"]):
        v = np.linspace(v0 - 0.5, v0 + 0.5, 8)
        sp = simulate_signal_spectra(inst, np.broadcast_to(v, (task["n"], 8)), w, -15.0, task["seed"] + i,
                                     correlation_time=tau)
        est = estimate(sp, inst).speed_e
        ok = np.isfinite(est)
        out["speeds"][str(v0)] = {
            "spec_mean": sp[:, :BINS].mean(0).tolist(), "spec_sd": sp[:, :BINS].std(0, ddof=1).tolist(),
            "availability": float(ok.mean()), "n": int(est.size), "n_ok": int(ok.sum()),
            "speed_mean": float(est[ok].mean()) if ok.any() else float("nan"),
            "speed_sd": float(est[ok].std(ddof=1)) if ok.sum() > 1 else float("nan")}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", metavar="DIR", help="the older checkout (required)")
    ap.add_argument("--n", type=int, default=300, help="estimates per speed and checkout")
    ap.add_argument("--json", default=None, metavar="PATH")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_main({"default": _child}, a.child)
    if not a.before:
        ap.error("--before DIR is required")
    res = {}
    for name, pp, seed in (("before", a.before, 1000), ("after", None, 2000)):
        r = _protocol.spawn(__file__, {"speeds": SPEEDS, "n": a.n, "seed": seed}, pythonpath=pp, timeout=7200)
        if "error" in r:
            print(r["error"], file=sys.stderr)
            return 1
        res[name] = r
    rows = []
    worst = 0.0
    for v0 in map(str, SPEEDS):
        b, f = res["before"]["speeds"][v0], res["after"]["speeds"][v0]
        zs = [(fm - bm) / math.sqrt((bs**2 + fs**2) / b["n"])
              for bm, bs, fm, fs in zip(b["spec_mean"], b["spec_sd"], f["spec_mean"], f["spec_sd"])]
        p = (b["n_ok"] + f["n_ok"]) / (b["n"] + f["n"])
        se_a = math.sqrt(max(p * (1 - p), 1e-12) * (1 / b["n"] + 1 / f["n"]))
        z_a = (f["availability"] - b["availability"]) / se_a
        z_m = (f["speed_mean"] - b["speed_mean"]) / math.hypot(b["speed_sd"] / math.sqrt(b["n_ok"]),
                                                              f["speed_sd"] / math.sqrt(f["n_ok"]))
        z_s = (f["speed_sd"] - b["speed_sd"]) / math.hypot(b["speed_sd"] / math.sqrt(2 * (b["n_ok"] - 1)),
                                                          f["speed_sd"] / math.sqrt(2 * (f["n_ok"] - 1)))
        row = {"speed": float(v0), "spectrum_z_max_abs": max(abs(z) for z in zs),
               "spectrum_z_mean": sum(zs) / len(zs), "spectrum_chi2_per_bin": sum(z * z for z in zs) / len(zs),
               "availability": [b["availability"], f["availability"]], "z_availability": z_a,
               "speed_mean": [b["speed_mean"], f["speed_mean"]], "z_speed_mean": z_m,
               "speed_sd": [b["speed_sd"], f["speed_sd"]], "z_speed_sd": z_s}
        worst = max(worst, abs(z_a), abs(z_m), abs(z_s), row["spectrum_z_max_abs"] / 1.7)
        rows.append(row)
        print(json.dumps(row), flush=True)
    print(f"{'v':>5s} {'|z| spec max':>12s} {'z spec mean':>11s} {'chi2/bin':>8s} {'avail b/a':>13s} {'z':>5s} "
          f"{'mean b/a':>15s} {'z':>5s} {'sd b/a':>15s} {'z':>5s}")
    for r in rows:
        print(f"{r['speed']:5.1f} {r['spectrum_z_max_abs']:12.2f} {r['spectrum_z_mean']:11.2f} "
              f"{r['spectrum_chi2_per_bin']:8.2f} {r['availability'][0]:6.3f}/{r['availability'][1]:6.3f} "
              f"{r['z_availability']:5.1f} {r['speed_mean'][0]:7.3f}/{r['speed_mean'][1]:7.3f} {r['z_speed_mean']:5.1f} "
              f"{r['speed_sd'][0]:7.4f}/{r['speed_sd'][1]:7.4f} {r['z_speed_sd']:5.1f}")
    # 41 bins: the largest of 41 |z| is below 3.5 with 98 % probability for independent bins
    # (the low bins move together within an estimate: their mean z is held to the one-bin bound)
    verdict = all(r["spectrum_z_max_abs"] < 3.5 and abs(r["spectrum_z_mean"]) < 3.5
                  and max(abs(r["z_availability"]), abs(r["z_speed_mean"]), abs(r["z_speed_sd"])) < 3.5
                  for r in rows)
    print(f"same law within the sampling scatter: {verdict} ({res['before']['cwlidar_sim']} -> "
          f"{res['after']['cwlidar_sim']})")
    if a.json:
        write_json(a.json, {"machine": machine(), "n": a.n, "rows": rows, "same_law": verdict,
                            "checkouts": [res["before"]["cwlidar_sim"], res["after"]["cwlidar_sim"]]})
    return 0 if verdict else 2


if __name__ == "__main__":
    sys.exit(main())
