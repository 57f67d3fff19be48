#!/usr/bin/env python3
"""Every headline of ``benchmarks/run_all.py``, a base revision against the working tree, with the noise.

Usage (from the repository root)::

    python tools/compare_benchmarks.py --base main --quick
    python tools/compare_benchmarks.py --base 561c7dd --quick --only signal cs --rounds 2
    python tools/compare_benchmarks.py --base main --quick --json results/compare.json --keep results/compare

The base revision is extracted with ``git archive REV`` into a temporary folder (nothing in the
repository or its worktrees changes).  For each benchmark both sides know, each side runs **its
own** ``benchmarks/run_all.py [--quick] --only NAME`` (a base with another layout of benchmarks/
runs its own scripts), with ``PYTHONPATH`` set to its own tree so that it imports its own
``cwlidar_sim`` (checked before the runs).  The sides alternate benchmark by benchmark, in the order
base, new, new, base, base, new, ... over ``--rounds`` rounds, so that a change of the machine's
load reaches both alike.

Before the rounds, each side runs each benchmark once with ``--quick`` and the result is thrown away
(``--no-warmup`` skips it): the base tree is a fresh copy, so its first run would compile and write
numba's on-disk cache inside timings that a benchmark's own warm-up does not cover (measured:
estimator_theory's campaign period 2.8 s on a fresh tree against 0.8 s once its cache existed).

Each side's headline is its best over the rounds: the minimum of a time, a ratio to a floor or a
memory figure, the maximum of a real-time factor, speed-up, throughput or efficiency (the shared
protocol's rule: other jobs only ever make a run slower).  The *noise* of a headline is the spread
of the rounds on one side, ``(worst - best) / best``, the larger of the two sides' (the same code
measured twice under the same conditions; ``--rounds 1`` measures none).  A headline of the working
tree is flagged when it is worse than the base's by more than both ``--noise-factor`` (default 2) times
that noise and ``--min-noise``: the change is the difference of two bests, each as uncertain as the
noise, and two rounds underestimate the spread (a comparison of identical packages at a load of 3-5
flagged 4 of 9 headlines with the factor 1, none with 2).
Accuracy figures (``error``, ``pareto``, strings) are shown and never flagged.  Exit status 1 when a
headline is flagged or a benchmark failed on either side.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: Substrings of a headline's last key that mark it higher-is-better (and bench_turbulence's ``ours/<peer>``,
#: the peer's time over ours).
HIGHER_IS_BETTER = ("realtime", "speedup", "sim_h_per_wall_h", "efficiency")
#: Memory headlines: lower is better, flagged as more memory (not as slower).
MEMORY = ("peak", "increment")
#: Not a cost: shown, never flagged.
NOT_A_COST = ("error", "pareto")


def kind(key: str) -> str:
    """'higher', 'memory', 'info' or 'lower' (lower is better: times and ratios to a floor) of a flattened key."""
    parts = key.split("/")
    last, last2 = parts[-1], "/".join(parts[-2:])  # bench_turbulence's "ours_peak/output"
    if any(s in last for s in NOT_A_COST):
        return "info"
    if any(s in last for s in HIGHER_IS_BETTER) or (len(parts) > 1 and parts[-2] == "ours"):
        return "higher"
    if any(s in last for s in MEMORY) or (last == "output" and any(s in last2 for s in MEMORY)):
        return "memory"
    return "lower"


def flatten(d, prefix="") -> dict:
    """{'a/b/c': number} of the numbers (not bools) in nested dicts."""
    out = {}
    for k, v in d.items():
        key = f"{prefix}/{k}" if prefix else str(k)
        if isinstance(v, dict):
            out.update(flatten(v, key))
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
            out[key] = float(v)
    return out


def side_env(tree: pathlib.Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONHOME", None)
    return env


def side_info(tree: pathlib.Path) -> dict:
    """The benchmarks a side's run_all.py knows and the cwlidar_sim it imports (in a fresh interpreter)."""
    code = ("import json, sys, cwlidar_sim; sys.path.insert(0, sys.argv[1]); import run_all; "
            "print(json.dumps({'names': list(run_all.BENCHMARKS), 'package': cwlidar_sim.__file__}))")
    r = subprocess.run([sys.executable, "-c", code, str(tree / "benchmarks")], env=side_env(tree), cwd=str(tree),
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"cannot read {tree}/benchmarks/run_all.py:\n{r.stderr[-2000:]}")
    info = json.loads(r.stdout.strip().splitlines()[-1])
    if not pathlib.Path(info["package"]).resolve().is_relative_to(tree.resolve()):
        raise SystemExit(f"the side in {tree} imports cwlidar_sim from {info['package']}, not from its own tree")
    return info


