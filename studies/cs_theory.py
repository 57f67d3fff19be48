"""The linear theory of the CS table: the bundled CS scene answered with ``[scan] theory = "only"``.

    python studies/cs_theory.py --json docs/cs_theory.json [--heights 40 100]

Runs every unit of the bundled CS scene (``reproduce cs``'s plan: 144 ten-minute periods at 40-100 m, four
mean speeds) at tier ``los`` with ``scan.theory = "only"``
(:mod:`cwlidar_sim.campaign.periods.conical_theory`: the continuum linear theory of the VAD u over the cup,
the scene's exact weighting, on the adaptive k1 grid), and per height and scan length averages the units'
``std_ratio`` as the simulation's table averages its periods' ratios (docs/cs_reproduce.json).  The theory
depends on the height, the speed and the period, not the seed: 16 distinct computations (cached), seconds each
(the cost per one is written).  tools/readme_numbers.py puts the result beside the simulation in the README's
reproductions row; docs/reproductions/cs.md's table quotes it (tests/campaign/test_cs_reproduce_numbers.py).
Full size is the default (a few minutes on 2 cores); ``--heights`` runs a subset.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from cwlidar_sim.campaign.execution.reproduce import bundled_scene  # noqa: E402
from cwlidar_sim.campaign.periods import conical  # noqa: E402


def run(heights=None) -> dict:
    cs = bundled_scene("cs")
    scene = cs.replace(scan=dataclasses.replace(cs.scan, theory="only"), lidar=dataclasses.replace(cs.lidar, tier="los"))
    out, t0 = {}, time.perf_counter()
    for i, (p, z) in enumerate(scene.units()):
        if heights and z not in heights:
            continue
        ds = conical.run_unit(scene, i)
        h = out.setdefault(f"{z:g}", {"periods": 0, "sum": {}, "by_speed": {}, "cost_s": {}})
        h["periods"] += 1
        key = f"{float(p.mean_speed):g}"
        for j, s in enumerate(ds.scan_s.values):
            r = float(ds.std_ratio.values[0, j])
            h["sum"][f"{s:g}s"] = h["sum"].get(f"{s:g}s", 0.0) + r
            h["by_speed"].setdefault(key, {})[f"{s:g}s"] = r
        h["cost_s"].setdefault(key, json.loads(ds.attrs["timing"])["theory"])
        numerics = json.loads(ds.std_ratio_theory.attrs["theory_numerics"])
        weighting = ds.std_ratio_theory.attrs["theory_weighting"]
    res = {"scene": "cs", "tier": "los", "theory": "continuum (scan.theory = 'only')", "weighting": weighting,
           "numerics": numerics, "wall_s": time.perf_counter() - t0, "heights": {}}
    for z, h in out.items():
        row = {"periods": h["periods"], "by_speed": h["by_speed"], "cost_s": h["cost_s"]}
        for s, v in h["sum"].items():
            row[f"std_ratio_{s}_theory"] = v / h["periods"]
        res["heights"][z] = row
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", required=True)
    ap.add_argument("--heights", type=float, nargs="+")
    a = ap.parse_args(argv)
    res = run(a.heights)
    with open(a.json, "w") as f:
        json.dump(res, f, indent=1, sort_keys=True)
        f.write("\n")
    for z, h in sorted(res["heights"].items(), key=lambda kv: float(kv[0])):
        print(z, "m:", {k: round(v, 4) for k, v in h.items() if k.startswith("std_ratio")}, "cost", h["cost_s"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
