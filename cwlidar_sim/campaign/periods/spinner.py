"""Run a spinner scene's period: the box(es), the SpinnerLidar's rosettes, the disc fit per rosette, the rotor's REWS.

Per period (:mod:`cwlidar_sim.campaign.scenes.spinner`):

1. Turbulence: one Mann box (frozen) or two (evolving: the rotor plane's and
   the focus's on the axis, :func:`cwlidar_sim.turbulence.cover.cover_box`),
   holding the rotor disc and every look's probe volume.
2. Lidar: the whole rosettes of the period
   (:func:`cwlidar_sim.sensors.spinner.measure_spinner`).
3. Disc fits per rosette (:func:`cwlidar_sim.analysis.disc_fit.fit_disc` at
   the probe volume's first moment, ``w = 0`` assumed with ``scan.w_zero``)
   for every *estimate kind*: ``tier1`` (the chain's ideal ``vlos_e``),
   ``main`` (the lidar's tier and estimator, usable estimates only) and each
   processing variant.  Two fits: without ``du/dy`` (well conditioned: REWS
   ``u0`` along the rotor axis, speed, yaw misalignment, vertical shear,
   veer, w0) and with it (the horizontal shear only: ``du/dy`` and ``v0``
   are nearly degenerate at one focus distance, :mod:`cwlidar_sim.analysis.disc_fit`).
4. Truth: the REWS the rotor feels, along its axis (``u cos gamma + v sin
   gamma`` of the box, disc-averaged, :func:`cwlidar_sim.analysis.rews.rews_from_box`),
   at the rosette's mid-time plus the preview ``d / U`` (d the probe's mean
   upwind distance over the rosette), and its error statistics; the yaw
   from the disc-averaged wind (the set yaw less the turbulent wind's
   direction), which is what a yaw estimate estimates.

5. Coherence of each estimate kind's REWS with the rotor's over the
   rosettes, and beside it the linear theory's
   (:func:`cwlidar_sim.campaign.periods.scanner_theory.spinner_variables`;
   frozen periods only).

Results: dims ``period``, ``estimate``, ``rosette``, ``k`` (the coherence's
bins, per period ``k_coherence``); units on every variable.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ..._seeding import seed_int
from ..._version import __version__
from ...signal.processing import usable_mask
from ..scenes.spec import RESULTS_VERSION
from ..scenes.spinner import SpinnerScene
from .scanner_theory import spinner_variables

__all__ = ["run_unit", "estimate_bytes", "estimate_unit", "summarise", "period_record", "summary",
           "COST_S_PER_SIM_HOUR", "PRODUCTS"]

#: Wall time [s] on one core per simulated hour (492 estimates per second, 4 looks each; measured on the
#: bundled scene's quick mode on the shared machine, rounded up).
COST_S_PER_SIM_HOUR = {"los": 150.0, "spectral": 1500.0, "signal": 500000.0}
#: The per-rosette products: name -> (DiscFit attribute, units, long name).
PRODUCTS = {
    "rews": ("rews_g", "m s-1", "rotor-effective wind speed along the rotor axis, u0 of the disc fit"),
    "speed": ("speed_g", "m s-1", "horizontal speed at the hub |(u0, v0)|"),
    "yaw_estimate": ("yaw_misalignment_g", "degree", "yaw misalignment atan2(-v0, u0) of the disc fit"),
    "vertical_shear": ("vertical_shear_g", "s-1", "dS/dz of the horizontal speed at the hub"),
    "horizontal_shear": ("horizontal_shear_g", "s-1", "du/dy across the rotor (the fit with du/dy)"),
    "veer": ("veer_g", "degree m-1", "turning of the wind direction with height, from +x toward +y"),
}


def _n_rosettes(scene, p) -> int:
    return int(math.floor(scene.period_duration(p) / scene.sensor(p).rosette_time + 1e-9))


def estimate_unit(scene: SpinnerScene, index: int, params=None) -> dict:
    """Estimated wall time [s] on one core and memory [bytes] of one period (box, record, fits)."""
    from ...turbulence.cover import plan_box

    p = scene.periods[index]
    s = scene.scan
    lid = scene.sensor(p)
    dur = scene.period_duration(p)
    nx, ny, nz = plan_box(lid.box_region(s.spacing, s.rotor_radius), p.mean_speed, dur, s.spacing,
                          min_extent=2.0 * scene.period_params(p).length_scale).shape
    planes = 1 if p.lifetime is None else 2
    points = nx * ny * nz * (2 if s.lateral_doubling else 1)
    seconds = (3 * points * 30e-9 * planes * (3 if planes > 1 else 1)
               + dur / 3600.0 * COST_S_PER_SIM_HOUR[scene.lidar.tier] * (1 + 0.2 * len(scene.lidar.variants)))
    return {"seconds": seconds, "memory_bytes": 3 * 4 * points * (planes + 1) + 100e6 + 2000.0 * dur * 492}


def estimate_bytes(scene: SpinnerScene) -> float:
    """Size of a spinner scene's results [bytes]: the products per period, estimate and rosette."""
    ne = 2 + len(scene.lidar.variants)
    nr = max(_n_rosettes(scene, p) for p in scene.periods)
    return 8.0 * (len(PRODUCTS) + 4) * len(scene.periods) * ne * nr + 1e6


