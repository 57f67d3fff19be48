"""Run a WindScanner scene's period: the box, the three units, the reconstructed wind, a sonic, the transfer functions.

Per period (:mod:`cwlidar_sim.campaign.scenes.windscanner`):

1. Turbulence: one frozen Mann box (:func:`cwlidar_sim.turbulence.cover.cover_box`)
   holding every unit's cells over the period.
2. Lidar: the WindScanner's record (:func:`cwlidar_sim.sensors.windscanner.measure_windscanner`),
   seeded from the unit's seed.
3. Reconstruction per step (:func:`cwlidar_sim.analysis.reconstruction.reconstruct_uvw`)
   for every *estimate kind*: ``tier1`` (the chain's signed ideal
   ``vlos_e``), ``main`` (the homodyne speeds with the mean wind's sign,
   unusable estimates NaN) and each processing variant of ``[lidar] variants``.
   Steps above ``scanner.max_condition`` are flagged and NaN, counted.
4. Sonic: a point sensor at the target sampled at the steps' times (the
   common clock; no path average, no noise), so that the comparison is of
   the probe volumes and the chain alone.
5. Transfer functions of each component against the sonic's, by A2012's
   methods 1 and 2 (:func:`cwlidar_sim.analysis.transfer_functions`: the
   ratio of spectra and the squared real cross-spectrum over the sonic's
   squared spectrum), segments of ``scanner.segment_duration``, log bins;
   steps with a NaN are filled as that function does (``max_gap_fraction``
   5 %).  For a held point only: with a moving focus (``pattern =
   'lissajous'``) the sonic at the pattern's centre is not the wind at the
   focus, and the transfer functions are NaN.

Results: dims ``period``, ``estimate`` (tier1, main, variants),
``component`` (u, v, w), ``k`` [rad/m]; units on every variable.
Beside them, the linear theory (:func:`cwlidar_sim.campaign.periods.scanner_theory.windscanner_variables`):
each component's transfer functions by both methods and the w-variance
ratio, from the beams' weightings and the reconstruction matrix on the
frozen continuum, once per period; and beside the simulated ``std_ratio``
(each reconstructed component's std over the sonic's) its theory on the
continuum (``std_ratio_theory``) and on the period's own box
(``std_ratio_theory_lattice``, :func:`cwlidar_sim.campaign.periods.scanner_theory.windscanner_std_ratio_variables`).
"""

from __future__ import annotations

import json
import time

import numpy as np

from ..._seeding import seed_int
from ..._version import __version__
from ...signal.processing import usable_mask
from ..scenes.spec import RESULTS_VERSION
from ..scenes.windscanner import WindScannerScene
from .scanner_theory import windscanner_std_ratio_variables, windscanner_variables
from .in_situ import field_subgrid_variance, sonic_variables, subgrid_unavailable

__all__ = ["run_unit", "box_grid", "estimate_bytes", "estimate_unit", "summarise", "summary", "period_record",
           "COST_S_PER_SIM_HOUR", "COMPONENTS"]

#: Wall time [s] on one core per simulated hour of the three units' records (~323 estimates per second and
#: unit; measured on the bundled scene's quick mode, tier 1 about 0.01 ms per estimate).
COST_S_PER_SIM_HOUR = {"los": 60.0, "spectral": 1500.0, "signal": 2e6}
#: The reconstructed components.
COMPONENTS = ("u", "v", "w")


def estimate_unit(scene: WindScannerScene, index: int, params=None) -> dict:
    """Estimated wall time [s] on one core and memory [bytes] of one period (box, records, analysis)."""
    from ...turbulence.cover import plan_box

    p = scene.periods[index]
    s = scene.scanner
    dur = scene.period_duration(p)
    nx, ny, nz = plan_box(scene.sensor().box_region(s.spacing), p.mean_speed, dur, s.spacing,
                          min_extent=2.0 * scene.period_params(p).length_scale).shape
    points = 2 * nx * ny * nz
    n_e = 3 * dur * scene.lidar.build_instrument().estimate_rate
    seconds = (3 * points * 30e-9 + dur / 3600.0 * COST_S_PER_SIM_HOUR[scene.lidar.tier]
               * (1 + 0.2 * len(scene.lidar.variants)))
    return {"seconds": seconds, "memory_bytes": 3 * 4 * points * 2 + 200 * n_e + 100e6}


def estimate_bytes(scene: WindScannerScene) -> float:
    """Size of a WindScanner scene's results [bytes]: spectra per period, estimate, component and wavenumber."""
    ne = 2 + len(scene.lidar.variants)
    return 8.0 * 8 * len(scene.periods) * ne * 3 * scene.scanner.n_k + 1e6


def box_grid(box, n_samples: int):
    """The std-ratio theory's grid of a period's box: ``(generated shape, spacing [m], first node [m], n_samples)``."""
    return (tuple(int(n) for n in box.attrs["generated_shape"]),
            tuple(float(box[c][1] - box[c][0]) for c in "xyz"),
            tuple(float(box[c][0]) for c in "xyz"), int(n_samples))


def _estimate_kinds(scene):
    return ["tier1", "main"] + [v["name"] for v in scene.lidar.variants]


