"""Run every benchmark and write one JSON with every ratio.

    python benchmarks/run_all.py [--quick] [--out DIR] [--only NAME ...]

Runs, each as its own command (each under the shared child-process protocol
of ``benchmarks/_protocol.py``), and keeps its full report under
``DIR/<name>.json``:

* ``turbulence``: ``bench_turbulence.py`` -- ours against the FFT floor and
  against the peers mannrs and hipersim (periodic and default settings);
* ``signal``: ``bench_signal.py`` -- the real-time factors of tiers 2 and 3,
  tier 3 against its FFT floor;
* ``campaign``: ``bench_campaign.py`` -- the A2012 reproduction against its
  tier-1 floor;
* ``cs``: ``bench_cs.py`` -- the CS conical reproduction against its tier-1 floor;
* ``nacelle``: ``bench_nacelle.py`` -- the nacelle reproduction against its tier-1 floor;
* ``spinner``, ``windscanner``: ``bench_spinner.py``, ``bench_windscanner.py`` -- each instrument's
  scene in tier ``spectral`` against its tier-1 floor, and its real-time factor;
* ``estimator_theory``: ``bench_estimator_theory.py`` -- the estimator-aware
  theory against one campaign period;
* ``linear_theory``: ``bench_linear_theory.py`` -- the general linear theory at one
  height of the CS scene against CS's 1-D filter model;
* ``scaling``: ``bench_scaling.py`` -- campaign throughput, 1 and N workers;
* ``speed_vs_accuracy``: ``speed_vs_accuracy.py`` -- the fidelity chart;
* ``speed_vs_accuracy_conical``: ``speed_vs_accuracy_conical.py --measure`` -- the
  conical panel's cost per setting, against the converged default's;
* ``subbin``: ``bench_subbin.py`` -- tier 2's gridded ``continuum_moments`` against
  the exact cosine sums;
* ``conditioning``: ``bench_conditioning.py --no-accuracy`` -- conditioned boxes
  (ours, hipersim, mannrs) against an unconditioned box.

Every script in benchmarks/ is one of these (the one-off studies that feed the docs
pages are in studies/).  ``DIR/<name>.json`` is removed before its benchmark runs, so
that a benchmark that fails to write it is reported as failed, never summarised from
an older run's report.

``DIR/run_all.json`` (default DIR ``results/benchmarks``) gathers the
headline ratios of all of them (``ratios``), the machine and the wall time of
each benchmark.  A benchmark that fails is reported with its error; the
others still run.  ``--quick`` passes ``--quick`` to each (about 8-10
minutes on 2 cores); without it the full set takes about 30-60 minutes.

``tools/compare_benchmarks.py --base REV`` runs a base revision's own run_all.py and this
one's, alternating, and prints every headline side by side.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from _protocol import log, machine, write_json  # noqa: E402


def _get(d, *path):
    for p in path:
        if not isinstance(d, dict) or p not in d:
            return None
        d = d[p]
    return d


def ratios_turbulence(rep):
    out = {}
    for sh in rep.get("shapes", []):
        rt = sh.get("ratios", {})
        keep = {k: v for k, v in rt.items() if isinstance(v, (int, float))}
        out[sh["label"]] = keep
    return out


def ratios_signal(rep):
    return {"tier2_realtime_factor": _get(rep, "tier2", "realtime_factor"),
            "tier3_realtime_factor": _get(rep, "tier3", "realtime_factor"),
            "tier3_over_fft_floor": _get(rep, "tier3", "ratio_to_floor"),
            "tier3_over_fft_floor_median": _get(rep, "tier3", "ratio_to_floor_median"),
            "tier3_over_fft_floor_cpu": _get(rep, "tier3", "cpu_ratio_to_floor")}


def ratios_campaign(rep):
    return {"wall_s": rep.get("wall_s_min"), "over_tier1_floor": rep.get("ratio_to_floor"),
            "peak_gib": rep.get("peak_gib")}


def ratios_cs(rep):
    """A bundled scene against its tier-1 floor (``bench_cs.py``, ``bench_nacelle.py``)."""
    return {"wall_s": rep.get("wall_s"), "over_tier1_floor": rep.get("ratio_to_floor"),
            "peak_gib": (rep.get("peak_bytes") or 0) / 2**30}


def ratios_instrument(rep):
    """An instrument's scene in tier spectral against its tier-1 floor, and its real-time factors (issue 31)."""
    return {**ratios_cs(rep), "cpu_over_tier1_floor": rep.get("cpu_ratio_to_floor"),
            "compute_over_tier1_floor": rep.get("compute_ratio_to_floor"),
            "lidar_cpu_over_tier1_floor": rep.get("lidar_cpu_ratio_to_floor"),
            "spectral_realtime_factor": rep.get("realtime_factor"),
            "spectral_realtime_factor_cpu": rep.get("realtime_factor_cpu"),
            "spectral_lidar_realtime_factor_cpu": rep.get("realtime_factor_lidar_cpu")}


