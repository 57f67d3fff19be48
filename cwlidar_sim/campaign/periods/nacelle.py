"""Run a nacelle scene's period: the box(es), the lidar at each focus distance, the REWS, the coherence, the theory.

Per period (:mod:`cwlidar_sim.campaign.scenes.nacelle`):

1. Turbulence: one Mann box (frozen) or one per plane (evolving:
   :func:`cwlidar_sim.turbulence.cover.cover_box`), holding the rotor disc
   and every focus distance's cells for the period.
2. REWS: :func:`cwlidar_sim.analysis.rews.rews_from_box` at the lidar's x
   (the rotor plane), the disc about the hub at the lidar's (y, z), at the
   estimates' times.  Only u enters (the wind along x; with yaw misalignment
   the field's u, not the component along the turned rotor axis).
3. Lidar: each focus distance a fixed-focus record
   (:func:`cwlidar_sim.sensors.measure_nacelle`); each estimate's
   line-of-sight wind turned into u assuming v = w = 0 (``u_b = los / n_x``)
   and averaged over the last revolution (lost estimates left out of the
   average), for every *estimate kind*: ``tier1`` (the chain's ideal
   ``vlos_e``, exact weighting, no noise), ``main`` (the lidar's tier and
   estimator) and each processing variant of ``[lidar] variants`` (other
   estimators on the same spectra).
4. Preview: the estimate at t is paired with the REWS at
   ``t + d / U - (T_rev - dt) / 2`` (d the focus's upwind distance ``r cos a``,
   the trailing revolution average's own delay taken off), rounded to a
   sample (:func:`cwlidar_sim.analysis.rews.align_preview`).
5. Coherence: Hann-windowed segments of ``scan.segment_duration``, spectra
   averaged in the scene's log-spaced wavenumber bins before the coherence is
   formed (:func:`cwlidar_sim.analysis.rews.coherence_estimate`), with its
   Fisher-z 95 % interval; the wavenumber where it falls to 0.5; the
   Wiener preview filter's gain.
6. Theory: the analytic REWS-lidar spectra from the continuous Mann
   tensor, the full cw weighting (untruncated) and ``scan.theory_beams``
   point beams spread over the revolution with their delays
   (:func:`cwlidar_sim.analysis.rews_theory.rews_spectra`, polar resolution
   30; with evolution the model's decorrelation over each beam's distance),
   paired like the simulation (the preview less the beams' mean delay), on
   a log grid of wavenumbers (``theory_wavenumbers``), then seen as the
   estimate sees them (:func:`cwlidar_sim.analysis.rews_theory.estimated_spectra`:
   each ordinate's Hann kernel with the segment mean removed, the same
   bins) and the coherence formed from those; aligned rotors with a
   circular scan only.  With 60-s segments the kernels' leakage of the
   coherent low frequencies raises the coherence near its fall: k at 0.5
   is 15-27 % above that of the spectra at the bin centres (bundled scene,
   studies/nacelle_coherence.py).  What the simulation has and the
   theory lacks: the box's grid (spacing, lateral size), the span's
   truncation (the tail sees the mean wind), 50 estimates swept over their
   dwells instead of N point beams; in the bundled scene they move k at
   0.5 by less than the sampling error (the same benchmark).
7. Std ratio and correlation: per focus and estimate kind, the paired
   series' within-period stds (the lidar's ``lidar_std``, the rotor's
   ``rotor_std``, 1/N about the span's mean, over the samples finite in
   the lidar's), their ratio and correlation coefficient; beside them the
   general linear theory's (``*_theory``,
   :mod:`cwlidar_sim.campaign.periods.nacelle_theory`: frozen Mann
   continuum, the simulation's looks and range cells at tier ``los``, the
   same span and delay, on an adaptive k1 grid with its convergence in the
   attributes; NaN for evolving turbulence or a moving platform), and the
   same statistics over the period's own box (``*_theory_lattice``,
   :mod:`cwlidar_sim.campaign.periods.nacelle_lattice`: the box's shape,
   spacing, cell correction and lateral doubling in the attributes; NaN,
   with the reason, for evolving turbulence or a box read from a file).

Results: dims ``period``, ``focus`` [m], ``estimate`` (tier1, main,
variants), ``k`` [rad/m], ``time_preview`` [s]; units on every variable.

Preview signal: the main estimate's series (``preview_estimate``), the REWS
(``preview_rews``) and the delay that pairs them (``preview_delay``) are kept,
and ``run`` writes them as ``DIR/<scene>.preview.csv``
(:func:`write_preview`) for lidar-assisted control studies.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ..._atomic import atomic_open
from ..._seeding import seed_int
from ..._version import __version__
from ...signal.processing import usable_mask
from ..scenes.nacelle import NacelleScene
from ..scenes.spec import RESULTS_VERSION
from .nacelle_lattice import LATTICE_VARS, period_lattice
from .nacelle_theory import paired_statistics, period_theory, theory_attrs

__all__ = ["run_unit", "estimate_bytes", "estimate_unit", "summarise", "period_records", "summary", "statistics",
           "write_preview", "preview_table", "COST_S_PER_SIM_HOUR"]

#: Wall time [s] on one core per simulated hour of one focus distance's record (50 estimates per second,
#: 2 looks each; measured on the bundled scene: tier 1 about 0.03 ms, tier 2 about 0.3 ms per estimate).
COST_S_PER_SIM_HOUR = {"los": 10.0, "spectral": 80.0, "signal": 50000.0}
#: Wall time [s] of the analytic coherence per focus distance, beam squared and wavenumber of its grid
#: (bundled scene: 8 beams, 12 bins, 8-12 s per focus distance on the shared machine).
THEORY_S_PER_BEAM2_BIN = 0.012
#: Wall time [s] on one core of the general theory's std ratio and correlation per focus of a frozen period
#: (:mod:`cwlidar_sim.campaign.periods.nacelle_theory`; bundled scene, 100 m, 600 s: 10.7 s of CPU on the adaptive
#: k1 grid, 29 k1; 7.6 s on the fixed 4-per-decade grid before); once per geometry.
THEORY_STD_S_PER_FOCUS = 11.0
#: Wall time [s] on one core of the lattice theory per focus of a frozen period with a generated box
#: (:mod:`cwlidar_sim.campaign.periods.nacelle_lattice`; bundled scene, 100 m, 600 s: 8.8 s of CPU, 63 rows).
THEORY_LATTICE_S_PER_FOCUS = 10.0


def estimate_unit(scene: NacelleScene, index: int, params=None) -> dict:
    """Estimated wall time [s] on one core and memory [bytes] of one period (boxes, records, theory)."""
    from ...turbulence.cover import plan_box

    p = scene.periods[index]
    s = scene.scan
    lid = scene.sensor(p)
    dur = scene.period_duration(p)
    nx, ny, nz = plan_box(lid.box_region(s.spacing, s.rotor_radius), p.mean_speed, dur, s.spacing,
                          min_extent=2.0 * scene.period_params(p).length_scale).shape
    planes = 1 if p.lifetime is None else 1 + len(s.focus_distances)
    points = nx * ny * nz * (2 if s.lateral_doubling else 1)
    nf = len(s.focus_distances)
    seconds = (3 * points * 30e-9 * planes * (3 if planes > 1 else 1)
               + dur / 3600.0 * nf * COST_S_PER_SIM_HOUR[scene.lidar.tier] * (1 + 0.2 * len(scene.lidar.variants))
               + nf * THEORY_S_PER_BEAM2_BIN * s.theory_beams**2 * theory_wavenumbers(scene, p).size
               + (nf * (THEORY_STD_S_PER_FOCUS + THEORY_LATTICE_S_PER_FOCUS) if p.lifetime is None else 0.0))
    return {"seconds": seconds, "memory_bytes": 3 * 4 * points * (planes + 1) + 100e6}


def estimate_bytes(scene: NacelleScene) -> float:
    """Size of a nacelle scene's results [bytes]: spectra per period, focus, estimate and wavenumber."""
    ne = 2 + len(scene.lidar.variants)
    nf = len(scene.scan.focus_distances)
    series = sum(scene.period_duration(p) for p in scene.periods) / scene.sensor(scene.periods[0]).dwell_time
    return 8.0 * 8 * len(scene.periods) * nf * ne * scene.scan.n_k + 8.0 * (nf + 2) * series + 1e6


