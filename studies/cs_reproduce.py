"""The CS reproduction's numbers for the docs: ``cwlidar-sim reproduce cs``'s run, summarised to JSON.

    python studies/cs_reproduce.py [--out DIR] [--json PATH] [--figures DIR] [--quick]
                                      [--run-info JSON]

Runs the bundled ``cs`` scene exactly as ``cwlidar-sim reproduce cs --out DIR`` does
(``run_scene`` of ``bundled_scene("cs")``: its converged settings and its plan of ten-minute
periods per height, ``[scan] periods_per_height``), resuming the units already stored in
``DIR`` (so a finished ``reproduce cs --out DIR`` is summarised without recomputing anything),
and writes per height and scan length the lidar/cup std ratio, its standard error, CS's filter
model (Kaimal and Mann spectra), the radial-variance ratio, the mean-speed bias and the periods
selected (``--json``, the numbers the CS page's table quotes, docs/reproductions/cs.md; tests/campaign/
test_cs_reproduce_numbers.py holds the page to them, tests/test_readme.py the README's summary) and the CS figures (``--figures``).

The JSON's ``cost`` is the units' own wall time (each unit's stage timings as the run stored
them, summed per height); ``run`` is this process's wall and CPU time and load average when it
computed units, or ``--run-info`` (a JSON object: how the ``reproduce cs`` run that wrote DIR was
timed) when every unit was reused.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import machine, write_json  # noqa: E402

SE_TARGET = 0.01


def rows_of(ds, plan) -> dict:
    """Per height (key ``f"{z:g}"``): the summary numbers of a ``reproduce cs`` result."""
    rows = {}
    for i, z in enumerate(ds.height.values):
        row = {"periods": int(plan[float(z)]), "n_periods": int(ds["n_periods"][i])}
        for j, s in enumerate(ds.scan_s.values):
            tag = f"{s:g}s"
            for var in ("std_ratio", "radial_variance_ratio"):
                row[f"{var}_{tag}"] = float(ds[var][i, j])
                row[f"{var}_{tag}_se"] = float(ds[f"{var}_sigma"][i, j])
                row[f"{var}_{tag}_model_kaimal"] = float(ds[f"{var}_model"][i, j])
                row[f"{var}_{tag}_model_mann"] = float(ds[f"{var}_model_mann"][i, j])
            row[f"n_selected_{tag}"] = int(ds["n_selected"][i, j])
            row[f"mean_speed_bias_{tag}"] = float(ds["mean_speed_bias"][i, j])
        rows[f"{z:g}"] = row
    return rows


def unit_cost(ds) -> dict:
    """Sum per height of the units' stored stage timings [s] (``attrs['timing']``, one entry per unit)."""
    timing = json.loads(ds.attrs.get("timing", "{}"))
    heights = dict(zip(ds.period.values.tolist(), ds.unit_height.values.tolist()))
    out = {}
    for name, t in timing.items():
        z = f"{heights[name]:g}"
        c = out.setdefault(z, {"units": 0, "wall_s": 0.0})
        c["units"] += 1
        c["wall_s"] += float(t.get("total", math.nan))
        for stage in ("box", "lidar", "fit_and_model"):
            c[f"{stage}_s"] = c.get(f"{stage}_s", 0.0) + float(t.get(stage, 0.0))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results", help="the run's folder (as reproduce's --out; resumed)")
    ap.add_argument("--json", default=None, help="summary file")
    ap.add_argument("--figures", default=None, help="folder for the CS figures")
    ap.add_argument("--quick", action="store_true", help="the --quick scene")
    ap.add_argument("--run-info", default=None, help="JSON object: the timing of the run that wrote --out")
    a = ap.parse_args(argv)

    from cwlidar_sim.campaign import bundled_scene, run_scene

    scene = bundled_scene("cs", quick=a.quick)
    plan = scene.periods_at()
    load0, t, c = os.getloadavg(), time.perf_counter(), time.process_time()
    ds = run_scene(scene, a.out, progress=False)
    run = {"wall_s": time.perf_counter() - t, "cpu_s": time.process_time() - c, "loadavg_start": list(load0),
           "loadavg_end": list(os.getloadavg())}
    reused = json.loads(ds.attrs.get("periods_reused", "[]"))
    if len(reused) == len(scene.unit_names()):
        run = json.loads(a.run_info) if a.run_info else {"note": "every unit reused; no timing of the run"}
    rows = rows_of(ds, plan)
    worst = max(r[k] for r in rows.values() for k in r if k.startswith("std_ratio") and k.endswith("_se"))
    print("height  N   std ratio 1 s (model K / M)        std ratio 3 s (model K / M)        radial var 1 s")
    for z, r in rows.items():
        print(f"{z:>5} m {r['periods']:3d}  {r['std_ratio_1s']:.3f} +- {r['std_ratio_1s_se']:.3f} "
              f"({r['std_ratio_1s_model_kaimal']:.3f} / {r['std_ratio_1s_model_mann']:.3f})   "
              f"{r['std_ratio_3s']:.3f} +- {r['std_ratio_3s_se']:.3f} "
              f"({r['std_ratio_3s_model_kaimal']:.3f} / {r['std_ratio_3s_model_mann']:.3f})   "
              f"{r['radial_variance_ratio_1s']:.3f} +- {r['radial_variance_ratio_1s_se']:.3f}")
    met = worst <= SE_TARGET
    print(f"largest standard error of a std ratio: {worst:.4f} (target <= {SE_TARGET}: {'met' if met else 'MISSED'})")
    if a.json:
        write_json(a.json, {"machine": machine(), "time": time.strftime("%Y-%m-%dT%H:%M:%S"), "quick": a.quick,
                            "scene": "cs", "units": len(scene.unit_names()),
                            "plan": {f"{z:g}": n for z, n in plan.items()}, "run": run, "cost": unit_cost(ds),
                            "heights": rows, "largest_std_ratio_se": worst, "se_target": SE_TARGET,
                            "se_target_met": bool(met)})
    if a.figures:
        from cwlidar_sim.campaign.figures.conical import make_cs_figures

        make_cs_figures(ds, a.figures)
    return 0 if all(math.isfinite(r["std_ratio_1s"]) for r in rows.values()) and math.isfinite(worst) else 1


if __name__ == "__main__":
    sys.exit(main())