def run_one(tree: pathlib.Path, name: str, quick: bool, out: pathlib.Path) -> dict:
    """One side's ``run_all.py --only NAME``: {'ratios': {...}, 'wall_s': ...} or {'error': ...}."""
    out.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, str(tree / "benchmarks" / "run_all.py"), "--only", name, "--out", str(out)]
    if quick:
        cmd.insert(2, "--quick")
    t0 = time.perf_counter()
    r = subprocess.run(cmd, env=side_env(tree), cwd=str(out), capture_output=True, text=True)
    wall = time.perf_counter() - t0
    summary = out / "run_all.json"
    if not summary.is_file():
        return {"error": f"rc={r.returncode}: {r.stderr[-1500:]}", "wall_s": wall}
    rep = json.loads(summary.read_text())
    entry = rep.get("benchmarks", {}).get(name, {})
    if "error" in entry or name not in rep.get("ratios", {}):
        return {"error": str(entry.get("error", "no ratios"))[-1500:], "wall_s": wall}
    return {"ratios": flatten(rep["ratios"][name]), "wall_s": entry.get("wall_s", wall),
            "load": rep.get("machine", {}).get("loadavg_1min")}


def best(values: list, k: str) -> float:
    return max(values) if k == "higher" else min(values)


def spread(values: list, k: str):
    """(worst - best) / best over the rounds of one side; None with one round."""
    if len(values) < 2:
        return None
    b, w = (max(values), min(values)) if k == "higher" else (min(values), max(values))
    return abs(w - b) / abs(b) if b else None


def compare(base_runs: list, new_runs: list, min_noise: float, noise_factor: float = 2.0) -> list:
    """Rows (key, kind, base, new, change, noise, flag) of one benchmark's headlines."""
    keys = sorted(set().union(*(r["ratios"] for r in base_runs + new_runs if "ratios" in r)))
    rows = []
    for key in keys:
        k = kind(key)
        b = [r["ratios"][key] for r in base_runs if key in r.get("ratios", {})]
        n = [r["ratios"][key] for r in new_runs if key in r.get("ratios", {})]
        if not b or not n:
            rows.append((key, k, best(b, k) if b else None, best(n, k) if n else None, None, None, "one side only"))
            continue
        bb, nb = best(b, k), best(n, k)
        change = (nb - bb) / abs(bb) if bb else None
        noises = [x for x in (spread(b, k), spread(n, k)) if x is not None]
        noise = max(noises) if noises else None
        worse = None if change is None else (-change if k == "higher" else change)
        flag = ""
        if k != "info" and worse is not None and worse > max(noise_factor * (noise or 0.0), min_noise):
            flag = "MORE MEMORY" if k == "memory" else "SLOWER"
        rows.append((key, k, bb, nb, change, noise, flag))
    return rows