def period_record(scene: WindScannerScene, index: int, *, status=None):
    """The period's box, WindScanner record and sonic: ``(box, record, sonic_kc, time_k, cost)``."""
    from ...sensors.sonic import Sonic, sample_sonic
    from ...sensors.windscanner import measure_windscanner
    from ...turbulence.cover import cover_box

    p = scene.periods[index]
    s = scene.scanner
    U, dur = p.mean_speed, scene.period_duration(p)
    ws = scene.sensor()
    cost = {}
    t0 = time.perf_counter()
    if status is not None:
        status(f"{p.name}: box")
    box = cover_box(ws.box_region(s.spacing), U, dur, scene.period_params(p), scene.unit_seed(index),
                    spacing=s.spacing, min_extent=2.0 * scene.period_params(p).length_scale)
    cost["box"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if status is not None:
        status(f"{p.name}: three units")
    seed = seed_int(np.random.SeedSequence(scene.unit_seed(index), spawn_key=(1,)))
    rec = measure_windscanner(box, ws, dur, U, seed=None if ws.tier == "los" else seed,
                              variants=scene.lidar.variant_list)
    cost["lidar"] = time.perf_counter() - t0
    time_k, _ = ws.schedule(dur)
    sonic_kc = sample_sonic(box, Sonic(position=s.target), time_k, U)
    return box, rec, sonic_kc, time_k, cost


def _signed(st, kind, rec, U):
    """The signed line-of-sight speeds (n_k, 3) of an estimate kind; NaN where unusable."""
    from ...analysis.reconstruction import homodyne_signs

    if kind == "tier1":
        return st["vlos_ki"], None
    if kind == "main":
        speed, flags = st["speed_ki"], st["flags_ki"]
    else:
        speed, flags = (np.asarray(a).reshape(-1, 3) for a in rec.variants[kind])
    sign = homodyne_signs(st["direction_kic"], (U, 0.0, 0.0))
    return np.where(usable_mask(speed, flags), speed * sign, np.nan), flags


def run_unit(scene: WindScannerScene, index: int, params=None, *, status=None):
    """Simulate period ``index`` as a Dataset on ``period`` (module notes); ``params`` is ignored."""
    import xarray as xr

    from ...analysis.reconstruction import reconstruct_uvw
    from ...analysis.spectra import transfer_functions
    from ...sensors.windscanner import record_steps

    t_start = time.perf_counter()
    p = scene.periods[index]
    s = scene.scanner
    U = p.mean_speed
    box, rec, sonic_kc, time_k, cost = period_record(scene, index, status=status)
    st = record_steps(rec)
    kinds = _estimate_kinds(scene)
    edges = s.k_edges()
    kc = np.sqrt(edges[:-1] * edges[1:])
    ne, nk = len(kinds), kc.size
    fs = scene.sensor().instrument.estimate_rate
    mean, std, avail = (np.full((ne, 3), np.nan) for _ in range(3))
    rmse = np.full((ne, 3), np.nan)
    t1, t2 = np.full((ne, 3, nk), np.nan), np.full((ne, 3, nk), np.nan)
    n_ill, n_missing = np.zeros(ne, dtype=np.int64), np.zeros(ne, dtype=np.int64)
    held = s.pattern == "point"
    t0 = time.perf_counter()
    for j, kind in enumerate(kinds):
        vlos_ki, flags_ki = _signed(st, kind, rec, U)
        res = reconstruct_uvw(st["direction_kic"], vlos_ki, flags_ki=flags_ki, max_condition=s.max_condition)
        n_ill[j], n_missing[j] = res.n_ill_conditioned, res.n_missing
        uvw = res.uvw_kc
        ok = np.isfinite(uvw)
        avail[j] = ok.mean(axis=0)
        with np.errstate(invalid="ignore"):
            mean[j] = np.nanmean(uvw, axis=0) if ok.any() else np.nan
            std[j] = np.nanstd(uvw, axis=0, ddof=1) if ok.sum(axis=0).min() > 1 else np.nan
            if held:
                rmse[j] = np.sqrt(np.nanmean((uvw - sonic_kc) ** 2, axis=0))
        if not held:
            continue
        for c in range(3):
            try:
                est = transfer_functions(uvw[:, c], sonic_kc[:, c], fs=fs, U=U, k_edges=edges,
                                         segment_duration=s.segment_duration)
            except ValueError:
                continue  # too many gaps in every segment: NaN, the availability says why
            t1[j, c], t2[j, c] = est.transfer_ratio_k, est.transfer_cross_k
    cost["analysis"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    theory = windscanner_variables(scene, index, kc)
    theory.update(windscanner_std_ratio_variables(scene, index, box_grid(box, time_k.size)))
    cost["theory"] = time.perf_counter() - t0
    cond = scene.sensor().condition_numbers()
    P = ("period",)
    E, C = ("estimate", "component"), ("estimate", "component", "k")
    dv = {
        "transfer_ratio": (P + C, t1[None], {"units": "1", "long_name": "A2012 method 1: F_lidar / F_sonic of the "
                                                                     "reconstructed component (NaN for a moving focus)"}),
        "transfer_cross": (P + C, t2[None], {"units": "1", "long_name": "A2012 method 2: Re(chi)^2 / F_sonic^2 of the "
                                                                     "reconstructed component (NaN for a moving focus)"}),
        "wind_mean": (P + E, mean[None], {"units": "m s-1", "long_name": "mean of the reconstructed component"}),
        "wind_std": (P + E, std[None], {"units": "m s-1", "long_name": "std of the reconstructed component"}),
        "wind_rmse": (P + E, rmse[None], {"units": "m s-1", "long_name": "rms difference from the sonic at the "
                                                                        "target (NaN for a moving focus)"}),
        "availability": (P + E, avail[None], {"units": "1", "long_name": "fraction of steps with a finite "
                                                                         "reconstructed component"}),
        "n_ill_conditioned": (P + ("estimate",), n_ill[None], {"units": "1", "long_name": "steps flagged "
                                                                                          "ill-conditioned (NaN)"}),
        "n_missing": (P + ("estimate",), n_missing[None], {"units": "1", "long_name": "steps with a unit's speed "
                                                                                      "missing or unusable (NaN)"}),
        "sonic_mean": (P + ("component",), sonic_kc.mean(axis=0)[None], {"units": "m s-1"}),
        "sonic_std": (P + ("component",), sonic_kc.std(axis=0, ddof=1)[None], {"units": "m s-1"}),
        "std_ratio": (P + E, (std / sonic_kc.std(axis=0, ddof=1))[None], {
            "units": "1", "long_name": "wind_std over sonic_std: the reconstructed component's std within the "
                                       "period over the sonic's (std_ratio_theory, std_ratio_theory_lattice beside "
                                       "it)"}),
        "condition_min": (P, np.array([cond.min()]), {"units": "1", "long_name": "smallest condition number of the "
                                                                                 "beams over the pattern"}),
        "condition_max": (P, np.array([cond.max()]), {"units": "1", "long_name": "largest condition number of the "
                                                                                 "beams over the pattern"}),
        "mean_speed": (P, np.array([U]), {"units": "m s-1", "long_name": "mean wind"}),
    }
    dv.update(theory)
    # the sonic's variance below the box's grid per component and its sigma with it restored (periods.in_situ)
    sub_c = np.array([field_subgrid_variance(box, s.target, scene.period_params(p), U, time_k.size / fs,
                                             direction=tuple(d), sample_interval=1.0 / fs) for d in np.eye(3)])
    dv.update(sonic_variables(P + ("component",), sonic_kc.std(axis=0, ddof=1)[None], sub_c[None],
                              subgrid_unavailable(box)))
    cont_c = dv["sonic_std_continuum"][1][0]
    dv["std_ratio_sonic_continuum"] = (P + E, (std / cont_c)[None], {"units": "1", "long_name": "wind_std over "
                                       "sonic_std_continuum: the reconstructed component against the continuum sonic"})
    coords = {
        "period": ("period", np.array([p.name], dtype=object)),
        "estimate": ("estimate", np.array(kinds, dtype=object)),
        "component": ("component", np.array(COMPONENTS, dtype=object)),
        "k": ("k", kc, {"units": "rad m-1", "long_name": "wavenumber (bin centre, geometric)"}),
    }
    attrs = {
        "title": f"cwlidar_sim windscanner campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "sensor": "windscanner",
        "lidar_tier": scene.lidar.tier,
        "scene": json.dumps(scene.as_dict()),
        "cwlidar_sim_version": __version__,
        "period_index": int(index),
        "field_reason": f"box {'x'.join(str(int(n)) for n in box.u.shape)} at {s.spacing:g} m, laterally doubled",
        "timing": json.dumps({k: float(v) for k, v in cost.items()} | {"total": time.perf_counter() - t_start}),
    }
    return xr.Dataset(dv, coords=coords, attrs=attrs)


def summarise(ds):
    """The joined periods as they are (every variable is per period already)."""
    return ds


def summary(scene: WindScannerScene, ds) -> dict:
    """The CLI's short report: per period and estimate, each component's std ratio and rmse, the theory's."""
    out = {}
    for ip, p in enumerate(ds.period.values):
        row = {}
        for je, e in enumerate(ds.estimate.values):
            row[str(e)] = {str(c): {"std_ratio": round(float(ds.wind_std.values[ip, je, ic]
                                                             / ds.sonic_std.values[ip, ic]), 4),
                                    "rmse": round(float(ds.wind_rmse.values[ip, je, ic]), 4)}
                           for ic, c in enumerate(ds.component.values)}
        if "std_ratio_theory" in ds:  # results written before the std ratios' theory lack it
            row["theory"] = {str(c): {"std_ratio": round(float(ds.std_ratio_theory.values[ip, ic]), 4),
                                      "std_ratio_lattice": round(float(ds.std_ratio_theory_lattice.values[ip, ic]), 4)}
                             for ic, c in enumerate(ds.component.values)}
        row["condition_max"] = round(float(ds.condition_max.values[ip]), 3)
        out[str(p)] = row
    return {"windscanner": out}
