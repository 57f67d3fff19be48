#!/usr/bin/env python3
"""Bit-identity of every scene kind's results, in every tier, between two revisions.

A refactor of the wiring around the sensors (the registry of scene kinds, the
Sensor protocol, the probe volume) must not change a single number.  This runs a
small scene of each kind (staring, conical, nacelle) in each tier of the signal
chain (``los``, ``spectral``, ``signal``) through ``cwlidar-sim run``, once with
the package of a base revision (checked out into a temporary git worktree) and
once with the working tree, and compares every data variable and coordinate of
the results files bit for bit (NaN equal to NaN).  Attributes are compared too,
except those that hold wall-clock times or the package version.

Usage (from the repository root)::

    python tools/compare_kinds.py --base main          # base revision against the working tree
    python tools/compare_kinds.py --base main --only staring-los
    python tools/compare_kinds.py --base main --allow-added   # new variables / attributes listed, not failing

Exit status 0 when every case is identical, 1 otherwise (the differing
variables are listed).  About 1-3 minutes per tree on 2 cores.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

STARING = """
name = "cmp_staring"
seed = 3
duration = {duration}
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "{tier}"
[analysis]
segment_duration = {segment}
fit = false
[[period]]
name = "aligned"
mean_speed = 8.0
[[period]]
name = "turned"
mean_speed = 6.0
misalignment_deg = 3.0
"""

CONICAL = """
name = "cmp_conical"
kind = "conical"
seed = 4
duration = {duration}
[scan]
heights = [40.0]
scan_revs = [1]
[lidar]
tier = "{tier}"
[turbulence]
source = "fixed"
alpha_eps = 0.05
length_scale = 15.0
gamma = 3.9
[[period]]
name = "a"
mean_speed = 8.0
"""

NACELLE = """
name = "cmp_nacelle"
kind = "nacelle"
seed = 3
duration = {duration}
[scan]
half_angle_deg = 15.0
focus_distances = [40.0, 80.0]
rotor_radius = 20.0
spacing = 8.0
segment_duration = {segment}
k_min = 0.04
k_max = 0.3
n_k = 5
theory_beams = 4
[lidar]
tier = "{tier}"
[turbulence]
alpha_eps = 0.1
length_scale = 20.0
gamma = 3.9
[[period]]
name = "p0"
mean_speed = 10.0
"""

KINDS = {"staring": STARING, "conical": CONICAL, "nacelle": NACELLE}
TIERS = ("los", "spectral", "signal")
#: (duration, segment duration) [s] of each kind's scene: the signal tier (the 50 MHz heterodyne signal
#: itself) runs the shortest scene each kind accepts, the others a few minutes of wind.
DURATIONS = {("staring", "signal"): (60.0, 30.0), ("staring", None): (300.0, 150.0),
             ("conical", "signal"): (10.0, None), ("conical", None): (60.0, None),
             ("nacelle", "signal"): (30.0, 10.0), ("nacelle", None): (60.0, 15.0)}
#: Attributes that differ between any two runs (clocks) or revisions (the version string).
VOLATILE_ATTRS = ("timing", "wall_time", "created", "cwlidar_sim_version", "history")


def cases(only=None):
    out = {}
    for k, text in KINDS.items():
        for t in TIERS:
            duration, segment = DURATIONS.get((k, t), DURATIONS[(k, None)])
            out[f"{k}-{t}"] = text.format(tier=t, duration=duration, segment=segment)
    if only:
        missing = sorted(set(only) - set(out))
        if missing:
            raise SystemExit(f"unknown case(s) {missing}; allowed: {sorted(out)}")
        out = {k: out[k] for k in only}
    return out


def run_tree(tree: pathlib.Path, work: pathlib.Path, selected: dict) -> dict:
    """Run every case with the package of ``tree``; return {case: results file}."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    files = {}
    for case, text in selected.items():
        scene = work / f"{case}.toml"
        scene.write_text(text)
        out = work / case
        cmd = [sys.executable, "-m", "cwlidar_sim", "run", str(scene), "--out", str(out), "--no-progress"]
        r = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=work)
        if r.returncode != 0:
            raise SystemExit(f"{case} failed with the package of {tree}:\n{r.stderr[-2000:]}")
        files[case] = out / f"cmp_{case.split('-')[0]}.nc"
    return files


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    if a.dtype.kind in "fc":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


def compare(base_file, new_file, added=None) -> list:
    """Names of the variables, coordinates and attributes that differ (empty: identical).

    ``added``: a list that receives what only the new file has (variables, attributes) instead of the
    differences (``--allow-added``); None: those differ too.
    """
    import xarray as xr

    def only_new(label):
        (diff if added is None else added).append(label)

    with xr.open_dataset(base_file, engine="h5netcdf") as a, xr.open_dataset(new_file, engine="h5netcdf") as b:
        diff = []
        names = set(a.variables) | set(b.variables)
        for n in sorted(names):
            if n not in a.variables:
                only_new(f"{n} (only in new)")
            elif n not in b.variables:
                diff.append(f"{n} (only in base)")
            elif not _same(a[n].values, b[n].values):
                diff.append(n)
            else:
                for key in sorted(set(a[n].attrs) | set(b[n].attrs)):
                    if key not in VOLATILE_ATTRS and str(a[n].attrs.get(key)) != str(b[n].attrs.get(key)):
                        (only_new if key not in a[n].attrs else diff.append)(f"{n}.attrs[{key}]")
        for key in sorted(set(a.attrs) | set(b.attrs)):
            if key not in VOLATILE_ATTRS and str(a.attrs.get(key)) != str(b.attrs.get(key)):
                (only_new if key not in a.attrs else diff.append)(f"attrs[{key}]")
    return diff


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="git revision to compare against (e.g. main)")
    ap.add_argument("--only", nargs="*", help="cases to run, e.g. staring-los nacelle-spectral")
    ap.add_argument("--json", help="write the comparison to this JSON file")
    ap.add_argument("--allow-added", action="store_true",
                    help="variables and attributes only the new file has are listed as added, not as differences "
                         "(a change that adds results and leaves every old value and attribute as it was)")
    args = ap.parse_args(argv)
    root = pathlib.Path(__file__).resolve().parents[1]
    selected = cases(args.only)
    with tempfile.TemporaryDirectory(prefix="compare_kinds_") as tmp:
        tmp = pathlib.Path(tmp)
        base_tree = tmp / "base"
        subprocess.run(["git", "-C", str(root), "worktree", "add", "--detach", "-q", str(base_tree), args.base],
                       check=True)
        try:
            (tmp / "a").mkdir()
            (tmp / "b").mkdir()
            base = run_tree(base_tree, tmp / "a", selected)
            new = run_tree(root, tmp / "b", selected)
            added = {case: ([] if args.allow_added else None) for case in selected}
            report = {case: compare(base[case], new[case], added[case]) for case in selected}
        finally:
            subprocess.run(["git", "-C", str(root), "worktree", "remove", "--force", str(base_tree)], check=False)
    for case, diff in report.items():
        more = f" (added: {', '.join(added[case])})" if added[case] else ""
        print(f"{case:18s} {'identical' if not diff else 'DIFFERS: ' + ', '.join(diff)}{more}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({"base": args.base, "cases": report}, indent=1) + "\n")
    return 0 if not any(report.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