def ratios_estimator_theory(rep):
    rows = rep.get("rows", [])
    camp = [r for r in rows if "campaign_period_s" in r]
    out = {f"{r['estimators']} est, {r['lines']} lines, {r['grid']}": r["wall_s"] for r in rows if "grid" in r}
    if camp and rows and "grid" in rows[0]:
        out["theory_1_estimator_over_campaign_period"] = rows[0]["wall_s"] / camp[0]["wall_s"]
    return out


def ratios_linear_theory(rep):
    rows = rep.get("rows", [])
    return {"wall_s": rows[0]["wall_s"], "per_k1_s": rows[0]["per_k1_s"],
            "over_cs_model": rows[0]["ratio_to_baseline"]} if rows else {}


def ratios_scaling(rep):
    return {f"{r['workers']}w_x_{r['threads']}t": {"sim_h_per_wall_h": r["sim_h_per_wall_h"],
                                                   "efficiency": r["efficiency"]} for r in rep.get("runs", [])}


def ratios_speed(rep):
    """The fidelity chart's time and error per setting.

    ``speed_vs_accuracy.json`` is a list of records (older reports: a dict with ``records``).  The
    over-cheapest ratio uses the CPU time (the chart's own time axis: one thread, so steady under load).
    """
    recs = rep.get("records", []) if isinstance(rep, dict) else list(rep)

    def t(r, key):
        v = r.get(key)
        return v if isinstance(v, (int, float)) and v > 0 else None

    best = {}
    for r in recs:
        v = t(r, "cpu_s_per_sim_hour")
        if v is not None:
            best[r.get("scene")] = min(v, best.get(r.get("scene"), v))
    out = {}
    for r in recs:
        cpu, cheapest = t(r, "cpu_s_per_sim_hour"), best.get(r.get("scene"))
        out[f"{r.get('scene')}: {r.get('label')}"] = {
            "wall_s_per_sim_hour": r.get("wall_s_per_sim_hour"), "cpu_s_per_sim_hour": r.get("cpu_s_per_sim_hour"),
            "error": r.get("error"), "over_cheapest_in_scene": cpu / cheapest if cpu and cheapest else None,
            "pareto": r.get("pareto")}
    return out


def ratios_subbin(rep):
    """``continuum_moments`` exact and gridded (the default) as real-time factors, and the speed-up."""
    pkg = [r for r in rep.get("rows", []) if "speedup_of_continuum_moments" in r]
    return {"realtime_exact": rep.get("realtime_exact"), "realtime_gridded": rep.get("realtime_gridded"),
            "speedup_gridded_over_exact": pkg[0]["speedup_of_continuum_moments"] if pkg else None}


def ratios_conditioning(rep):
    """Per constraint set and method: set-up + one conditioned box [s] and its ratio to an unconditioned box."""
    out = {}
    for label, st in rep.get("sets", {}).items():
        for name, t in st.get("timing", {}).items():
            if "wall_s_min" in t:
                out[f"{label}: {name}"] = {"wall_s": t["wall_s_min"], "over_box": t.get("over_box"),
                                           "peak_mb": t.get("peak_mb")}
    return out