def _trailing_nanmean(x, n):
    """Mean of the finite values among the last ``n`` samples (NaN before a full window or with none)."""
    ok = np.isfinite(x)
    c = np.concatenate([[0.0], np.cumsum(np.where(ok, x, 0.0))])
    m = np.concatenate([[0], np.cumsum(ok)])
    out = np.full(x.size, np.nan)
    if x.size >= n:
        cnt = m[n:] - m[:-n]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[n - 1:] = np.where(cnt > 0, (c[n:] - c[:-n]) / np.maximum(cnt, 1), np.nan)
    return out


def period_records(scene: NacelleScene, index: int, *, status=None):
    """The period's REWS and per-focus lidar records: ``(rews_t, time_t, {focus: LidarRecord}, info)``."""
    from ...analysis.rews import RotorDisc, rews_from_box
    from ...sensors.nacelle import measure_nacelle
    from ...turbulence.cover import cover_box
    from ...turbulence.evolution import EddyLifetimeEvolution

    p = scene.periods[index]
    s = scene.scan
    U, dur = p.mean_speed, scene.period_duration(p)
    params = scene.period_params(p)
    lidar_all = scene.sensor(p)
    evolution = None if p.lifetime is None else EddyLifetimeEvolution(p.lifetime, U)
    cost = {}
    t0 = time.perf_counter()
    if status is not None:
        status(f"{p.name}: box")
    source = scene.turbulence.field_source(scene.base_dir)
    if source is not None and evolution is not None:
        raise ValueError(f"{p.name!r}: lifetime = {p.lifetime!r} evolves the boxes it generates; a field read from "
                         f"turbulence.file is flown as it is: drop the period's lifetime or the file")
    boxes = cover_box(lidar_all.box_region(s.spacing, s.rotor_radius), U, dur, params, scene.unit_seed(index),
                      spacing=s.spacing, lateral_doubling=s.lateral_doubling, evolution=evolution,
                      planes=None if evolution is None else lidar_all.box_planes(), source=source)
    if source is not None and "t" in boxes.dims:
        raise ValueError("turbulence.file: a time-resolved field (t, x, y, z) is not taken by a nacelle scene: its "
                         "rotor-effective wind speed (cwlidar_sim.analysis.rews.rews_from_box) samples a frozen box "
                         "advected at the mean speed; allowed: a frozen (x, y, z) field")
    rotor_box = boxes if evolution is None else boxes[0]
    cost["box"] = time.perf_counter() - t0
    recs = {}
    seeds = np.random.SeedSequence(scene.unit_seed(index), spawn_key=(1,)).spawn(len(s.focus_distances))
    t0 = time.perf_counter()
    for i, r in enumerate(s.focus_distances):
        if status is not None:
            status(f"{p.name}: lidar at {r:g} m")
        lid = scene.sensor(p, (r,))
        fld = rotor_box if evolution is None else boxes[1 + i]
        seed = seed_int(seeds[i])
        recs[r] = measure_nacelle(fld, lid, dur, U, seed=None if lid.tier == "los" else seed,
                                  variants=scene.lidar.variant_list)
    cost["lidar"] = time.perf_counter() - t0
    any_rec = recs[s.focus_distances[0]]
    pos = lidar_all.position
    rews = rews_from_box(rotor_box, RotorDisc(s.rotor_radius, s.rotor_exponent), pos[1], pos[2], x=pos[0],
                         times=any_rec.time_e, U=U)
    shape = tuple(int(n) for n in rotor_box.u.shape)
    info = {"box_shape": shape, "generated_shape": rotor_box.attrs.get("generated_shape", shape), "cost_s": cost,
            "spacing": tuple(float(rotor_box[c][1] - rotor_box[c][0]) for c in "xyz"), "y": rotor_box["y"].values,
            "z": rotor_box["z"].values, "lateral_doubling": bool(rotor_box.attrs.get("lateral_doubling", False)),
            "evolution": None if evolution is None else evolution.as_dict()}
    return rews, any_rec.time_e, recs, info


