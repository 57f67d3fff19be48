"""The conically scanning ZephIR against a cup and a sonic (CS): units of work and results.

A conical scene (:mod:`cwlidar_sim.campaign.scenes.conical`) runs every
``[[period]]`` at every height of ``scan.heights``: one *unit* is (period,
height), a record of one Mann box (CS: 10 minutes), the scanning lidar dwelling at
that height, a cup and a sonic on the scan axis
(:func:`cwlidar_sim.campaign.periods.conical_simulation.simulate_conical_period`); with
``scan.cycle = true`` one unit is a period, the lidar cycling through the
heights in one box (:func:`~cwlidar_sim.campaign.periods.conical_simulation.simulate_conical_cycle`),
and gives one row per height.  The 1 s and 3 s scans (``scan.scan_revs``) are
two evaluations of the same record, as a ZephIR's two software settings
would see the same air.  Units are independent and seeded from the scene, so
they run here or on Dask with the same bits, are written one by one as they
finish, and resume like the periods of a staring scene.

The scene's results (:func:`summarise`) average the units of each height
over the periods that pass CS's selection (mean points used in the fits
>= 65 % of the maximum), on dimensions ``height`` [m] and ``scan_s`` [s].

The scene file these units run is described, with an example, in
:mod:`cwlidar_sim.campaign.scenes.conical`.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ..._version import __version__
from . import conical_simulation, conical_theory, in_situ, lattice_theory
from .conical_simulation import cycle_reference_height
from .._labels import WIND_DIRECTION_CONVENTION, duration_phrase, periods_phrase, wind_from_toward
from ..scenes.conical import ConicalScene, default_spacing
from ..scenes.spec import RESULTS_VERSION

__all__ = ["run_unit", "unit_dataset", "summarise", "summary", "estimate_unit", "estimate_bytes"]

#: Scalars of one unit (period x height), with units and meaning ('{span}': the period's length, '10-min', '120-s').
UNIT_VARS = {
    "cup_mean": ("m s-1", "cup {span} mean horizontal speed"),
    "cup_std": ("m s-1", "cup {span} standard deviation"),
    "sonic_std": ("m s-1", "sonic horizontal-speed standard deviation"),
    "sonic_radial_variance": ("m2 s-2", "sonic-equivalent radial variance (point sonic projected on the rotating beam)"),
    "availability": ("1", "fraction of usable line-of-sight estimates: finite, with no failure, NEAR_ZERO or "
                          "NEAR_NYQUIST flag (signal.processing.usable_mask)"),
    "zero_crossing_loss": ("1", "fraction of estimates flagged NO_SIGNAL or NEAR_ZERO (cross-wind zero crossings)"),
    "second_peak_fraction": ("1", "fraction of estimates flagged SECOND_PEAK (e.g. a cloud return)"),
    "cloud_fraction": ("1", "the cloud's share of the received power (0: clear air)"),
    "sonic_direction": ("degree", "sonic mean direction the wind blows toward, in the lidar's frame "
                                  "(from its azimuth 0, east, toward +y, north), in [-180, 180)"),
}
#: Per-unit coordinates of the cup and the sonic: (axis of ``in_situ_position``, units, long name).
POSITION_VARS = {
    "in_situ_y": (1, "m", "cross-wind position of the cup and the sonic (the box's node nearest the mast, y = 0)"),
    "in_situ_height": (2, "m", "height of the cup and the sonic (the box's node nearest the measurement height)"),
}
#: Per-scan-length results of one unit.
SCAN_VARS = {
    "lidar_mean": ("m s-1", "lidar {span} mean horizontal speed (VAD fits)"),
    "lidar_std": ("m s-1", "lidar {span} standard deviation of the VAD horizontal speed"),
    "lidar_direction": ("degree", "mean VAD direction the wind blows toward, in the lidar's frame "
                                  "(from its azimuth 0, east, toward +y, north), in [-180, 180)"),
    "std_ratio": ("1", "lidar / cup {span} standard deviation"),
    "mean_speed_bias": ("1", "lidar mean / cup mean - 1"),
    "tp": ("1", "mean turbulence parameter TP (CS Eq. 8)"),
    "radial_variance": ("m2 s-2", "mean (TP U)^2"),
    "radial_variance_ratio": ("1", "radial_variance / sonic_radial_variance"),
    "scan_availability": ("1", "fraction of scans fitted"),
    "points_used_fraction": ("1", "mean fraction of points used in the fits"),
    "selected": ("1", "CS's selection: points_used_fraction >= 0.65"),
    "ambiguity_rate": ("1", "fraction of fitted scans whose direction is > 90 deg from the sonic's"),
    "unresolved_rate": ("1", "fraction of scans whose 180 deg ambiguity stayed unresolved"),
    "l_az": ("m", "CS scan length l_az = D + U (n - 0.5)"),
    "std_ratio_model": ("1", "CS filter model of std_ratio with the Kaimal spectrum (CS Eqs. 4-17)"),
    "std_ratio_model_mann": ("1", "CS filter model of std_ratio with the simulation's Mann spectra"),
    "radial_variance_ratio_model": ("1", "CS filter model of the radial-variance ratio (Kaimal)"),
    "radial_variance_ratio_model_mann": ("1", "CS filter model of the radial-variance ratio (Mann spectra)"),
}
#: Per-scan-length results of every processing variant (``lidar.variants``), on ``variant``.
VARIANT_VARS = {k: SCAN_VARS[k] for k in ("lidar_mean", "lidar_std", "std_ratio", "mean_speed_bias", "tp",
                                          "scan_availability", "points_used_fraction", "selected")}
_FROM_SIM = {"scan_availability": "availability", "std_ratio_model": "std_ratio_model_kaimal",
             "radial_variance_ratio_model": "radial_variance_ratio_model_kaimal"}


#: Wall time per simulated hour of the scanning lidar on one idle core [s], by tier (sub_dwells = 8;
#: measured on the reference machine with the CS reproduction, see benchmarks/bench_cs.py).
COST_S_PER_SIM_HOUR = {"los": 20.0, "spectral": 150.0, "signal": 50000.0}


def _box_points(scene: ConicalScene, index: int) -> tuple:
    """(generated points, spacing [m]) of unit ``index``'s box (as cover_box sizes it, approximately)."""
    p, z = scene.units()[index]
    hs = tuple(z) if scene.scan.cycle else (z,)
    d = scene.scan.spacing or default_spacing(min(hs))
    phi = math.radians(scene.scan.half_angle_deg)
    tensor = scene.turbulence.params(_tensor_height(scene, index), p.mean_speed)

    inst = scene.lidar.build_instrument()
    zr_per_r2 = inst.wavelength / (math.pi * inst.telescope_radius**2)  # z_R / r^2 (A2012 Eq. 1)

    def reach(h):  # the simulated span along the beam at height h [m]
        return scene.lidar.span * zr_per_r2 * (h / math.cos(phi)) ** 2

    radius = max(h * math.tan(phi) + reach(h) * math.sin(phi) for h in hs)
    ext = 2.0 * tensor.length_scale
    nx = (p.mean_speed * scene.period_duration(p) + 2 * radius + 4 * d) / d
    ny = max(2 * radius + 2 * d, ext) / d * (2 if scene.scan.lateral_doubling else 1)
    if scene.scan.cycle:
        vertical = max(hs) - min(hs) + (reach(max(hs)) + reach(min(hs))) * math.cos(phi)
    else:
        vertical = 2 * radius / math.tan(phi) * 0.3
    nz = max(vertical + 2 * d, ext) / d
    return nx * ny * nz, d


