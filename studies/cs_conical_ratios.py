"""CS reproduction at tier 1 (and a tier-2 check): lidar/cup std ratios, TP, radial variances, costs.

Run from the repository root:
    CWLIDAR_SIM_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python studies/cs_conical_ratios.py [n_seeds] [out.json]

Wall times are of this machine at the time of the run (shared, unloaded or not): indicative only.
"""

import json
import sys
import time

import numpy as np

from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period

HEIGHTS = (40.0, 60.0, 80.0, 100.0)


def summarise(runs):
    out = {}
    for n in (1, 3):
        for key in ("std_ratio", "radial_variance_ratio", "tp", "mean_speed_bias", "points_used_fraction",
                    "ambiguity_rate", "std_ratio_model_kaimal", "std_ratio_model_mann",
                    "radial_variance_ratio_model_kaimal", "radial_variance_ratio_model_mann"):
            v = np.array([r["scans"][n][key] for r in runs])
            out[f"{key}_{n}s"] = (float(v.mean()), float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else None)
    out["zero_crossing_loss"] = float(np.mean([r["zero_crossing_loss"] for r in runs]))
    out["cost_s"] = float(np.mean([sum(r["cost_s"].values()) for r in runs]))
    out["box_shape"] = runs[0]["box_shape"]
    return out


def main():
    n_seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 4
    path = sys.argv[2] if len(sys.argv) > 2 else None
    res = {"tier1": {}, "doubling_off": {}, "tier2": {}}
    for z in HEIGHTS:
        runs = [simulate_conical_period(z, s) for s in range(n_seeds)]
        res["tier1"][z] = summarise(runs)
        print(z, json.dumps(res["tier1"][z]), flush=True)
    for z in (40.0, 100.0):
        runs = [simulate_conical_period(z, s, lateral_doubling=False) for s in range(n_seeds)]
        res["doubling_off"][z] = summarise(runs)
        print("no doubling", z, json.dumps(res["doubling_off"][z]), flush=True)
    for z in (40.0, 100.0):
        t = time.perf_counter()
        runs = [simulate_conical_period(z, 0, tier="spectral")]
        res["tier2"][z] = summarise(runs)
        res["tier2"][z]["wall_s"] = time.perf_counter() - t
        res["tier2"][z]["cost_detail"] = runs[0]["cost_s"]
        print("tier2", z, json.dumps(res["tier2"][z]), flush=True)
    if path:
        with open(path, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