def _estimate_kinds(scene):
    return ["tier1", "main"] + [v["name"] for v in scene.lidar.variants]


def _u_series(rec, kind):
    """The estimate's u series [m/s]; NaN where the estimate is unusable (signal.processing.usable_mask)."""
    corr = 0.0 if rec.correction_e is None else rec.correction_e  # the platform's motion correction
    if kind == "tier1":
        los = rec.vlos_e + corr  # noise-free: no flags
    elif kind == "main":
        los = np.where(usable_mask(rec.speed_e, rec.flags_e), rec.los_e, np.nan)
    else:
        speed, flags = rec.variants[kind]
        los = np.where(usable_mask(speed, flags), -speed + corr, np.nan)
    return los / rec.direction_ec[:, 0]


#: Wavenumbers per decade of the analytic spectra's grid, interpolated log-log for the estimate's kernels.
THEORY_K_PER_DECADE = 8
#: Reach of the Hann kernel's quadrature beyond the last ordinate [ordinate spacings]: there it has fallen
#: below 1e-5 of its peak.
THEORY_KERNEL_REACH = 8.0


def theory_wavenumbers(scene, period) -> np.ndarray:
    """Grid [rad/m] of a period's analytic spectra: a quarter of the first ordinate to the last bin plus the kernel's reach."""
    s = scene.scan
    U = period.mean_speed
    k_lo = 0.25 * 2.0 * math.pi / (U * s.segment_duration)
    k_hi = s.k_max + 2.0 * math.pi * THEORY_KERNEL_REACH / (U * s.segment_duration)
    return np.geomspace(k_lo, k_hi, int(math.ceil(THEORY_K_PER_DECADE * math.log10(k_hi / k_lo))) + 1)


