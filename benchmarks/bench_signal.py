"""Throughput of the Doppler tiers as real-time factors (simulated seconds per wall second).

    python benchmarks/bench_signal.py [--quick] [--json PATH]

* tier 2 (spectral): prototype preset (1953 blocks per estimate, 50 Hz), expected
  spectrum of 8 range cells with distinct speeds, speckle draw, threshold and median,
  chunked as ``simulate_uniform`` does;
* tier 3 (signal): the whole 50 MHz stream of 8 range cells with distinct speeds,
  512-point real FFTs, averaging, threshold and median; and its floor measured in
  the same run: batched 512-point float32 real FFTs of the same number of samples
  with pyfftw (through ``cwlidar_sim._fft.rfft_rows``), the ratio reported.
Each figure is the best of a few repeats after a warm-up (compilation excluded).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time

import numpy as np

from cwlidar_sim import _config
from cwlidar_sim._fft import rfft_rows
from cwlidar_sim.signal import PROTOTYPE_2003, estimate, simulate_signal_spectra, speckle_looks
from cwlidar_sim.signal.spectral import _draw_rows, _speckle_draws, expected_spectrum, line_shape_table


def _best(fn, repeats):
    fn()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return min(ts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    inst = PROTOTYPE_2003
    tau = inst.speckle_time(1.0)
    m = inst.blocks_per_estimate
    w = np.full(8, 1 / 8)
    v = np.linspace(9.0, 10.0, 8)
    rep = {"threads": _config.get_num_threads(), "cpu": platform.processor() or platform.machine(),
           "cores": os.cpu_count()}

    # tier 2
    n2 = 50_000 if args.quick else 250_000
    sig, noise = expected_spectrum(inst, v, w, -15.0, correlation_time=tau)
    m_eff = speckle_looks(m, inst.block_duration, tau)
    table = line_shape_table(inst.n_fft, inst.window)

    def tier2():
        key, gain = _speckle_draws(np.random.default_rng(0), n2, inst.n_bins, m_eff, "coherent")
        buf = np.empty((4096, inst.n_bins))
        for e0 in range(0, n2, 4096):
            e1 = min(n2, e0 + 4096)
            _draw_rows(sig, noise, m, gain[e0:e1], key, e0, buf[: e1 - e0])
            estimate(buf[: e1 - e0], inst, line_table=table)

    t2 = _best(tier2, 2 if args.quick else 3)
    rep["tier2"] = {"estimates": n2, "wall_s": t2, "realtime_factor": n2 / inst.estimate_rate / t2,
                    "target": 1e4}

    # tier 3
    n3 = 10 if args.quick else 50
    vv = np.broadcast_to(v, (n3, 8))

    def tier3():
        sp = simulate_signal_spectra(inst, vv, w, -15.0, 1, correlation_time=tau)
        estimate(sp, inst)

    t3 = _best(tier3, 2)
    sim_s = n3 / inst.estimate_rate  # the estimates cover their 50 Hz periods (99.98 % of the stream)
    x = np.random.default_rng(0).standard_normal((n3 * m, inst.n_fft)).astype(np.float32)
    out = np.empty((n3 * m, inst.n_bins), dtype=np.complex64)
    tf = _best(lambda: rfft_rows(x, out=out), 3)
    rep["tier3"] = {"estimates": n3, "samples": n3 * m * inst.n_fft, "wall_s": t3,
                    "realtime_factor": sim_s / t3, "target": 1.0,
                    "fft_floor_realtime_factor": sim_s / tf, "ratio_to_floor": t3 / tf}
    print(json.dumps(rep, indent=2))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rep, f, indent=2)


if __name__ == "__main__":
    main()
