"""The CS std ratio against the probe volume's weighting, with the turbulence held fixed (issue 33).

    python studies/cs_weighting.py [--heights 40 100] [--periods 6] [--tier los] [--json PATH] [--markdown PATH]
    python studies/cs_weighting.py --summarise LOG [--markdown PATH]   # the table from a run's printed lines
    python studies/cs_weighting.py --heights 100 --skip 3 --periods 6 >> LOG   # more units for LOG (resume)

The bundled ``cs`` scene's units (its period templates, seeds, settings: tier ``spectral``, span
30, the mean-wind tail) at each height, each run once per weighting with everything else the same:
the same seed, box and turbulence (the span is counted in z_R for every weighting, so the box is the
same size; the cup's std, printed, is the same in every row of a unit), the same scan.  Only the
probe volume changes, so the paired differences against ``exact`` (the default, the published
numbers' weighting) scatter far less than the ratios themselves: their mean over the units, with
its standard error, is the weighting's effect.  The units are the first ``--periods`` of the scene's
plan at each height (the templates in order: 6 m/s to 12 m/s, three wind directions).  ``--tier los``
runs tier 1 instead of the scene's tier ``spectral``: there the mean-wind tail enters the weighted
average itself, while tiers 2 and 3 leave it out of the Doppler spectrum (:mod:`cwlidar_sim.signal.chain`)
and normalise the spectrum, so what the tail is given matters at tier 1 only.

Weightings (names registered here, in this process only):

* ``exact``: the focused Gaussian beam's Cauchy density, cut at the telescope, renormalised;
* ``lorentzian``: A2012 Eq. 4, cut at the telescope and renormalised (since issue 33);
* ``lorentzian_to_tail``: Eq. 4 with its real-line weight behind the telescope given to the
  mean-wind tail (the ``lorentzian`` weighting before issue 33), for the size of that change;
* ``aperture_t13``: the beam clipped by the telescope's aperture at T = R / a0 = 1.3
  (docs/aperture.md: the truncation that lengthens the probe volume as A2012's residual asks).

Writes per unit and weighting the 1 s and 3 s std ratios, and per height and weighting their mean
and the mean paired difference to ``exact`` with its standard error (``--json``); ``--markdown``
writes the rows of docs/convergence.md's table.
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

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import machine, write_json  # noqa: E402

from cwlidar_sim.beam import WEIGHTINGS, Weighting, register_weighting  # noqa: E402
from cwlidar_sim.beam.probe import ApertureWeighting  # noqa: E402

TRUNCATION = 1.3


class LorentzianToTail(Weighting):
    """Eq. 4 on the whole line: its weight behind the telescope is left to the mean-wind tail (pre-issue-33)."""

    def density(self, s, optics):
        zR = optics.rayleigh_length
        s = np.asarray(s, dtype=float)
        return zR / (math.pi * (zR * zR + s * s))

    def primitive(self, s, optics):
        return np.arctan(np.asarray(s, dtype=float) / optics.rayleigh_length) / math.pi

    def fourier(self, k, optics):
        return np.exp(-optics.rayleigh_length * np.abs(np.asarray(k, dtype=float))).astype(complex)


@dataclasses.dataclass(frozen=True, repr=True)
class ApertureT13(ApertureWeighting):
    """The aperture weighting at T = 1.3, constructible without arguments (as the registry needs)."""

    truncation: float = TRUNCATION


EXTRA = {"lorentzian_to_tail": LorentzianToTail, "aperture_t13": ApertureT13}
WEIGHTS = ("exact", "lorentzian", "lorentzian_to_tail", "aperture_t13")


def register():
    for name, cls in EXTRA.items():
        if name not in WEIGHTINGS:
            register_weighting(name, cls)


def run(heights, n_periods, weights, tier=None, skip=0):
    from cwlidar_sim.campaign import bundled_scene
    from cwlidar_sim.campaign.periods.conical import run_unit

    register()
    scene = bundled_scene("cs")
    units = scene.units()
    tier = tier or scene.lidar.tier
    out = {"units": [], "weightings": list(weights), "heights": [float(z) for z in heights], "periods": n_periods,
           "tier": tier}
    for z in heights:
        idx = [i for i, (_, zz) in enumerate(units) if zz == z][skip:n_periods]
        for i in idx:
            p = units[i][0]
            row = {"height": float(z), "unit": scene.unit_names()[i], "seed": scene.unit_seed(i),
                   "mean_speed": p.mean_speed, "toward_deg": p.toward_deg}
            for w in weights:
                t = time.perf_counter()
                ds = run_unit(scene.with_values({"lidar.weighting": w, "lidar.tier": tier}), i)
                r = {f"std_ratio_{s:g}s": float(ds["std_ratio"].sel(scan_s=s).values.ravel()[0])
                     for s in ds.scan_s.values}
                r["cup_std"] = float(ds["cup_std"].values.ravel()[0])
                r["wall_s"] = time.perf_counter() - t
                row[w] = r
            print(json.dumps(row), flush=True)
            out["units"].append(row)
    out["summary"] = summarise(out)
    return out


def summarise(out):
    summ = {}
    for z in out["heights"]:
        rows = [r for r in out["units"] if r["height"] == z]
        keys = [k for k in rows[0]["exact"] if k.startswith("std_ratio")]
        zs = summ[f"{z:g}"] = {"n": len(rows)}
        for w in out["weightings"]:
            d = zs[w] = {}
            for k in keys:
                v = np.array([r[w][k] for r in rows])
                diff = v - np.array([r["exact"][k] for r in rows])
                se = lambda x: float(x.std(ddof=1) / math.sqrt(x.size)) if x.size > 1 else math.nan  # noqa: E731
                d[k] = {"mean": float(v.mean()), "se": se(v), "effect": float(diff.mean()), "effect_se": se(diff)}
            d["cup_std_same"] = bool(all(r[w]["cup_std"] == r["exact"]["cup_std"] for r in rows))
            d["wall_s"] = float(np.mean([r[w]["wall_s"] for r in rows]))
    return summ


LABELS = {"exact": "weighting exact (default)", "lorentzian": "weighting lorentzian (cut at the telescope)",
          "lorentzian_to_tail": "lorentzian, weight behind the telescope to the tail (before issue 33)",
          "aperture_t13": f"weighting aperture, T = {TRUNCATION:g}"}


def markdown(out) -> str:
    lines = ["| z [m] | weighting | units | std ratio 1 s | effect 1 s | std ratio 3 s | effect 3 s |",
             "|---|---|---|---|---|---|---|"]
    for z, zs in out["summary"].items():
        for w in out["weightings"]:
            d = zs[w]
            cells = []
            for k in ("std_ratio_1s", "std_ratio_3s"):
                e = d[k]
                eff = "+0.0000" if w == "exact" else f"{e['effect']:+.4f} ± {e['effect_se']:.4f}"
                cells += [f"{e['mean']:.4f}", eff]
            lines.append(f"| {z} | {LABELS.get(w, w)} | {zs['n']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heights", type=float, nargs="+", default=[40.0, 100.0])
    ap.add_argument("--periods", type=int, default=6, help="units per height (the scene's plan, in order)")
    ap.add_argument("--skip", type=int, default=0, help="leave out each height's first units (those a log has)")
    ap.add_argument("--weightings", nargs="+", default=list(WEIGHTS))
    ap.add_argument("--tier", default=None, help="lidar tier (default: the scene's, spectral)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--markdown", default=None)
    ap.add_argument("--summarise", default=None, help="a run's printed output (one JSON line per unit): its table")
    a = ap.parse_args(argv)
    if a.summarise:  # a run stopped early (or its JSON lost): the units it printed
        with open(a.summarise, encoding="utf-8") as f:
            units = [json.loads(line) for line in f if line.startswith("{")]
        weights = [w for w in WEIGHTS if w in units[0]]
        out = {"units": units, "weightings": weights, "heights": sorted({u["height"] for u in units})}
        out["summary"] = summarise(out)
        md = markdown(out)
        print(md)
        if a.markdown:
            with open(a.markdown, "w", encoding="utf-8") as f:
                f.write(md)
        return 0
    t, c = time.perf_counter(), time.process_time()
    load0 = os.getloadavg()
    out = run(a.heights, a.periods, a.weightings, a.tier, a.skip)
    out["run"] = {"wall_s": time.perf_counter() - t, "cpu_s": time.process_time() - c, "loadavg_start": list(load0),
                  "loadavg_end": list(os.getloadavg())}
    md = markdown(out)
    print(md)
    if a.json:
        write_json(a.json, {"machine": machine(), "time": time.strftime("%Y-%m-%dT%H:%M:%S"), **out})
    if a.markdown:
        with open(a.markdown, "w", encoding="utf-8") as f:
            f.write(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