def _tensor_height(scene: ConicalScene, index: int) -> float:
    """Height [m] whose surface layer gives unit ``index``'s tensor (cycle: :func:`cycle_reference_height`)."""
    z = scene.units()[index][1]
    return cycle_reference_height(z) if scene.scan.cycle else z


def estimate_unit(scene: ConicalScene, index: int, params=None) -> dict:
    """Estimated wall time [s] on one core and memory [bytes] of one unit (box + scan + fits); ``params`` is ignored."""
    points, _ = _box_points(scene, index)
    p, _ = scene.units()[index]
    hours = scene.period_duration(p) / 3600.0
    seconds = 3 * points * 30e-9 + hours * COST_S_PER_SIM_HOUR[scene.lidar.tier]
    return {"seconds": seconds, "memory_bytes": 3 * 4 * points * 2.0 + 50e6}


def estimate_bytes(scene: ConicalScene) -> float:
    """Size of a conical scene's results [bytes]: a few hundred numbers per (period, height)."""
    return 20e3 * len(scene.units()) * (len(scene.scan.heights) if scene.scan.cycle else 1) + 1e6


def run_unit(scene: ConicalScene, index: int, params=None, *, status=None, condition=None, box_options=None):
    """Simulate unit ``index`` (period x height, or a period in cycle mode) as a Dataset on ``period``.

    ``params`` is ignored (the tensor comes from ``scene.turbulence`` at the
    unit's height); it is accepted for the runner's uniform call.
    ``condition`` and ``box_options`` are the virtual twin's
    (:mod:`cwlidar_sim.campaign.twin.run`): ``condition(box) -> box`` and the
    box's exact x period and spacing (see
    :func:`cwlidar_sim.campaign.periods.conical_simulation.simulate_conical_period`);
    a scene naming ``condition_on`` runs only with them.
    """
    import time

    if condition is None and scene.turbulence.condition_on:
        raise ValueError(f"scene {scene.name!r} names records in [turbulence] condition_on: its periods are the "
                         f"records' and its boxes are conditioned on them; run it with 'cwlidar-sim twin' "
                         f"(cwlidar_sim.campaign.twin.run.run_twin)")
    p, z = scene.units()[index]
    name = scene.unit_names()[index]
    if status is not None:
        status(f"{name}: box, lidar, cup, sonic")
    t0 = time.perf_counter()
    tensor, su, ustar = scene.turbulence.resolve(_tensor_height(scene, index), p.mean_speed)
    s = scene.scan
    theory = scene.resolve_theory()[0]  # "auto" chosen here too where the runner's resolve did not run
    if theory == "only":  # the linear theory alone (conical_theory): no box, no lidar, no cup
        rows = conical_theory.theory_rows(scene, index, tensor, su, ustar)
        rows[0]["wall_s"] = time.perf_counter() - t0
        return unit_dataset(scene, index, rows)
    hs = tuple(z) if s.cycle else (z,)
    spacing = s.spacing or default_spacing(min(hs))
    lidar = scene.lidar_fields(spacing)
    tier, sub_dwells = lidar.pop("tier"), lidar.pop("sub_dwells")
    kw = dict(speed=p.mean_speed, duration=scene.period_duration(p), scan_revs=s.scan_revs, tier=tier,
              sub_dwells=sub_dwells, spacing=spacing, lateral_doubling=s.lateral_doubling, params=tensor,
              reference=s.reference, wind_direction_deg=p.toward_deg, variants=scene.lidar.variant_list,
              condition=condition, box_options=box_options,
              field_source=scene.turbulence.field_source(scene.base_dir))
    if s.cycle:
        revs, refocus = lidar.pop("revs_per_height"), lidar.pop("refocus_time")
        rows = conical_simulation.simulate_conical_cycle(z, scene.unit_seed(index), revs_per_height=revs,
                                                     refocus_time=refocus, lidar_overrides=lidar, **kw)
    else:
        rows = [conical_simulation.simulate_conical_period(z, scene.unit_seed(index), lidar_overrides=lidar, **kw)]
    t_theory = time.perf_counter()
    if theory in ("continuum", "lattice"):
        conical_theory.add_theory(rows, scene, index, tensor, spacing)
    if theory == "lattice":
        lattice_theory.add_lattice_theory(rows, scene, index, tensor, spacing, box_options=box_options,
                                          condition=condition)
    if theory != "none":  # the theory's wall time in this unit (0 where this process had it already)
        for r in rows:
            r["cost_s"]["theory"] = time.perf_counter() - t_theory
    wall = time.perf_counter() - t0
    for r in rows:
        r["sigma_u_target"], r["u_star"] = su, ustar
        r["wall_s"] = wall
    return unit_dataset(scene, index, rows)


