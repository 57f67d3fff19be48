"""A cloud layer above the conical ZephIR: bias of the 10-minute mean speed and std ratio, SECOND_PEAK flags.

Run from the repository root:
    PYTHONPATH=. CWLIDAR_SIM_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python studies/cs_clouds.py \
        [n_seeds] [out.json] [grid,cnr]
    python studies/cs_clouds.py --table out.json      # the Markdown table of docs/cs_clouds.md

Tier 2 (spectral), 10 m/s, 10-minute periods at 40 and 100 m
(:func:`cwlidar_sim.campaign.periods.conical_simulation.simulate_conical_period`), for every seed a clear
period and the same period (same box, same random streams) under a cloud layer of base
300-3000 m, depth 30 m and backscatter 1e3 or 1e4 times the aerosol's, moving

* ``same``: with the mean wind (speed U along +x, the ConicalLidar default), or
* ``sheared``: faster and veered, ``U ln(z_b / z0) / ln(z / z0)`` (log law, z0 = 0.01 m, a
  plausible upper bound: the surface layer does not reach cloud base) toward 20 deg (Ekman veer).

The VAD fits leave SECOND_PEAK points out (the default); for a few cases the fit is repeated
keeping them (``flags_off``), to show what the flag removes; and two cases are repeated at
aerosol CNRs of -15 and -5 dB (section ``cnr``; default -10 dB).  Results are the mean over seeds
and the paired difference cloud - clear (the clear period is the same air, so the difference
carries little scatter); standard errors over seeds.  Wall times are indicative only.
"""

import json
import math
import os
import sys
import time

import numpy as np

from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
from cwlidar_sim.signal import Flag

HEIGHTS = (40.0, 100.0)
BASES = (300.0, 600.0, 1000.0, 1600.0, 3000.0)
STRENGTHS = (1e3, 1e4)
SCENARIOS = ("same", "sheared")
SPEED = 10.0
Z0 = 0.01
VEER_DEG = 20.0
FLAGS_OFF = ((600.0, 1e4), (1600.0, 1e4))  # (base, strength) fitted again with SECOND_PEAK points kept
CNRS = (-15.0, -5.0)  # besides the default -10 dB: the SECOND_PEAK flag depends on the CNR
CNR_CASES = (("sheared", 1e4, 1000.0), ("sheared", 1e4, 1600.0))
KEYS = ("mean_speed_bias", "std_ratio", "points_used_fraction", "selected")


def cloud_overrides(z, base, strength, scenario):
    ov = {"cloud_base": base, "cloud_strength": strength, "cloud_depth": 30.0}
    if scenario == "sheared":
        ov.update(cloud_speed=SPEED * math.log(base / Z0) / math.log(z / Z0), cloud_direction_deg=VEER_DEG)
    return ov


def run(z, seed, overrides=None, excluded=None, cnr_db=None):
    ov = dict(overrides or {})
    if cnr_db is not None:
        ov["cnr_db"] = cnr_db
    return simulate_conical_period(z, seed, speed=SPEED, tier="spectral", model=False, lidar_overrides=ov or None,
                                   excluded_flags=excluded)


def stats(v):
    v = np.asarray(v, dtype=float)
    return [float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else None]


def summarise(runs, clear):
    out = {"cloud_fraction": float(np.mean([r["cloud_fraction"] for r in runs])),
           "second_peak_fraction": stats([r["second_peak_fraction"] for r in runs]),
           "zero_crossing_loss": stats([r["zero_crossing_loss"] for r in runs])}
    for n in (1, 3):
        for k in KEYS:
            out[f"{k}_{n}s"] = stats([float(r["scans"][n][k]) for r in runs])
        for k in ("mean_speed_bias", "std_ratio"):
            out[f"d_{k}_{n}s"] = stats([r["scans"][n][k] - c["scans"][n][k] for r, c in zip(runs, clear)])
    out["cost_s"] = float(np.mean([sum(r["cost_s"].values()) for r in runs]))
    return out


def main():
    n_seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 2
    path = sys.argv[2] if len(sys.argv) > 2 else None
    sections = sys.argv[3].split(",") if len(sys.argv) > 3 else ["grid", "cnr"]
    res = {}
    if path and os.path.exists(path):  # add sections to an earlier run's file
        with open(path) as f:
            res = json.load(f)
    res.setdefault("settings", {"speed": SPEED, "tier": "spectral", "cloud_depth": 30.0, "z0": Z0,
                                "veer_deg": VEER_DEG, "n_seeds": n_seeds, "duration_s": 600.0, "cnr_db": -10.0})
    kept = int(Flag.NO_SIGNAL | Flag.NEAR_ZERO | Flag.NEAR_NYQUIST | Flag.FIT_FAILED | Flag.PAUSED)
    t_all = time.perf_counter()

    def dump():
        if path:
            with open(path, "w") as f:
                json.dump(res, f, indent=1)

    if "grid" in sections:
        res.update(clear={}, cloud={}, flags_off={})
        grid(res, n_seeds, kept, dump)
    if "cnr" in sections:
        res["cnr"] = {}
        for z in HEIGHTS:
            for cnr in CNRS:
                clear = [run(z, s, cnr_db=cnr) for s in range(n_seeds)]
                for scen, strength, base in CNR_CASES:
                    runs = [run(z, s, cloud_overrides(z, base, strength, scen), cnr_db=cnr) for s in range(n_seeds)]
                    key = f"{z:g}/{scen}/{strength:g}/{base:g}/cnr{cnr:g}"
                    res["cnr"][key] = summarise(runs, clear)
                    print(key, json.dumps(res["cnr"][key]), flush=True)
                    dump()
    res[f"wall_s_{'_'.join(sections)}"] = time.perf_counter() - t_all
    dump()


