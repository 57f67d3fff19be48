"""Cost of the general linear theory (analysis.linear_theory) for one height of the CS scene.

    python benchmarks/bench_linear_theory.py [--quick] [--json PATH]

Times (this interpreter, after a warm-up at one k1) ``functional_spectra`` of a
1-s VAD scan's u (50 looks on the 30-degree cone, the focused beam's exact
weighting, each look at its own time in the revolution) together with a cup
(first-order response) at 100 m and U = 8 m/s, on 30 wavenumbers (1e-4..1
rad/m; ``--quick``: 10), and, in the same run, the baseline: CS's 1-D filter
model at that height (``cs_model.model_ratios``, spectrum "mann").  Prints the
ratio of the two times and the two std ratios (lidar u over cup).  Runs in one
fresh interpreter under the shared protocol of ``benchmarks/_protocol.py``.
"""

from __future__ import annotations

import argparse
import math
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
    import numpy as np

    from cwlidar_sim.analysis import cs_model
    from cwlidar_sim.analysis import linear_theory as lt
    from cwlidar_sim.analysis.rews_theory import beam_transfer
    from cwlidar_sim.turbulence import MannParameters

    a = SimpleNamespace(quick=task["quick"])
    p = MannParameters(0.05, 60.0, 3.2)
    z, U, half, n_looks, cup_l = 100.0, 8.0, 30.0, 50, 2.3
    r = z / math.cos(math.radians(half))
    th = 2.0 * math.pi * (np.arange(n_looks) + 0.5) / n_looks
    looks = lt.conical_looks(z, half, th, time_l=(th / (2.0 * math.pi) - 0.5), probe=beam_transfer(r, "exact"))
    vad = lt.least_squares_functional(looks, ("u", "v", "w"))
    cup = lt.point_functional((0.0, 0.0, z), ("u",), response=lt.first_order_response(cup_l / U))
    k1 = np.geomspace(1e-4, 1.0, 10 if a.quick else 30)
    lt.functional_spectra(k1[:1], p, [vad, cup], U)  # warm-up
    t0 = time.perf_counter()
    s = lt.functional_spectra(k1, p, [vad, cup], U)
    dt = time.perf_counter() - t0
    t0 = time.perf_counter()
    cs_model._mann_coarse.cache_clear()
    base = cs_model.model_ratios(z, U, 1, spectrum="mann", params=p)
    db = time.perf_counter() - t0
    lk = np.log(k1)
    var_l = float(np.trapezoid(s.spectrum("0.u") * k1, lk))
    var_c = float(np.trapezoid(s.spectrum("1.u") * k1, lk))
    log = [f"linear theory, one CS height (VAD 1 s, {n_looks} looks, exact weighting, + cup), "
           f"{k1.size} k1: {dt:.2f} s ({dt / k1.size:.3f} s per k1)",
           f"baseline cs_model.model_ratios (1-D filter model, Mann spectra): {db:.2f} s; ratio {dt / db:.1f}",
           f"std ratio lidar u / cup over {k1[0]:g}..{k1[-1]:g} rad/m: linear theory {math.sqrt(var_l / var_c):.4f}, "
           f"CS model {base['std_ratio']:.4f}"]
    rows = [{"case": "cs_height", "k1": int(k1.size), "looks": n_looks, "wall_s": dt, "per_k1_s": dt / k1.size,
             "baseline_wall_s": db, "ratio_to_baseline": dt / db,
             "std_ratio_linear": math.sqrt(var_l / var_c), "std_ratio_cs_model": base["std_ratio"]}]
    return {"rows": rows, "log": log}


if __name__ == "__main__":
    sys.exit(main())
