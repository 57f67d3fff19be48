"""Convergence of the nacelle results' linear theory (campaign/periods/nacelle_theory.py): each knob refined alone.

The bundled nacelle scene's frozen period (12 m/s, 600 s), the results' own pairing (the span and the whole-sample
preview delay), one focus at a time.  Against the production setting (``nacelle_theory``'s defaults: the adaptive k1
grid from ``N_START`` k1 to ``TOL``, ``THEORY_RESOLUTION``, ``THEORY_ROTOR_NODES``, ``THEORY_PHASES``, one look
per dwell), each of: the tolerance / 4, twice the starting k1, twice the resolution, the rotor's nodes refined,
the grid's top end raised past the revolution mean's first zeros, four scan phases, the lidar's own sub-dwell looks,
the rotor's variance from its nodes instead of the disc's closed form;
and a dense fixed grid (``--dense N`` log-spaced k1 over the same span).  Prints one JSON line per run (std ratio,
correlation, stds, k1 evaluated, CPU seconds) and the moves against the production run.

Full run (the three foci, every knob; ~1 CPU minute per run)::

    python studies/nacelle_theory_convergence.py --foci 50 100 150 --dense 241 --json results/nacelle_conv.json

Reduced (what the module's ``CONVERGENCE`` quotes was run at this size per focus)::

    python studies/nacelle_theory_convergence.py --foci 100
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from cwlidar_sim.campaign.execution.reproduce import bundled_scene
from cwlidar_sim.campaign.periods import nacelle_theory as nt

#: Each knob: name -> keyword arguments of nacelle_theory (None: the dense fixed grid).
KNOBS = {
    "tol / 4": {"tol": nt.TOL / 4},
    "n_start x 2": {"n_start": 2 * nt.N_START - 1},
    "resolution x 2": {"resolution": 2 * nt.THEORY_RESOLUTION},
    "rotor nodes x 1.5": {"rotor_nodes": tuple(int(1.5 * n) for n in nt.THEORY_ROTOR_NODES)},
    "rotor nodes x 2": {"rotor_nodes": tuple(2 * n for n in nt.THEORY_ROTOR_NODES)},
    "rotor nodes x 3": {"rotor_nodes": tuple(3 * n for n in nt.THEORY_ROTOR_NODES)},
    "rotor from nodes": {"rotor_disc": False},
    "k1 top x 3": {"top": 3.0},
    "phases 4": {"phases": 4},
    "sub_dwells own": {"sub_dwells": None},
}


def pairing(scene, r):
    """The results' lidar (hub at the origin), span [s] and delay [s] of the frozen period at focus r."""
    p = scene.periods[0]
    lid = scene.sensor(p, (r,)).replace(position=(0.0, 0.0, 0.0))
    dt = lid.dwell_time
    shift = max(lid.preview_distance(r) / p.mean_speed - 0.5 * (lid.revolution_time - dt), 0.0)  # as run_unit
    m = round(shift / dt)
    n = int(round(scene.period_duration(p) / dt))
    return p, lid, (n - lid.estimates_per_rev + 1 - m) * dt, m * dt


def run(scene, r, **kw):
    p, lid, span, delay = pairing(scene, r)
    s = scene.scan
    U = p.mean_speed
    top = kw.pop("top", None)
    if top is not None:
        lo, hi = nt.k1_range(U, span, lid.revolution_time)
        kw["k1_ends"] = (lo, hi * top)
    t0 = time.process_time()
    out = nt.nacelle_theory(lid, r, scene.period_params(p), U, span, s.rotor_radius, rotor_exponent=s.rotor_exponent,
                            preview_shift=delay, **kw)
    out["cpu_s"] = time.process_time() - t0
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--foci", type=float, nargs="+", default=[100.0])
    ap.add_argument("--knobs", nargs="+", default=list(KNOBS), help="which knobs (default all)")
    ap.add_argument("--dense", type=int, default=0, help="also a fixed grid of N log-spaced k1 (0: none)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    scene = bundled_scene("nacelle")
    rows = []
    for r in a.foci:
        base = run(scene, r)
        runs = [("production", base)] + [(k, run(scene, r, **dict(KNOBS[k]))) for k in a.knobs]
        if a.dense:
            p, lid, span, _ = pairing(scene, r)
            runs.append((f"fixed {a.dense} k1", run(scene, r, k1=np.geomspace(*nt.k1_range(p.mean_speed, span,
                                                                                              lid.revolution_time),
                                                                           a.dense))))
        for name, o in runs:
            row = {"focus": r, "run": name, **{k: o[k] for k in ("std_ratio", "correlation", "lidar_std", "rotor_std",
                                                                  "n_k1", "grid_error", "cpu_s")},
                   "d_ratio": o["std_ratio"] - base["std_ratio"], "d_corr": o["correlation"] - base["correlation"]}
            rows.append(row)
            print(json.dumps({k: (round(v, 7) if isinstance(v, float) and math.isfinite(v) else v)
                              for k, v in row.items()}), flush=True)
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
