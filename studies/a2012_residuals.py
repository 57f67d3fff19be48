"""A2012's open residuals as hypotheses tested with the simulator (docs/estimator_theory.md, "Findings").

    python studies/a2012_residuals.py aperture [--lines 4] [--truncations inf 1.5 1.37 1.3] [--json PATH]
    python studies/a2012_residuals.py floor [--estimates 4000] [--seed 7] [--json PATH]

``aperture``: the median's method 2 (estimator theory, A2012's scene: focus 67.5 m, the bundled scene's
Mann parameters, U = 8.1 m/s, CNR -10 dB, 4 lines) with the probe cells weighted by the truncated-aperture
beam (:mod:`cwlidar_sim.beam.aperture`, truncation ratio T = R / a0) instead of the untruncated Gaussian,
as T2 / exp(-2 k 5.61 m) at 0.28 and 0.56 rad/m (the table of studies/candidates_a2012.py).  The cells are
the theory's own (same edges and sub-points); only their weights change, each the integral of the
aperture weighting over the cell (Simpson, 8 panels), the weight beyond the span going to the mean-wind
tail as usual.  This swaps a private helper of the theory for the run (a tool, not a package option).

``floor``: method 1's high-k floor is white estimator noise: F_n(k) = sigma_n^2 dx_e / pi (one-sided,
dx_e = U / f_e the distance between estimates) over the sonic's F_u(k).  The error of the estimates about
the noise-free line-of-sight speed is measured with the staring lidar (tier 'spectral', median, continuum
speckle) on a Mann line of A2012's scene, for the default instrument and for each candidate that raises
uncorrelated noise: fewer spectra per estimate than the 50 MHz stream allows (``blocks_per_estimate`` at the
same 50 Hz), lower CNR (excess receiver noise is a CNR loss by the excess factor).  Reported: its std
sigma_n, the floor its own spectrum gives at 0.8 and 2.2 rad/m (what method 1 sees), the floor it would give
were it white (sigma_n^2 dx_e / 2 pi: most of sigma_n is not white), and the white sigma_n that A2012's ~4 %
near 0.8 rad/m needs.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import pathlib
import time

import numpy as np

SCENE = dict(alpha_eps=0.06224407174474577, length_scale=18.76, gamma=3.9)
U = 8.1


def _aperture_cells(truncation, base):
    """The theory's cell builder ``base`` with the cells' weights from the truncated aperture."""
    from cwlidar_sim.beam.aperture import TruncatedAperture, weight_aperture

    def cells(instrument, weighting="exact", span=20.0, cell_length=0.5, *, growth=0.0, tail="mean_wind"):
        c = base(instrument, weighting, span, cell_length, growth=growth, tail=tail)
        if math.isinf(truncation):
            return c
        opt, ap = instrument.optics(), TruncatedAperture(truncation=truncation)
        e = c.edges
        t = np.linspace(0.0, 1.0, 17)
        s = e[:-1, None] + (e[1:] - e[:-1])[:, None] * t[None, :]
        phi = weight_aperture(s.ravel(), opt, ap).reshape(s.shape)
        simpson = np.array([1.0] + [4.0, 2.0] * 7 + [4.0, 1.0]) / 48.0
        w = (phi @ simpson) * (e[1:] - e[:-1])
        if c.sub_j.size != c.n_cells:
            raise SystemExit("aperture cells: sub-points per cell are not supported (use growth=0, cell = dx)")
        kept = float(w.sum())
        return dataclasses.replace(c, weight_s=w, kept_fraction=kept, truncated_fraction=max(0.0, 1 - kept),
                                   tail_weight=max(0.0, 1 - kept) if tail == "mean_wind" else 0.0)

    return cells


def aperture(a):
    from cwlidar_sim.analysis import estimator_theory as et
    from cwlidar_sim.analysis import estimator_transfer, log_bins
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.turbulence import MannParameters

    p = MannParameters(**SCENE)
    inst = PROTOTYPE_2003.replace(focus=67.5)
    edges = log_bins(0.2, 0.8, 10)
    k = np.sqrt(edges[:-1] * edges[1:])
    i28, i56 = int(np.argmin(abs(k - 0.28))), int(np.argmin(abs(k - 0.56)))
    zR = inst.rayleigh_length
    rows = []
    orig = et._line_cells
    cases = [("T", float(t), inst) for t in a.truncations] + [("a0 = 17 mm", math.inf,
                                                               inst.replace(telescope_radius=0.017))]
    try:
        for name, T, ins in cases:
            et._line_cells = _aperture_cells(T, orig)
            t0 = time.perf_counter()
            r = estimator_transfer(ins, p, U, estimators=("median",), k_edges=edges, n_lines=a.lines)
            ref = np.exp(-2 * k * zR)
            row = {"case": name if name != "T" else f"T = {T:g}", "truncation": T,
                   "T2_over_exp_028": float(r.transfer_cross_ek[0][i28] / ref[i28]),
                   "T2_over_exp_056": float(r.transfer_cross_ek[0][i56] / ref[i56]),
                   "zR_eff": float(r.zR_eff_e[0]), "wall_s": time.perf_counter() - t0}
            rows.append(row)
            print(json.dumps(row), flush=True)
    finally:
        et._line_cells = orig
    return rows


def floor(a):
    from cwlidar_sim.sensors import StaringLidar, measure_staring
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.turbulence import MannParameters, generate_line, one_point_spectra

    p = MannParameters(**SCENE)
    inst = PROTOTYPE_2003.replace(focus=67.5)
    n_e = a.estimates
    dx = 0.25
    n = 1 << int(math.ceil(math.log2(U * n_e / inst.estimate_rate / dx + 400)))
    fld = generate_line(p, n, dx, a.seed)
    t = np.arange(n_e) / inst.estimate_rate
    k = np.array([0.8, 2.2])
    Fu = one_point_spectra(k, p)[0]                   # one-sided [m^3/s^2]
    dxe = U / inst.estimate_rate
    cases = [("default (1953 blocks, CNR -10 dB)", {}, {}),
             ("390 blocks (20 % of the stream)", {"blocks_per_estimate": 390}, {}),
             ("98 blocks (5 %)", {"blocks_per_estimate": 98}, {}),
             ("20 blocks (1 %)", {"blocks_per_estimate": 20}, {}),
             ("10 blocks (0.5 %)", {"blocks_per_estimate": 10}, {}),
             ("5 blocks (0.25 %)", {"blocks_per_estimate": 5}, {}),
             ("CNR -15 dB", {}, {"cnr_db": -15.0}),
             ("CNR -20 dB", {}, {"cnr_db": -20.0}),
             ("CNR -22 dB", {}, {"cnr_db": -22.0}),
             ("CNR -24 dB", {}, {"cnr_db": -24.0})]
    rows = []
    for name, ikw, lkw in cases:
        lid = StaringLidar(instrument=inst.replace(**ikw), cell_length=dx, **lkw)
        t0 = time.perf_counter()
        rec = measure_staring(fld, lid, t, U, a.seed + 4)
        ok = np.isfinite(rec.speed_e)
        err = rec.speed_e - rec.vlos_e
        sn = float(np.std(err[ok]))
        # the error's own spectrum (failed estimates replaced by the mean error, as the analysis does),
        # one-sided: P(k) = dx_e |sum e_j exp(-i k x_j)|^2 / (pi N), averaged over +-12 % around each k
        e = np.where(ok, err, np.nanmean(err[ok]) if ok.any() else 0.0)
        e = e - e.mean()
        P = dxe * np.abs(np.fft.rfft(e)) ** 2 / (math.pi * e.size)
        kk = 2 * math.pi * np.fft.rfftfreq(e.size, dxe)
        Fe = [float(P[(kk > 0.88 * q) & (kk < 1.12 * q)].mean()) for q in k]
        Fn = sn * sn * dxe / math.pi
        row = {"case": name, "sigma_n": sn, "availability": float(ok.mean()),
               "floor_08": Fe[0] / float(Fu[0]), "floor_22": Fe[1] / float(Fu[1]),
               "white_floor_08": float(Fn / Fu[0]), "white_floor_22": float(Fn / Fu[1]),
               "wall_s": time.perf_counter() - t0}
        rows.append(row)
        print(json.dumps(row), flush=True)
    need = math.sqrt(0.04 * Fu[0] * math.pi / dxe)
    rows.append({"case": "sigma_n for a 4 % floor at 0.8 rad/m", "sigma_n": need, "F_u_08": float(Fu[0]),
                 "F_u_22": float(Fu[1]), "dx_e": dxe})
    print(json.dumps(rows[-1]))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    a1 = sub.add_parser("aperture")
    a1.add_argument("--lines", type=int, default=4)
    a1.add_argument("--truncations", type=float, nargs="*", default=[math.inf, 1.5, 1.37, 1.3, 1.25, 1.2])
    a2 = sub.add_parser("floor")
    a2.add_argument("--estimates", type=int, default=4000)
    a2.add_argument("--seed", type=int, default=7, help="seed of the Mann line (the lidar's: seed + 4)")
    for x in (a1, a2):
        x.add_argument("--json")
    a = ap.parse_args(argv)
    rows = aperture(a) if a.what == "aperture" else floor(a)
    path = pathlib.Path(a.json or f"results/a2012_residuals_{a.what}.json")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(rows, indent=1))
    tmp.replace(path)


if __name__ == "__main__":
    main()
