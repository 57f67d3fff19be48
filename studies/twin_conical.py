"""The conical lidar's 10-minute std predicted from a mast at the circle's centre: does the twins' spread hold the truth?

Usage::

    python studies/twin_conical.py [--quick] [--periods P] [--twins N] [--duration T] [--json PATH]
                                      [--workers W]

Everything goes through the scene path a user runs (``cwlidar-sim twin`` on a conical scene):

1. The truth: per period, the conical scene's own unit (:func:`cwlidar_sim.campaign.periods.conical.run_unit`,
   CS's geometry at 40 m, 1-s scans, tier 'los', the surface layer's tensor at 40 m, U = 10 m/s) in an
   unconditioned box of the normal size (x period U T plus the circle: *not* periodic over the
   record, so the record's ends meet unmeasured air as a real mast's do).  A sonic on a mast at the
   circle's centre (0, 0, 40 m) samples that box at U / dx = 5 Hz with 0.05 m/s of white noise; the
   periods' records are written as one CSV.
2. The twins: the scene with ``[turbulence] condition_on`` naming that CSV, run by
   :func:`cwlidar_sim.campaign.twin.run.run_twin` (N twins per period; ``--workers W``: on a local Dask
   cluster of W processes, the same bits).
3. Per period the truth's 10-minute std of the VAD horizontal speed against the twins'.

If the twins are draws from the conditional distribution the truth is drawn from, the truth's
rank among its N twins is uniform on 0..N, so it lies between the twins' smallest and largest
value in a fraction (N - 1) / (N + 1) of periods (binomial sampling error over P periods).  The
same is reported for N unconditioned boxes (the prior spread: the truth scene's own units with
other seeds), to show what the mast removes.  No assumption of Gaussian spread enters the check.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import log, machine, write_json  # noqa: E402

HEIGHT, U, DX, NOISE = 40.0, 10.0, 2.0, 0.05

SCENE = """
name = "twin_conical"
kind = "conical"
seed = {seed}
duration = {T}
[scan]
heights = [{z}]
scan_revs = [1]
spacing = {dx}
[lidar]
tier = "los"
[turbulence]
condition_on = [{{ path = "mast.csv", kind = "sonic", position = [0.0, 0.0, {z}], noise_std = {noise}, rotation = "none" }}]
[[period]]
name = "p0"
mean_speed = {U}
"""


def _scenes(folder, T, seed):
    from cwlidar_sim.campaign import loads_scene

    twin = loads_scene(SCENE.format(seed=seed, T=T, z=HEIGHT, dx=DX, noise=NOISE, U=U), base_dir=folder)
    plain = twin.replace(turbulence=dataclasses.replace(twin.turbulence, condition_on=()))
    return twin, plain


def _unit_std(ds):
    return float(ds["lidar_std"].values.ravel()[0])


def truth_and_records(plain, P, seed0, folder, periodic=False):
    """The truth's lidar std per period and the mast's CSV (all periods, one after the other)."""
    from cwlidar_sim.campaign.periods.conical import run_unit
    from cwlidar_sim.campaign.scenes.conical import ConicalPeriodSpec
    from cwlidar_sim.sensors import Sonic, sample_sonic

    T = plain.duration
    fs = U / DX
    n = int(round(T * fs))
    t = np.arange(n) / fs
    truths, vel = [], []
    for p in range(P):
        ss = np.random.SeedSequence([seed0, p]).generate_state(2, np.uint64) >> np.uint64(1)
        boxes = []

        def keep(box):
            boxes.append(box)
            return box

        sc = plain.replace(periods=(ConicalPeriodSpec(name=f"t{p}", mean_speed=U, seed=int(ss[0])),))
        opts = {"period_x": U * T, "spacing": (DX, DX, DX)} if periodic else None
        truths.append(_unit_std(run_unit(sc, 0, condition=keep, box_options=opts)))
        box = boxes[0]
        vel.append(sample_sonic(box, Sonic(position=(0.0, 0.0, HEIGHT), rate=fs, noise_std=NOISE), t, U,
                                seed=int(ss[1])))
        boxes.clear()
        log(f"truth {p + 1}/{P}: lidar std {truths[-1]:.3f} m/s")
    vel = np.concatenate(vel)
    with open(os.path.join(folder, "mast.csv"), "w") as f:
        f.write("time,u,v,w\n")
        for ti, (u, v, w) in zip(np.arange(vel.shape[0]) / fs, vel):
            f.write(f"{ti:.4f},{u:.6f},{v:.6f},{w:.6f}\n")
    return truths


def prior_spread(plain, P, N, seed0):
    """N unconditioned units per period (other seeds): the spread without the mast."""
    from cwlidar_sim.campaign.periods.conical import run_unit
    from cwlidar_sim.campaign.scenes.conical import ConicalPeriodSpec

    out = []
    for p in range(P):
        row = []
        for j in range(N):
            s = int(np.random.SeedSequence([seed0, p, 1 + j]).generate_state(1, np.uint64)[0] >> np.uint64(1))
            row.append(_unit_std(run_unit(plain.replace(periods=(ConicalPeriodSpec(name="q", mean_speed=U,
                                                                                    seed=s),)), 0)))
        out.append(row)
    return out


def summary(rows, N):
    P = len(rows)
    expected = (N - 1) / (N + 1)
    out = {"periods": P, "twins": N, "expected_fraction_inside": expected,
           "fraction_sampling_error": math.sqrt(expected * (1 - expected) / P)}
    for key in ("twin_std", "prior_std"):
        if not all(key in r for r in rows):
            continue
        inside = [min(r[key]) <= r["truth_std"] <= max(r[key]) for r in rows]
        sd = [float(np.std(r[key], ddof=1)) for r in rows]
        z = [(r["truth_std"] - np.mean(r[key])) / np.std(r[key], ddof=1) for r in rows]
        out[key] = {"fraction_inside": float(np.mean(inside)), "mean_spread_m_s": float(np.mean(sd)),
                    "rms_z": float(np.sqrt(np.mean(np.square(z))))}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="4 periods of 300 s, 5 twins, no prior")
    ap.add_argument("--periods", type=int, default=None)
    ap.add_argument("--twins", type=int, default=None)
    ap.add_argument("--duration", type=float, default=None, help="period length [s] (default 600)")
    ap.add_argument("--prior", action="store_true", help="also N unconditioned units per period")
    ap.add_argument("--workers", type=int, default=0, help="run the twins on a local Dask cluster of W processes")
    ap.add_argument("--seed", type=int, default=2019)
    ap.add_argument("--periodic-truth", action="store_true",
                    help="truth boxes periodic over U T exactly (the twin's own model; a diagnostic)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--keep", default=None, metavar="DIR",
                    help="keep the records, scenes and twin files in DIR (a rerun resumes the twins there)")
    a = ap.parse_args(argv)
    P = a.periods or (4 if a.quick else 12)
    N = a.twins or (5 if a.quick else 8)
    T = a.duration or (300.0 if a.quick else 600.0)
    from cwlidar_sim.campaign import read_results
    from cwlidar_sim.campaign.twin.run import run_twin

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        folder = a.keep or tmp
        os.makedirs(folder, exist_ok=True)
        twin, plain = _scenes(folder, T, a.seed)
        truths = truth_and_records(plain, P, a.seed, folder, periodic=a.periodic_truth)
        with open(os.path.join(folder, "truth.json"), "w") as f:
            f.write(str(truths))
        client = None
        if a.workers:
            from dask.distributed import Client, LocalCluster

            client = Client(LocalCluster(n_workers=a.workers, threads_per_worker=1, dashboard_address=None))
        try:
            files = run_twin(twin, os.path.join(folder, "out"), n_twins=N, progress=log, client=client)
        finally:
            if client is not None:
                client.close()
        rows = []
        for p, f in enumerate(files):
            ds = read_results(f)
            rows.append({"period": p, "truth_std": truths[p],
                         "twin_std": [float(x) for x in ds["lidar_std"].values.ravel()],
                         "record_u_std": float(ds["record0_std"]),
                         "twin_cup_std": [float(x) for x in ds["cup_std"].values.ravel()]})
        if a.prior:
            for r, pr in zip(rows, prior_spread(plain, P, N, a.seed)):
                r["prior_std"] = pr
    rep = {"machine": machine(), "periodic_truth": a.periodic_truth, "height_m": HEIGHT, "mean_speed_m_s": U, "spacing_m": DX, "noise_m_s": NOISE,
           "duration_s": T, "wall_s": time.perf_counter() - t0, "summary": summary(rows, N), "rows": rows}
    for r in rows:
        tw = np.array(r["twin_std"])
        log(f"period {r['period']}: truth {r['truth_std']:.3f} m/s, twins {tw.mean():.3f} +- {tw.std(ddof=1):.3f} "
            f"[{tw.min():.3f}, {tw.max():.3f}]")
    log(str(rep["summary"]))
    if a.json:
        write_json(a.json, rep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