def unit_dataset(scene: ConicalScene, index: int, rows):
    """One unit's results as a Dataset on ``period``: one row per height it measured (dwell: one).

    ``rows``: the dict of :func:`~cwlidar_sim.campaign.periods.conical_simulation.simulate_conical_period`,
    or the list of dicts of :func:`~cwlidar_sim.campaign.periods.conical_simulation.simulate_conical_cycle`.
    """
    import xarray as xr


    rows = [rows] if isinstance(rows, dict) else list(rows)
    p, _ = scene.units()[index]
    revs = list(scene.scan.scan_revs)
    scan_s = [n * scene.scan.revolution_time for n in revs]
    dv = {}
    span = duration_phrase(scene.period_duration(p))
    for key, (units, long) in UNIT_VARS.items():
        dv[key] = (("period",), np.array([float(r[key]) for r in rows]),
                   {"units": units, "long_name": long.format(span=span)})
    for key, (axis, units, long) in POSITION_VARS.items():
        dv[key] = (("period",), np.array([float(r["in_situ_position"][axis]) for r in rows]),
                   {"units": units, "long_name": long})
    for key, (units, long) in SCAN_VARS.items():
        src = _FROM_SIM.get(key, key)
        vals = [[float(r["scans"][n].get(src, np.nan)) for n in revs] for r in rows]
        dv[key] = (("period", "scan_s"), np.array(vals), {"units": units, "long_name": long.format(span=span)})
    # the cup's and the sonic's variance below the box's grid, and their sigma with it restored (periods.in_situ)
    for key, (units, long) in in_situ.UNIT_VARS.items():
        dv[key] = (("period",), np.array([float(r.get(key, np.nan)) for r in rows]),
                   {"units": units, "long_name": long.format(span=span)})
    for key, (units, long) in in_situ.SCAN_VARS.items():
        vals = [[float(r["scans"][n].get(key, np.nan)) for n in revs] for r in rows]
        dv[key] = (("period", "scan_s"), np.array(vals),
                   {"units": units, "long_name": long.format(span=span)})
    names = [v["name"] for v in scene.lidar.variants]
    for key, (units, long) in (VARIANT_VARS.items() if names else ()):
        src = _FROM_SIM.get(key, key)
        vals = [[[float(r["variants"][v][n].get(src, np.nan)) for n in revs] for v in names] for r in rows]
        dv[f"{key}_variant"] = (("period", "variant", "scan_s"), np.array(vals),
                                {"units": units, "long_name": f"{long.format(span=span)}, processing variant"})
    if "theory" in rows[0]:
        t_attrs = rows[0]["theory_attrs"]
        for key, (per_scan, units, long) in conical_theory.THEORY_VARS.items():
            name = key[:-len("_theory")]
            vals = [[r["theory"]["scans"][n][name] for n in revs] if per_scan else r["theory"][name] for r in rows]
            dv[key] = ((("period", "scan_s") if per_scan else ("period",)), np.array(vals, dtype=float),
                       {"units": units, "long_name": long.format(span=span), **t_attrs})
        dv["theory_u_nodes"] = (("period",), np.array([len(r["theory"].get("u_nodes", ())) for r in rows]),
                                {"units": "1", "long_name": "nodes in U the unit's *_theory are interpolated "
                                                            "between (0: computed at its own U)",
                                 "theory_u": t_attrs["theory_u"]})
    dv.update(lattice_theory.unit_variables(rows, revs, span))  # the same over the unit's box, beside it
    dv["mean_speed"] = (("period",), np.array([float(p.mean_speed)] * len(rows)), {"units": "m s-1"})
    dv["u_star"] = (("period",), np.array([np.nan if r.get("u_star") is None else float(r["u_star"]) for r in rows]),
                    {"units": "m s-1", "long_name": "friction velocity of the surface layer"})
    for name in ("alpha_eps", "length_scale", "gamma"):
        dv[f"mann_{name}"] = (("period",), np.array([float(r["params"][name]) for r in rows]),
                              {"units": {"alpha_eps": "m4/3 s-2", "length_scale": "m", "gamma": "1"}[name],
                               "long_name": f"Mann {name} of the unit's box"})
    coords = {
        "period": ("period", np.array(scene.row_names(index), dtype=object)),
        "unit_height": ("period", np.array([float(r["height"]) for r in rows]),
                        {"units": "m", "long_name": "measurement height of the unit"}),
        "period_name": ("period", np.array([p.name] * len(rows), dtype=object)),
        "scan_s": ("scan_s", np.array(scan_s), {"units": "s", "long_name": "VAD scan length"}),
        "scan_revs": ("scan_s", np.array(revs), {"units": "1", "long_name": "revolutions per VAD scan"}),
    }
    if names:
        coords["variant"] = ("variant", np.array(names, dtype=object))
    r = rows[0]
    if r.get("answer") == "theory":
        reason = "no field: the linear theory's continuum (scan.theory = 'only')"
    else:
        reason = (f"box {'x'.join(map(str, r['box_shape']))} at {r['spacing']:g} m"
                  f"{', laterally doubled' if r['lateral_doubling'] else ''}")
    attrs = {
        "title": f"cwlidar_sim conical campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "sensor": "conical",
        "lidar_tier": scene.lidar.tier,
        "scene": json.dumps(scene.as_dict()),
        "cwlidar_sim_version": __version__,
        "period_index": int(index),
        "field_reason": reason,
        "timing": json.dumps({k: float(v) for k, v in r["cost_s"].items()} | {"total": r["wall_s"]}),
    }
    if r.get("answer") == "theory":
        attrs["answer"] = ("linear theory alone (scan.theory = 'only'), no simulation: std_ratio, lidar_std and "
                           "cup_std are the *_theory values, cup_mean is U, the rest NaN")
    if scene.scan.cycle:
        heights = ", ".join(f"{float(x['height']):g}" for x in rows)
        attrs["field_reason"] = (f"{reason}: one box for the heights {heights} m, the lidar cycling "
                                 f"({scene.scan.revs_per_height} revolutions per height)")
        attrs["unit_name"] = scene.unit_names()[index]
    return xr.Dataset(dv, coords=coords, attrs=attrs)


