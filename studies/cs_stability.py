#!/usr/bin/env python3
"""CS's lidar/cup std ratio by stability class, simulated and from CS's model (issue 18).

For each height (40 m, 100 m) and stability class (Obukhov length L_MO; the same z / L_MO at
both heights: -0.4, -0.08, 0 (neutral), +0.08, +0.4), the Mann parameters of the surface layer
(:func:`cwlidar_sim.turbulence.surface_layer.surface_layer_parameters`: Businger-Dyer u*,
local-TKE-balance dissipation, Pena et al. 2010's length scale L = 0.59 z / phi_m, Gamma 3.9)
drive :func:`cwlidar_sim.campaign.simulate_conical_period` at the converged defaults (span 30
z_R, d = z / 20, tier 'los', 8 sub-dwells, laterally doubled box, 10 m/s, 600-s periods), and
CS's filter model with the same Mann spectra gives its ratio.

Pairing: at one height every class's box has one physical size (the largest any class needs:
the unstable class's 2 L) and seed s is the same seed in every class, so the same normals
drive the same wavenumbers; the class-to-neutral differences are paired (their scatter is far
below the ratio's own).

A stability mix is the frequency-weighted mean over classes (a campaign's mean ratio of
10-minute periods, each period one class).  No published Hoevsoere class frequencies were
available when this was written (docs/stability_parameters.md), so the mix below is
ILLUSTRATIVE, not a site's.

Usage (one core, in the background)::

    NUMBA_NUM_THREADS=1 CWLIDAR_SIM_NUM_THREADS=1 nohup python studies/cs_stability.py \
        --json docs/cs_stability.json > cs_stability.log 2>&1 &
    python studies/cs_stability.py --quick            # 120-s periods, 1 seed: a smoke run
    python studies/cs_stability.py --markdown docs/cs_stability.json   # the table again

Every finished period is written at once to the JSON (atomically) and a rerun resumes from it.
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

SPEED = 10.0
SPAN = 30.0
#: z / L_MO of the classes (the same at every height; L_MO = z / zeta), None: neutral
ZETAS = (-0.4, -0.08, None, 0.08, 0.4)
CLASS_NAMES = {-0.4: "unstable", -0.08: "near-neutral unstable", None: "neutral", 0.08: "near-neutral stable",
               0.4: "stable"}
#: ILLUSTRATIVE class weights (not a site's frequencies: none were available, see the module notes)
ILLUSTRATIVE_MIX = {-0.4: 0.15, -0.08: 0.2, None: 0.3, 0.08: 0.2, 0.4: 0.15}
HEIGHTS = (40.0, 100.0)


def obukhov(z, zeta):
    return None if zeta is None else z / zeta


def key(z, zeta, seed):
    return f"{z:g}|{'neutral' if zeta is None else f'{zeta:+g}'}|{seed}"


def class_params(z, zeta):
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    return surface_layer_parameters(z, SPEED, obukhov_length=obukhov(z, zeta))


def height_extent(z, duration):
    """One physical box size at height z for every class: the cone of span SPAN and 2 L of the largest L."""
    from cwlidar_sim.campaign.scenes.conical import default_spacing
    from cwlidar_sim.sensors.conical import ConicalLidar
    from cwlidar_sim.turbulence.grids import common_extent

    d = default_spacing(z)
    lid = ConicalLidar(heights=(z,), span=SPAN, cell_length=d)
    lmax = max(class_params(z, zeta)[0].length_scale for zeta in ZETAS)
    be = lid.beam_extent(z)
    need = (SPEED * duration + 2 * be["radius"] + 4 * d,
            max(2 * be["radius"] + 3 * d, 2 * lmax + d),
            max(be["z_hi"] - min(be["z_lo"], z) + 3 * d, 2 * lmax + d))
    return tuple(common_extent(n, (d,)) for n in need)


def run_one(z, zeta, seed, duration, extent):
    from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
    from cwlidar_sim.campaign.scenes.conical import default_spacing

    p, su, us = class_params(z, zeta)
    d = default_spacing(z)
    t0 = time.perf_counter()
    r = simulate_conical_period(z, seed, speed=SPEED, duration=duration, tier="los", spacing=d,
                                params=p, lidar_overrides={"span": SPAN, "cell_length": d},
                                box_options={"extent": extent})
    out = {"height": z, "zeta": zeta, "obukhov_length": obukhov(z, zeta), "seed": seed,
           "params": p.as_dict(), "sigma_u_tensor": su, "u_star": us, "cup_std": r["cup_std"],
           "sonic_std": r["sonic_std"], "box_shape": r["box_shape"], "cost_s": time.perf_counter() - t0}
    for n, s in r["scans"].items():
        out[f"std_ratio_{n}s"] = s["std_ratio"]
        out[f"model_mann_{n}s"] = s["std_ratio_model_mann"]
        out[f"model_kaimal_{n}s"] = s["std_ratio_model_kaimal"]
    return out


def _mean_se(v):
    v = np.asarray(v, dtype=float)
    return float(v.mean()), (float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else None)


def summarise(rows, mix=ILLUSTRATIVE_MIX):
    """Per height and class: mean ratio +- SE, model, difference; paired shift against neutral; the mix."""
    out = {}
    for z in sorted({r["height"] for r in rows}):
        at = [r for r in rows if r["height"] == z]
        neutral = {r["seed"]: r for r in at if r["zeta"] is None}
        cls = {}
        for zeta in ZETAS:
            rs = [r for r in at if r["zeta"] == zeta]
            if not rs:
                continue
            c = {"name": CLASS_NAMES[zeta], "zeta": zeta, "obukhov_length": obukhov(z, zeta), "seeds": len(rs),
                 "length_scale": rs[0]["params"]["length_scale"], "alpha_eps": rs[0]["params"]["alpha_eps"],
                 "sigma_u_tensor": rs[0]["sigma_u_tensor"], "cost_s": float(np.mean([r["cost_s"] for r in rs]))}
            for n in (1, 3):
                m, se = _mean_se([r[f"std_ratio_{n}s"] for r in rs])
                model = rs[0][f"model_mann_{n}s"]
                c[f"sim_{n}s"], c[f"sim_se_{n}s"], c[f"model_{n}s"] = m, se, model
                c[f"sim_minus_model_{n}s"] = m - model
                c[f"seed_scatter_{n}s"] = (float(np.std([r[f"std_ratio_{n}s"] for r in rs], ddof=1))
                                           if len(rs) > 1 else None)
                diffs = [r[f"std_ratio_{n}s"] - neutral[r["seed"]][f"std_ratio_{n}s"] for r in rs
                         if r["seed"] in neutral]
                if diffs and None in [r["zeta"] for r in at]:
                    c[f"shift_sim_{n}s"], c[f"shift_sim_se_{n}s"] = _mean_se(diffs)
                    nm = [r for r in at if r["zeta"] is None][0][f"model_mann_{n}s"]
                    c[f"shift_model_{n}s"] = model - nm
            cls["neutral" if zeta is None else f"{zeta:+g}"] = c
        entry = {"classes": cls}
        names = {zt: ("neutral" if zt is None else f"{zt:+g}") for zt in mix}
        if all(nm in cls for nm in names.values()):
            wsum = sum(mix.values())
            w = {zt: v / wsum for zt, v in mix.items()}
            # the seeds every class ran: one mixed campaign per seed (the classes share seeds, so their
            # errors are correlated; the mix's standard error is taken over these per-seed mixes)
            by = {(r["zeta"], r["seed"]): r for r in at}
            seeds = sorted(sd for sd in {r["seed"] for r in at} if all((zt, sd) in by for zt in mix))
            mx = {"weights": {names[zt]: w[zt] for zt in mix}, "illustrative": True, "seeds": len(seeds)}
            for n in (1, 3):
                per_seed = [sum(w[zt] * by[(zt, sd)][f"std_ratio_{n}s"] for zt in mix) for sd in seeds]
                mx[f"sim_{n}s"], mx[f"sim_se_{n}s"] = _mean_se(per_seed)
                mx[f"model_{n}s"] = sum(w[zt] * cls[names[zt]][f"model_{n}s"] for zt in mix)
                mx[f"sim_minus_model_{n}s"] = mx[f"sim_{n}s"] - mx[f"model_{n}s"]
                shift = [p - by[(None, sd)][f"std_ratio_{n}s"] for p, sd in zip(per_seed, seeds)]
                mx[f"shift_sim_{n}s"], mx[f"shift_sim_se_{n}s"] = _mean_se(shift)
                mx[f"shift_model_{n}s"] = mx[f"model_{n}s"] - cls["neutral"][f"model_{n}s"]
            entry["mix"] = mx
        out[f"{z:g}"] = entry
    return out


def _f(x, se=None, nd=3):
    if x is None:
        return "–"
    s = f"{x:.{nd}f}"
    if se is not None:
        s += f" ± {se:.{nd}f}"
    return s


def _zeta_s(zeta):
    return "0" if zeta is None else f"{zeta:+g}"


def _lmo_s(lmo):
    return "∞" if lmo is None else f"{lmo:+.0f}"


def _pm(x, se):
    if x is None:
        return "–"
    return f"{x:+.3f}" + ("" if se is None else f" ± {se:.3f}")


def _opt(x):
    return "–" if x is None else f"{x:+.3f}"


def markdown(summary):
    lines = ["| z [m] | class | z/L_MO | L_MO [m] | L [m] | sim 1 s | model 1 s | sim − model | sim 3 s | "
             "model 3 s | sim − model | shift vs neutral 1 s: sim (paired) | model |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for z, e in summary.items():
        for c in e["classes"].values():
            lines.append(
                f"| {z} | {c['name']} | {_zeta_s(c['zeta'])} | {_lmo_s(c['obukhov_length'])} | "
                f"{c['length_scale']:.1f} | "
                f"{_f(c['sim_1s'], c['sim_se_1s'])} | {c['model_1s']:.3f} | {c['sim_minus_model_1s']:+.3f} | "
                f"{_f(c['sim_3s'], c['sim_se_3s'])} | {c['model_3s']:.3f} | {c['sim_minus_model_3s']:+.3f} | "
                f"{_pm(c.get('shift_sim_1s'), c.get('shift_sim_se_1s'))} | {_opt(c.get('shift_model_1s'))} |")
        if "mix" in e:
            m = e["mix"]
            lines.append(f"| {z} | **illustrative mix** | | | | {_f(m['sim_1s'], m['sim_se_1s'])} | "
                         f"{m['model_1s']:.3f} | {m['sim_minus_model_1s']:+.3f} | {_f(m['sim_3s'], m['sim_se_3s'])} | "
                         f"{m['model_3s']:.3f} | {m['sim_minus_model_3s']:+.3f} | "
                         f"{_pm(m['shift_sim_1s'], m['shift_sim_se_1s'])} | {m['shift_model_1s']:+.3f} |")
    return "\n".join(lines)


def grid_check(seeds, duration, json_path=None, z=40.0, zetas=(None, 0.4), span=5.0):
    """Paired effect of halving the across-wind spacing (dy = dz = d/2) on the 1-s ratio, by class.

    The convergence study measured it in neutral conditions (span 5: its ``grid`` group); the stable
    class's L = 7.9 m at 40 m is resolved by 4 cells of d = 2 m, so the effect is measured again per
    class, at span 5 as there (the span's effect is separate and barely grid-dependent).
    """
    from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
    from cwlidar_sim.campaign.scenes.conical import default_spacing
    from cwlidar_sim.sensors.conical import ConicalLidar
    from cwlidar_sim.turbulence.grids import common_extent

    d = default_spacing(z)
    spacings = (d, d / 2)
    lid = ConicalLidar(heights=(z,), span=span, cell_length=d)
    be = lid.beam_extent(z)
    lmax = max(class_params(z, zeta)[0].length_scale for zeta in zetas)
    need = (SPEED * duration + 2 * be["radius"] + 4 * d, max(2 * be["radius"] + 3 * d, 2 * lmax + d),
            max(be["z_hi"] - min(be["z_lo"], z) + 3 * d, 2 * lmax + d))
    ext = tuple(common_extent(n, spacings) for n in need)
    rows = []
    for seed in seeds:
        for zeta in zetas:
            p = class_params(z, zeta)[0]
            r = {}
            for name, sp in (("d", (d, d, d)), ("across d/2", (d, d / 2, d / 2))):
                out = simulate_conical_period(z, seed, speed=SPEED, duration=duration, tier="los", spacing=d,
                                              params=p, model=False,
                                              lidar_overrides={"span": span, "cell_length": d},
                                              box_options={"extent": ext, "spacing": sp})
                r[name] = out["scans"][1]["std_ratio"]
            rows.append({"seed": seed, "zeta": zeta, "ratio_d": r["d"], "ratio_across_half": r["across d/2"],
                         "effect": r["across d/2"] - r["d"]})
            log(f"grid check z={z:g} zeta={zeta} seed={seed}: d {r['d']:.4f}, across d/2 "
                f"{r['across d/2']:.4f}, effect {rows[-1]['effect']:+.4f}")
    summary = {}
    for zeta in zetas:
        m, se = _mean_se([r["effect"] for r in rows if r["zeta"] == zeta])
        summary["neutral" if zeta is None else f"{zeta:+g}"] = {"effect_1s": m, "effect_se_1s": se}
        log(f"zeta={zeta}: across d/2 effect on the 1-s ratio {m:+.4f}" + ("" if se is None else f" ± {se:.4f}"))
    if json_path:
        write_json(json_path, {"machine": machine(), "height": z, "span": span, "duration": duration,
                               "extent": ext, "rows": rows, "summary": summary})
    return summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", default=None, help="results file (resumed from if it exists)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    ap.add_argument("--heights", type=float, nargs="+", default=list(HEIGHTS))
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--quick", action="store_true", help="120-s periods, seed 1, 40 m only (a smoke run)")
    ap.add_argument("--grid-check", metavar="JSON", default=None,
                    help="the paired across-wind spacing check by class (40 m, neutral and stable) into JSON")
    ap.add_argument("--markdown", metavar="JSON", default=None, help="print the table of a finished run and exit")
    a = ap.parse_args(argv)
    if a.markdown:
        with open(a.markdown) as f:
            res = json.load(f)
        res["summary"] = summarise(res["rows"])  # the summary of this version of the script
        write_json(a.markdown + ".tmp", res)
        os.replace(a.markdown + ".tmp", a.markdown)
        print(markdown(res["summary"]))
        return 0
    if a.quick:
        a.seeds, a.heights, a.duration = [1], [40.0], 120.0
    if a.grid_check:
        grid_check(a.seeds, a.duration, a.grid_check)
        return 0
    res = {"machine": machine(), "settings": {"speed": SPEED, "span": SPAN, "tier": "los", "duration": a.duration,
                                              "seeds": a.seeds, "heights": a.heights, "zetas": list(ZETAS),
                                              "mix": {("neutral" if k is None else f"{k:+g}"): v
                                                      for k, v in ILLUSTRATIVE_MIX.items()},
                                              "mix_is_illustrative": True},
           "rows": []}
    if a.json and os.path.exists(a.json):
        with open(a.json) as f:
            old = json.load(f)
        if old.get("settings", {}).get("duration") == a.duration:
            res["rows"] = old["rows"]
    done = {key(r["height"], r["zeta"], r["seed"]) for r in res["rows"]}
    extents = {z: height_extent(z, a.duration) for z in a.heights}
    for z, ext in extents.items():
        log(f"z = {z:g} m: box extent {tuple(round(e, 1) for e in ext)} m (all classes)")
    for seed in a.seeds:  # seeds outermost: a run stopped early leaves every height and class alike
        for z, ext in extents.items():
            for zeta in ZETAS:
                if key(z, zeta, seed) in done:
                    continue
                r = run_one(z, zeta, seed, a.duration, ext)
                res["rows"].append(r)
                log(f"z={z:g} zeta={zeta} seed={seed}: 1 s {r['std_ratio_1s']:.4f} (model {r['model_mann_1s']:.4f}),"
                    f" 3 s {r['std_ratio_3s']:.4f} (model {r['model_mann_3s']:.4f}), {r['cost_s']:.0f} s")
                if a.json:
                    res["summary"] = summarise(res["rows"])
                    write_json(a.json + ".tmp", res)
                    os.replace(a.json + ".tmp", a.json)
    res["summary"] = summarise(res["rows"])
    if a.json:
        write_json(a.json + ".tmp", res)
        os.replace(a.json + ".tmp", a.json)
    print(markdown(res["summary"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
