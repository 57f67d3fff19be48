"""Scan radius of a single-beam circular scan ahead of a 15 MW rotor: where the REWS coherence bandwidth peaks.

    python studies/guo_radius_sweep.py --seeds 8 --beams 12 --context --json docs/guo_radius_sweep.json --figure docs/guo_radius_sweep.png
    python studies/guo_radius_sweep.py --from-json docs/guo_radius_sweep.json --figure docs/guo_radius_sweep.png

Published number (issue 31): Fu, Guo, Schlipf & Pena (2023, Wind Energ. Sci. 8, 1893-1907,
"Feedforward pitch control for a 15 MW wind turbine using a spinner-mounted single-beam
lidar"; the issue calls it Guo et al.) optimise the focus distance and cone angle of a
spinner-mounted single-beam lidar (cw and pulsed) on the IEA 15 MW rotor with a REWS
coherence model and 4-D Mann fields with evolution, and find the optimum at a scan radius of
0.6 R.  Only the paper's abstract could be read here; every other setting below is assumed
(docs/reproductions/guo2023.md lists them).

Set-up (assumed unless said): rotor R = 120 m, uniform disc weight (the REWS of
:class:`cwlidar_sim.analysis.rews.RotorDisc`); the lidar on the rotor axis in the rotor
plane, one beam turning with the rotor at 7.56 rpm (rated; one revolution 7.94 s), 50
estimates per revolution, the REWS estimate the trailing revolution's mean of
``los / n_x``; the cw optics of the package's CS preset; mean wind U = 15 m/s; Mann
``L = 33.6 m``, ``Gamma = 3.9`` (IEC above 60 m; ``alpha_eps`` only scales the spectra);
eddy-lifetime evolution ``T = 15 s`` (:class:`cwlidar_sim.turbulence.evolution.EddyLifetimeEvolution`).
The scan radius r is swept at a fixed upwind distance x = ``--x`` (120 m): cone half-angle
``atan(r / x)``, focus distance ``sqrt(x^2 + r^2)``.

Theory (:func:`cwlidar_sim.analysis.rews_theory.rews_spectra`, continuous tensor, full cw
weighting, ``BEAMS`` point beams over the revolution with their delays, paired like the
simulation: preview ``x / U`` less the beams' mean delay): k at coherence 0.5 of the spectra
themselves on a fine log grid, per radius, frozen and evolving; the optimum by a parabola
through the points within 0.15 R of the grid's best (evolving: the 9 radii of the sweep and
0.55, 0.65); its quadrature error at 0.6 R by ``resolution`` 60 against 30 and 4 more beams;
with ``--context`` the same sweep at x = 60 and 240 m (evolving).

Simulation (tier ``los``, the chain's ideal line-of-sight average, the same lidar and rotor as
nacelle scenes built in code): per seed one box (frozen) and one evolving pair of planes (the
rotor's and x's) of ``--duration`` s, shared by all radii, so the radii are compared on the
same air; REWS from the box (:func:`cwlidar_sim.analysis.rews.rews_from_box`), each radius's
record (:func:`cwlidar_sim.sensors.measure_nacelle`), paired as the campaign pairs them
(preview less ``(T_rev - dt) / 2``); Hann segments of ``--segment`` s, every ordinate its
own bin; the coherence from the periodograms pooled over all segments; k at 0.5 by
:func:`cwlidar_sim.analysis.rews.coherence_bandwidth`.  Against it the theory *as the
estimate sees it* (:func:`cwlidar_sim.analysis.rews_theory.estimated_spectra`, the same
segments and ordinates).  Uncertainty: a bootstrap over segments (paired across radii:
every radius resamples the same segments) of each k at 0.5 and of the optimum (the same
parabola through the best grid radius and its neighbours).

Sizes: the committed JSON is ``--seeds 3 --beams 8 --duration 1520 --segment 300`` (15
segments per radius and turbulence; about 15 min on the shared 2-core machine at load ~7); the
full size is ``--seeds 8 --beams 12 --context`` (40 segments, about an hour there).  ``--quick`` (2 seeds,
theory on fewer points) is a smoke run of a few minutes.
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
from _protocol import machine, write_json  # noqa: E402

R = 120.0  # IEA 15 MW rotor radius [m]
HUB = 150.0  # hub height [m] (enters only through the assumed IEC length scale, constant above 60 m)
U = 15.0  # above-rated mean wind [m/s] (assumed)
RPM = 7.56  # IEA 15 MW rated rotor speed [rpm]: the spinner beam's revolution
T_REV = 60.0 / RPM
EST_PER_REV = 50
LIFETIME = 15.0  # eddy-lifetime scale [s] (assumed)
MANN = dict(alpha_eps=0.1, length_scale=33.6, gamma=3.9)
RADII = np.round(np.linspace(0.2, 1.0, 9), 3)
EXTRA = np.array([0.55, 0.65])  # evolving: the optimum's neighbourhood
BEAMS = 12
K_GRID = np.geomspace(6e-4, 0.05, 30)  # rad/m: the crossings lie at 0.002-0.02
SPACING = 8.0
BOOT = 1000


def _params():
    from cwlidar_sim.turbulence import MannParameters

    return MannParameters(**MANN)


def _beams(rr, x, n=BEAMS):
    from cwlidar_sim.analysis.rews_theory import circular_scan

    r = rr * R
    return circular_scan(n, math.degrees(math.atan2(r, x)), math.hypot(x, r), revolution_time=T_REV)


_CACHE = {}


def theory_spectra(rr, x, *, evolving, n_beams=BEAMS, resolution=30.0, k=K_GRID, lifetime=LIFETIME):
    """Analytic REWS-lidar spectra for scan radius ``rr`` R at upwind distance ``x`` [m] (cached)."""
    key = (round(float(rr), 6), float(x), bool(evolving), n_beams, resolution, lifetime, k is K_GRID)
    if key not in _CACHE:
        _CACHE[key] = _theory_spectra(rr, x, evolving=evolving, n_beams=n_beams, resolution=resolution, k=k,
                                      lifetime=lifetime)
    return _CACHE[key]


def _theory_spectra(rr, x, *, evolving, n_beams, resolution, k, lifetime):
    from cwlidar_sim.analysis.rews import RotorDisc
    from cwlidar_sim.analysis.rews_theory import rews_spectra
    from cwlidar_sim.turbulence.evolution import EddyLifetimeEvolution

    b = _beams(rr, x, n_beams)
    lid = _scene(rr, x).sensor(_period(0, False))
    opt = lid.instrument_at(float(b.focus_b[0])).optics()
    ev = EddyLifetimeEvolution(lifetime, U) if evolving else None
    return rews_spectra(k, _params(), RotorDisc(R), b, U, weighting=lid.weighting, evolution=ev,
                        resolution=resolution, preview_shift=x / U - float(b.delay_pb.mean()),
                        wavelength=opt.wavelength, radius=opt.radius)


def k_half(k, g):
    from cwlidar_sim.analysis.rews import coherence_bandwidth

    good = np.isfinite(g)
    return coherence_bandwidth(k[good], g[good]) if good.sum() >= 2 else math.nan


def parabola_peak(r, y, half_width=None):
    """Vertex of a parabola through the best point and its neighbours (or all within ``half_width``), clipped."""
    r = np.asarray(r, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(y)
    r, y = r[ok], y[ok]
    if r.size < 3:
        return math.nan
    order = np.argsort(r)
    r, y = r[order], y[order]
    j = int(np.argmax(y))
    if half_width is None:
        sel = np.arange(max(j - 1, 0), min(j + 2, r.size))
        if sel.size < 3:
            return float(r[j])
    else:
        sel = np.nonzero(np.abs(r - r[j]) <= half_width + 1e-9)[0]
    c = np.polyfit(r[sel], y[sel], 2)
    if c[0] >= 0:
        return float(r[j])
    return float(np.clip(-c[1] / (2 * c[0]), r[sel].min(), r[sel].max()))


# --------------------------------------------------------------------------
# scenes built in code
# --------------------------------------------------------------------------
def _scene(rr, x, duration=600.0):
    from cwlidar_sim.campaign.scenes.nacelle import (NacelleLidarSpec, NacellePeriodSpec, NacelleScanSpec,
                                                     NacelleScene, NacelleTurbulenceSpec)

    r = rr * R
    scan = NacelleScanSpec(focus_distances=(round(math.hypot(x, r), 9),), half_angle_deg=math.degrees(math.atan2(r, x)),
                           revolution_time=T_REV, estimates_per_rev=EST_PER_REV, rotor_radius=R, spacing=SPACING,
                           segment_duration=min(300.0, duration / 3.0), theory_beams=0)
    return NacelleScene(name="guo", periods=(NacellePeriodSpec(name="p", mean_speed=U),), scan=scan,
                        lidar=NacelleLidarSpec(tier="los"), turbulence=NacelleTurbulenceSpec(**MANN),
                        duration=duration)


def _period(seed, evolving):
    from cwlidar_sim.campaign.scenes.nacelle import NacellePeriodSpec

    return NacellePeriodSpec(name="evolving" if evolving else "frozen", mean_speed=U, seed=seed,
                             lifetime=LIFETIME if evolving else None)


def _union(regions):
    from cwlidar_sim.turbulence.cover import Region

    x_lo = min(g.x_lo for g in regions)
    x_hi = max(g.x_lo + g.length for g in regions)
    return Region(x_lo=x_lo, length=x_hi - x_lo, y_mid=0.0, half_width=max(g.half_width for g in regions),
                  z_mid=0.0, half_height=max(g.half_height for g in regions))


def simulate_seed(seed, x, duration, segment, evolving):
    """Per radius the Hann periodograms (rr, ll, rl) of every segment at every ordinate, one seed."""
    from cwlidar_sim.analysis.rews import RotorDisc, align_preview, rews_from_box
    from cwlidar_sim.analysis.spectra import segment_spectra
    from cwlidar_sim.campaign.periods.nacelle import _trailing_nanmean
    from cwlidar_sim.sensors.nacelle import measure_nacelle
    from cwlidar_sim.turbulence.cover import cover_box
    from cwlidar_sim.turbulence.evolution import EddyLifetimeEvolution

    p = _period(seed, evolving)
    lids = [_scene(rr, x, duration).sensor(p) for rr in RADII]
    region = _union([lid.box_region(SPACING, R) for lid in lids])
    ev = EddyLifetimeEvolution(LIFETIME, U) if evolving else None
    t0 = time.perf_counter()
    boxes = cover_box(region, U, duration, _params(), seed, spacing=SPACING, lateral_doubling=True, evolution=ev,
                      planes=None if ev is None else [0.0, -x])
    rotor_box, lidar_box = (boxes, boxes) if ev is None else (boxes[0], boxes[1])
    t_box = time.perf_counter() - t0
    out = []
    rews = None
    t0 = time.perf_counter()
    for lid in lids:
        r = lid.focus_distances[0]
        rec = measure_nacelle(lidar_box, lid, duration, U)
        if rews is None:
            rews = rews_from_box(rotor_box, RotorDisc(R), 0.0, 0.0, x=0.0, times=rec.time_e, U=U)
        dt = lid.dwell_time
        u = rec.vlos_e / rec.direction_ec[:, 0]
        lid_t = _trailing_nanmean(u, lid.estimates_per_rev)
        ok = slice(lid.estimates_per_rev - 1, None)
        shift = max(lid.preview_distance(r) / U - 0.5 * (lid.revolution_time - dt), 0.0)
        rot, li, _ = align_preview(rews[ok], lid_t[ok], dt, shift)
        n_per = int(round(segment / dt))
        segs = []
        for s0 in range(0, rot.size - n_per + 1, n_per):
            ss = segment_spectra(rot[s0:s0 + n_per], li[s0:s0 + n_per], fs=1.0 / dt, segment_duration=n_per * dt,
                                 window="hann")
            segs.append(np.stack([ss.psd_xf, ss.psd_yf, ss.csd_f]))
        out.append(np.array(segs))  # (n_seg, 3, n_f)
        f = ss.f_f
    return {"spectra": out, "f": f, "dt": lids[0].dwell_time, "box_s": t_box,
            "lidar_s": time.perf_counter() - t0, "box_shape": [int(n) for n in rotor_box.u.shape]}


def pooled_k_half(spec_rsf, k, idx=None):
    """k at 0.5 per radius from the segments' periodograms (indices ``idx`` of the segments)."""
    out = []
    for s in spec_rsf:
        a = s if idx is None else s[idx]
        m = a.mean(axis=0)
        g = np.abs(m[2]) ** 2 / (m[0].real * m[1].real)
        out.append(k_half(k, g))
    return np.array(out)