def _theory(scene, p, r, edges):
    """The analytic coherence as the estimate sees it, per bin: spectra, then the segments' kernels and bins."""
    from ...analysis.rews import RotorDisc
    from ...analysis.rews_theory import circular_scan, estimated_spectra, rews_spectra
    from ...turbulence.evolution import EddyLifetimeEvolution

    s = scene.scan
    lid = scene.sensor(p, (r,))
    nan = np.full(edges.size - 1, np.nan)
    if p.yaw_misalignment_deg != 0.0 or not lid.circle or lid.motion is not None:
        return nan
    if s.theory_beams == 0:
        return nan
    opt = lid.instrument_at(r).optics()
    U = p.mean_speed
    # N beams evenly over the revolution, each sampled N / estimates_per_rev dwells apart: the scan's
    # average and delays at the theory's resolution (the beam-pair sums cost N^2)
    beams = circular_scan(s.theory_beams, lid.half_angle_deg, r, revolution_time=lid.revolution_time,
                          azimuth0_deg=lid.azimuth0_deg)
    ev = None if p.lifetime is None else EddyLifetimeEvolution(p.lifetime, p.mean_speed)
    # paired as the simulation pairs: the preview less the revolution average's mean delay
    shift = lid.preview_distance(r) / U - float(beams.delay_pb.mean())
    th = rews_spectra(theory_wavenumbers(scene, p), scene.period_params(p),
                      RotorDisc(s.rotor_radius, s.rotor_exponent), beams, U, weighting=lid.weighting, evolution=ev,
                      resolution=30.0, preview_shift=shift, wavelength=opt.wavelength, radius=opt.radius)
    est = estimated_spectra(th, U, fs=1.0 / lid.dwell_time, segment_duration=s.segment_duration, window="hann",
                            f_edges=U * edges / (2.0 * math.pi), reach=THEORY_KERNEL_REACH)
    out = nan.copy()
    at = np.searchsorted(edges, est.k1_k) - 1
    out[at] = est.coherence_k
    return out


