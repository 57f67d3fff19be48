"""Cost of the general linear theory (analysis.linear_theory) for one height of the CS scene.

    python benchmarks/bench_linear_theory.py [--quick] [--json PATH]

Times (this interpreter, after a warm-up at one k1) ``functional_spectra`` of
one height of the CS scene as its period theory builds it
(``campaign.periods.theory.conical_functionals`` of the bundled scene's lidar at
100 m, U = 8 m/s: the VAD fit of one 1-s revolution, 50 estimates of 8
sub-dwell looks each at its own azimuth and time, the beam's exact weighting;
and the cup with its first-order response) on 30 wavenumbers (1e-4..1 rad/m;
``--quick``: 10), and,
in the same run, the baseline: CS's 1-D filter model at that height
(``cs_model.model_ratios``, spectrum "mann").  Prints the ratio of the two
times and the std ratios (VAD u over cup: the linear theory's over a 600-s
period by ``period_variance``, and the 1-D model's).  Runs in one fresh
interpreter under the shared protocol of ``benchmarks/_protocol.py``.
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
    from cwlidar_sim.campaign.execution.reproduce import bundled_scene
    from cwlidar_sim.campaign.periods.theory import conical_functionals
    from cwlidar_sim.sensors import ConicalLidar, Cup

    a = SimpleNamespace(quick=task["quick"])
    z, U, period = 100.0, 8.0, 600.0
    cs = bundled_scene("cs")
    lidar = ConicalLidar(heights=(z,), **cs.lidar_fields(1.0))
    p = cs.turbulence.params(z, U)
    vad, cup = conical_functionals(lidar, z, U, revolutions=1, cup=Cup(position=(0.0, 0.0, z)))
    n_looks = vad.looks.n_looks
    k1 = np.geomspace(1e-4, 1.0, 10 if a.quick else 30)
    lt.functional_spectra(k1[:1], p, [vad, cup], U)  # warm-up
    t0 = time.perf_counter()
    s = lt.functional_spectra(k1, p, [vad, cup], U)
    dt = time.perf_counter() - t0
    t0 = time.perf_counter()
    cs_model._mann_coarse.cache_clear()
    base = cs_model.model_ratios(z, U, 1, spectrum="mann", params=p)
    db = time.perf_counter() - t0
    var_l = lt.period_variance(k1, s.spectrum("0.u"), U, period)["within"]
    var_c = lt.period_variance(k1, s.spectrum("1.u"), U, period)["within"]
    log = [f"linear theory, one CS height (VAD 1 s, {n_looks} looks, exact weighting, + cup), "
           f"{k1.size} k1: {dt:.2f} s ({dt / k1.size:.3f} s per k1)",
           f"baseline cs_model.model_ratios (1-D filter model, Mann spectra): {db:.2f} s; ratio {dt / db:.1f}",
           f"std ratio lidar u / cup within {period:g} s: linear theory {math.sqrt(var_l / var_c):.4f}, "
           f"CS model {base['std_ratio']:.4f}"]
    rows = [{"case": "cs_height", "k1": int(k1.size), "looks": n_looks, "wall_s": dt, "per_k1_s": dt / k1.size,
             "baseline_wall_s": db, "ratio_to_baseline": dt / db,
             "std_ratio_linear": math.sqrt(var_l / var_c), "std_ratio_cs_model": base["std_ratio"]}]
    return {"rows": rows, "log": log}


if __name__ == "__main__":
    sys.exit(main())
