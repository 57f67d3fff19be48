#!/usr/bin/env python3
"""Convergence of the published numbers in each numerical knob, the turbulence held fixed (issue 18).

Two quantities, each measured with every numerical knob moved on its own from the
default while the realisation stays the same (paired seeds):

* **conical** (CS's ZephIR, :func:`cwlidar_sim.campaign.simulate_conical_period`, 10 m/s, a
  neutral surface layer, 40 m and 100 m): the lidar/cup 10-min standard-deviation ratio of
  1 s and 3 s VAD scans, the same ratio against the point (unfiltered sonic) sigma, and the
  radial-variance ratio (TP U)^2 / sonic;
* **staring** (A2012 period C: 8.1 m/s, 1.2 deg off the beam, prototype at 67.5 m, median,
  the bundled a2012 scene's tensor): T2 = Re(chi)^2 / F_vs^2 (10-min segments), as the band
  RMS of log10(T2 / T2_default) over 0.002-0.6 rad/m, and the estimator noise: the standard
  deviation of the 50 Hz estimates about the noise-free line-of-sight speed (tier 'los' of
  the same cells and field).

Pairing.  A group of knobs shares one field: its physical size is fixed first (the largest
any member needs; :func:`cwlidar_sim.turbulence.grids.common_extent` over the spacings compared)
so that boxes and planes on other grids hold the same Fourier coefficients at the wavenumbers
they share (:mod:`cwlidar_sim.turbulence.grids`).  Knobs that change the physical size (the box's
lateral size, its lateral doubling, its length) cannot be paired: their rows are other
realisations, to be read against the seed scatter (rows marked ``paired: false``).

Groups (conical; d = the default spacing z / 20):

* ``tail``: span 5, 10, 20, 30 z_R, and 10 and 30 with the renormalised tail (which errs the other
  way: the two rules bracket the long-span limit), the box sized for the longest;
  ``tail_long`` (40 m only): 30 and 60 z_R in a box sized for 60;
* ``grid``: the default box and grids of d / 2 along x, across (y, z) and in all three, with and
  without high-frequency compensation, cells of d / 2, sub-dwells 4 and 16, tier 'spectral'
  with independent and continuum speckle (the speckle looks);
* ``size`` (unpaired): the default sizing, no lateral doubling, twice the lateral size, a 1.5
  times longer box.

Staring: span 20 (default), 60, 200; plane dx and dy halved; cells 0.25, 1, 2, 4 m; speckle
'independent'; twice the lateral size and a longer plane (unpaired).

Every finished row is written at once (atomically) to the JSON, and a rerun resumes from it.

Usage::

    python studies/convergence.py --quick               # 300-s conical, 1200-s staring, 1 seed
    python studies/convergence.py --json results/convergence.json --seeds 1 2
    python studies/convergence.py --parts staring --seeds 1 2 3
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import log, machine, write_json  # noqa: E402

HEIGHTS = (40.0, 100.0)
SPEED = 10.0
#: (group, label, settings, paired); settings: span, spacing (factor of d; scalar or (x, y, z)), hf,
#: cell (factor of d), sub_dwells, tier, speckle, doubling, size (factors of the group's extent), own_box
CONICAL = [
    ("tail", "span 5 (default)", {}, True),
    ("tail", "span 10", {"span": 10.0}, True),
    ("tail", "span 20", {"span": 20.0}, True),
    ("tail", "span 30", {"span": 30.0}, True),
    ("tail", "span 10, renormalised tail", {"span": 10.0, "tail": "renormalise"}, True),
    ("tail", "span 30, renormalised tail", {"span": 30.0, "tail": "renormalise"}, True),
    ("tail", "tier spectral, span 5", {"tier": "spectral"}, True),
    ("tail", "tier spectral, span 10", {"span": 10.0, "tier": "spectral"}, True),
    ("tail", "tier spectral, span 20", {"span": 20.0, "tier": "spectral"}, True),
    ("tail", "tier spectral, span 30", {"span": 30.0, "tier": "spectral"}, True),
    ("tail_long", "span 30 (long box)", {"span": 30.0, "heights": (40.0,)}, True),
    ("tail_long", "span 60", {"span": 60.0, "heights": (40.0,)}, True),
    ("tail_long", "span 60, renormalised tail", {"span": 60.0, "tail": "renormalise", "heights": (40.0,)}, True),
    ("tail_long", "tier spectral, span 30 (long box)", {"span": 30.0, "tier": "spectral", "heights": (40.0,)},
     True),
    ("tail_long", "tier spectral, span 60", {"span": 60.0, "tier": "spectral", "heights": (40.0,)}, True),
    ("grid", "default grid d = z/20", {}, True),
    ("grid", "dx = d/2 (along)", {"spacing": (0.5, 1.0, 1.0)}, True),
    ("grid", "dy = dz = d/2 (across)", {"spacing": (1.0, 0.5, 0.5)}, True),
    ("grid", "d/2 everywhere", {"spacing": 0.5}, True),
    ("grid", "hf compensation", {"hf": True}, True),
    ("grid", "hf compensation, d/2", {"hf": True, "spacing": 0.5}, True),
    ("grid", "cells d/2", {"cell": 0.5}, True),
    ("grid", "sub-dwells 4", {"sub_dwells": 4}, True),
    ("grid", "sub-dwells 16", {"sub_dwells": 16}, True),
    ("grid", "tier spectral (independent speckle)", {"tier": "spectral"}, True),
    ("grid", "tier spectral, continuum speckle", {"tier": "spectral", "speckle": "continuum"}, True),
    ("across", "across d (default)", {}, True),
    ("across", "across d/2", {"spacing": (1.0, 0.5, 0.5)}, True),
    ("across", "across d/3", {"spacing": (1.0, 1 / 3, 1 / 3)}, True),
    ("across", "across d/4", {"spacing": (1.0, 0.25, 0.25), "heights": (100.0,)}, True),
    ("size", "default box (own sizing)", {"own_box": True}, False),
    ("size", "no lateral doubling", {"own_box": True, "doubling": False}, False),
    ("size", "lateral size x2", {"own_box": True, "min_extent_factor": 2.0}, False),
    ("size", "lateral size x4", {"own_box": True, "min_extent_factor": 4.0}, False),
    ("size", "lateral size x2.05", {"own_box": True, "min_extent_factor": 2.05}, False),
    ("size", "box length x1.5", {"size": (1.5, 1.0, 1.0)}, False),
]
#: staring rows: (group, label, settings, paired); spacing factors of 0.5 m, cell [m]
STARING = [
    ("tail", "span 20 (default)", {}, True),
    ("tail", "span 60", {"span": 60.0}, True),
    ("tail", "span 200", {"span": 200.0}, True),
    ("grid", "default plane dx = dy = 0.5 m", {}, True),
    ("grid", "dx = 0.25 m (along)", {"dx": 0.25}, True),
    ("grid", "dy = 0.25 m (across)", {"dy": 0.25}, True),
    ("grid", "cells 0.25 m", {"cell": 0.25}, True),
    ("grid", "cells 1 m", {"cell": 1.0}, True),
    ("grid", "cells 2 m", {"cell": 2.0}, True),
    ("grid", "cells 4 m", {"cell": 4.0}, True),
    ("grid", "speckle independent", {"speckle": "independent"}, True),
    ("size", "lateral size x2", {"ny_factor": 2}, False),
    ("size", "plane length x1.5", {"nx_factor": 1.5}, False),
]
BAND = (0.002, 0.6)
#: spacings (factors of d) a group's one extent must hold a whole number of
GROUP_SPACINGS = {"grid": (1.0, 0.5), "across": (1.0, 0.5, 1 / 3, 0.25)}
#: the row each group's effects are taken against (the default; for 'size', other realisations)
CONICAL_BASE = {"tail": "span 5 (default)", "tail_long": "span 30 (long box)", "grid": "default grid d = z/20",
                "across": "across d (default)",
                "size": "default box (own sizing)"}


def _atomic_write(path, obj):
    tmp = path + ".tmp"
    write_json(tmp, obj)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------
# conical
# ---------------------------------------------------------------------------
def conical_extent(z, duration, span, spacings, size=(1.0, 1.0, 1.0)):
    """Physical size (Lx, Ly, Lz) [m] holding the cone of ``span`` for every spacing in ``spacings``."""
    from cwlidar_sim.campaign.scenes.conical import default_spacing
    from cwlidar_sim.sensors.conical import ConicalLidar
    from cwlidar_sim.turbulence.grids import common_extent
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    d = default_spacing(z)
    lid = ConicalLidar(heights=(z,), span=span, cell_length=d)
    p = surface_layer_parameters(z, SPEED)[0]
    be = lid.beam_extent(z)
    dmax = max(spacings)
    need = (SPEED * duration + 2 * be["radius"] + 4 * dmax,
            max(2 * be["radius"] + 3 * dmax, 2 * p.length_scale + dmax),
            max(be["z_hi"] - min(be["z_lo"], z) + 3 * dmax, 2 * p.length_scale + dmax))
    return tuple(common_extent(n * f, spacings) for n, f in zip(need, size))


def conical_row(z, seed, duration, group, settings):
    from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
    from cwlidar_sim.campaign.scenes.conical import default_spacing

    d = default_spacing(z)
    span = settings.get("span", 5.0)
    overrides = {"span": span, "cell_length": settings.get("cell", 1.0) * d}
    for k in ("speckle", "tail"):
        if k in settings:
            overrides[k] = settings[k]
    box = {"hf_compensation": bool(settings.get("hf", False))}
    sp = settings.get("spacing", 1.0)
    box["spacing"] = tuple(f * d for f in sp) if isinstance(sp, tuple) else sp * d
    if "min_extent_factor" in settings:
        from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

        box["min_extent"] = settings["min_extent_factor"] * 2.0 * surface_layer_parameters(z, SPEED)[0].length_scale
    # the group's one field: sized (and placed) for the group's longest span
    group_span = max(s.get("span", 5.0) for g, _, s, _ in CONICAL if g == group)
    if not settings.get("own_box"):
        spacings = tuple(f * d for f in GROUP_SPACINGS.get(group, (1.0,)))
        box["extent"] = conical_extent(z, duration, group_span, spacings,
                                       settings.get("size", (1.0, 1.0, 1.0)))
    t0 = time.perf_counter()
    r = simulate_conical_period(z, seed, speed=SPEED, duration=duration, tier=settings.get("tier", "los"),
                                spacing=d, lateral_doubling=settings.get("doubling", True),
                                sub_dwells=settings.get("sub_dwells", 8), model=False, lidar_overrides=overrides,
                                field_span=group_span, box_options=box)
    out = {"cost_s": time.perf_counter() - t0, "box_shape": r["box_shape"], "box_spacing": r["box_spacing"],
           "cup_std": r["cup_std"], "sonic_std": r["sonic_std"], "sonic_radial_variance": r["sonic_radial_variance"]}
    for n, s in r["scans"].items():
        out[f"std_ratio_{n}s"] = s["std_ratio"]
        out[f"std_ratio_point_{n}s"] = s["lidar_std"] / r["sonic_std"]
        out[f"radial_variance_ratio_{n}s"] = s["radial_variance_ratio"]
    return out


# ---------------------------------------------------------------------------
# staring (A2012 period C)
# ---------------------------------------------------------------------------
def _staring_setup():
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.turbulence import MannParameters

    p = MannParameters(alpha_eps=0.06224407174474577, length_scale=18.76, gamma=3.9)
    return p, 8.1, 1.2, PROTOTYPE_2003.replace(focus=67.5, estimator="median")


def staring_extent(duration, span, spacings_x, spacings_y, nx_factor=1.0, ny_factor=1):
    """Plane size (Lx, Ly) [m] for the beam of ``span`` and the sonic, for every spacing compared."""
    from cwlidar_sim.beam import direction_from_angles
    from cwlidar_sim.turbulence.grids import common_extent

    p, U, theta, inst = _staring_setup()
    n = direction_from_angles(180.0 + theta, 0.0)
    reach = span * inst.rayleigh_length
    lx = (U * duration + 2 * (inst.focus + reach) + 8) * nx_factor
    ly = ((inst.focus + reach) * abs(n[1]) + 4 * p.length_scale) * ny_factor
    return common_extent(lx, spacings_x), common_extent(ly, spacings_y)


def a2012_sonic(field, focus_pt, n, duration, U):
    """A noise-free sonic at ``focus_pt`` read at 32 Hz and resampled to 10 Hz (A2012 Eqs. 5-7), projected on
    the beam ``n`` (speed toward the lidar [m/s]), and the lidar's 50-Hz estimate times [s] over ``duration``."""
    from cwlidar_sim.sensors import Sonic, resample_a2012, sample_sonic

    n10 = int(math.floor(duration / 0.5 + 1e-9)) * 5
    t32 = 1 / 64 + np.arange(n10 // 5 * 16) / 32.0
    vel = sample_sonic(field, Sonic(position=tuple(focus_pt), noise_std=0.0), t32, U)
    return resample_a2012(-(vel @ n)), (np.arange(n10 * 5) + 0.5) / 50.0


def staring_row(seed, duration, group, settings):
    """One staring setting: T2 at the analysis bins, the estimator noise about the same cells' tier 'los'."""
    from cwlidar_sim.analysis import log_bins, transfer_functions
    from cwlidar_sim.beam import direction_from_angles
    from cwlidar_sim.sensors import StaringLidar, block_average, measure_staring
    from cwlidar_sim.turbulence import generate_plane
    from cwlidar_sim.turbulence.grids import grid_for_extent

    p, U, theta, inst = _staring_setup()
    n = direction_from_angles(180.0 + theta, 0.0)
    span = settings.get("span", 20.0)
    gspan = max(s.get("span", 20.0) for g, _, s, _ in STARING if g == group)
    if group == "size":
        ext = staring_extent(duration, 20.0, (0.5,), (0.5,), settings.get("nx_factor", 1.0),
                             settings.get("ny_factor", 1))
    else:
        ext = staring_extent(duration, gspan, (0.5, 0.25), (0.5, 0.25))
    shape, spacing = grid_for_extent(ext, (settings.get("dx", 0.5), settings.get("dy", 0.5)))
    t0 = time.perf_counter()
    field = generate_plane(p, shape, spacing, seed=seed)
    field.attrs["z"] = 0.0
    # placed by physical size only (not by the spacing): the paired grids see the same air
    x_last = float(field.x.values[0]) + ext[0] - 0.5
    reach = gspan * inst.rayleigh_length
    pos = np.array([x_last - (inst.focus + reach) * abs(n[0]) - 4.0,
                    float(field.y.values[0]) + 0.5 * ext[1] - inst.focus * n[1], 0.0])
    vs10, t50 = a2012_sonic(field, pos + inst.focus * n, n, duration, U)
    speeds = {}
    for tier in ("los", "spectral"):
        lid = StaringLidar(instrument=inst, position=tuple(pos), azimuth_deg=180.0 + theta, tier=tier, span=span,
                           cell_length=settings.get("cell", 0.5), speckle=settings.get("speckle", "continuum"),
                           transverse_speed=1.0)
        speeds[tier] = measure_staring(field, lid, t50, U, seed + 1).speed_e.astype(np.float64)
    cost = time.perf_counter() - t0
    diff = speeds["spectral"] - speeds["los"]
    ok = np.isfinite(diff)
    vr10 = block_average(speeds["spectral"], 5)[0]
    tf = transfer_functions(vr10, vs10, fs=10.0, U=U, k_edges=log_bins(1e-3, 5.0, 10), segment_duration=600.0,
                            window="hann")
    return {"cost_s": cost, "shape": list(shape), "spacing": list(spacing), "k": tf.k_k.tolist(),
            "t2": tf.transfer_cross_k.tolist(), "estimator_noise": float(np.std(diff[ok])),
            "estimator_bias": float(np.mean(diff[ok])), "availability": float(np.mean(ok))}


# ---------------------------------------------------------------------------
# summaries
# ---------------------------------------------------------------------------
def _key(*parts):
    return "|".join(str(p) for p in parts)


def summarise_conical(rows, seeds, heights):
    out = []
    qs = ("std_ratio_1s", "std_ratio_3s", "std_ratio_point_1s", "std_ratio_point_3s",
          "radial_variance_ratio_1s", "radial_variance_ratio_3s")
    for z in heights:
        for group, label, _, paired in CONICAL:
            base = CONICAL_BASE[group]
            sel = [(rows.get(_key("conical", z, s, label)), rows.get(_key("conical", z, s, base))) for s in seeds]
            sel = [(a, b) for a, b in sel if a is not None and b is not None]
            if not sel:
                continue
            row = {"height": z, "group": group, "label": label, "paired": paired, "n_seeds": len(sel),
                   "cost_s": float(np.mean([a["cost_s"] for a, _ in sel])),
                   "cost_ratio": float(np.mean([a["cost_s"] / b["cost_s"] for a, b in sel])),
                   "box_shape": sel[0][0]["box_shape"]}
            for q in qs:
                v = np.array([a[q] for a, _ in sel])
                dlt = np.array([a[q] - b[q] for a, b in sel])
                row[q] = float(v.mean())
                row[f"{q}_effect"] = float(dlt.mean())
                row[f"{q}_effect_se"] = float(dlt.std(ddof=1) / math.sqrt(dlt.size)) if dlt.size > 1 else None
            out.append(row)
        # seed scatter: the default box over every seed run (also seeds run for this row alone); the other
        # groups' default rows are not independent of it: one seed keys the same normals at the same
        # wavenumber indices, so a box of another size is the same draws stretched, and its variances
        # (sums over the modes) nearly the same
        b = [v for k, v in rows.items() if k.startswith(_key("conical", z, "")) and
             k.endswith("|default box (own sizing)")]
        if len(b) > 1:
            out.append({"height": z, "group": "scatter", "label": "seed scatter (std of one period)",
                        "n_seeds": len(b), **{q: float(np.std([x[q] for x in b], ddof=1)) for q in qs}})
    return out


def summarise_staring(rows, seeds):
    out = []
    for group, label, _, paired in STARING:
        base = "span 20 (default)" if group == "tail" else "default plane dx = dy = 0.5 m"
        sel = [(rows.get(_key("staring", s, label)), rows.get(_key("staring", s, base))) for s in seeds]
        sel = [(a, b) for a, b in sel if a is not None and b is not None]
        if not sel:
            continue
        k = np.asarray(sel[0][0]["k"])
        band = (k >= BAND[0]) & (k <= BAND[1])
        d = np.array([np.log10(np.asarray(a["t2"])[band] / np.asarray(b["t2"])[band]) for a, b in sel])
        en = np.array([a["estimator_noise"] for a, _ in sel])
        enb = np.array([b["estimator_noise"] for _, b in sel])
        out.append({"group": group, "label": label, "paired": paired, "n_seeds": len(sel),
                    "cost_s": float(np.mean([a["cost_s"] for a, _ in sel])),
                    "cost_ratio": float(np.mean([a["cost_s"] / b["cost_s"] for a, b in sel])),
                    "t2_rms_log10_vs_default": float(np.sqrt(np.nanmean(d ** 2))),
                    "t2_mean_log10_vs_default": float(np.nanmean(d)),
                    "estimator_noise": float(en.mean()),
                    "estimator_noise_rel_effect": float(np.mean(en / enb - 1.0))})
    # seed scatter: the default plane over every seed run (see summarise_conical)
    b = [v for k, v in rows.items() if k.startswith("staring|") and k.endswith("|default plane dx = dy = 0.5 m")]
    if len(b) > 1:
        k = np.asarray(b[0]["k"])
        band = (k >= BAND[0]) & (k <= BAND[1])
        pairs = [np.log10(np.asarray(x["t2"])[band] / np.asarray(y["t2"])[band])
                 for i, x in enumerate(b) for y in b[i + 1:]]
        out.append({"group": "scatter", "label": "seed scatter (RMS log10 T2 between seeds)",
                    "n_seeds": len(b), "t2_rms_log10_vs_default": float(np.sqrt(np.nanmean(np.square(pairs)))),
                    "estimator_noise": float(np.mean([x["estimator_noise"] for x in b])),
                    "estimator_noise_scatter": float(np.std([x["estimator_noise"] for x in b], ddof=1))})
    return out


def cs_estimate(rows, height):
    """The std ratios at the converged settings from the study's rows (docs/convergence.md), per quantity:
    (estimate, standard error of the seed mean, seeds, offset, grid).

    The default box's tier-'los', span-5 ratio averaged over every seed run, plus the paired offset to tier
    'spectral' at span 30 (the 'tail' group, over the seeds that ran it), plus the grid's effect extrapolated
    to d -> 0: that of d/2 across (the 'grid' group, over its seeds), the 'across' group's d/3 and d/4 having
    shown it converged by d/2.
    """
    def of(label):
        return {int(k.split("|")[2]): v for k, v in rows.items()
                if k.startswith(_key("conical", height, "")) and k.endswith("|" + label)}

    own, lo, hi = of("default box (own sizing)"), of("span 5 (default)"), of("tier spectral, span 30")
    across, base = of("dy = dz = d/2 (across)"), of("default grid d = z/20")
    out = {}
    for q in ("std_ratio_1s", "std_ratio_3s", "std_ratio_point_1s", "std_ratio_point_3s"):
        v = np.array([r[q] for r in own.values()])
        off = [hi[s][q] - lo[s][q] for s in hi if s in lo]
        grid = [across[s][q] - base[s][q] for s in across if s in base]
        if v.size < 2 or not off or not grid:
            continue
        est = v.mean() + np.mean(off) + np.mean(grid)
        out[q] = (float(est), float(v.std(ddof=1) / math.sqrt(v.size)), int(v.size), float(np.mean(off)),
                  float(np.mean(grid)))
    return out


def markdown(res) -> str:
    """The docs' tables (docs/convergence.md) from a finished run's summaries."""
    lines = ["| z [m] | knob | paired | seeds | std ratio 1 s | effect 1 s | std ratio 3 s | effect 3 s | "
             "ratio to point 1 s | rad. var. ratio 1 s | effect | cost [s] | cost x |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def f(v, fmt="+.4f"):
        return "" if v is None else format(v, fmt)

    for r in res.get("conical", []):
        if r["group"] == "scatter":
            lines.append(f"| {r['height']:g} | *seed scatter (std of one period)* | | {r['n_seeds']} | "
                         f"{r['std_ratio_1s']:.4f} | | {r['std_ratio_3s']:.4f} | | {r['std_ratio_point_1s']:.4f} | "
                         f"{r['radial_variance_ratio_1s']:.4f} | | | |")
            continue
        se1 = r.get("std_ratio_1s_effect_se")
        lines.append(f"| {r['height']:g} | {r['label']} | {'yes' if r['paired'] else 'no'} | {r['n_seeds']} | "
                     f"{r['std_ratio_1s']:.4f} | {f(r['std_ratio_1s_effect'])}{' ± ' + f(se1, '.4f') if se1 else ''}"
                     f" | {r['std_ratio_3s']:.4f} | {f(r['std_ratio_3s_effect'])} | {r['std_ratio_point_1s']:.4f} | "
                     f"{r['radial_variance_ratio_1s']:.4f} | {f(r['radial_variance_ratio_1s_effect'])} | "
                     f"{r['cost_s']:.0f} | {r['cost_ratio']:.2f} |")
    lines += ["", "| knob | paired | seeds | RMS log10(T2 / default) | mean log10 | estimator noise [m/s] | "
              "noise effect | cost [s] | cost x |", "|---|---|---|---|---|---|---|---|---|"]
    for r in res.get("staring", []):
        if r["group"] == "scatter":
            lines.append(f"| *seed scatter (between seeds)* | | {r['n_seeds']} | "
                         f"{r['t2_rms_log10_vs_default']:.4f} | | {r['estimator_noise']:.4f} ± "
                         f"{r['estimator_noise_scatter']:.4f} | | | |")
            continue
        lines.append(f"| {r['label']} | {'yes' if r['paired'] else 'no'} | {r['n_seeds']} | "
                     f"{r['t2_rms_log10_vs_default']:.4f} | {r['t2_mean_log10_vs_default']:+.4f} | "
                     f"{r['estimator_noise']:.4f} | {100 * r['estimator_noise_rel_effect']:+.1f} % | "
                     f"{r['cost_s']:.0f} | {r['cost_ratio']:.2f} |")
    lines += ["", "| z [m] | ratio | default box, tier los, span 5 (seeds) | + tier spectral, span 30 | + grid "
              "d -> 0 | converged estimate |", "|---|---|---|---|---|---|"]
    for z in sorted({float(k.split("|")[1]) for k in res["rows"] if k.startswith("conical")}):
        for q, (est, se, n, off, grid) in cs_estimate(res["rows"], z).items():
            name = q.replace("std_ratio_point_", "lidar / point ").replace("std_ratio_", "lidar / cup ")
            lines.append(f"| {z:g} | {name} | {est - off - grid:.3f} ({n}) | {off:+.3f} | {grid:+.3f} | "
                         f"{est:.3f} ± {se:.3f} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="300-s conical periods, 1200-s staring, seed 1")
    ap.add_argument("--json", default=os.path.join("results", "convergence.json"))
    ap.add_argument("--parts", nargs="+", default=["conical", "staring"], choices=["conical", "staring"])
    ap.add_argument("--seeds", nargs="+", type=int, default=None)
    ap.add_argument("--heights", nargs="+", type=float, default=list(HEIGHTS))
    ap.add_argument("--only", nargs="+", default=None, help="row labels (substrings) to run")
    ap.add_argument("--conical-duration", type=float, default=None)
    ap.add_argument("--staring-duration", type=float, default=None)
    ap.add_argument("--markdown", action="store_true", help="print the docs' tables of the JSON and stop")
    ap.add_argument("--merge", nargs="+", default=None,
                    help="runs' JSONs (of one set of durations) to join into --json, with the tables printed")
    args = ap.parse_args(argv)
    from cwlidar_sim import _config

    _config.set_num_threads(1)
    seeds = args.seeds or ([1] if args.quick else [1, 2, 3])
    dc = args.conical_duration or (300.0 if args.quick else 600.0)
    ds = args.staring_duration or (1200.0 if args.quick else 3600.0)
    path = os.path.abspath(args.json)
    if args.merge:
        res = {"rows": {}, "runs": []}
        for m in args.merge:
            with open(m) as f:
                part = json.load(f)
            st = res.setdefault("settings", {"speed": SPEED, "band": BAND})
            for kind in {k.split("|")[0] for k in part["rows"]}:  # the durations of the parts it holds
                name = f"{kind}_duration"
                if st.setdefault(name, part["settings"][name]) != part["settings"][name]:
                    raise SystemExit(f"{m} holds {kind} rows of another duration")
            res["rows"].update(part["rows"])
            res["runs"].append({"file": os.path.basename(m), "machine": part.get("machine")})
        _atomic_write(path, res)
    if args.markdown or args.merge:
        with open(path) as f:
            res = json.load(f)
        seeds = sorted({int(k.split("|")[-2]) for k in res["rows"]})
        heights = sorted({float(k.split("|")[1]) for k in res["rows"] if k.startswith("conical")})
        res["conical"] = summarise_conical(res["rows"], seeds, heights)
        res["staring"] = summarise_staring(res["rows"], seeds)
        if args.merge:
            _atomic_write(path, res)
        print(markdown(res))
        return 0
    res = {}
    if os.path.exists(path):
        with open(path) as f:
            res = json.load(f)
        if res.get("settings", {}).get("conical_duration") != dc or res["settings"].get("staring_duration") != ds:
            raise SystemExit(f"{path} holds another run's durations; give another --json")
    res.setdefault("rows", {})
    res["settings"] = {"conical_duration": dc, "staring_duration": ds, "speed": SPEED, "band": BAND}
    res["machine"] = machine()
    rows = res["rows"]

    def want(label):
        return not args.only or any(o in label for o in args.only)

    for seed in seeds:
        if "staring" in args.parts:
            for group, label, st, _ in STARING:
                key = _key("staring", seed, label)
                if key in rows or not want(label):
                    continue
                rows[key] = staring_row(seed, ds, group, st)
                log(f"staring seed {seed} {label}: noise {rows[key]['estimator_noise']:.4f} m/s "
                    f"({rows[key]['cost_s']:.0f} s)")
                _atomic_write(path, res)
        if "conical" in args.parts:
            for z in args.heights:
                for group, label, st, _ in CONICAL:
                    key = _key("conical", z, seed, label)
                    if key in rows or not want(label) or z not in st.get("heights", (z,)):
                        continue
                    rows[key] = conical_row(z, seed, dc, group, st)
                    r = rows[key]
                    log(f"conical z={z:g} seed {seed} {label}: ratio 1 s {r['std_ratio_1s']:.4f} "
                        f"3 s {r['std_ratio_3s']:.4f} rv {r['radial_variance_ratio_1s']:.3f} ({r['cost_s']:.0f} s)")
                    _atomic_write(path, res)
    res["conical"] = summarise_conical(rows, seeds, args.heights)
    res["staring"] = summarise_staring(rows, seeds)
    _atomic_write(path, res)
    print(json.dumps({"conical": res["conical"], "staring": res["staring"]}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
