"""Cost of the estimator-aware theory per estimator and k grid, against one campaign period.

    python benchmarks/bench_estimator_theory.py [--quick] [--json PATH]

Times (this interpreter, after a warm-up that loads numba's cache) ``estimator_transfer`` for
A2012's instrument and turbulence at 1 and 4 estimators, 2 and 4 lines of 4096 points, and the
analysis's k grid (10 per decade, 1e-3..5 rad/m) against a 40-per-decade grid; then one 1-h (``--quick``:
10-min) period of the bundled a2012 scene, aligned, spectral tier, no fit, theory off.
Wall times on a shared machine only grow: take the minimum of repeated runs.  The whole
measurement runs in one fresh interpreter under the shared protocol of
``benchmarks/_protocol.py`` (peak memory VmHWM, ``machine()`` in the JSON).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from types import SimpleNamespace

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import child_main, machine, write_json  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_main({"default": _child}, a.child)
    r = _protocol.spawn(__file__, {"quick": a.quick})
    if "error" in r:
        print(r["error"], file=sys.stderr)
        return 1
    for line in r["log"]:
        print(line)
    if a.json:
        write_json(a.json, {"machine": machine(), "rows": r["rows"], "peak_bytes": r["peak_bytes"]})
    return 0


def _child(task):
    a = SimpleNamespace(quick=task["quick"])
    log = []
    from cwlidar_sim.analysis import estimator_transfer, log_bins
    from cwlidar_sim.campaign import bundled_scene, run_scene
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.turbulence import MannParameters

    p = MannParameters(0.06224407174474577, 18.76, 3.9)
    inst = PROTOTYPE_2003.replace(focus=67.5)
    estimator_transfer(inst, p, 8.1, estimators=("median",), n_lines=1, n_points=256)    # warm-up
    rows = []
    grids = {"10/decade": log_bins(1e-3, 5.0, 10), "40/decade": log_bins(1e-3, 5.0, 40)}
    cases = [(("median",), 2, "10/decade"), (("median", "centroid", "peak", "ml"), 2, "10/decade"),
             (("median", "centroid", "peak", "ml"), 2, "40/decade")]
    if not a.quick:
        cases.append((("median", "centroid", "peak", "ml"), 4, "10/decade"))
    for est, lines, g in cases:
        t0 = time.perf_counter()
        estimator_transfer(inst, p, 8.1, estimators=est, n_lines=lines, k_edges=grids[g])
        dt = time.perf_counter() - t0
        rows.append({"estimators": len(est), "lines": lines, "grid": g, "wall_s": dt,
                     "per_line_s": dt / lines, "estimates": lines * 4096})
        log.append(f"theory: {len(est)} estimator(s), {lines} lines x 4096, k grid {g}: {dt:.1f} s")
    s = bundled_scene("a2012")
    per = dataclasses.replace(s.periods[2], misalignment_deg=0.0)
    T = 600.0 if a.quick else 3600.0
    s = s.replace(duration=T, periods=(per,), lidar=dataclasses.replace(s.lidar, variants=()),
                  analysis=dataclasses.replace(s.analysis, fit=False, estimator_theory_lines=0))
    t0 = time.perf_counter()
    run_scene(s, progress=False)
    dt = time.perf_counter() - t0
    log.append(f"campaign period: {T:g} s, spectral tier, {int(T * 50)} estimates: {dt:.1f} s "
               f"({dt / (T * 50) * 4096:.2f} s per 4096 estimates)")
    rows.append({"campaign_period_s": T, "wall_s": dt, "estimates": int(T * 50)})
    return {"rows": rows, "log": log}


if __name__ == "__main__":
    sys.exit(main())