def grid(res, n_seeds, kept, dump):
    for z in HEIGHTS:
        clear = [run(z, s) for s in range(n_seeds)]
        c = summarise(clear, clear)
        res["clear"][str(z)] = c
        print("clear", z, json.dumps(c), flush=True)
        for scen in SCENARIOS:
            for strength in STRENGTHS:
                for base in BASES:
                    runs = [run(z, s, cloud_overrides(z, base, strength, scen)) for s in range(n_seeds)]
                    key = f"{z:g}/{scen}/{strength:g}/{base:g}"
                    res["cloud"][key] = summarise(runs, clear)
                    print(key, json.dumps(res["cloud"][key]), flush=True)
                    if (base, strength) in FLAGS_OFF:
                        runs = [run(z, s, cloud_overrides(z, base, strength, scen), kept) for s in range(n_seeds)]
                        res["flags_off"][key] = summarise(runs, clear)
                        print("flags off", key, json.dumps(res["flags_off"][key]), flush=True)
                    dump()


def pm(x, scale=1.0, fmt="{:+.1f}"):
    m, e = x
    s = fmt.format(m * scale)
    return s if e is None else f"{s} ± {abs(e) * scale:.1g}"


def table(path):
    res = json.load(open(path))
    lines = []
    for z in HEIGHTS:
        c = res["clear"][str(z)]
        lines.append(f"\n**{z:g} m** (clear air: mean-speed bias {pm(c['mean_speed_bias_1s'], 100, '{:+.2f}')} %, "
                     f"std ratio {c['std_ratio_1s'][0]:.3f} (1 s) / {c['std_ratio_3s'][0]:.3f} (3 s), "
                     f"points used {100 * c['points_used_fraction_1s'][0]:.0f} %)\n")
        lines.append("| cloud wind | strength | base [m] | cloud power | Δ mean speed [%] 1 s | Δ std ratio 1 s | "
                     "Δ std ratio 3 s | SECOND_PEAK [%] | points used [%] | periods kept [%] |")
        lines.append("|---|---|---|---|---|---|---|---|---|---|")
        for scen in SCENARIOS:
            for strength in STRENGTHS:
                for base in BASES:
                    key = f"{z:g}/{scen}/{strength:g}/{base:g}"
                    r = res["cloud"].get(key)
                    if r is None:
                        continue
                    lines.append(
                        f"| {scen} | {strength:.0e} | {base:g} | {100 * r['cloud_fraction']:.1f} % | "
                        f"{pm(r['d_mean_speed_bias_1s'], 100, '{:+.2f}')} | "
                        f"{pm(r['d_std_ratio_1s'], 1, '{:+.3f}')} | {pm(r['d_std_ratio_3s'], 1, '{:+.3f}')} | "
                        f"{100 * r['second_peak_fraction'][0]:.2f} | {100 * r['points_used_fraction_1s'][0]:.0f} | "
                        f"{100 * r['selected_1s'][0]:.0f} |")
    if res.get("flags_off"):
        lines.append("\n**SECOND_PEAK points kept in the fit** (same periods)\n")
        lines.append("| case (height/wind/strength/base) | Δ mean speed [%] 1 s, flags off | with flags | "
                     "Δ std ratio 1 s, flags off | with flags |")
        lines.append("|---|---|---|---|---|")
        for key, r in res["flags_off"].items():
            w = res["cloud"][key]
            lines.append(f"| {key} | {pm(r['d_mean_speed_bias_1s'], 100, '{:+.2f}')} | "
                         f"{pm(w['d_mean_speed_bias_1s'], 100, '{:+.2f}')} | {pm(r['d_std_ratio_1s'], 1, '{:+.3f}')} | "
                         f"{pm(w['d_std_ratio_1s'], 1, '{:+.3f}')} |")
    if res.get("cnr"):
        lines.append("\n**Other CNRs** (aerosol wideband CNR; the same periods, clear air at the same CNR)\n")
        lines.append("| case (height/wind/strength/base/CNR) | Δ mean speed [%] 1 s | Δ std ratio 1 s | "
                     "SECOND_PEAK [%] | points used [%] | periods kept [%] |")
        lines.append("|---|---|---|---|---|---|")
        for key, r in res["cnr"].items():
            lines.append(f"| {key} | {pm(r['d_mean_speed_bias_1s'], 100, '{:+.2f}')} | "
                         f"{pm(r['d_std_ratio_1s'], 1, '{:+.3f}')} | {100 * r['second_peak_fraction'][0]:.2f} | "
                         f"{100 * r['points_used_fraction_1s'][0]:.0f} | {100 * r['selected_1s'][0]:.0f} |")
    print("\n".join(lines))


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--table":
        table(sys.argv[2])
    else:
        main()