def run_unit(scene: NacelleScene, index: int, params=None, *, status=None):
    """Simulate period ``index`` as a Dataset on ``period`` (module notes); ``params`` is ignored."""
    import xarray as xr

    from ...analysis.rews import align_preview, coherence_bandwidth, coherence_estimate

    t_start = time.perf_counter()
    p = scene.periods[index]
    s = scene.scan
    U = p.mean_speed
    rews, time_t, recs, info = period_records(scene, index, status=status)
    kinds = _estimate_kinds(scene)
    edges = s.k_edges()
    kc = np.sqrt(edges[:-1] * edges[1:])
    nf, ne, nk = len(s.focus_distances), len(kinds), kc.size
    coh = np.full((nf, ne, nk), np.nan)
    lo, hi, gain, lpsd = (np.full((nf, ne, nk), np.nan) for _ in range(4))
    rpsd = np.full((nf, nk), np.nan)
    ndof = np.zeros(nk)
    k50 = np.full((nf, ne), np.nan)
    theory, k50_th = np.full((nf, nk), np.nan), np.full(nf, np.nan)
    preview, avail = np.empty(nf), np.empty((nf, ne))
    series_ft, delay = np.full((nf, time_t.size), np.nan), np.empty(nf)  # the preview signal: the main estimate
    n_blocked = np.zeros(nf, dtype=np.int64)
    l_std, r_std, ratio, corr = (np.full((nf, ne), np.nan) for _ in range(4))
    th_names = ("lidar_std", "rotor_std", "std_ratio", "correlation")
    th_std = {k: np.full(nf, np.nan) for k in th_names}
    th_lat = {k: np.full(nf, np.nan) for k in th_names}
    t_std_theory = t_lattice = 0.0
    lat_attrs = {}
    t0 = time.perf_counter()
    for i, r in enumerate(s.focus_distances):
        rec = recs[r]
        lid = scene.sensor(p, (r,))
        dt = lid.dwell_time
        preview[i] = lid.preview_distance(r) / U
        shift = max(preview[i] - 0.5 * (lid.revolution_time - dt), 0.0)
        n_blocked[i] = rec.info["n_blocked"]
        for j, kind in enumerate(kinds):
            u = _u_series(rec, kind)
            avail[i, j] = float(np.isfinite(u).mean())
            lid_t = _trailing_nanmean(u, lid.estimates_per_rev)
            ok = slice(lid.estimates_per_rev - 1, None)
            rot_seg, lid_seg, _ = align_preview(rews[ok], lid_t[ok], dt, shift)
            if kind == "main":
                series_ft[i], delay[i] = lid_t, dt * round(shift / dt)  # align_preview's whole samples
            l_std[i, j], _, corr[i, j] = paired_statistics(rot_seg, lid_seg)
            r_std[i, j] = paired_statistics(rot_seg, rot_seg)[0]  # over the samples this estimate kind pairs
            ratio[i, j] = l_std[i, j] / r_std[i, j]
            est = coherence_estimate(rot_seg, lid_seg, fs=1.0 / dt, U=U, segment_duration=s.segment_duration,
                                     f_edges=U * edges / (2 * math.pi), window="hann")
            at = np.searchsorted(edges, est.k_f) - 1  # the bins that held frequencies
            coh[i, j, at], lo[i, j, at], hi[i, j, at] = est.coherence_f, est.lower_f, est.upper_f
            gain[i, j, at], lpsd[i, j, at] = est.gain_f, est.lidar_f
            rpsd[i, at], ndof[at] = est.rotor_f, est.n_dof_f
            good = np.isfinite(coh[i, j])
            if good.sum() >= 2:
                k50[i, j] = coherence_bandwidth(kc[good], coh[i, j, good])
        t1 = time.perf_counter()
        m = round(shift / dt)  # the pairing's delay in samples; the span: the trailing means less the delay
        th = period_theory(scene, p, r, (time_t.size - lid.estimates_per_rev + 1 - m) * dt, m * dt)
        for k in th_names:
            th_std[k][i] = th[k]
        t_std_theory += time.perf_counter() - t1
        t1 = time.perf_counter()
        lat = period_lattice(scene, p, r, (time_t.size - lid.estimates_per_rev + 1 - m) * dt, m * dt, info)
        for k in th_names:
            th_lat[k][i] = lat[k]
        lat_attrs = lat["attrs"] if not lat_attrs or math.isfinite(lat["std_ratio"]) else lat_attrs
        t_lattice += time.perf_counter() - t1
        theory[i] = _theory(scene, p, r, edges)
        fin = np.isfinite(theory[i])
        if fin.sum() >= 2:
            k50_th[i] = coherence_bandwidth(kc[fin], theory[i, fin])
    info["cost_s"]["coherence_and_theory"] = time.perf_counter() - t0
    info["cost_s"]["std_theory"] = t_std_theory
    info["cost_s"]["std_theory_lattice"] = t_lattice
    how = theory_attrs(scene.sensor(p).weighting)
    sim_how = ("the paired series of the coherence (the lidar's trailing revolution mean, the REWS the whole-sample "
               "delay later), 1/N about the span's mean, over the samples finite in the lidar's")
    P = ("period",)
    dv = {
        "coherence": (P + ("focus", "estimate", "k"), coh[None],
                      {"units": "1", "long_name": "magnitude-squared coherence of the REWS and the lidar's "
                                                  "preview-shifted estimate"}),
        "coherence_lower": (P + ("focus", "estimate", "k"), lo[None], {"units": "1", "long_name": "95 % lower bound"}),
        "coherence_upper": (P + ("focus", "estimate", "k"), hi[None], {"units": "1", "long_name": "95 % upper bound"}),
        "wiener_gain": (P + ("focus", "estimate", "k"), gain[None],
                        {"units": "1", "long_name": "gain |S_RL| / S_LL of the optimal preview filter"}),
        "lidar_psd": (P + ("focus", "estimate", "k"), lpsd[None],
                      {"units": "m2 s-1", "long_name": "one-sided PSD in f of the lidar's REWS estimate"}),
        "rews_psd": (P + ("focus", "k"), rpsd[None],
                     {"units": "m2 s-1", "long_name": "one-sided PSD in f of the REWS over the focus's preview-aligned "
                                                     "segments"}),
        "n_dof": (P + ("k",), ndof[None], {"units": "1", "long_name": "effective independent periodogram ordinates "
                                                                  "averaged per bin (segments x ordinates, Hann)"}),
        "k_half": (P + ("focus", "estimate"), k50[None],
                   {"units": "rad m-1", "long_name": "wavenumber where the coherence falls to 0.5"}),
        "coherence_theory": (P + ("focus", "k"), theory[None],
                             {"units": "1", "long_name": "analytic REWS-lidar coherence (Mann tensor, cw weighting, "
                                                         "scan) as the estimate sees it (its segments' Hann kernels "
                                                         "and bins); NaN for a yawed rotor, fixed beams or a "
                                                         "moving platform"}),
        "k_half_theory": (P + ("focus",), k50_th[None], {"units": "rad m-1",
                                                         "long_name": "analytic wavenumber at coherence 0.5"}),
        "lidar_std": (P + ("focus", "estimate"), l_std[None],
                      {"units": "m s-1", "long_name": "std of the lidar's REWS estimate over the paired span",
                       "statistic": sim_how}),
        "rotor_std": (P + ("focus", "estimate"), r_std[None],
                      {"units": "m s-1", "long_name": "std of the REWS over the samples paired with the estimate",
                       "statistic": sim_how}),
        "std_ratio": (P + ("focus", "estimate"), ratio[None],
                      {"units": "1", "long_name": "lidar_std / rotor_std", "statistic": sim_how}),
        "correlation": (P + ("focus", "estimate"), corr[None],
                        {"units": "1", "long_name": "correlation coefficient of the lidar's estimate and the REWS "
                                                    "it previews", "statistic": sim_how}),
        "lidar_std_theory": (P + ("focus",), th_std["lidar_std"][None],
                             {"units": "m s-1", "long_name": "lidar_std, linear theory", **how}),
        "rotor_std_theory": (P + ("focus",), th_std["rotor_std"][None],
                             {"units": "m s-1", "long_name": "rotor_std, linear theory", **how}),
        "std_ratio_theory": (P + ("focus",), th_std["std_ratio"][None],
                             {"units": "1", "long_name": "std_ratio, linear theory", **how}),
        "correlation_theory": (P + ("focus",), th_std["correlation"][None],
                               {"units": "1", "long_name": "correlation, linear theory", **how}),
        **{key: (P + ("focus",), th_lat[key[:-len("_theory_lattice")]][None],
                 {"units": units, "long_name": long, "theory_weighting": how["theory_weighting"], **lat_attrs})
           for key, (units, long) in LATTICE_VARS.items()},
        "preview_time": (P + ("focus",), preview[None], {"units": "s", "long_name": "preview time r cos(a) / U"}),
        "availability": (P + ("focus", "estimate"), avail[None],
                         {"units": "1", "long_name": "fraction of usable estimates: finite, with no failure, "
                                                     "NEAR_ZERO or NEAR_NYQUIST flag (signal.processing.usable_mask)"}),
        "n_blocked": (P + ("focus",), n_blocked[None], {"units": "1", "long_name": "estimates lost to blade blockage"}),
        "mean_speed": (P, np.array([U]), {"units": "m s-1", "long_name": "mean wind at hub height"}),
        "yaw_misalignment": (P, np.array([p.yaw_misalignment_deg]), {"units": "degree"}),
        "lifetime": (P, np.array([np.nan if p.lifetime is None else p.lifetime]),
                     {"units": "s", "long_name": "eddy-lifetime scale (NaN: frozen turbulence)"}),
        "rews_std": (P, np.array([float(np.std(rews))]), {"units": "m s-1", "long_name": "std of the REWS"}),
        "preview_estimate": (P + ("focus", "time_preview"), series_ft[None],
                             {"units": "m s-1",
                              "long_name": "the lidar's REWS estimate (main estimate, u over the last revolution; "
                                           "NaN before a full one) at its own time"}),
        "preview_rews": (P + ("time_preview",), (U + rews)[None],
                         {"units": "m s-1", "long_name": "the simulated REWS, U + u_R (the rotor disc's u)"}),
        "preview_delay": (P + ("focus",), delay[None],
                          {"units": "s", "long_name": "delay applied to preview_estimate to pair it with the REWS: "
                                                      "preview_time less half the revolution average's span, in whole "
                                                      "samples"}),
    }
    coords = {
        "period": ("period", np.array([p.name], dtype=object)),
        "focus": ("focus", np.array(s.focus_distances), {"units": "m", "long_name": "focus distance along the beam"}),
        "estimate": ("estimate", np.array(kinds, dtype=object)),
        "k": ("k", kc, {"units": "rad m-1", "long_name": "wavenumber (bin centre, geometric)"}),
        "time_preview": ("time_preview", np.asarray(time_t, dtype=float),
                         {"units": "s", "long_name": "time of the lidar's estimates from the period's start"}),
    }
    attrs = {
        "title": f"cwlidar_sim nacelle campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "sensor": "nacelle",
        "lidar_tier": scene.lidar.tier,
        "scene": json.dumps(scene.as_dict()),
        "cwlidar_sim_version": __version__,
        "period_index": int(index),
        "field_reason": f"box {'x'.join(map(str, info['box_shape']))} at {s.spacing:g} m"
                        f"{', laterally doubled' if s.lateral_doubling else ''}"
                        f"{', evolving (one box per plane)' if info['evolution'] else ''}",
        "timing": json.dumps({k: float(v) for k, v in info["cost_s"].items()}
                             | {"total": time.perf_counter() - t_start}),
    }
    return xr.Dataset(dv, coords=coords, attrs=attrs)


