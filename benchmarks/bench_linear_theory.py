"""Cost and convergence of the conical linear theory (campaign.periods.conical_theory) for one CS height.

    python benchmarks/bench_linear_theory.py [--quick] [--heights 40 100] [--unmerged] [--json PATH]

Times (this interpreter, after a warm-up at one k1) the production path of a
conical scene's theory at each height of the bundled CS scene (U = 8 m/s, a
600-s period, scans of 1 and 3 revolutions: ``conical_theory._unit_theory``,
the VAD u of one 1-s revolution with its 8 sub-dwell looks merged into 50, the
beam's exact weighting, the cup with its first-order response, on the
adaptive k1 grid of ``analysis.linear_theory.adaptive_spectra``), and, in the
same run, the baseline: CS's 1-D filter model at that height
(``cs_model.model_ratios``, spectrum "mann").  Prints the ratio of the two
times and the std ratios; without ``--quick`` also the theory refined, one
choice at a time (the grid's tolerance divided by 4, twice the starting k1,
twice the plane quadrature's resolution; ``--unmerged``: the 400 sub-dwell looks unmerged),
and how far each moves the ratios (the convergence stated in
``conical_theory``'s module notes).  Runs in one fresh interpreter under the
shared protocol of ``benchmarks/_protocol.py``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from types import SimpleNamespace

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import child_main, machine, write_json  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--heights", type=float, nargs="+", default=[100.0])
    ap.add_argument("--unmerged", action="store_true", help="also the 400 sub-dwell looks unmerged (8x the cost)")
    ap.add_argument("--json")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_main({"default": _child}, a.child)
    r = _protocol.spawn(__file__, {"quick": a.quick, "heights": a.heights, "unmerged": a.unmerged})
    if "error" in r:
        print(r["error"], file=sys.stderr)
        return 1
    for line in r["log"]:
        print(line)
    if a.json:
        write_json(a.json, {"machine": machine(), "rows": r["rows"], "peak_bytes": r["peak_bytes"]})
    return 0


def _child(task):
    from cwlidar_sim.analysis import cs_model
    from cwlidar_sim.analysis import linear_theory as lt
    from cwlidar_sim.campaign.execution.reproduce import bundled_scene
    from cwlidar_sim.campaign.periods import conical_theory as ct
    from cwlidar_sim.campaign.periods.theory import conical_functionals
    from cwlidar_sim.sensors import ConicalLidar, Cup

    a = SimpleNamespace(**task)
    U, period, revs = 8.0, 600.0, (1, 3)
    cs = bundled_scene("cs")
    rows, log = [], []
    for z in a.heights:
        lidar = ConicalLidar(heights=(z,), **cs.lidar_fields(1.0))
        p = cs.turbulence.params(z, U)
        cup = Cup(position=(0.0, 0.0, z))
        vad, cupf = conical_functionals(lidar, z, U, revolutions=1, cup=cup)
        lt.functional_spectra([0.01], p, [ct._merge_sub_dwells(vad, lidar.sub_dwells), cupf], U)  # warm-up

        def theory(merge=True):
            t0 = time.perf_counter()
            out = ct._unit_theory(lidar, z, U, period, p, revs, cup, merge=merge)
            return out, time.perf_counter() - t0

        c0 = time.process_time()
        prod, dt = theory()
        cpu = time.process_time() - c0
        t0 = time.perf_counter()
        cs_model._mann_coarse.cache_clear()
        base = cs_model.model_ratios(z, U, 1, spectrum="mann", params=p)
        db = time.perf_counter() - t0
        ratios = [prod["scans"][n]["std_ratio"] for n in revs]
        log += [f"{z:g} m: linear theory (VAD {lidar.sub_dwells} x {vad.looks.n_looks // lidar.sub_dwells} looks "
                f"merged to {vad.looks.n_looks // lidar.sub_dwells}, + cup), {prod['n_k1']} k1 (adaptive, tol "
                f"{ct.TOL:g}): {dt:.2f} s; std ratio 1 / 3 rev {ratios[0]:.5f} / {ratios[1]:.5f}",
                f"{z:g} m: baseline cs_model.model_ratios (1-D filter model, Mann spectra): {db:.2f} s "
                f"(ratio of times {dt / db:.1f}); CS model std ratio {base['std_ratio']:.5f}"]
        log.append(f"{z:g} m: CPU {cpu:.1f} s (this process, all threads), 1-min load {os.getloadavg()[0]:.1f}")
        row = {"case": "cs_height", "height": z, "k1": prod["n_k1"], "wall_s": dt, "cpu_s": cpu,
               "loadavg_1min": os.getloadavg()[0], "baseline_wall_s": db,
               "ratio_to_baseline": dt / db, "std_ratio_1rev": ratios[0], "std_ratio_3rev": ratios[1],
               "grid_error": prod["grid_error"], "std_ratio_cs_model": base["std_ratio"], "moves": {}}
        if not a.quick:
            saved = (ct.TOL, ct.N_START, ct.RESOLUTION)
            variants = {"tol / 4": ({"TOL": ct.TOL / 4}, True), "n_start x 2": ({"N_START": 2 * ct.N_START - 1}, True),
                        "resolution x 2": ({"RESOLUTION": 2 * ct.RESOLUTION}, True)}
            if a.unmerged:
                variants["sub_dwells unmerged"] = ({}, False)
            for name, (consts, merge) in variants.items():
                for k, v in consts.items():
                    setattr(ct, k, v)
                try:
                    ref, dr = theory(merge)
                finally:
                    ct.TOL, ct.N_START, ct.RESOLUTION = saved
                moves = [ref["scans"][n]["std_ratio"] - prod["scans"][n]["std_ratio"] for n in revs]
                row["moves"][name] = {"k1": ref["n_k1"], "wall_s": dr, "move_1rev": moves[0], "move_3rev": moves[1]}
                log.append(f"{z:g} m: {name}: {ref['n_k1']} k1, {dr:.1f} s; ratios "
                           f"{ref['scans'][1]['std_ratio']:.5f} / {ref['scans'][3]['std_ratio']:.5f} "
                           f"(moves {moves[0]:+.5f} / {moves[1]:+.5f})")
        rows.append(row)
    return {"rows": rows, "log": log}


if __name__ == "__main__":
    sys.exit(main())