def period_record(scene: SpinnerScene, index: int, *, status=None):
    """The period's record and truth: ``(LidarRecord, rews_t at the rotor along its axis (total) [m/s], preview [s], info)``.

    ``rews_t`` is at each rosette's mid-time plus the preview; ``info['yaw_rotor']``
    the rotor's yaw from the disc-averaged wind then [deg] (the set yaw less
    the direction ``atan2(v, U + u)`` of the turbulent wind).
    """
    from ...analysis.rews import RotorDisc, rews_from_box
    from ...sensors.spinner import measure_spinner
    from ...turbulence.cover import cover_box
    from ...turbulence.evolution import EddyLifetimeEvolution

    p = scene.periods[index]
    s = scene.scan
    U, dur = p.mean_speed, scene.period_duration(p)
    lid = scene.sensor(p)
    evolution = None if p.lifetime is None else EddyLifetimeEvolution(p.lifetime, U)
    cost = {}
    t0 = time.perf_counter()
    if status is not None:
        status(f"{p.name}: box")
    boxes = cover_box(lid.box_region(s.spacing, s.rotor_radius), U, dur, scene.period_params(p),
                      scene.unit_seed(index), spacing=s.spacing, lateral_doubling=s.lateral_doubling,
                      evolution=evolution, planes=None if evolution is None else lid.box_planes())
    rotor_box, lidar_box = (boxes, boxes) if evolution is None else (boxes[0], boxes[1])
    cost["box"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if status is not None:
        status(f"{p.name}: lidar")
    seed = seed_int(np.random.SeedSequence(scene.unit_seed(index), spawn_key=(1,)))
    rec = measure_spinner(lidar_box, lid, dur, U, seed=None if lid.tier == "los" else seed,
                          variants=scene.lidar.variant_list)
    cost["lidar"] = time.perf_counter() - t0
    # the preview: the probe's mean upwind distance over a rosette, carried to the rotor at U
    axial = float(-(rec.direction_ec[:, 0]).mean()) * rec.info["probe_centre"]
    preview = axial / U
    n_ros = int(rec.rosette_e.max()) + 1
    t_r = (np.arange(n_ros) + 0.5) * lid.rosette_time + preview
    disc = RotorDisc(s.rotor_radius, s.rotor_exponent)
    pos = lid.position
    u_r = rews_from_box(rotor_box, disc, pos[1], pos[2], x=pos[0], times=t_r, U=U)
    v_r = rews_from_box(rotor_box[["v"]].rename(v="u"), disc, pos[1], pos[2], x=pos[0], times=t_r, U=U)
    g = math.radians(p.yaw_misalignment_deg)
    rews = (U + u_r) * math.cos(g) + v_r * math.sin(g)
    # the yaw from the disc-averaged wind the rotor sees: its direction atan2(v, U + u), less the rotor's
    yaw = p.yaw_misalignment_deg - np.degrees(np.arctan2(v_r, U + u_r))
    info = {"yaw_rotor": yaw,"box_shape": tuple(int(n) for n in rotor_box.u.shape), "cost_s": cost,
            "evolution": None if evolution is None else evolution.as_dict()}
    return rec, rews, preview, info


def _estimate_kinds(scene):
    return ["tier1", "main"] + [v["name"] for v in scene.lidar.variants]


def _los(rec, kind):
    """The estimate kind's line-of-sight wind [m/s]; NaN where unusable (signal.processing.usable_mask)."""
    corr = rec.correction_e
    if kind == "tier1":
        return rec.vlos_e + corr
    if kind == "main":
        return np.where(usable_mask(rec.speed_e, rec.flags_e), rec.los_e, np.nan)
    speed, flags = rec.variants[kind]
    return np.where(usable_mask(speed, flags), -speed + corr, np.nan)


def run_unit(scene: SpinnerScene, index: int, params=None, *, status=None):
    """Simulate period ``index`` as a Dataset on ``period`` (module notes); ``params`` is ignored."""
    import xarray as xr

    from ...analysis.disc_fit import fit_disc

    t_start = time.perf_counter()
    p = scene.periods[index]
    rec, rews, preview, info = period_record(scene, index, status=status)
    kinds = _estimate_kinds(scene)
    n_ros = rews.size
    ne = len(kinds)
    prod = {k: np.full((ne, n_ros), np.nan) for k in PRODUCTS}
    w0, n_used = np.full((ne, n_ros), np.nan), np.zeros((ne, n_ros), dtype=np.int64)
    cond = np.full((2, n_ros), np.nan)
    avail = np.empty(ne)
    t0 = time.perf_counter()
    for j, kind in enumerate(kinds):
        los = _los(rec, kind)
        avail[j] = float(np.isfinite(los).mean())
        args = (los, rec.direction_elc, rec.info["probe_centre"], rec.rosette_e)
        fit = fit_disc(*args, w_zero=scene.scan.w_zero, horizontal_shear=False)
        full = fit_disc(*args, w_zero=scene.scan.w_zero)
        at = fit.groups
        for name, (attr, _, _) in PRODUCTS.items():
            prod[name][j, at] = getattr(full if name == "horizontal_shear" else fit, attr)
        w0[j, at], n_used[j, at] = fit.param("w0"), fit.n_used_g
        if kind == "tier1":
            cond[:, at] = fit.condition_g, full.condition_g
    info["cost_s"]["fits"] = time.perf_counter() - t0
    err = prod["rews"] - rews[None, :]
    bias, rmse, corr = (np.full(ne, np.nan) for _ in range(3))
    for j in range(ne):
        ok = np.isfinite(err[j])
        if ok.any():
            bias[j], rmse[j] = float(err[j, ok].mean()), float(np.sqrt((err[j, ok] ** 2).mean()))
        if ok.sum() >= 3 and np.std(rews[ok]) > 0 and np.std(prod["rews"][j, ok]) > 0:
            corr[j] = float(np.corrcoef(prod["rews"][j, ok], rews[ok])[0, 1])
    t0 = time.perf_counter()
    coherence = spinner_variables(scene, index, prod["rews"], rews)
    info["cost_s"]["coherence_and_theory"] = time.perf_counter() - t0
    P, E, R = ("period",), ("estimate",), ("rosette",)
    dv = {name: (P + E + R, prod[name][None], {"units": u, "long_name": ln})
          for name, (_, u, ln) in PRODUCTS.items()}
    dv.update({
        "w0": (P + E + R, w0[None], {"units": "m s-1", "long_name": "vertical wind of the disc fit (0: assumed)"}),
        "n_used": (P + E + R, n_used[None], {"units": "1", "long_name": "usable estimates in the rosette's fit"}),
        "condition": (P + ("fit",) + R, cond[None], {"units": "1", "long_name": "condition number of the fit's "
                                                                              "scaled columns (tier 1)"}),
        "rosette_time": (P + R, ((np.arange(n_ros) + 0.5) * rec.info["rosette_time"])[None],
                         {"units": "s", "long_name": "rosette mid-time"}),
        "yaw_rotor": (P + R, info["yaw_rotor"][None], {"units": "degree", "long_name": "yaw of the rotor from the "
                                                       "disc-averaged wind, preview-shifted to the rosette"}),
        "rews_rotor": (P + R, rews[None], {"units": "m s-1", "long_name": "REWS the rotor feels along its axis, "
                                                                          "preview-shifted to the rosette"}),
        "rews_bias": (P + E, bias[None], {"units": "m s-1", "long_name": "mean of lidar REWS minus the rotor's"}),
        "rews_rmse": (P + E, rmse[None], {"units": "m s-1", "long_name": "RMS of lidar REWS minus the rotor's"}),
        "rews_correlation": (P + E, corr[None], {"units": "1", "long_name": "correlation of the lidar REWS with the "
                                                                            "rotor's over the rosettes"}),
        "availability": (P + E, avail[None], {"units": "1", "long_name": "fraction of usable estimates"}),
        "n_blocked": (P, np.array([rec.info["n_blocked"]]), {"units": "1", "long_name": "estimates lost to blades"}),
        "preview_time": (P, np.array([preview]), {"units": "s", "long_name": "mean upwind distance of the probe / U"}),
        "mean_speed": (P, np.array([p.mean_speed]), {"units": "m s-1", "long_name": "mean wind at hub height"}),
        "yaw_misalignment": (P, np.array([p.yaw_misalignment_deg]), {"units": "degree"}),
        "rotor_rpm": (P, np.array([p.rotor_rpm]), {"units": "rpm"}),
        "lifetime": (P, np.array([np.nan if p.lifetime is None else p.lifetime]),
                     {"units": "s", "long_name": "eddy-lifetime scale (NaN: frozen turbulence)"}),
    })
    dv.update(coherence)
    coords = {"period": ("period", np.array([p.name], dtype=object)),
              "estimate": ("estimate", np.array(kinds, dtype=object)),
              "fit": ("fit", np.array(["without_dudy", "with_dudy"], dtype=object)),
              "rosette": ("rosette", np.arange(n_ros), {"long_name": "rosette number"})}
    attrs = {
        "title": f"cwlidar_sim spinner campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "sensor": "spinner",
        "lidar_tier": scene.lidar.tier,
        "scene": json.dumps(scene.as_dict()),
        "cwlidar_sim_version": __version__,
        "period_index": int(index),
        "field_reason": f"box {'x'.join(map(str, info['box_shape']))} at {scene.scan.spacing:g} m"
                        f"{', laterally doubled' if scene.scan.lateral_doubling else ''}"
                        f"{', evolving (rotor and focus planes)' if info['evolution'] else ''}",
        "timing": json.dumps({k: float(v) for k, v in info["cost_s"].items()}
                             | {"total": time.perf_counter() - t_start}),
    }
    return xr.Dataset(dv, coords=coords, attrs=attrs)


def summarise(ds):
    """The joined periods as they are (every variable is per period already)."""
    return ds


def summary(scene: SpinnerScene, ds) -> dict:
    """The CLI's short report: per period and estimate kind the REWS error and the rosettes' mean products."""
    out = {}
    for ip, p in enumerate(ds.period.values):
        row = {}
        for je, e in enumerate(ds.estimate.values):
            row[str(e)] = {"rews_rmse": round(float(ds.rews_rmse.values[ip, je]), 4),
                           "rews_bias": round(float(ds.rews_bias.values[ip, je]), 4)}
            for k, nd in (("yaw_estimate", 3), ("vertical_shear", 5), ("veer", 5)):
                v = ds[k].values[ip, je]
                v = v[np.isfinite(v)]
                row[str(e)][k] = round(float(v.mean()), nd) if v.size else None
        out[str(p)] = row
    return {"per_period": out}
