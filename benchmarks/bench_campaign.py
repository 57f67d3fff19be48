"""Wall time and peak memory of ``cwlidar-sim reproduce a2012`` (four 1-h periods, spectral tier).

    python benchmarks/bench_campaign.py [--quick] [--json PATH] [--children N] [--out DIR]

Protocol (the shared one, ``benchmarks/_protocol.py``)
-----------------------------------------------------
Each run is a fresh interpreter (``--child``) that imports the package, warms the JIT
on a 2-period, 5-minute version of the scene (numba's on-disk cache load and any
compilation excluded), records the load average, and then times
``run_scene(bundled_scene('a2012'))`` plus the figures, as the command does.  The
reported time is the minimum over ``--children`` runs (default 2; other jobs on a
shared machine only add time), with the median beside it, the per-stage times the
runner records (field, lidar, total per period) and ``cpu_per_wall``, which is about
the thread count when the cores are ours.  Peak memory is the child's VmHWM (its own
high-water resident set), with the RSS after the warm-up as the baseline.

Baseline measured in the same run: ``floor_s`` is the time of the four tier-1 lidars
alone (the cells sampled and averaged, no Doppler spectra), the part of the run that
any tier must do; the ratio total / floor shows what the spectral tier and the
analysis add.  Target (issue): the full reproduction under 5 minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import child_main, machine, vmhwm, vmrss, write_json  # noqa: E402

TARGET_S = 300.0


def _child(task) -> dict:
    quick, out = task["quick"], task["out"]
    import dataclasses

    from cwlidar_sim.campaign import bundled_scene, run_scene
    from cwlidar_sim.campaign.figures.staring import make_figures

    scene = bundled_scene("a2012", quick=quick)
    warm = scene.replace(duration=300.0, periods=scene.periods[:2],
                         analysis=dataclasses.replace(scene.analysis, segment_duration=150.0))
    run_scene(warm, progress=False)
    base = vmrss()
    load0 = os.getloadavg()
    w, c = time.perf_counter(), time.process_time()
    ds = run_scene(scene, out, progress=False)
    make_figures(ds, out)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    # the floor: the same four lidars through tier 1 only, no spectra, no fit
    los = scene.replace(lidar=dataclasses.replace(scene.lidar, tier="los", variants=()),
                        analysis=dataclasses.replace(scene.analysis, fit=False))
    f0 = time.perf_counter()
    run_scene(los, progress=False)
    floor = time.perf_counter() - f0
    return {"wall_s": wall, "cpu_s": cpu, "cpu_per_wall": cpu / wall, "floor_s": floor,
            "peak_bytes": vmhwm(), "baseline_bytes": base, "load_before": load0, "load_after": os.getloadavg(),
            "timing": json.loads(ds.attrs["timing"]), "periods": int(ds.sizes["period"])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the --quick scene (shortened periods)")
    ap.add_argument("--children", type=int, default=2)
    ap.add_argument("--json", default=None, metavar="PATH")
    ap.add_argument("--out", default=None, metavar="DIR", help="results folder (default: a temporary one)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child_main({"default": _child}, args.child)
    runs = []
    for i in range(args.children):
        with tempfile.TemporaryDirectory() as tmp:
            out = args.out or tmp
            res = _protocol.spawn(__file__, {"quick": args.quick, "out": out})
            if "error" in res:
                print(res["error"], file=sys.stderr)
                return 1
            runs.append(res)
        r = runs[-1]
        print(f"run {i + 1}: {r['wall_s']:.1f} s wall (tier-1 floor {r['floor_s']:.1f} s), "
              f"cpu/wall {r['cpu_per_wall']:.2f}, peak {r['peak_bytes'] / 2**30:.2f} GiB, "
              f"load {r['load_before'][0]:.2f}")
    walls = [r["wall_s"] for r in runs]
    best = min(runs, key=lambda r: r["wall_s"])
    summary = {
        "scene": "a2012" + (" --quick" if args.quick else ""),
        "wall_s_min": min(walls), "wall_s_median": statistics.median(walls),
        "floor_s": best["floor_s"], "ratio_to_floor": best["wall_s"] / best["floor_s"],
        "peak_gib": best["peak_bytes"] / 2**30, "peak_minus_baseline_gib": (best["peak_bytes"] - best["baseline_bytes"]) / 2**30,
        "target_s": TARGET_S, "met": min(walls) < TARGET_S, "cpu_count": os.cpu_count(), "runs": runs,
        "time": time.strftime("%Y-%m-%dT%H:%M:%S"), "machine": machine(),
    }
    print(f"reproduce a2012{' --quick' if args.quick else ''}: {summary['wall_s_min']:.1f} s "
          f"(median {summary['wall_s_median']:.1f} s; {summary['ratio_to_floor']:.2f}x the tier-1 floor), "
          f"peak {summary['peak_gib']:.2f} GiB; target < {TARGET_S:.0f} s: {'met' if summary['met'] else 'MISSED'}")
    if args.json:
        write_json(args.json, summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