def ratios_speed_conical(rep):
    """The conical panel's CPU s per 10-minute period and setting, and its ratio to the default C's."""
    recs = rep.get("records", {})
    default = {r["height"]: r["cpu_s"] for r in recs.values() if "(default C)" in r.get("label", "")}
    out = {}
    for key, r in recs.items():
        d = default.get(r.get("height"))
        out[key] = {"cpu_s": r.get("cpu_s"), "wall_s": r.get("wall_s"),
                    "over_default": r["cpu_s"] / d if d and r.get("cpu_s") else None}
    return out


#: name -> (script, arguments full, arguments quick, ratio extractor, json flag)
BENCHMARKS = {
    "turbulence": ("bench_turbulence.py", [], ["--quick"], ratios_turbulence, "--json"),
    "signal": ("bench_signal.py", [], ["--quick"], ratios_signal, "--json"),
    "campaign": ("bench_campaign.py", [], ["--quick", "--children", "1"], ratios_campaign, "--json"),
    "cs": ("bench_cs.py", [], ["--quick"], ratios_cs, "--json"),
    "estimator_theory": ("bench_estimator_theory.py", [], ["--quick"], ratios_estimator_theory, "--json"),
    "linear_theory": ("bench_linear_theory.py", [], ["--quick"], ratios_linear_theory, "--json"),
    "scaling": ("bench_scaling.py", [], ["--quick"], ratios_scaling, "--json"),
    "speed_vs_accuracy": ("speed_vs_accuracy.py", [], ["--quick"], ratios_speed, "--out"),
    "nacelle": ("bench_nacelle.py", [], ["--quick"], ratios_cs, "--json"),
    "spinner": ("bench_spinner.py", [], ["--quick"], ratios_instrument, "--json"),
    "windscanner": ("bench_windscanner.py", [], ["--quick"], ratios_instrument, "--json"),
    "speed_vs_accuracy_conical": ("speed_vs_accuracy_conical.py", ["--measure"], ["--measure", "--quick"],
                                  ratios_speed_conical, "--json"),
    "subbin": ("bench_subbin.py", [], ["--quick"], ratios_subbin, "--json"),
    "conditioning": ("bench_conditioning.py", ["--no-accuracy"], ["--quick", "--no-accuracy"], ratios_conditioning,
                     "--json"),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="each benchmark's --quick")
    ap.add_argument("--out", default=os.path.join("results", "benchmarks"), metavar="DIR")
    ap.add_argument("--only", nargs="+", choices=list(BENCHMARKS), help="run only these")
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    summary = {"machine": machine(), "mode": "quick" if a.quick else "full", "benchmarks": {}, "ratios": {}}
    for name in a.only or BENCHMARKS:
        script, full, quick, extract, flag = BENCHMARKS[name]
        path = os.path.join(a.out, f"{name}.json")
        if flag == "--out":
            target = os.path.join(a.out, name)
            path = os.path.join(target, f"{name}.json")
        else:
            target = path
        if os.path.exists(path):  # a benchmark that fails to write its report must not be read from an old one
            os.remove(path)
        cmd = [sys.executable, os.path.join(HERE, script), *(quick if a.quick else full), flag, target]
        log(f"== {name}: {' '.join(cmd[1:])}")
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        entry = {"command": cmd[1:], "wall_s": wall, "returncode": p.returncode, "report": path}
        if p.returncode != 0 or not os.path.isfile(path):
            entry["error"] = p.stderr[-3000:]
            log(f"   FAILED (rc={p.returncode}): {p.stderr[-500:]}")
        else:
            try:
                with open(path) as f:
                    summary["ratios"][name] = extract(json.load(f))
            except Exception as exc:  # a report this summary cannot read must not stop the other benchmarks
                entry["error"] = f"summary of {path} failed: {type(exc).__name__}: {exc}"
                log(f"   {entry['error']}")
            else:
                log(f"   {wall:.0f} s: {json.dumps(summary['ratios'][name], default=float)[:600]}")
        summary["benchmarks"][name] = entry
        write_json(os.path.join(a.out, "run_all.json"), summary)
    log(f"written {os.path.join(a.out, 'run_all.json')}")
    return 0 if all("error" not in e for e in summary["benchmarks"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
