#!/usr/bin/env python3
"""Bit-identity check of the one-signal-chain refactor: every lidar result before and after.

Runs a fixed set of sensor configurations (staring lidar in every tier and
speckle model with processing variants, CNR variation and background drift;
the conical lidar in every tier, one height and a height cycle, with a cloud;
the uniform-target runs of ``cwlidar-sim doppler``) once with the package of a
base revision (checked out into a temporary git worktree) and once with the
working tree, and compares the arrays bit for bit.

Usage (from the repository root)::

    python tools/compare_chain.py --base 954f0ce        # the commit before the refactor
    python tools/compare_chain.py --dump OUT.npz       # just write this tree's arrays

Where the refactor changes physics or seeding on purpose, the settings that
restore the old behaviour are passed when the new package knows them (the
``LEGACY`` table: the staring lidar's renormalised span, the conical lidar's
mean-wind tail cell), and the cases whose random draws changed by design (the
conical lidar in tiers 2 and 3: one seeding rule for every sensor) are
compared statistically instead (mean and standard deviation of the estimate
minus the ideal, with the standard error of their difference).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import tempfile

import numpy as np

#: Fields that select the pre-refactor behaviour, applied only where the sensor has them.
LEGACY = {
    "staring": {"tail": "renormalise"},
    "conical": {"tail": "mean_wind"},
}
#: Cases compared statistically (changed by design), by name prefix: the conical lidar's tiers 2 and 3
#: (its mean-wind tail cell is no longer a narrow Doppler line at the mean speed in the spectrum, see
#: cwlidar_sim.signal.chain; tier 3 draws from the group's simulation stream, not from a per-2048-block
#: child), the uniform target of ``cwlidar-sim doppler`` in tiers 2 and 3 (the chain's exact lag-sum
#: spectrum and block draws instead of a tabulated line shape and one draw of the whole record).
STATISTICAL = ("conical_spectral", "conical_signal", "uniform_spectral", "uniform_signal")


def _with_legacy(cls, kind, **kw):
    names = {f.name for f in dataclasses.fields(cls)}
    kw.update({k: v for k, v in LEGACY[kind].items() if k in names})
    return cls(**kw)


def _conical_box(lid, U, duration, params, seed, **kw):
    """The conical lidar's box, built by whichever function the revision has."""
    try:
        from cwlidar_sim.turbulence.cover import cover_box
    except ImportError:  # revisions before turbulence.cover: the sensor module built it
        from cwlidar_sim.sensors.conical import conical_field

        return conical_field(lid, U, duration, params, seed, **kw)
    return cover_box(lid.box_region(kw["spacing"]), U, duration, params, seed, **kw)


def dump(path):
    from cwlidar_sim.sensors import ConicalLidar, StaringLidar, measure_conical, measure_staring
    from cwlidar_sim.signal import PROTOTYPE_2003, simulate_uniform
    from cwlidar_sim.turbulence import MannParameters, generate_line, generate_plane

    out = {}
    p = MannParameters(alpha_eps=0.06224407174474577, length_scale=18.76, gamma=3.9)
    U = 8.1
    # --- staring: a plane (misaligned beam) and a line (aligned) ---------
    plane = generate_plane(p, (4096, 64), (0.5, 0.5), seed=7, dtype=np.float64)
    line = generate_line(p, 8192, 0.5, seed=8, dtype=np.float64)
    t = (np.arange(2000) + 0.5) / 50.0
    inst = PROTOTYPE_2003.replace(background_mismatch=0.02, background_drift=0.01)
    variants = [{"name": "raise10", "threshold_raise_percent": 10.0}, {"name": "centroid", "estimator": "centroid"},
                {"name": "peak", "estimator": "peak"}]

    def staring(name, field, y, az, **kw):
        kw.setdefault("instrument", inst)
        lid = _with_legacy(StaringLidar, "staring", position=(float(field.x.values[-1]) - 400.0, y, 0.0),
                           azimuth_deg=az, cell_length=0.5, **kw)
        n = kw.pop("n", None)
        rec = measure_staring(field, lid, t if n is None else t[:n], U, 11, variants=variants,
                              calibration_time=1800.0)
        out[f"{name}_vlos"] = rec.vlos_e
        out[f"{name}_speed"] = rec.speed_e
        out[f"{name}_flags"] = rec.flags_e
        for v, (s, f) in sorted(rec.variants.items()):
            out[f"{name}_{v}_speed"] = s
            out[f"{name}_{v}_flags"] = f

    yc = float(plane.y.values[32])
    for tier in ("los", "spectral"):
        staring(f"staring_plane_{tier}", plane, yc, 183.0, tier=tier)
    for sp in ("independent", "coherent"):
        staring(f"staring_plane_spectral_{sp}", plane, yc, 183.0, tier="spectral", speckle=sp)
    staring("staring_plane_cnrvar", plane, yc, 183.0, tier="spectral", cnr_variation_db=3.0, cnr_time_scale=5.0)
    staring("staring_line_spectral", line, 0.0, 180.0, tier="spectral")
    lid = _with_legacy(StaringLidar, "staring", position=(float(line.x.values[-1]) - 400.0, 0.0, 0.0),
                       azimuth_deg=180.0, tier="signal", cell_length=2.0)
    rec = measure_staring(line, lid, t[:60], U, 12)
    out["staring_line_signal_speed"] = rec.speed_e
    out["staring_line_signal_flags"] = rec.flags_e
    # --- conical ------------------------------------------------------------
    for tier, dur in (("los", 20.0), ("spectral", 20.0), ("signal", 2.0)):
        for heights in ((40.0,), (40.0, 60.0)):
            kw = dict(heights=heights, tier=tier, revs_per_height=2, refocus_time=0.5)
            if len(heights) == 1:
                kw.update(cloud_base=700.0, cloud_strength=3e3)
            if tier == "signal":
                kw["instrument"] = ConicalLidar().instrument.replace(blocks_per_estimate=400)
            lid = _with_legacy(ConicalLidar, "conical", **kw)
            box = _conical_box(lid, 10.0, dur, p, 5, spacing=2.0, lateral_doubling=False)
            rec = measure_conical(box, lid, dur, 10.0, 13)
            name = f"conical_{tier}_{len(heights)}h"
            out[f"{name}_vlos"] = rec.vlos_e
            out[f"{name}_speed"] = rec.speed_e
            out[f"{name}_flags"] = rec.flags_e
    # --- uniform target (the doppler command) --------------------------------
    for tier in ("los", "spectral", "signal"):
        for speckle in ("coherent", "independent"):
            if tier == "los" and speckle == "independent":
                continue
            est, _ = simulate_uniform(5.3, -20.0, tier=tier, n=40 if tier == "signal" else 500, seed=3,
                                      speckle=speckle)
            out[f"uniform_{tier}_{speckle}_speed"] = est.speed_e
            out[f"uniform_{tier}_{speckle}_flags"] = est.flags_e
        est, _ = simulate_uniform(5.3, -20.0, tier=tier, n=40 if tier == "signal" else 500, seed=3,
                                  cloud_range=1600.0, cloud_weight=6e5, cloud_speed=12.0)
        out[f"uniform_{tier}_cloud_speed"] = est.speed_e
        out[f"uniform_{tier}_cloud_flags"] = est.flags_e
    np.savez(path, **out)


