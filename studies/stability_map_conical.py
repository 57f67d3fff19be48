"""Stability map, conical panel: where the conically scanning ZephIR's 10-minute statistics fail.

    python studies/stability_map_conical.py [--quick] [--out DIR] [--heights Z ...] [--seeds S ...]

Not a benchmark (no timing): a sweep run by hand that writes ``stability_map_conical.json``,
``stability_table_conical.md`` and ``stability_map_conical.png`` to DIR (default
``results/stability``); docs/stability.md holds the table and the criteria, docs/ the map.

Periods of :func:`cwlidar_sim.campaign.simulate_conical_period` at the converged conical defaults
(span 30 z_R, tier ``spectral``, CS's series instrument, 8 sub-dwells, the z/20 box laterally
doubled), ``--duration`` s each (300), one at a time around the base (10 m/s, CNR -10 dB, wind
along the lidar's azimuth 0), paired seeds (the same seeds at every point of a sweep, so a sweep's
changes are not seed scatter):

* CNR from -5 to -25 dB at 10 m/s;
* mean speed from 1 to 12 m/s at CNR -10 dB (the cross-wind zero crossings: near them the
  line-of-sight speed is below the near-zero band and the estimate is lost; the 180 deg ambiguity
  is resolved against the previous scan);
* the same light winds with the ambiguity resolved by a vane (``reference = 'vane'``).

Clouds are mapped in docs/cs_clouds.md (studies/cs_clouds.py).

Failure criteria (per point, over the seeds; stated here and in docs/stability.md)
-------------------------------------------------------------------------------
* ``unselected``: CS's 65 % rule rejects the period (fewer than 65 % of the line-of-sight
  points used by the VAD fits) in more than half the seeds;
* ``biased``: |mean speed / cup - 1| > 1 % (CS's own accuracy claim is about 0.5 %);
* ``std off``: the 1-s lidar/cup std ratio differs from the same seeds' at the sweep's
  reference point (CNR -5 dB; for the speed sweep the 10 m/s point, less CS's model's own change
  with speed) by more than 0.05 on average and by more than two standard errors of that paired
  change (CNR: the same box, so the change is the method's alone; speed: other boxes, so the seed
  scatter enters);
* ``ambiguous``: more than 1 % of the 1-s scans left with an unresolved 180 deg ambiguity, or
  more than 1 % resolved against the previous scan (``ambiguity_rate``) in a light wind, where a
  wrong resolution flips the direction.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import log, machine, write_json  # noqa: E402

SELECT_MIN, BIAS_MAX, STD_OFF_MAX, AMBIGUITY_MAX = 0.65, 0.01, 0.05, 0.01
CNRS = (-5.0, -10.0, -15.0, -18.0, -20.0, -22.0, -25.0)
SPEEDS = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0)
LIGHT = (1.0, 2.0, 3.0, 4.0)


def _one(z, seed, speed, cnr, reference, duration):
    from cwlidar_sim.campaign import simulate_conical_period
    from cwlidar_sim.campaign.scenes.conical import default_spacing

    # the scene's lidar: span 30, cells of the box spacing (what a conical scene's [lidar] gives)
    r = simulate_conical_period(z, seed, speed=speed, duration=duration, tier="spectral", reference=reference,
                                lidar_overrides={"span": 30.0, "cnr_db": cnr, "cell_length": default_spacing(z)},
                                model=True)
    s1 = r["scans"][1]
    return {"height": z, "seed": seed, "speed": speed, "cnr_db": cnr, "reference": reference,
            "availability": r["availability"], "zero_crossing_loss": r["zero_crossing_loss"],
            "std_ratio": s1["std_ratio"], "std_ratio_model": s1.get("std_ratio_model_kaimal", math.nan),
            "mean_speed_bias": s1["mean_speed_bias"], "points_used_fraction": s1["points_used_fraction"],
            "selected": float(s1["selected"]), "ambiguity_rate": s1["ambiguity_rate"],
            "unresolved_rate": s1["unresolved_rate"], "scan_availability": s1["availability"]}


def _mean(rows, key):
    v = np.array([r[key] for r in rows], dtype=float)
    return float(np.nanmean(v)) if np.isfinite(v).any() else math.nan


def _verdict(rows, ref_rows, model_shift=0.0):
    """Failure labels of one point (rows) against the paired reference rows (same seeds)."""
    out = []
    if np.mean([r["selected"] for r in rows]) < 0.5:
        out.append("unselected")
    if abs(_mean(rows, "mean_speed_bias")) > BIAS_MAX:
        out.append("biased")
    if ref_rows is not None:
        d = [a["std_ratio"] - b["std_ratio"] for a, b in zip(rows, ref_rows)]
        d = np.array(d, dtype=float) - model_shift
        n = int(np.isfinite(d).sum())
        se = float(np.nanstd(d, ddof=1) / math.sqrt(n)) if n > 1 else 0.0
        if n == 0 or (abs(np.nanmean(d)) > STD_OFF_MAX and abs(np.nanmean(d)) > 2.0 * se):
            out.append("std off")
    if _mean(rows, "unresolved_rate") > AMBIGUITY_MAX or (
            rows[0]["speed"] < 5.0 and rows[0]["reference"] == "previous" and _mean(rows, "ambiguity_rate") > AMBIGUITY_MAX):
        out.append("ambiguous")
    return out


def _summary(rows, key_fn, ref_fn, model_shift_fn=lambda g, ref: 0.0):
    groups = {}
    for r in rows:
        groups.setdefault(key_fn(r), []).append(r)
    out = []
    for k in sorted(groups):
        g = sorted(groups[k], key=lambda r: r["seed"])
        ref = ref_fn(k)
        ref_rows = sorted(groups.get(ref, []), key=lambda r: r["seed"]) if ref is not None else None
        shift = model_shift_fn(g, ref_rows) if ref_rows else 0.0
        pt = {"point": k, "seeds": len(g)}
        for key in ("availability", "zero_crossing_loss", "std_ratio", "std_ratio_model", "mean_speed_bias",
                    "points_used_fraction", "selected", "ambiguity_rate", "unresolved_rate"):
            pt[key] = _mean(g, key)
        if ref_rows:
            d = np.array([a["std_ratio"] - b["std_ratio"] for a, b in zip(g, ref_rows)], dtype=float) - shift
            pt["std_ratio_paired_change"] = float(np.nanmean(d)) if np.isfinite(d).any() else math.nan
            pt["std_ratio_paired_change_se"] = (float(np.nanstd(d, ddof=1) / math.sqrt(np.isfinite(d).sum()))
                                                if np.isfinite(d).sum() > 1 else math.nan)
        pt["fails"] = _verdict(g, ref_rows, shift)
        out.append(pt)
    return out


def _table(summary):
    lines = []
    for z, sweeps in summary.items():
        for name, pts in sweeps.items():
            lines.append(f"\n**{z} m, {name}**\n")
            lines.append("| point | estimates lost or flagged | points used | selected | mean bias | std ratio (paired change) | "
                         "ambiguity / unresolved | fails |")
            lines.append("|---|---|---|---|---|---|---|---|")
            for p in pts:
                ch = p.get("std_ratio_paired_change", math.nan)
                se = p.get("std_ratio_paired_change_se", math.nan)
                chs = "" if not math.isfinite(ch) else f" ({ch:+.3f} ± {se:.3f})"
                lines.append(f"| {p['point']} | {max(1 - p['availability'], p['zero_crossing_loss']):.2f} | "
                             f"{p['points_used_fraction']:.2f} | {p['selected']:.2f} | {100 * p['mean_speed_bias']:+.2f} % | "
                             f"{p['std_ratio']:.3f}{chs} | {p['ambiguity_rate']:.3f} / {p['unresolved_rate']:.3f} | "
                             f"{', '.join(p['fails']) or '-'} |")
    return "\n".join(lines) + "\n"


def _plot(summary, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for i, (z, sweeps) in enumerate(summary.items()):
        c = f"C{i}"
        pts = sweeps["CNR"]
        x = [p["point"] for p in pts]
        axes[0].plot(x, [p["points_used_fraction"] for p in pts], "o-", color=c, label=f"{z} m: points used")
        axes[0].plot(x, [p["std_ratio"] for p in pts], "s--", color=c, mfc="none", label=f"{z} m: 1-s std ratio")
        pts = sweeps["speed"]
        x = [p["point"] for p in pts]
        axes[1].plot(x, [p["points_used_fraction"] for p in pts], "o-", color=c, label=f"{z} m: points used")
        axes[1].plot(x, [p["std_ratio"] for p in pts], "s--", color=c, mfc="none", label=f"{z} m: 1-s std ratio")
        axes[1].plot(x, [10 * p["ambiguity_rate"] for p in pts], "^:", color=c, label=f"{z} m: 10 x ambiguity rate")
    for ax, xl in zip(axes, ("CNR [dB] (10 m/s)", "mean speed [m/s] (CNR -10 dB)")):
        ax.axhline(SELECT_MIN, color="k", lw=0.8, ls=":")
        ax.set_xlabel(xl)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("fraction / ratio")
    axes[1].set_ylim(0.0, 2.5)  # below 4 m/s the unselected periods' ratios run off the scale (table)
    fig.suptitle("Conical ZephIR: where the 10-minute statistics fail (dotted: CS's 65 % selection)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="results/stability")
    ap.add_argument("--heights", type=float, nargs="+", default=[40.0, 100.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--duration", type=float, default=300.0)
    ap.add_argument("--quick", action="store_true", help="40 m, one seed, 120-s periods, three points per sweep")
    a = ap.parse_args(argv)
    cnrs, speeds, light = CNRS, SPEEDS, LIGHT
    if a.quick:
        a.heights, a.seeds, a.duration = [40.0], [1], 120.0
        cnrs, speeds, light = (-5.0, -10.0, -22.0), (2.0, 6.0, 10.0), (2.0,)
    os.makedirs(a.out, exist_ok=True)
    path = os.path.join(a.out, "stability_map_conical.json")
    done = {}
    if os.path.exists(path):
        with open(path) as f:
            old = json.load(f)
        if old.get("settings", {}).get("duration") == a.duration:
            done = {(r["height"], r["seed"], r["speed"], r["cnr_db"], r["reference"]): r for r in old["rows"]}
    plan = []
    for z in a.heights:
        for s in a.seeds:
            plan += [(z, s, 10.0, c, "previous") for c in cnrs]
            plan += [(z, s, v, -10.0, "previous") for v in speeds if v != 10.0]
            plan += [(z, s, v, -10.0, "vane") for v in light]
    rows = [done[k] for k in plan if k in done]
    settings = {"duration": a.duration, "span": 30.0, "tier": "spectral", "base_speed": 10.0, "base_cnr_db": -10.0}
    for k in plan:
        if k in done:
            continue
        log(f"z {k[0]:g} m seed {k[1]} speed {k[2]:g} m/s CNR {k[3]:g} dB reference {k[4]}")
        rows.append(_one(*k, a.duration))
        write_json(path, {"machine": machine(), "settings": settings, "rows": rows})
    summary = {}
    for z in a.heights:
        rz = [r for r in rows if r["height"] == z]
        cnr_rows = [r for r in rz if r["speed"] == 10.0 and r["reference"] == "previous"]
        spd_rows = [r for r in rz if r["cnr_db"] == -10.0 and r["reference"] == "previous"]
        vane_rows = [r for r in rz if r["reference"] == "vane"]

        def model_shift(g, ref):
            # the filter model's own change with speed (scan length U T), so the criterion sees the method
            return _mean(g, "std_ratio_model") - _mean(ref, "std_ratio_model")

        summary[f"{z:g}"] = {
            "CNR": _summary(cnr_rows, lambda r: r["cnr_db"], lambda k: max(cnrs)),
            "speed": _summary(spd_rows, lambda r: r["speed"], lambda k: 10.0, model_shift),
            "speed, vane": _summary(vane_rows, lambda r: r["speed"], lambda k: None),
        }
    write_json(path, {"machine": machine(), "settings": settings, "rows": rows, "summary": summary,
                      "criteria": {"select_min": SELECT_MIN, "bias_max": BIAS_MAX, "std_off_max": STD_OFF_MAX,
                                   "ambiguity_max": AMBIGUITY_MAX}})
    table = _table(summary)
    with open(os.path.join(a.out, "stability_table_conical.md"), "w") as f:
        f.write(table)
    _plot(summary, os.path.join(a.out, "stability_map_conical.png"))
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
