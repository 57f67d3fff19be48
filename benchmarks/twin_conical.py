"""The conical lidar's 10-minute std predicted from a mast at the circle's centre: does the twins' spread hold the truth?

Usage::

    python benchmarks/twin_conical.py [--quick] [--periods P] [--twins N] [--json PATH]

Per period: a truth box (periodic along x with length exactly U T, so that the mast's record
covers one whole line, as the twin assumes), a sonic on a mast at the circle's centre (0, 0,
40 m) sampling it (one sample per node, 0.05 m/s of white noise), and N twins conditioned on that
record alone (:func:`cwlidar_sim.turbulence.conditioning.condition_field`).  The conical lidar
(CS's geometry: 30 deg half-angle, 1-s revolutions, 50 estimates per revolution, tier 'los') flies
through the truth and through every twin with the package's sensor code
(:func:`cwlidar_sim.sensors.conical.measure_conical`); the VAD fits
(:func:`cwlidar_sim.analysis.vad.fit_record`, 1-s scans) give each one's 10-minute std of the
horizontal speed.

If the twins are draws from the conditional distribution the truth is drawn from, the truth's
rank among its N twins is uniform on 0..N, so it lies between the twins' smallest and largest
value in a fraction (N - 1) / (N + 1) of periods (binomial sampling error over P periods).  The
same is reported for N unconditioned boxes (the prior spread), to show what the mast removes.
No assumption of Gaussian spread enters the check.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _protocol import log, machine, write_json  # noqa: E402

HEIGHT, U, DX, NOISE = 40.0, 10.0, 2.0, 0.05


def _setup(T):
    from cwlidar_sim.sensors.conical import ConicalLidar
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    params = surface_layer_parameters(HEIGHT, U)[0]
    lidar = ConicalLidar(heights=(HEIGHT,), tier="los")
    nx = int(round(U * T / DX))
    # lateral and vertical: the circle (radius z tan 30 deg = 23 m) plus two length scales
    ny = nz = int(2 ** math.ceil(math.log2((2 * HEIGHT * math.tan(math.radians(30.0)) + 2 * params.length_scale) / DX)))
    return params, lidar, (nx, ny, nz)


def _box(params, shape, seed):
    from cwlidar_sim.turbulence import generate_box

    b = generate_box(params, shape, (DX,) * 3, seed)
    nx, ny, nz = shape
    # lidar at the origin on the ground; the box centred on the circle laterally and on the mast height
    return b.assign_coords(x=-30.0 + np.arange(nx) * DX, y=(np.arange(ny) - 0.5 * (ny - 1)) * DX,
                           z=HEIGHT + (np.arange(nz) - 0.5 * (nz - 1)) * DX)


def _lidar_std(field, lidar, T):
    from cwlidar_sim.analysis.vad import fit_record, period_statistics
    from cwlidar_sim.sensors.conical import measure_conical

    rec = measure_conical(field, lidar, T, U)
    fit = fit_record(rec, HEIGHT, 1, half_angle_deg=lidar.half_angle_deg, reference_deg=np.array([0.0]))
    return float(period_statistics(fit)["std_speed"])


def run(P, N, T, seed0=2019, on_period=None):
    from cwlidar_sim.sensors import Sonic, sample_sonic
    from cwlidar_sim.turbulence.conditioning import LineRecord, condition_field

    params, lidar, shape = _setup(T)
    fs = U / DX
    t = np.arange(shape[0]) / fs
    rows = []
    t0 = time.perf_counter()
    for p in range(P):
        ss = np.random.SeedSequence([seed0, p]).generate_state(3, np.uint64) >> np.uint64(1)
        truth = _box(params, shape, int(ss[0]))
        vel = sample_sonic(truth, Sonic(position=(0.0, 0.0, HEIGHT), rate=fs, noise_std=NOISE), t, U, seed=int(ss[1]))
        rec = LineRecord((0.0, 0.0, HEIGHT), fs, {c: vel[:, i] for i, c in enumerate("uvw")}, noise_std=NOISE,
                         name="mast40")
        s_truth = _lidar_std(truth, lidar, T)
        del truth
        twins, prior = [], []
        for j in range(N):
            sj = int(ss[2]) + 1000 * j + 1
            box = _box(params, shape, sj)
            prior.append(_lidar_std(box, lidar, T))
            twins.append(_lidar_std(condition_field(box, rec, seed=sj, U=U, params=params, inplace=True), lidar, T))
            del box
        rows.append({"period": p, "truth_std": s_truth, "twin_std": twins, "prior_std": prior,
                     "record_u_std": float(np.std(vel[:, 0]))})
        if on_period is not None:
            on_period(params, shape, rows)  # what is finished is kept (the report so far)
        tw = np.array(twins)
        log(f"period {p + 1}/{P}: truth {s_truth:.3f} m/s, twins {tw.mean():.3f} +- {tw.std(ddof=1):.3f} "
            f"[{tw.min():.3f}, {tw.max():.3f}], prior spread {np.std(prior, ddof=1):.3f} "
            f"({time.perf_counter() - t0:.0f} s)")
    return params, shape, rows


def summary(rows, N):
    P = len(rows)
    expected = (N - 1) / (N + 1)
    out = {"periods": P, "twins": N, "expected_fraction_inside": expected,
           "fraction_sampling_error": math.sqrt(expected * (1 - expected) / P)}
    for key in ("twin_std", "prior_std"):
        inside = [min(r[key]) <= r["truth_std"] <= max(r[key]) for r in rows]
        sd = [float(np.std(r[key], ddof=1)) for r in rows]
        z = [(r["truth_std"] - np.mean(r[key])) / np.std(r[key], ddof=1) for r in rows]
        out[key] = {"fraction_inside": float(np.mean(inside)), "mean_spread_m_s": float(np.mean(sd)),
                    "rms_z": float(np.sqrt(np.mean(np.square(z))))}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="6 periods of 300 s, 5 twins")
    ap.add_argument("--periods", type=int, default=None)
    ap.add_argument("--twins", type=int, default=None)
    ap.add_argument("--duration", type=float, default=None, help="period length [s] (default 600)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    P = a.periods or (6 if a.quick else 30)
    N = a.twins or (5 if a.quick else 8)
    T = a.duration or (300.0 if a.quick else 600.0)
    def report(params, shape, rows):
        rep = {"machine": machine(), "height_m": HEIGHT, "mean_speed_m_s": U, "spacing_m": DX, "noise_m_s": NOISE,
               "duration_s": T, "box_shape": shape, "params": params.as_dict(), "summary": summary(rows, N),
               "rows": rows, "complete": len(rows) == P}
        if a.json:
            write_json(a.json, rep)
        return rep

    rep = report(*run(P, N, T, on_period=report))
    log(str(rep["summary"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