def _fmt(x, pct=None):
    """A number (4 significant digits), or a fraction as a per cent (``pct``: the format's sign, '+' or '')."""
    if x is None:
        return "-"
    if pct is not None:
        return f"{100 * x:{pct}.1f}%"
    return f"{x:.4g}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="git revision to compare against (e.g. main)")
    ap.add_argument("--quick", action="store_true", help="each benchmark's --quick (run_all.py --quick)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="these benchmarks (run_all.py's names)")
    ap.add_argument("--rounds", type=int, default=2, help="runs per side and benchmark (default 2; the noise needs 2)")
    ap.add_argument("--min-noise", type=float, default=0.05,
                    help="flag only changes above this fraction too (default 0.05)")
    ap.add_argument("--noise-factor", type=float, default=2.0,
                    help="flag changes worse than this many times the measured noise (default 2)")
    ap.add_argument("--no-warmup", action="store_true",
                    help="skip the discarded --quick run of each benchmark on each side (it fills numba's cache)")
    ap.add_argument("--json", help="write the comparison to this JSON file")
    ap.add_argument("--keep", metavar="DIR", help="keep every run's reports under DIR (default: a temporary folder)")
    args = ap.parse_args(argv)
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")
    with tempfile.TemporaryDirectory(prefix="compare_benchmarks_") as tmp:
        tmp = pathlib.Path(tmp)
        base_tree = tmp / "base"
        base_tree.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.base], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(base_tree)], input=archive.stdout, check=True)
        work = pathlib.Path(args.keep).resolve() if args.keep else tmp / "runs"
        sides = {"base": base_tree, "new": ROOT}
        info = {s: side_info(t) for s, t in sides.items()}
        for s in sides:
            print(f"{s}: {args.base if s == 'base' else 'working tree'}, cwlidar_sim from {info[s]['package']}",
                  flush=True)
        names = args.only or [n for n in info["new"]["names"] if n in info["base"]["names"]]
        only_one = {s: sorted(set(info[s]["names"]) - set(info[o]["names"]))
                    for s, o in (("base", "new"), ("new", "base"))}
        runs = {n: {"base": [], "new": []} for n in names}
        order = ("base", "new")
        for name in names:
            missing = [s for s in sides if name not in info[s]["names"]]
            if missing:
                runs[name] = {"skipped": f"not in the {' and the '.join(missing)} side's run_all.py"}
                print(f"== {name}: skipped ({runs[name]['skipped']})", flush=True)
                continue
            for s in () if args.no_warmup else order:
                print(f"== {name}, warm-up (--quick, not counted), {s}", flush=True)
                r = run_one(sides[s], name, True, work / name / f"{s}-warmup")
                print(f"   {r['wall_s']:.0f} s" + (f"  failed: {r['error'][-300:]}" if "error" in r else ""), flush=True)
            for i in range(args.rounds):
                for s in order:
                    print(f"== {name}, round {i + 1}, {s}", flush=True)
                    r = run_one(sides[s], name, args.quick, work / name / f"{s}{i + 1}")
                    runs[name][s].append(r)
                    print(f"   {r['wall_s']:.0f} s" + (f"  FAILED: {r['error'][-300:]}" if "error" in r else ""),
                          flush=True)
                order = order[::-1]
    report = {"base": args.base, "quick": args.quick, "rounds": args.rounds, "min_noise": args.min_noise,
              "noise_factor": args.noise_factor, "warmup": not args.no_warmup,
              "only_in": only_one, "benchmarks": {}}
    bad = False
    print(f"\n{'headline':70s} {'base':>10s} {'new':>10s} {'change':>8s} {'noise':>7s}  flag")
    for name in names:
        r = runs[name]
        if "skipped" in r:
            report["benchmarks"][name] = r
            continue
        failed = {s: [x["error"] for x in r[s] if "error" in x] for s in ("base", "new")}
        rows = compare(r["base"], r["new"], args.min_noise, args.noise_factor)
        walls = {s: [x["wall_s"] for x in r[s]] for s in ("base", "new")}
        print(f"-- {name} (command wall s: base {', '.join(f'{w:.0f}' for w in walls['base'])}; "
              f"new {', '.join(f'{w:.0f}' for w in walls['new'])})")
        for key, k, b, n, ch, noise, flag in rows:
            print(f"   {key[:67]:67s} {_fmt(b):>10s} {_fmt(n):>10s} {_fmt(ch, '+'):>8s} {_fmt(noise, ''):>7s}  {flag}")
        for s, errs in failed.items():
            for e in errs:
                print(f"   FAILED on the {s} side: {e[-300:]}")
        bad = bad or any(failed.values()) or any(row[6] in ("SLOWER", "MORE MEMORY") for row in rows)
        report["benchmarks"][name] = {
            "rows": [dict(zip(("headline", "kind", "base", "new", "change", "noise", "flag"), row)) for row in rows],
            "command_wall_s": walls, "load_before": {s: [x.get("load") for x in r[s]] for s in ("base", "new")},
            "failed": failed}
    for s, extra in only_one.items():
        if extra:
            print(f"only in the {s} side's run_all.py (not compared): {', '.join(extra)}")
    flagged = [f"{name}: {row['headline']}" for name, b in report["benchmarks"].items()
               for row in b.get("rows", []) if row["flag"] in ("SLOWER", "MORE MEMORY")]
    print(f"\n{len(flagged)} headline(s) worse than the noise" + (": " + "; ".join(flagged) if flagged else ""))
    if args.json:
        pathlib.Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        pathlib.Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
