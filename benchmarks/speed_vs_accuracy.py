"""Speed against accuracy: every fidelity setting of the staring scene on one chart.

    python benchmarks/speed_vs_accuracy.py [--quick] [--out DIR] [--repeats N]

Reference scenes (the bundled A2012 scene, period C: U = 8.1 m/s, misalignment
1.2 deg, prototype at 67.5 m, CNR -10 dB, median estimator; no tensor fit,
no processing variants, so that only the simulation is timed):

* ``hour``: one period of 3600 s (``--quick``: 60 s), 600-s segments (20 s);
  tiers ``los`` and ``spectral``; every field (plane / box at several
  resolutions), probe-volume cell length, speckle model, weighting and span.
  Reference: the finest plane (dx = dy = 0.25 m) with 0.25-m cells.
* ``aligned``: the same with the beam along the wind (misalignment 0), where
  a line along x holds every sensor: line / plane / box side by side.
  Reference: the finest line.
* ``short``: 20 s (``--quick``: 10 s) with 10-s segments, because tier 3
  ``signal`` is limited to 60 s: tiers ``signal`` / ``spectral`` / ``los``,
  speckle models and the averaging (``blocks_per_estimate`` M).  Reference:
  tier 3 with M = 1953.

Every setting of a scene runs on the same field seed.  Recorded per setting
(``speed_vs_accuracy.json``, a list of records): ``wall_s_per_sim_hour``
(wall time of ``run_scene`` per simulated hour, after a warm-up of every tier;
minimum over ``--repeats``), ``cpu_s_per_sim_hour`` (its CPU time: the chart's
axis and the Pareto front use it, being steady on a shared machine; the runs
use one thread), ``peak_bytes`` (VmHWM reset before each
setting), and the errors

* ``error`` = ``error_t2_ref``: RMS over the wavenumber bins of
  ``log10(T2 / T2_reference)``, method 2 (A2012 Eq. 11) against the scene's
  highest-fidelity setting, over ``k`` in [0.01, 0.5] rad/m where both are finite
  and positive (up to 0.5 rad/m: exp(-2 k zR) > 4e-3 for zR = 5.6 m);
* ``error_t2_theory``: the same against the misaligned theory
  (A2012 Eqs. 12-14 with the scene's Mann parameters);
* ``speed_bias``, ``speed_std``: mean and standard deviation of the 50-Hz
  estimates minus the same run's noise-free tier-1 line-of-sight average
  (the estimator's own error; 0 for tier ``los``) [m/s], over valid estimates;
* ``speed_std_vs_sonic``: standard deviation of the 10-Hz lidar minus the
  10-Hz sonic [m/s] (spatial filtering and estimator noise together);
* ``availability``: fraction of valid 50-Hz estimates.

The T2 errors of two settings that draw different speckle or fields include
sampling noise of the record (about ``0.43 / sqrt(n)`` in log10 for ``n``
averaged periodogram values per bin): differences below the reference's own
scatter (``error_floor`` in the report: the RMS log error of T2 between two
seeds of the reference) are not resolved.

Protocol: each scene runs in a fresh interpreter (``benchmarks/_protocol.py``)
that warms every tier and field kind it uses on a 10-s scene first (numba's cache
load and the per-process set-up -- the tensor's covariances and sub-cell variance,
a few seconds once per parameter set -- are excluded: the figure is the marginal
cost of simulated time).  The chart (``speed_vs_accuracy.png``)
has one panel per scene: time per simulated hour on a log axis against the
error, the Pareto front (no other setting is both faster and more accurate)
marked and joined, each point labelled.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402
from _protocol import child_main, log, machine, reset_peak, timed, vmhwm, write_json  # noqa: E402

K_LO, K_HI = 0.01, 0.5

#: Scene groups: name -> (duration full, quick, segment full, quick, misalignment [deg]).
GROUPS = {
    "hour": (3600.0, 60.0, 600.0, 20.0, None),
    "aligned": (3600.0, 60.0, 600.0, 20.0, 0.0),
    "short": (20.0, 10.0, 10.0, 10.0, None),
}


def settings(group, quick):
    """The settings of a scene group: list of (label, overrides); the first is the reference."""
    P = {"field.kind": "plane"}
    if group == "hour":
        s = [
            ("plane dx.25 dy.25 c.25", {**P, "field.dx": 0.25, "field.dy": 0.25}),
            ("plane dx.5 dy.5 (default)", {**P}),
            ("plane dx1 dy1", {**P, "field.dx": 1.0, "field.dy": 1.0}),
            ("plane dx.5 dy2", {**P, "field.dy": 2.0}),
            ("box dx1 dy4 dz4", {"field.kind": "box", "field.dx": 1.0, "field.dy": 4.0, "field.dz": 4.0}),
            ("los tier", {**P, "lidar.tier": "los"}),
            ("cells 1 m", {**P, "lidar.cell_length": 1.0}),
            ("cells 2 m", {**P, "lidar.cell_length": 2.0}),
            ("cells 4 m", {**P, "lidar.cell_length": 4.0}),
            ("speckle independent", {**P, "lidar.speckle": "independent"}),
            ("speckle coherent", {**P, "lidar.speckle": "coherent"}),
            ("lorentzian", {**P, "lidar.weighting": "lorentzian"}),
            ("span 5 zR", {**P, "lidar.span": 5.0}),
            ("seed 2 (scatter)", {**P, "field.dx": 0.25, "field.dy": 0.25, "seed": 7}),
        ]
        if quick:
            s = [x for x in s if x[0] not in ("plane dx.5 dy2", "cells 2 m", "speckle coherent", "span 5 zR")]
        else:
            s.insert(5, ("box dx.5 dy2 dz2", {"field.kind": "box", "field.dy": 2.0, "field.dz": 2.0}))
        return s
    if group == "aligned":
        s = [
            ("line dx.25", {"field.kind": "line", "field.dx": 0.25}),
            ("line dx.5", {"field.kind": "line"}),
            ("line dx1", {"field.kind": "line", "field.dx": 1.0}),
            ("plane dx.5 dy.5", {"field.kind": "plane"}),
            ("box dx1 dy4 dz4", {"field.kind": "box", "field.dx": 1.0, "field.dy": 4.0, "field.dz": 4.0}),
            ("line los tier", {"field.kind": "line", "lidar.tier": "los"}),
            ("line seed 2 (scatter)", {"field.kind": "line", "field.dx": 0.25, "seed": 7}),
        ]
        return [x for x in s if x[0] not in ("line dx1",)] if quick else s
    sig = {**P, "lidar.tier": "signal"}
    s = [
        ("signal M1953", sig),
        ("signal M488", {**sig, "lidar.instrument.blocks_per_estimate": 488}),
        ("spectral continuum", {**P}),
        ("spectral independent", {**P, "lidar.speckle": "independent"}),
        ("spectral coherent", {**P, "lidar.speckle": "coherent"}),
        ("spectral M488", {**P, "lidar.instrument.blocks_per_estimate": 488}),
        ("los tier", {**P, "lidar.tier": "los"}),
        ("signal seed 2 (scatter)", {**sig, "seed": 7}),
    ]
    if quick:
        s = [x for x in s if x[0] not in ("spectral coherent", "spectral M488", "signal seed 2 (scatter)")]
    return s


def base_scene(group, quick, duration=None, segment=None):
    from cwlidar_sim.campaign import bundled_scene

    full, q, seg_full, seg_q, theta = GROUPS[group]
    if duration:
        full = q = duration
    if segment:
        seg_full = seg_q = segment
    sc = bundled_scene("a2012")
    (pc,) = [p for p in sc.periods if p.name == "C"]
    if theta is not None:
        pc = dataclasses.replace(pc, misalignment_deg=theta)
    pc = dataclasses.replace(pc, duration=None)
    return sc.replace(name=f"sva_{group}", duration=q if quick else full, periods=(pc,),
                      lidar=dataclasses.replace(sc.lidar, variants=()),
                      analysis=dataclasses.replace(sc.analysis, fit=False,
                                                   segment_duration=seg_q if quick else seg_full))


def apply(scene, overrides):
    """The scene with dotted overrides (``field.dx``, ``lidar.instrument.blocks_per_estimate``, ``seed``)."""
    d = scene.as_dict()
    for key, val in overrides.items():
        if key == "seed":
            d["period"][0]["seed"] = val
            continue
        node = d
        parts = key.split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = val
    from cwlidar_sim.campaign import Scene

    return Scene.from_dict(d)


def _measure(scene):
    from cwlidar_sim.campaign import run_scene

    ds = run_scene(scene, progress=False)
    k = ds["k"].values
    T2 = ds["transfer_cross"].values[0]
    th = ds["transfer_theory_cross"].values[0]
    sp = ds["lidar_speed"].values[0].astype(np.float64)
    ideal = ds["lidar_ideal"].values[0].astype(np.float64)
    d = sp - ideal  # both are speeds toward the lidar [m/s]
    ok = np.isfinite(d)
    dv = ds["lidar_10hz"].values[0] - ds["sonic_10hz"].values[0]
    okv = np.isfinite(dv)
    return {"k": k.tolist(), "T2": T2.tolist(), "T2_theory": th.tolist(),
            "n_k": ds["n_k"].values[0].tolist(),
            "speed_bias": float(np.mean(d[ok])) if ok.any() else float("nan"),
            "speed_std": float(np.std(d[ok])) if ok.any() else float("nan"),
            "speed_std_vs_sonic": float(np.std(dv[okv])) if okv.any() else float("nan"),
            "availability": float(ds["availability"].values[0]),
            "field_kind": str(ds["field_kind"].values[0]), "field_shape": str(ds["field_shape"].values[0])}


def child_group(task):
    """One scene group in this fresh interpreter: warm-up of every tier, then every setting."""
    from cwlidar_sim import _config

    _config.set_num_threads(1)  # CPU time = wall time on an idle core; the chart compares settings, not cores
    group, quick, repeats = task["group"], task["quick"], task["repeats"]
    base = base_scene(group, quick, task.get("duration"), task.get("segment"))
    every = settings(group, quick)
    chosen = [x for x in every if not task.get("only") or x[0] == every[0][0] or any(o in x[0] for o in task["only"])]
    warm = base.replace(duration=10.0, analysis=dataclasses.replace(base.analysis, segment_duration=10.0))
    used = {(apply(base, ov).lidar.tier, ov.get("field.kind", "auto")) for _, ov in chosen}
    for tier, kind in sorted(used):
        _measure(apply(warm, {"lidar.tier": tier, "field.kind": kind, "field.dy": 4.0, "field.dz": 4.0}))
    out = []
    for label, ov in chosen:
        sc = apply(base, ov)
        best = cpu = None
        reset_peak()
        for _ in range(repeats):
            wall, c, r = timed(lambda: _measure(sc))
            best = wall if best is None else min(best, wall)
            cpu = c if cpu is None else min(cpu, c)
        T = sc.period_duration(sc.periods[0])
        out.append(dict(r, label=label, overrides=ov, wall_s=best, cpu_s=cpu, sim_s=T,
                        wall_s_per_sim_hour=best * 3600.0 / T, cpu_s_per_sim_hour=cpu * 3600.0 / T,
                        peak_bytes=vmhwm(), tier=sc.lidar.tier, field=f"{r['field_kind']} {r['field_shape']}",
                        field_dx=sc.field.dx, cell_length=sc.lidar.cell_length or sc.field.dx,
                        speckle=sc.lidar.speckle, weighting=sc.lidar.weighting, span=sc.lidar.span,
                        blocks_per_estimate=sc.lidar.build_instrument().blocks_per_estimate))
        log(f"  [{group}] {label}: {best:.2f} s wall, {cpu:.2f} s CPU")
    return {"group": group, "records": out}


def rms_log(a, b, k):
    a, b, k = (np.asarray(x, dtype=np.float64) for x in (a, b, k))
    ok = (k >= K_LO) & (k <= K_HI) & np.isfinite(a) & np.isfinite(b) & (a > 0) & (b > 0)
    if not ok.any():
        return float("nan")
    return float(np.sqrt(np.mean(np.log10(a[ok] / b[ok]) ** 2)))


#: The time the chart and the Pareto front use: CPU seconds per simulated hour.  The runs use one
#: thread, so on an idle core this is the wall time; on a shared machine it is the steadier figure
#: (the wall time is recorded too, ``wall_s_per_sim_hour``).
TIME_KEY = "cpu_s_per_sim_hour"


def pareto(records):
    """Mark ``pareto`` on each record: no other record is at most as slow and at most as wrong, one strictly."""
    for r in records:
        t, e = r[TIME_KEY], r["error"]
        r["pareto"] = bool(math.isfinite(e)) and not any(
            (q[TIME_KEY] <= t and q["error"] <= e and (q[TIME_KEY] < t or q["error"] < e))
            for q in records if q is not r and math.isfinite(q["error"]))


def finish(group, recs):
    ref = recs[0]
    for r in recs:
        r["scene"] = group
        r["reference"] = ref["label"]
        r["error_t2_ref"] = 0.0 if r is ref else rms_log(r["T2"], ref["T2"], r["k"])
        r["error_t2_theory"] = rms_log(r["T2"], r["T2_theory"], r["k"])
        r["error"] = r["error_t2_ref"]
    scatter = [r for r in recs if "scatter" in r["label"]]
    floor = scatter[0]["error"] if scatter else float("nan")
    for r in recs:
        r["error_floor"] = floor
    pareto([r for r in recs if "scatter" not in r["label"]])
    for r in recs:
        r.setdefault("pareto", False)
    return recs


def chart(records, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = list(dict.fromkeys(r["scene"] for r in records))
    fig, axes = plt.subplots(1, len(groups), figsize=(6.2 * len(groups), 5.4), squeeze=False)
    colors = {"los": "tab:green", "spectral": "tab:blue", "signal": "tab:red"}
    for ax, g in zip(axes[0], groups):
        rs = [r for r in records if r["scene"] == g]
        for r in rs:
            e = max(r["error"], 1e-3)
            mk = "*" if r["label"] == r["reference"] else ("x" if "scatter" in r["label"] else "o")
            kw = {"edgecolors": "k" if r["pareto"] else "none"} if mk != "x" else {}
            ax.scatter(r[TIME_KEY], e, c=colors[r["tier"]], marker=mk, s=70 if r["pareto"] else 30,
                       zorder=3, **kw)
            ax.annotate(r["label"], (r[TIME_KEY], e), fontsize=7, xytext=(4, 3),
                        textcoords="offset points")
        front = sorted((r for r in rs if r["pareto"]), key=lambda r: r[TIME_KEY])
        if front:
            ax.step([r[TIME_KEY] for r in front], [max(r["error"], 1e-3) for r in front],
                    where="post", color="k", lw=1, ls="--", label="Pareto front")
        fl = rs[0]["error_floor"]
        if math.isfinite(fl):
            ax.axhline(fl, color="0.5", lw=0.8, ls=":", label=f"seed-to-seed scatter {fl:.3f}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time per simulated hour [s] (one thread; = wall time on an idle core)")
        ax.set_ylabel("RMS log10 error of T2 vs reference (0.01-0.5 rad/m)")
        T = rs[0]["sim_s"]
        ax.set_title(f"{g}: period C, {T:g} s; reference {rs[0]['reference']!r}", fontsize=9)
        for t, c in colors.items():
            ax.scatter([], [], c=c, label=f"tier {t}")
        ax.legend(fontsize=7, loc="lower left")
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("cwlidar_sim: speed against accuracy (star: reference; ringed: on the Pareto front; "
                 "x: reference with another seed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short periods (about a minute)")
    ap.add_argument("--out", default=os.path.join("results", "speed_vs_accuracy"), metavar="DIR")
    ap.add_argument("--repeats", type=int, default=None, help="timed runs per setting (1; full 2)")
    ap.add_argument("--groups", nargs="+", choices=list(GROUPS), default=list(GROUPS))
    ap.add_argument("--duration", type=float, default=None, help="override the groups' period [s]")
    ap.add_argument("--segment", type=float, default=None, help="override the groups' segment [s]")
    ap.add_argument("--only", nargs="+", default=None, metavar="TEXT",
                    help="run only the settings whose label contains one of these (and each reference)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_main({"default": child_group}, a.child)
    repeats = a.repeats or (1 if a.quick else 2)
    t0 = time.perf_counter()
    records = []
    for g in a.groups:
        log(f"== {g}")
        r = _protocol.spawn(__file__, {"group": g, "quick": a.quick, "repeats": repeats, "duration": a.duration,
                                       "segment": a.segment, "only": a.only}, timeout=7200)
        if "error" in r:
            log(r["error"])
            return 1
        records += finish(g, r["records"])
    os.makedirs(a.out, exist_ok=True)
    slim = [{k: v for k, v in r.items() if k not in ("k", "T2", "T2_theory", "n_k")} for r in records]
    write_json(os.path.join(a.out, "speed_vs_accuracy.json"), slim)
    write_json(os.path.join(a.out, "speed_vs_accuracy_spectra.json"), records)
    chart(records, os.path.join(a.out, "speed_vs_accuracy.png"))
    log(f"{'scene':8s} {'setting':28s} {'tier':8s} {'wall s/h':>9s} {'cpu s/h':>9s} {'peak MB':>8s} {'err ref':>8s} "
        f"{'err th':>7s} {'bias':>7s} {'std':>6s} {'avail':>6s} pareto")
    for r in records:
        log(f"{r['scene']:8s} {r['label']:28s} {r['tier']:8s} {r['wall_s_per_sim_hour']:9.1f} "
            f"{r['cpu_s_per_sim_hour']:9.1f} "
            f"{r['peak_bytes'] / 1e6:8.0f} {r['error']:8.3f} {r['error_t2_theory']:7.3f} {r['speed_bias']:7.3f} "
            f"{r['speed_std']:6.3f} {r['availability']:6.3f} {'*' if r['pareto'] else ''}")
    log(f"total {time.perf_counter() - t0:.0f} s; machine {json.dumps(machine()['loadavg_1min'])} load; "
        f"written {a.out}/speed_vs_accuracy.json and .png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