def summarise(ds):
    """The scene's results on dimensions ``height`` and ``scan_s``, beside the units' own.

    The units' variables (dimension ``period``: one per period x height) are
    renamed ``<name>_unit``.  For each height and scan length the plain
    names hold the mean over the periods that pass CS's selection of
    ``std_ratio``, ``radial_variance_ratio``, ``mean_speed_bias``, ``tp`` and
    ``ambiguity_rate`` and ``std_ratio_cup_continuum`` (``<name>_sigma``: the
    standard error over those periods), the mean over all periods of ``scan_availability`` and
    ``points_used_fraction``, and the filter model (``std_ratio_model``,
    ``radial_variance_ratio_model``: CS's Kaimal spectrum; ``..._mann``: the
    simulation's Mann spectra); per height ``availability`` (line-of-sight
    estimates), ``zero_crossing_loss``, ``n_periods``; ``n_selected``.
    ``lidar_wind_from_unit`` and ``sonic_wind_from_unit`` are the units'
    directions in the meteorological convention (attribute
    ``wind_direction_convention``).  The long names give the periods'
    length ('10-min', '120-s'; 'period' where the periods differ).
    """
    import xarray as xr

    span = periods_phrase(ds)
    ds = ds.copy()
    for key, (_, long) in (UNIT_VARS | SCAN_VARS).items():
        for name, suffix in ((key, ""), (f"{key}_variant", ", processing variant")):
            if name in ds and "{span}" in long:  # every unit's own length, or 'period' where they differ
                ds[name].attrs["long_name"] = long.format(span=span) + suffix
    units = ds.rename({v: f"{v}_unit" for v in ds.data_vars})
    for who, what in (("lidar", "mean VAD direction"), ("sonic", "sonic mean direction")):
        toward = ds[f"{who}_direction"]
        units[f"{who}_wind_from_unit"] = toward.copy(data=wind_from_toward(toward.values)).assign_attrs(
            units="degree", long_name=f"{what} the wind comes from, meteorological: clockwise from north (the "
                                      f"lidar's +y), in [0, 360); {who}_direction_unit in that convention")
    heights = np.unique(ds.unit_height.values)
    out = {}

    def by_height(var, selected):
        mean, err, count = [], [], []
        for z in heights:
            at = ds[var].where(ds.unit_height == z, drop=True)
            if selected:
                keep = (ds["selected"] > 0.5).where(ds.unit_height == z, drop=True)
                at = at.where(keep.astype(bool)) if "scan_s" in at.dims else at
            n = at.notnull().sum("period")
            mean.append(at.mean("period", skipna=True).values)
            err.append((at.std("period", skipna=True, ddof=1) / np.sqrt(n.where(n > 1))).values)
            count.append(n.values)
        return np.array(mean), np.array(err), np.array(count)

    HS = ("height", "scan_s")
    averaged = (("std_ratio", True), ("radial_variance_ratio", True), ("mean_speed_bias", True),
                ("tp", True), ("ambiguity_rate", True), ("scan_availability", False),
                ("points_used_fraction", False), ("std_ratio_model", False),
                ("std_ratio_model_mann", False), ("radial_variance_ratio_model", False),
                ("radial_variance_ratio_model_mann", False))
    if "std_ratio_cup_continuum" in ds:  # against the cup with its sub-grid variance restored (periods.in_situ)
        averaged += (("std_ratio_cup_continuum", True),)
    for var, selected in averaged:
        mean, err, n = by_height(var, selected)
        attrs = dict(ds[var].attrs)
        how = "selected periods" if selected else "periods"
        out[var] = (HS, mean, {**attrs, "long_name": f"{attrs.get('long_name', var)} (mean over the {how})"})
        if selected:
            out[f"{var}_sigma"] = (HS, err, {"units": attrs.get("units", "1"), "long_name": f"standard error of {var}"})
        if var == "std_ratio":
            out["n_selected"] = (HS, n.astype(np.int64), {"units": "1", "long_name": "periods passing CS's selection"})
    for var, (per_scan, _, _) in {**conical_theory.THEORY_VARS, **lattice_theory.LATTICE_VARS}.items():
        if var in ds:  # the theory of the same periods the simulation's means take (selected, per scan)
            mean, _, _ = by_height(var, per_scan)
            how = "selected periods" if per_scan else "periods"
            out[var] = (HS if per_scan else ("height",), mean,
                        {**ds[var].attrs, "long_name": f"{ds[var].attrs['long_name']} (mean over the {how})"})
    if "answer" in ds.attrs:  # the theory alone: no scatter over seeds to take a standard error of
        for var in [v for v in out if v.endswith("_sigma")]:
            out[var] = (out[var][0], np.full(np.shape(out[var][1]), np.nan), out[var][2])
    for var in ("std_ratio_variant", "mean_speed_bias_variant", "tp_variant", "scan_availability_variant"):
        if var not in ds:
            continue
        selected = var != "scan_availability_variant"
        mean, err, _ = by_height(var, selected)
        attrs = dict(ds[var].attrs)
        out[var] = (("height", "variant", "scan_s"), mean, attrs)
        if selected:
            out[f"{var}_sigma"] = (("height", "variant", "scan_s"), err,
                                   {"units": attrs.get("units", "1"), "long_name": f"standard error of {var}"})
    for var in ("availability", "zero_crossing_loss", "second_peak_fraction", "cloud_fraction"):
        mean, _, n = by_height(var, False)
        out[var] = (("height",), mean, {**ds[var].attrs, "long_name": ds[var].attrs["long_name"] + " (mean over periods)"})
    out["n_periods"] = (("height",), n.astype(np.int64), {"units": "1", "long_name": "periods simulated"})
    res = xr.merge([units, xr.Dataset(out, coords={"height": ("height", heights, {"units": "m"})})],
                   combine_attrs="override")
    # here, not in the units' files: a unit stored before the attribute existed still joins the others
    res.attrs = dict(ds.attrs) | {"wind_direction_convention": WIND_DIRECTION_CONVENTION}
    return res


def summary(scene: ConicalScene, ds) -> dict:
    """The CLI's short report: the std ratio per height and scan length, the scan lengths, the wind directions."""
    return {"std_ratio": {f"{float(z):g} m": [round(float(x), 3) for x in row]
                          for z, row in zip(ds.height.values, ds.std_ratio.values)},
            "scan_s": [float(s) for s in ds.scan_s.values],
            "wind_from_deg": {p.name: wind_from_toward(p.toward_deg) for p in scene.periods}}