def summarise(ds):
    """The joined periods as they are (every variable is per period already)."""
    return ds


def summary(scene: NacelleScene, ds) -> dict:
    """The CLI's short report: k at coherence 0.5 per period, focus and estimate, and the theory's."""
    out = {}
    for ip, p in enumerate(ds.period.values):
        row = {}
        for jf, r in enumerate(ds.focus.values):
            row[f"{float(r):g} m"] = {str(e): round(float(ds.k_half.values[ip, jf, je]), 4)
                                      for je, e in enumerate(ds.estimate.values)}
            row[f"{float(r):g} m"]["theory"] = round(float(ds.k_half_theory.values[ip, jf]), 4)
        out[str(p)] = row
    return {"k_half_rad_per_m": out}


def statistics(ds) -> dict:
    """The tidy table's variables (:meth:`cwlidar_sim.campaign.registry.SceneKind.statistics`) and their instrument."""
    names = {"mean_speed": "scene", "yaw_misalignment": "scene", "lifetime": "scene", "rews_std": "rotor",
             "preview_rews": "rotor", "k_half_theory": "theory", "k_half": "lidar", "availability": "lidar",
             "lidar_std": "lidar", "rotor_std": "rotor", "std_ratio": "lidar", "correlation": "lidar",
             "lidar_std_theory": "theory", "rotor_std_theory": "theory", "std_ratio_theory": "theory",
             "correlation_theory": "theory", **dict.fromkeys(LATTICE_VARS, "theory"),
             "preview_time": "lidar", "preview_delay": "lidar", "n_blocked": "lidar", "preview_estimate": "lidar"}
    return {k: v for k, v in names.items() if k in ds.data_vars}


