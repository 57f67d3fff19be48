#!/usr/bin/env python3
"""Speed against accuracy, conical panel: CS's lidar/cup std ratio (1 s scans) per numerical setting.

    python benchmarks/speed_vs_accuracy_conical.py --measure [--quick]   # costs -> JSON (one core; --quick:
                                                                         # 120-s periods, 40 m, into results/)
    python benchmarks/speed_vs_accuracy_conical.py --chart               # JSON + convergence -> PNG, table

**Error** of a setting: its 10-minute std ratio minus the converged reference's, from the
paired effects of ``docs/convergence.json`` (``studies/convergence.py``: every knob moved on
its own with the realisation held fixed), chained through the scenes' converged default C =
(tier 'los', span 30 z_R, d = z / 20, cells d, 8 sub-dwells, no hf compensation):

* span and tier rows: their paired effect against C in the ``tail`` group (at 40 m the
  ``tail_long`` group for spans 30 and 60 and the spectral tier there);
* grid, cells, sub-dwells, hf compensation, across-wind spacing: their effect in the ``grid``
  / ``across`` groups (measured at span 5), added to C on the assumption that the knobs'
  effects add (stated, not tested here);
* the reference R: the highest fidelity run, tier 'spectral' at the longest span run (60 z_R
  at 40 m, 30 at 100 m) with the finest across-wind spacing (d/3 at 40 m, d/4 at 100 m).
  Tier 'signal' is not in the convergence study (not measured).

So error(X) = Delta_C(X) - Delta_C(R).  Error bars: the paired effects' standard errors where
two or more seeds ran.  The seed scatter drawn is that of one 10-minute period and of a
6-period mean (the ``size`` group's own-sizing default box over its seeds).

**Cost**: CPU seconds of one 10-minute period (``simulate_conical_period``, seed 1, the
model off, one thread, after a warm-up of each tier), each setting in its own box (the
default sizing: what a user pays), measured here (``--measure``).  Settings whose box
refines the across-wind spacing (4-16 times the cells: gigabytes at span 30) are not run;
their cost is the default's measured cost times the cost ratio the convergence run measured
against its group default (marked 'cost estimated', hollow).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _protocol import log, machine, write_json  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DOCS = os.path.join(os.path.dirname(HERE), "docs")
CONV = os.path.join(DOCS, "convergence.json")
OUT_JSON = os.path.join(DOCS, "speed_vs_accuracy_conical.json")
OUT_PNG = os.path.join(DOCS, "speed_vs_accuracy_conical.png")
SPEED = 10.0

#: (label, tier, run settings, error chain); settings: span, spacing factors (x, y, z) of d, cell factor,
#: sub_dwells, hf, speckle, tail; chain: list of (group, label, sign) summed into Delta_C; 'estimate': the
#: cost from the convergence run's cost ratio (group, label) instead of a measurement
def settings(z):
    t40 = z == 40.0
    base30 = [("tail_long", "span 30 (long box)", -1)] if t40 else [("tail", "span 30", -1)]
    spec30 = ([("tail_long", "tier spectral, span 30 (long box)", 1), ("tail_long", "span 30 (long box)", -1)] if t40
              else [("tail", "tier spectral, span 30", 1), ("tail", "span 30", -1)])
    s = []
    for span in (5, 10, 20):
        s.append((f"los, span {span}", "los", {"span": span}, [("tail", f"span {span}" + (" (default)" if span == 5
                                                                                           else ""), 1),
                                                                ("tail", "span 30", -1)]))
    s.append(("los, span 30 (default C)", "los", {"span": 30}, []))
    if t40:
        s.append(("los, span 60", "los", {"span": 60}, [("tail_long", "span 60", 1)] + base30))
        s.append(("los, span 60, renormalised tail", "los", {"span": 60, "tail": "renormalise"},
                  [("tail_long", "span 60, renormalised tail", 1)] + base30))
    s.append(("los, span 10, renormalised tail", "los", {"span": 10, "tail": "renormalise"},
              [("tail", "span 10, renormalised tail", 1), ("tail", "span 30", -1)]))
    s.append(("los, span 30, renormalised tail", "los", {"span": 30, "tail": "renormalise"},
              [("tail", "span 30, renormalised tail", 1), ("tail", "span 30", -1)]))
    spec_spans = (5, 10, 20) if t40 else (5,)
    for span in spec_spans:
        s.append((f"spectral, span {span}", "spectral", {"span": span},
                  [("tail", f"tier spectral, span {span}", 1), ("tail", "tier spectral, span 30", -1)] + spec30))
    s.append(("spectral, span 30", "spectral", {"span": 30}, spec30))
    if t40:
        s.append(("spectral, span 60", "spectral", {"span": 60},
                  [("tail_long", "tier spectral, span 60", 1), ("tail_long", "span 30 (long box)", -1)]))
    s.append(("spectral, span 30, continuum speckle", "spectral", {"span": 30, "speckle": "continuum"},
              spec30 + [("grid", "tier spectral, continuum speckle", 1),
                        ("grid", "tier spectral (independent speckle)", -1)]))
    for label, st, conv in (("los, span 30, dx = d/2", {"spacing": (0.5, 1, 1)}, "dx = d/2 (along)"),
                            ("los, span 30, hf compensation", {"hf": True}, "hf compensation"),
                            ("los, span 30, cells d/2", {"cell": 0.5}, "cells d/2"),
                            ("los, span 30, sub-dwells 4", {"sub_dwells": 4}, "sub-dwells 4"),
                            ("los, span 30, sub-dwells 16", {"sub_dwells": 16}, "sub-dwells 16")):
        s.append((label, "los", {"span": 30, **st}, [("grid", conv, 1)]))
    across = [("d/2", 0.5), ("d/3", 1 / 3)] + ([] if t40 else [("d/4", 0.25)])
    for name, f in across:
        s.append((f"los, span 30, across {name}", "los", {"span": 30, "spacing": (1, f, f), "estimate":
                                                          ("across", f"across {name}")},
                  [("across", f"across {name}", 1)]))
    s.append(("los, span 30, d/2 everywhere", "los", {"span": 30, "spacing": (0.5, 0.5, 0.5),
                                                      "estimate": ("grid", "d/2 everywhere")},
              [("grid", "d/2 everywhere", 1)]))
    return s


def reference_chain(z):
    if z == 40.0:
        return [("tail_long", "tier spectral, span 60", 1), ("tail_long", "span 30 (long box)", -1),
                ("across", "across d/3", 1)]
    return [("tail", "tier spectral, span 30", 1), ("tail", "span 30", -1), ("across", "across d/4", 1)]


REFERENCE_LABEL = {40.0: "reference: spectral, span 60, across d/3", 100.0: "reference: spectral, span 30, across d/4"}


def _conv_rows():
    with open(CONV) as f:
        d = json.load(f)
    return {(r["height"], r["group"], r["label"]): r for r in d["conical"]}, d["rows"]


def _delta(rows, z, chain, key="std_ratio_1s"):
    tot, var, single = 0.0, 0.0, False
    for g, lab, sign in chain:
        r = rows[(z, g, lab)]
        tot += sign * r[f"{key}_effect"]
        se = r.get(f"{key}_effect_se")
        if r["n_seeds"] < 2 or se is None:
            single = True if r[f"{key}_effect"] != 0.0 else single
        else:
            var += se * se
    return tot, (None if single else math.sqrt(var))


def seed_scatter(raw, z, key="std_ratio_1s"):
    v = [r[key] for k, r in raw.items() if k.startswith(f"conical|{z}|") and k.endswith("|default box (own sizing)")]
    return float(np.std(v, ddof=1)), len(v)


# ---------------------------------------------------------------------------
def run_setting(z, tier, st, duration, seed=1):
    from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
    from cwlidar_sim.campaign.scenes.conical import default_spacing

    d = default_spacing(z)
    ov = {"span": float(st["span"]), "cell_length": st.get("cell", 1.0) * d}
    for k in ("speckle", "tail"):
        if k in st:
            ov[k] = st[k]
    box = {"hf_compensation": bool(st.get("hf", False))}
    sp = st.get("spacing", (1.0, 1.0, 1.0))
    box["spacing"] = tuple(f * d for f in sp)
    t0, c0 = time.perf_counter(), time.process_time()
    r = simulate_conical_period(z, seed, speed=SPEED, duration=duration, tier=tier, spacing=d, model=False,
                                sub_dwells=st.get("sub_dwells", 8), lidar_overrides=ov, box_options=box)
    return {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0, "box_shape": r["box_shape"],
            "std_ratio_1s_seed1": r["scans"][1]["std_ratio"]}


def measure(a):
    res = {"machine": machine(), "duration": a.duration, "records": {}}
    if os.path.exists(a.json):
        with open(a.json) as f:
            old = json.load(f)
        if old.get("duration") == a.duration:
            res["records"] = old["records"]
    for tier in ("los", "spectral"):  # warm-up: numba's cache load, FFTW plans, lazy imports
        run_setting(40.0, tier, {"span": 5}, 20.0)
    for z in a.heights:
        for label, tier, st, _ in settings(z):
            k = f"{z:g}|{label}"
            if "estimate" in st or k in res["records"]:
                continue
            r = run_setting(z, tier, st, a.duration)
            res["records"][k] = dict(r, height=z, label=label, tier=tier)
            log(f"{k}: {r['cpu_s']:.1f} s CPU, {r['wall_s']:.1f} s wall, box {r['box_shape']}")
            res["machine_end"] = machine()
            write_json(a.json + ".tmp", res)
            os.replace(a.json + ".tmp", a.json)
    return res


def table(meas):
    rows, raw = _conv_rows()
    out = []
    for z in sorted({r["height"] for r in meas["records"].values()}):
        ref, ref_se = _delta(rows, z, reference_chain(z))
        default = meas["records"][f"{z:g}|los, span 30 (default C)"]
        scat, nseed = seed_scatter(raw, z)
        for label, tier, st, chain in settings(z):
            dC, se = _delta(rows, z, chain)
            rec = meas["records"].get(f"{z:g}|{label}")
            if rec is not None:
                cost, est = rec["cpu_s"], False
            else:
                g, lab = st["estimate"]
                cost = default["cpu_s"] * rows[(z, g, lab)]["cost_ratio"]
                est = True
            out.append({"height": z, "label": label, "tier": tier, "error": dC - ref, "error_se": se,
                        "cost_cpu_s": cost, "cost_estimated": est, "seed_scatter": scat, "scatter_seeds": nseed,
                        "reference": REFERENCE_LABEL[z], "reference_minus_C": ref, "reference_se": ref_se})
    return out


def chart(recs, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker  # noqa: F401  (matplotlib.ticker below)

    hs = sorted({r["height"] for r in recs})
    fig, axes = plt.subplots(1, len(hs), figsize=(6.6 * len(hs), 5.6), squeeze=False)
    colors = {"los": "tab:blue", "spectral": "tab:orange"}
    floor = 3e-4
    for ax, z in zip(axes[0], hs):
        rs = [r for r in recs if r["height"] == z]
        for r in rs:
            e = max(abs(r["error"]), floor)
            filled = r["error"] >= 0
            ax.scatter(r["cost_cpu_s"], e, s=40, marker="s" if r["cost_estimated"] else "o",
                       facecolors=colors[r["tier"]] if filled else "none", edgecolors=colors[r["tier"]])
            if r["error_se"]:
                ax.errorbar(r["cost_cpu_s"], e, yerr=[[min(r["error_se"], e - floor * 0.999)], [r["error_se"]]],
                            color=colors[r["tier"]], lw=0.7, capsize=2)
            ax.annotate(r["label"].replace("los, ", "").replace("spectral, ", "spec. "), (r["cost_cpu_s"], e),
                        fontsize=6.5, xytext=(3, 2), textcoords="offset points")
        sc = rs[0]["seed_scatter"]
        ax.axhline(sc, color="0.4", ls=":", lw=0.9, label=f"seed scatter of one 10-min period ({sc:.3f})")
        ax.axhline(sc / math.sqrt(6), color="0.6", ls="--", lw=0.9,
                   label=f"standard error of a 6-period mean ({sc / math.sqrt(6):.3f})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.set_ylim(floor * 0.7, 0.3)
        ax.set_xlabel("CPU s per 10-min period (one thread; squares: estimated from the convergence run)")
        ax.set_ylabel("|std ratio (1 s) − reference|  (filled: above, open: below)")
        ax.set_title(f"{z:g} m; {rs[0]['reference']}", fontsize=9)
        for t, c in colors.items():
            ax.scatter([], [], c=c, label=f"tier {t}")
        ax.legend(fontsize=7, loc="upper right")
    fig.suptitle("Conical (CS, 10 m/s): cost against the lidar/cup std ratio's error, per numerical setting",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def markdown(recs):
    lines = ["| z [m] | setting | CPU s / 10-min period | error of the 1-s std ratio vs reference |",
             "|---|---|---|---|"]
    for r in recs:
        e = f"{r['error']:+.4f}" + (f" ± {r['error_se']:.4f}" if r["error_se"] else "")
        c = f"{r['cost_cpu_s']:.1f}" + (" (est.)" if r["cost_estimated"] else "")
        lines.append(f"| {r['height']:g} | {r['label']} | {c} | {e} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--measure", action="store_true")
    ap.add_argument("--chart", action="store_true")
    ap.add_argument("--quick", action="store_true", help="with --measure: 120-s periods, 40 m only")
    ap.add_argument("--json", default=OUT_JSON)
    ap.add_argument("--png", default=OUT_PNG)
    ap.add_argument("--heights", type=float, nargs="+", default=[40.0, 100.0])
    ap.add_argument("--duration", type=float, default=600.0)
    a = ap.parse_args(argv)
    if a.quick:
        a.heights, a.duration = [40.0], 120.0
        # a smoke run: never over the docs' files
        if a.json == OUT_JSON:
            a.json = os.path.join("results", "speed_vs_accuracy_conical_quick.json")
        if a.png == OUT_PNG:
            a.png = os.path.join("results", "speed_vs_accuracy_conical_quick.png")
    if a.measure:
        measure(a)
    if a.chart or not a.measure:
        with open(a.json) as f:
            meas = json.load(f)
        recs = table(meas)
        chart(recs, a.png)
        print(markdown(recs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