def run_theory(quick, context):
    t0 = time.perf_counter()
    res = {}
    x = 120.0
    radii = RADII if not quick else RADII[::2]
    for evolving in (False, True):
        name = "evolving" if evolving else "frozen"
        rows = {}
        for rr in np.concatenate([radii, [] if quick or not evolving else EXTRA]):
            s = theory_spectra(rr, x, evolving=evolving)
            rows[f"{rr:.3f}"] = {"k_half": k_half(K_GRID, s.coherence_k), "coherence": s.coherence_k.round(5).tolist()}
            print(f"theory {name} r/R {rr:.2f}: k0.5 {rows[f'{rr:.3f}']['k_half']:.5f} ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr, flush=True)
        rr_all = np.array([float(k_) for k_ in rows])
        kh = np.array([rows[k_]["k_half"] for k_ in rows])
        res[name] = {"radii": rr_all.tolist(), "k_half": kh.tolist(), "optimum": parabola_peak(rr_all, kh, 0.15),
                     "spectra": rows}
    # quadrature and beam-count error at the optimum and the ends (evolving)
    conv = {}
    if not quick:
        for rr in (0.6,) if not context else (0.2, 0.6, 1.0):
            base = res["evolving"]["spectra"][f"{rr:.3f}"]["k_half"]
            fine = k_half(K_GRID, theory_spectra(rr, x, evolving=True, resolution=60.0).coherence_k)
            more = k_half(K_GRID, theory_spectra(rr, x, evolving=True, n_beams=BEAMS + 4).coherence_k)
            conv[f"{rr:.3f}"] = {"base": base, "resolution_60": fine, f"beams_{BEAMS + 4}": more}
    res["convergence"] = conv
    # context: the sweep at other upwind distances (evolving)
    ctx = {}
    if context:
        for xc in (60.0, 240.0):
            kh = [k_half(K_GRID, theory_spectra(rr, xc, evolving=True).coherence_k) for rr in RADII]
            ctx[f"{xc:g}"] = {"radii": RADII.tolist(), "k_half": kh, "optimum": parabola_peak(RADII, kh, 0.15)}
            print(f"context x {xc:g}: {np.round(kh, 5)}", file=sys.stderr, flush=True)
    res["context_x"] = ctx
    res["x"] = x
    res["theory_s"] = time.perf_counter() - t0
    return res


def run_simulation(seeds, duration, segment, x=120.0):
    from cwlidar_sim.analysis.rews_theory import estimated_spectra

    rng = np.random.default_rng(31)
    res = {}
    for evolving in (False, True):
        name = "evolving" if evolving else "frozen"
        spec = [[] for _ in RADII]
        cost = []
        for s in seeds:
            o = simulate_seed(s, x, duration, segment, evolving)
            for i, a in enumerate(o["spectra"]):
                spec[i].append(a)
            cost.append({"seed": s, "box_s": round(o["box_s"], 1), "lidar_s": round(o["lidar_s"], 1),
                         "box_shape": o["box_shape"]})
            print(f"sim {name} seed {s}: box {o['box_s']:.0f} s, lidar {o['lidar_s']:.0f} s", file=sys.stderr,
                  flush=True)
            f, dt = o["f"], o["dt"]
        spec = [np.concatenate(a) for a in spec]
        k = 2 * math.pi * f / U
        use = k <= 0.05
        spec = [a[:, :, use] for a in spec]
        k = k[use]
        kh = pooled_k_half(spec, k)
        n_seg = spec[0].shape[0]
        boot = np.array([pooled_k_half(spec, k, rng.integers(0, n_seg, n_seg)) for _ in range(BOOT)])
        opt_boot = np.array([parabola_peak(RADII, b) for b in boot])
        # the theory as these segments see it
        th = []
        for rr in RADII:
            sp = theory_spectra(rr, x, evolving=evolving)
            e = estimated_spectra(sp, U, fs=1.0 / dt, segment_duration=segment, window="hann")
            th.append(k_half(e.k1_k[e.k1_k <= 0.05], e.coherence_k[e.k1_k <= 0.05]))
        g = [np.abs(a.mean(0)[2]) ** 2 / (a.mean(0)[0].real * a.mean(0)[1].real) for a in spec]
        res[name] = {"k": k.round(6).tolist(), "n_segments": int(n_seg), "k_half": kh.tolist(),
                     "k_half_boot_sd": np.nanstd(boot, axis=0).tolist(),
                     "k_half_boot_95": np.nanpercentile(boot, [2.5, 97.5], axis=0).tolist(),
                     "optimum": parabola_peak(RADII, kh), "optimum_boot_sd": float(np.nanstd(opt_boot)),
                     "optimum_boot_95": np.nanpercentile(opt_boot, [2.5, 97.5]).tolist(),
                     "argmax_boot_fraction": {f"{rr:.1f}": float(np.mean(np.nanargmax(boot, axis=1) == i))
                                              for i, rr in enumerate(RADII)},
                     "theory_as_estimated_k_half": th, "theory_as_estimated_optimum": parabola_peak(RADII, th),
                     "coherence": [np.round(c, 4).tolist() for c in g], "cost": cost}
    return res


def figure(out, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    th = out["theory"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for name, c in (("frozen", "C0"), ("evolving", "C3")):
        t = th[name]
        o = np.argsort(t["radii"])
        ax[0].plot(np.array(t["radii"])[o], np.array(t["k_half"])[o], "-", color=c, label=f"theory, {name}")
        ax[0].axvline(t["optimum"], color=c, ls=":", lw=1)
        sim = out.get("simulation", {}).get(name)
        if sim:
            lo, hi = np.array(sim["k_half_boot_95"])
            kh = np.array(sim["k_half"])
            ax[1].errorbar(RADII, kh, yerr=[kh - lo, hi - kh], fmt="o", color=c, capsize=3,
                           label=f"simulated ({sim['n_segments']} segments), {name}")
            ax[1].plot(RADII, sim["theory_as_estimated_k_half"], "--", color=c, label=f"theory as estimated, {name}")
            olo, ohi = sim["optimum_boot_95"]
            ax[1].axvspan(olo, ohi, color=c, alpha=0.12)
    for xc, t in th.get("context_x", {}).items():
        ax[0].plot(t["radii"], t["k_half"], "--", lw=1, color="0.5" if xc == "60" else "0.75",
                   label=f"theory, evolving, x = {xc} m")
    for a in ax:
        a.axvline(0.6, color="k", lw=0.8, alpha=0.5)
        a.set_xlabel("scan radius r / R")
        a.set_ylabel("k at coherence 0.5 [rad/m]")
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    ax[0].set_title(f"analytic, x = {th['x']:g} m upwind (dotted: optima; black: 0.6 R)", fontsize=9)
    ax[1].set_title("simulated (tier los) with bootstrap 95 % and the optimum's 95 % band", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    global BEAMS
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--duration", type=float, default=1520.0)
    ap.add_argument("--segment", type=float, default=300.0)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--theory-only", action="store_true")
    ap.add_argument("--beams", type=int, default=BEAMS, help="point beams of the theory (cost ~ their square)")
    ap.add_argument("--context", action="store_true", help="the theory's sweep at x = 60 and 240 m too")
    ap.add_argument("--json", default=None)
    ap.add_argument("--figure", default=None)
    ap.add_argument("--from-json", default=None, help="redraw the figure from a JSON written before")
    a = ap.parse_args(argv)
    if a.from_json:
        with open(a.from_json) as fh:
            out = json.load(fh)
    else:
        BEAMS = a.beams
        t = time.perf_counter()
        seeds = list(range(3100, 3100 + (2 if a.quick else a.seeds)))
        out = {"setup": {"R": R, "hub_height": HUB, "U": U, "rpm": RPM, "revolution_time": T_REV,
                         "estimates_per_rev": EST_PER_REV, "lifetime": LIFETIME, "mann": MANN, "beams": BEAMS,
                         "spacing": SPACING, "duration": a.duration, "segment": a.segment, "seeds": seeds},
               "theory": run_theory(a.quick, a.context)}
        if not a.theory_only:
            out["simulation"] = run_simulation(seeds, a.duration, a.segment)
        out.update(wall_s=time.perf_counter() - t, machine=machine())
    for name in ("frozen", "evolving"):
        t = out["theory"][name]
        print(f"theory {name}: optimum r/R {t['optimum']:.3f}; " +
              ", ".join(f"{r:.2f}: {k:.5f}" for r, k in sorted(zip(t["radii"], t["k_half"]))))
        s = out.get("simulation", {}).get(name)
        if s:
            print(f"  simulated ({s['n_segments']} segments): optimum {s['optimum']:.3f} +- {s['optimum_boot_sd']:.3f} "
                  f"[{s['optimum_boot_95'][0]:.3f}, {s['optimum_boot_95'][1]:.3f}]; theory as estimated "
                  f"{s['theory_as_estimated_optimum']:.3f}")
            for rr, kh, sd, te in zip(RADII, s["k_half"], s["k_half_boot_sd"], s["theory_as_estimated_k_half"]):
                print(f"    r/R {rr:.1f}: simulated {kh:.5f} +- {sd:.5f}, theory as estimated {te:.5f}")
    if a.json and not a.from_json:
        write_json(a.json, out)
    if a.figure:
        figure(out, a.figure)
    return 0


if __name__ == "__main__":
    sys.exit(main())
