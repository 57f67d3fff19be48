"""Simulated REWS-lidar coherence of the bundled nacelle scene against the analytic one, with its sampling error.

    python studies/nacelle_coherence.py [--periods 12] [--chain-periods 3] [--beams 16] [--json PATH]

Frozen turbulence, the bundled scene's lidar (15 deg circular scan, 50 estimates per
revolution, focus 50, 100, 150 m, CS optics, span 5 z_R with the mean-wind tail) and
rotor (R = 60 m), at 12 m/s; ``--periods`` periods of 620 s, each its own seed.

Simulation (tier 1, the chain's ideal weighted line-of-sight averages): the REWS and the
lidar's revolution-averaged estimate paired as the campaign pairs them
(:func:`cwlidar_sim.campaign.periods.nacelle.run_unit`: preview r cos a / U less (T_rev - dt) / 2);
Hann segments (the scene's 60 s, and 600 s), the segment spectra pooled over all periods,
averaged in the scene's 12 log bins, then the coherence.

Theory, computed the way the estimate is made: the analytic spectra
(:func:`cwlidar_sim.analysis.rews_theory.rews_spectra`: continuous Mann tensor, ``--beams``
point beams over the revolution with their delays (16: within 0.0001 rad/m of 50 in k at 0.5;
the bundled scene's 8 put it 0.0010-0.0012 rad/m low at 150 m), the same preview pairing) on a log grid of
36 wavenumbers, then :func:`cwlidar_sim.analysis.rews_theory.estimated_spectra` (each
ordinate's Hann kernel with the mean removed, the same bins): "exact" with the full cw
weighting; "box_exact" the sum over the generated box's lateral modes with the REWS's grid
nodes (what the box can hold), also with 8 and 50 beams; "box_cells" that with the simulated
probe volume (the span's sub-points; the tail beyond it sees the mean wind, i.e. nothing).
Beside it the coherence of the spectra at the bin
centres (what the campaign reported before: no leakage, no bin averaging).

Sampling error: Fisher's z of the estimate with the effective number of averages
(:func:`cwlidar_sim.analysis.rews.effective_averages`: segments times the bin's ordinates,
less for the Hann taper's correlated neighbours): the 95 % interval of the estimate about
the theory, ``tanh^2(atanh(sqrt(c)) + 1/(2(n-1)) +- 1.96 / sqrt(2(n-1)))``; reported: per bin
the z-score, the fraction of bins (theory above 0.02) inside, and k at coherence 0.5 with
the interval where the estimate's Fisher bounds cross 0.5.

The chain (``--chain-periods`` of the same periods, paired): tier 2 (the scene's spectral
tier, CNR -5 dB) with the centroid, median and peak estimators on the same spectra, against
tier 1 on the same records.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import machine, write_json  # noqa: E402

K_GRID = np.geomspace(1.5e-4, 0.6, 36)  # rad/m: below the first ordinate of 600 s to past the last bin + Hann reach
SEGMENTS = (60.0, 600.0)
BEAM_KNOB = (8, 50)  # point beams of the box-discrete theory beside --beams
Z95 = 1.959963984540054


def _cells_weighting(lid, r):
    from cwlidar_sim.beam import RangeCells

    c = lid.cells(r)
    w = np.repeat(c.weight_s, np.diff(c.ptr_s)) * c.fraction_j
    return RangeCells(s_s=c.sub_j, weight_s=w, edges=c.edges, kept_fraction=c.kept_fraction,
                      truncated_fraction=c.truncated_fraction, renormalised=False, weighting=c.weighting,
                      rayleigh_length=c.rayleigh_length)


def _box_modes(scene, period, U):
    """The (k2, k3) modes of the period's generated box and the REWS's grid nodes relative to the hub."""
    from cwlidar_sim.analysis.rews import RotorDisc, rotor_node_weights
    from cwlidar_sim.turbulence.cover import plan_box

    s = scene.scan
    nx, ny, nz = plan_box(scene.sensor(period).box_region(s.spacing, s.rotor_radius), U,
                          scene.period_duration(period), s.spacing,
                          min_extent=2.0 * scene.turbulence.length_scale).shape
    d = s.spacing
    yc = (np.arange(ny) - 0.5 * (ny - 1)) * d
    zc = (np.arange(nz) - 0.5 * (nz - 1)) * d
    w = rotor_node_weights(RotorDisc(s.rotor_radius, s.rotor_exponent), yc, zc, 0.0, 0.0)
    iy, iz = np.nonzero(w)
    shape = (nx, 2 * ny if s.lateral_doubling else ny, nz)
    return (shape, (d, d, d)), (yc[iy], zc[iz], w[iy, iz])


def _predicted_interval(c, n):
    s = 1.0 / np.sqrt(2.0 * (n - 1.0))
    z = np.arctanh(np.sqrt(np.clip(c, 0.0, 1.0 - 1e-12)))
    return np.tanh(np.maximum(z + s * s - Z95 * s, 0.0)) ** 2, np.tanh(z + s * s + Z95 * s) ** 2


def _z_score(chat, c, n):
    s = 1.0 / np.sqrt(2.0 * (n - 1.0))
    return (np.arctanh(np.sqrt(np.clip(chat, 0.0, 1.0 - 1e-12))) - s * s
            - np.arctanh(np.sqrt(np.clip(c, 0.0, 1.0 - 1e-12)))) / s


def _k_half(k, g):
    from cwlidar_sim.analysis.rews import coherence_bandwidth

    good = np.isfinite(g)
    return coherence_bandwidth(k[good], g[good]) if good.sum() >= 2 else math.nan


class _Pool:
    """Segment spectra summed over periods, per (focus, kind, segment length)."""

    def __init__(self):
        self.acc = {}

    def add(self, key, rews_t, u_e, lid, U, seg, edges):
        from cwlidar_sim.analysis.rews import align_preview
        from cwlidar_sim.analysis.spectra import bin_average, segment_spectra
        from cwlidar_sim.campaign.periods.nacelle import _trailing_nanmean

        dt = lid.dwell_time
        shift = max(lid.preview_distance(lid.focus_distances[0]) / U - 0.5 * (lid.revolution_time - dt), 0.0)
        lid_t = _trailing_nanmean(u_e, lid.estimates_per_rev)
        ok = slice(lid.estimates_per_rev - 1, None)
        R, L, _ = align_preview(rews_t[ok], lid_t[ok], dt, shift)
        ss = segment_spectra(R, L, fs=1.0 / dt, segment_duration=seg, window="hann")
        f_edges = U * edges / (2 * math.pi)
        parts = []
        for v in (ss.psd_xf, ss.psd_yf, ss.csd_f):
            m, cnt = bin_average(ss.f_f, v, f_edges)
            parts.append(np.nan_to_num(m) * ss.n_segments)
        a = self.acc.setdefault(key, {"rr": 0.0, "ll": 0.0, "rl": 0.0, "n_seg": 0, "count": cnt, "n_per": ss.n_per})
        a["rr"] = a["rr"] + parts[0]
        a["ll"] = a["ll"] + parts[1]
        a["rl"] = a["rl"] + parts[2]
        a["n_seg"] += ss.n_segments

    def coherence(self, key):
        from cwlidar_sim.analysis.rews import effective_averages

        a = self.acc[key]
        keep = a["count"] > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.abs(a["rl"]) ** 2 / (a["rr"] * a["ll"])
        n = effective_averages(a["count"], a["n_per"], "hann") * a["n_seg"]
        return np.where(keep, g, np.nan), n, a["n_seg"]


def run(n_periods, chain_periods, threads, n_beams):
    from cwlidar_sim import _config
    from cwlidar_sim.analysis.rews import RotorDisc, coherence_interval
    from cwlidar_sim.analysis.rews_theory import circular_scan, estimated_spectra, rews_spectra
    from cwlidar_sim.campaign import bundled_scene
    from cwlidar_sim.campaign.periods import nacelle as N
    from cwlidar_sim.campaign.scenes.nacelle import NacellePeriodSpec

    _config.set_num_threads(threads)
    base = bundled_scene("nacelle")
    U = 12.0
    periods = tuple(NacellePeriodSpec(name=f"frozen{i}", mean_speed=U, seed=2000 + i) for i in range(n_periods))
    scene1 = base.replace(duration=620.0, periods=periods,
                          lidar=dataclasses.replace(base.lidar, tier="los", variants=()))
    scene2 = base.replace(duration=620.0, periods=periods)  # the bundled chain: tier 2, centroid + median, peak
    s = scene1.scan
    edges = s.k_edges()
    kc = np.sqrt(edges[:-1] * edges[1:])
    pool = _Pool()
    timing = {"tier1_s": 0.0, "tier2_s": 0.0, "theory_s": 0.0}
    kinds2 = ["main"] + [v["name"] for v in scene2.lidar.variants]
    for ip in range(n_periods):
        t0 = time.perf_counter()
        rews, _, recs, _ = N.period_records(scene1, ip)
        for r in s.focus_distances:
            lid = scene1.sensor(periods[ip], (r,))
            u = N._u_series(recs[r], "tier1")
            for seg in SEGMENTS:
                pool.add((r, "tier1", seg), rews, u, lid, U, seg, edges)
            if ip < chain_periods:
                pool.add((r, "tier1_chain_periods", 60.0), rews, u, lid, U, 60.0, edges)
        timing["tier1_s"] += time.perf_counter() - t0
        if ip < chain_periods:
            t0 = time.perf_counter()
            rews2, _, recs2, _ = N.period_records(scene2, ip)
            for r in s.focus_distances:
                lid = scene2.sensor(periods[ip], (r,))
                for kind in kinds2:
                    pool.add((r, kind, 60.0), rews2, N._u_series(recs2[r], kind), lid, U, 60.0, edges)
            timing["tier2_s"] += time.perf_counter() - t0
        print(f"period {ip + 1}/{n_periods}: {timing}", file=sys.stderr, flush=True)

    out = {"k_bin_centre": kc.tolist(), "k_edges": edges.tolist(), "focus": {}}
    for r in s.focus_distances:
        lid = scene1.sensor(periods[0], (r,))
        opt = lid.instrument_at(r).optics()
        beams = circular_scan(n_beams, lid.half_angle_deg, r, revolution_time=lid.revolution_time,
                              azimuth0_deg=lid.azimuth0_deg)
        shift = lid.preview_distance(r) / U - float(beams.delay_pb.mean())
        t0 = time.perf_counter()
        th = {"exact": rews_spectra(K_GRID, scene1.turbulence.params(), RotorDisc(s.rotor_radius), beams, U,
                                    weighting="exact", resolution=30.0, preview_shift=shift,
                                    wavelength=opt.wavelength, radius=opt.radius)}
        grid, nodes = _box_modes(scene1, periods[0], U)
        for name, w in (("box_exact", "exact"), ("box_cells", _cells_weighting(lid, r))):
            th[name] = rews_spectra(K_GRID, scene1.turbulence.params(), nodes, beams, U, weighting=w,
                                    preview_shift=shift, box_grid=grid, wavelength=opt.wavelength, radius=opt.radius)
        for nb in BEAM_KNOB:  # the number of point beams, box-discrete (cheap)
            bk = circular_scan(nb, lid.half_angle_deg, r, revolution_time=lid.revolution_time,
                               azimuth0_deg=lid.azimuth0_deg)
            th[f"box_exact_{nb}_beams"] = rews_spectra(
                K_GRID, scene1.turbulence.params(), nodes, bk, U, weighting="exact",
                preview_shift=lid.preview_distance(r) / U - float(bk.delay_pb.mean()), box_grid=grid,
                wavelength=opt.wavelength, radius=opt.radius)
        point = rews_spectra(kc, scene1.turbulence.params(), RotorDisc(s.rotor_radius), beams, U, weighting="exact",
                             resolution=30.0, preview_shift=shift, wavelength=opt.wavelength,
                             radius=opt.radius).coherence_k
        timing["theory_s"] += time.perf_counter() - t0
        fo = {"theory_at_bin_centres": point.round(5).tolist(), "k_half_theory_at_bin_centres": _k_half(kc, point)}
        for seg in SEGMENTS:
            g, n, n_seg = pool.coherence((r, "tier1", seg))
            kb = kc[np.isfinite(g)]
            gs = g[np.isfinite(g)]
            ns = n[np.isfinite(g)]
            lo, hi = coherence_interval(gs, ns)
            row = {"k": kb.round(5).tolist(), "simulated": gs.round(4).tolist(), "n_segments": int(n_seg),
                   "n_effective": ns.round(1).tolist(), "k_half_simulated": _k_half(kb, gs),
                   "k_half_interval": [_k_half(kb, lo), _k_half(kb, hi)]}
            for name, sp in th.items():
                e = estimated_spectra(sp, U, fs=1.0 / lid.dwell_time, segment_duration=seg, window="hann",
                                      f_edges=U * edges / (2 * math.pi))
                c = e.coherence_k
                plo, phi = _predicted_interval(c, ns)
                z = _z_score(gs, c, ns)
                use = c > 0.02
                row[f"theory_{name}"] = c.round(4).tolist()
                row[f"theory_{name}_interval95"] = [plo.round(4).tolist(), phi.round(4).tolist()]
                row[f"z_{name}"] = z.round(2).tolist()
                row[f"inside95_{name}"] = f"{int(np.sum(use & (np.abs(z) <= Z95)))}/{int(use.sum())}"
                row[f"k_half_theory_{name}"] = _k_half(kb, c)
            fo[f"segment_{seg:g}s"] = row
        chain = {}
        g1, n1, _ = pool.coherence((r, "tier1_chain_periods", 60.0))
        for kind in kinds2:
            g, n, _ = pool.coherence((r, kind, 60.0))
            ok = np.isfinite(g)
            chain[kind] = {"coherence": g[ok].round(4).tolist(), "minus_tier1": (g - g1)[ok].round(4).tolist(),
                           "k_half": _k_half(kc[ok], g[ok])}
        chain["tier1"] = {"coherence": g1[np.isfinite(g1)].round(4).tolist(),
                          "k_half": _k_half(kc[np.isfinite(g1)], g1[np.isfinite(g1)])}
        fo["chain_segment_60s"] = chain
        out["focus"][f"{r:g}"] = fo
    out["timing"] = timing
    main = scene2.sensor(periods[0])
    out["names"] = {"main": f"tier 2 ({main.tier}), estimator {main.instrument.estimator}",
                    **{v["name"]: f"tier 2, estimator {v['estimator']}" for v in scene2.lidar.variants}}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=12)
    ap.add_argument("--chain-periods", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--beams", type=int, default=16, help="point beams of the theory (8 in the bundled scene)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    t = time.perf_counter()
    r = run(a.periods, min(a.chain_periods, a.periods), a.threads, a.beams)
    r.update(wall_s=time.perf_counter() - t, beams=a.beams, periods=a.periods, chain_periods=a.chain_periods, threads=a.threads,
             machine=machine())
    for f, fo in r["focus"].items():
        for seg in SEGMENTS:
            row = fo[f"segment_{seg:g}s"]
            print(f"focus {f} m, {seg:g}-s segments ({row['n_segments']}): k0.5 simulated {row['k_half_simulated']:.4f} "
                  f"[{row['k_half_interval'][0]:.4f}, {row['k_half_interval'][1]:.4f}], theory as estimated "
                  f"{row['k_half_theory_exact']:.4f} (exact), {row['k_half_theory_box_cells']:.4f} (box, cells); at bin "
                  f"centres {fo['k_half_theory_at_bin_centres']:.4f}; inside 95 %: {row['inside95_exact']} (exact), "
                  f"{row['inside95_box_exact']} (box), {row['inside95_box_cells']} (box, cells)")
        print("   chain k0.5:", {k: round(v["k_half"], 4) for k, v in fo["chain_segment_60s"].items()})
    print(f"wall {r['wall_s']:.0f} s")
    if a.json:
        write_json(a.json, r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