def compare(old, new):
    a, b = np.load(old), np.load(new)
    bad = 0
    for k in sorted(set(a.files) | set(b.files)):
        if k not in a.files or k not in b.files:
            print(f"  {k}: only in {'new' if k in b.files else 'base'}")
            continue
        x, y = a[k], b[k]
        if any(k.startswith(s) for s in STATISTICAL):
            if k.endswith("_speed"):
                base = k[: -len("_speed")]
                truth_a = np.abs(a[base + "_vlos"]) if base + "_vlos" in a.files else 5.3
                truth_b = np.abs(b[base + "_vlos"]) if base + "_vlos" in b.files else 5.3
                dx, dy = x - truth_a, y - truth_b
                ok_x, ok_y = np.isfinite(dx), np.isfinite(dy)
                se = np.hypot(np.nanstd(dx) / np.sqrt(ok_x.sum()), np.nanstd(dy) / np.sqrt(ok_y.sum()))
                print(f"  {k}: statistical (changed by design): error mean {np.nanmean(dx):+.4f} -> "
                      f"{np.nanmean(dy):+.4f} m/s (difference {np.nanmean(dy) - np.nanmean(dx):+.4f}, s.e. {se:.4f}), "
                      f"std {np.nanstd(dx):.4f} -> {np.nanstd(dy):.4f}, finite {ok_x.mean():.3f} -> {ok_y.mean():.3f}")
            continue
        same = x.shape == y.shape and np.array_equal(x, y, equal_nan=True)
        if not same:
            bad += 1
            diff = np.nanmax(np.abs(x.astype(float) - y.astype(float))) if x.shape == y.shape else "shape"
            print(f"  {k}: DIFFERS (max |diff| {diff})")
    n = len(set(a.files) & set(b.files))
    print(f"{n - bad} of {n} arrays bit-identical" + ("" if bad == 0 else f"; {bad} differ"))
    return bad


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", help="revision to compare with (checked out into a temporary worktree)")
    ap.add_argument("--dump", help="write this tree's arrays to this .npz and stop")
    args = ap.parse_args(argv)
    if args.dump:
        dump(args.dump)
        return 0
    if not args.base:
        ap.error("give --base REV or --dump PATH")
    root = subprocess.run(["git", "rev-parse", "--show-toplevel"], capture_output=True, text=True,
                          check=True).stdout.strip()
    me = os.path.abspath(__file__)
    with tempfile.TemporaryDirectory() as tmp:
        wt = os.path.join(tmp, "base")
        subprocess.run(["git", "-C", root, "worktree", "add", "--detach", "-q", wt, args.base], check=True)
        try:
            for tree, out in ((wt, os.path.join(tmp, "base.npz")), (root, os.path.join(tmp, "new.npz"))):
                env = dict(os.environ, PYTHONPATH=tree)
                subprocess.run([sys.executable, me, "--dump", out], env=env, check=True, cwd=tree)
            return 1 if compare(os.path.join(tmp, "base.npz"), os.path.join(tmp, "new.npz")) else 0
        finally:
            subprocess.run(["git", "-C", root, "worktree", "remove", "--force", wt], check=False)


if __name__ == "__main__":
    sys.exit(main())