def preview_table(ds):
    """The preview signal as a pandas DataFrame: a row per period, focus distance and sample (:func:`write_preview`)."""
    import pandas as pd

    t = np.asarray(ds["time_preview"].values, dtype=float)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    parts = []
    for ip, p in enumerate(ds["period"].values):
        rews = np.asarray(ds["preview_rews"].values[ip], dtype=float)
        for jf, r in enumerate(ds["focus"].values):
            d = float(ds["preview_delay"].values[ip, jf])
            m = int(round(d / dt)) if dt > 0 else 0
            est = np.asarray(ds["preview_estimate"].values[ip, jf], dtype=float)
            keep = np.isfinite(t) & (np.arange(t.size) + m < t.size)  # the estimate's rotor time within the period
            j = np.flatnonzero(keep)
            parts.append(pd.DataFrame({"period": str(p), "focus_m": float(r), "time_s": t[j + m],
                                       "rews_estimate_m_s": est[j], "delay_s": d, "estimate_time_s": t[j],
                                       "rews_m_s": rews[j + m]}))
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


#: Header of the preview file (:func:`write_preview`): the convention, in ``#`` lines.
PREVIEW_HEADER = """\
# cwlidar_sim nacelle preview signal: scene {scene}
# Convention (feed-forward of lidar-assisted control, e.g. OpenFAST with ROSCO or a Simulink controller): each row is
# the lidar's rotor-effective wind speed (REWS) estimate placed at the time the wind it saw reaches the rotor plane,
# time_s = estimate_time_s + delay_s, seconds from the period's start. The estimate is u = los / n_x averaged over
# the last revolution (NaN rows: no usable estimate); delay_s = r cos(a) / U less half the revolution's span,
# rounded to whole samples (the pairing of the results' coherence). A controller's own lead (pitch actuator,
# filter) is for the user to take off. rews_m_s: the simulated REWS at time_s, for checking.
# Delays [s] per period and focus distance: {delays}
# Read with pandas.read_csv(path, comment="#").
"""


def write_preview(ds, path) -> str:
    """Write the nacelle preview signal (:func:`preview_table`, header ``PREVIEW_HEADER``) as CSV, atomically.

    Columns ``period, focus_m, time_s, rews_estimate_m_s, delay_s,
    estimate_time_s, rews_m_s``; the delays also in the header.  Returns ``path``.
    """
    df = preview_table(ds)
    try:
        scene = json.loads(ds.attrs.get("scene", "{}")).get("name", "")
    except (TypeError, ValueError):
        scene = ""
    delays = "; ".join(f"{p} at {float(r):g} m: {float(ds['preview_delay'].values[ip, jf]):.6g}"
                       for ip, p in enumerate(ds["period"].values) for jf, r in enumerate(ds["focus"].values))
    with atomic_open(path, "w") as fh:
        fh.write(PREVIEW_HEADER.format(scene=scene, delays=delays))
        df.to_csv(fh, index=False, na_rep="NaN")
    return path
