"""The virtual twin of a conical scene: each box conditioned on the records inside it (see :mod:`.run`).

Called through :func:`cwlidar_sim.campaign.twin.run.run_twin`; the notes on
conical scenes are there.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from ..._seeding import seed_int
from ._common import _TWIN_TAG, TWIN_VERSION, clock_attrs, record_statistics
from ..scenes.conical import ConicalPeriodSpec, ConicalScene, default_spacing

__all__ = ["conical_unit_records", "conical_twin_scene", "conical_twin", "conical_twin_period"]


def _rotate_from_lidar(pos, wind_direction_deg):
    """A position in the lidar's frame (x toward azimuth 0) in the field's (x along the wind) [m]."""
    t = math.radians(wind_direction_deg)
    x, y, z = (float(c) for c in pos)
    return (x * math.cos(t) + y * math.sin(t), -x * math.sin(t) + y * math.cos(t), z)


def conical_unit_records(scene: ConicalScene, tp, h: int):
    """The records box ``h`` of period ``tp`` is conditioned on: (indices, LineRecords, U [m/s]).

    Box ``h`` is the dwell height ``scan.heights[h]`` (cycle: the one box,
    h = 0).  A record is used when its position lies inside the generated
    box (:func:`cwlidar_sim.turbulence.cover.cover_yz`), at the box's
    node nearest its position across the wind (where the period's cup and
    sonic read the field, :func:`cwlidar_sim.sensors.nearest_node`); U is the mean
    of the used records' mean speeds, the box's x period ``U T``.  Raises
    ValueError when no record lies in the box.
    """
    from ...sensors import nearest_node
    from ...sensors.conical import ConicalLidar
    from ...turbulence.cover import cover_yz
    from ..periods.conical import _tensor_height

    s = scene.scan
    hs = s.heights if s.cycle else (s.heights[h],)
    spacing = s.spacing or default_spacing(min(hs))
    kw = scene.lidar_fields(spacing)
    kw.pop("tier", None)
    lidar = ConicalLidar(heights=tuple(hs), tier=scene.lidar.tier, **kw)
    unit = 0 if s.cycle else h
    tensor = scene.turbulence.params(_tensor_height(scene.replace(periods=scene.periods[:1]), unit), tp.U)
    y_n, z_n = cover_yz(lidar.box_region(spacing), spacing, params=tensor, lateral_doubling=s.lateral_doubling)
    theta = scene.periods[0].toward_deg
    used, field_pos = [], []
    for i, spec in enumerate(scene.turbulence.condition_on):
        x, y, z = _rotate_from_lidar(spec.position, theta)
        p = (lidar.position[0] + x, lidar.position[1] + y, lidar.position[2] + z)
        if y_n[0] - 1e-9 <= p[1] <= y_n[-1] + 1e-9 and z_n[0] - 1e-9 <= p[2] <= z_n[-1] + 1e-9:
            # on the box's nearest node across the wind, where the period's cup and sonic read it:
            # a record between nodes would constrain their average
            p = nearest_node({"y": y_n, "z": z_n}, p)
            used.append(i)
            field_pos.append(p)
    if not used:
        pos = [list(r.position) for r in scene.turbulence.condition_on]
        raise ValueError(f"period {tp.index}, heights {list(hs)} m: no record of condition_on lies in the box "
                         f"(y in [{y_n[0]:.4g}, {y_n[-1]:.4g}] m, z in [{z_n[0]:.4g}, {z_n[-1]:.4g}] m in the "
                         f"field's frame); the records' positions in the lidar's frame are {pos}; allowed: a record "
                         f"within the box of every height (or fewer scan.heights)")
    U = float(np.mean([tp.records[i].mean_speed for i in used]))
    if not 1.0 <= U <= 30.0:
        raise ValueError(f"period {tp.index}, heights {list(hs)} m: the records' mean speed is {U:.3g} m/s; "
                         f"allowed: [1, 30] m/s (Taylor's hypothesis)")
    lines = []
    for i, p in zip(used, field_pos):
        lines.append(tp.records[i].line_record((p[0] - U * tp.delay, p[1], p[2])))
    return used, lines, U


def conical_twin_scene(scene: ConicalScene, tp, h: int, twin: int, U: float) -> ConicalScene:
    """The one-unit scene of twin ``twin`` of period ``tp`` at box ``h``: the records' U, its own seed.

    The scene's first ``[[period]]`` is the template (wind direction); the
    seed is ``SeedSequence(scene.seed, spawn_key=(0x7477, k, h, twin))``,
    distinct for every period, height (box) and twin.
    """
    tmpl = scene.periods[0]
    seq = np.random.SeedSequence(scene.seed, spawn_key=(_TWIN_TAG, tp.index, int(h), int(twin)))
    seed = seed_int(seq)
    p = ConicalPeriodSpec(name=f"P{tp.index:03d}", mean_speed=U, wind_direction_deg=tmpl.wind_direction_deg,
                          wind_from_deg=tmpl.wind_from_deg, duration=tp.duration, seed=seed)
    s = scene.scan
    scan = s if s.cycle else dataclasses.replace(s, heights=(s.heights[h],))
    return scene.replace(periods=(p,), duration=tp.duration, scan=scan)


def _conical_box_options(scene: ConicalScene, tp, U: float) -> dict:
    """The box's x period ``U T`` and spacing: a node per record sample where the record is no denser than the grid.

    With the scene's spacing d and the records' rate fs, ``r = U / (fs d)``:
    for r >= 0.5, ``nx = n max(1, round(r))`` nodes (each sample on a node,
    read as the package's sensors read the box: exact); for a denser record
    (a 20 Hz sonic on a 2 m grid) the grid keeps its spacing and the
    record's Fourier modes beyond the grid's Nyquist are left out (read
    band-limited).
    """

    d = scene.scan.spacing or default_spacing(min(scene.scan.heights))
    r0 = tp.records[0]
    L = U * tp.duration
    r = U / (r0.sample_rate * d)
    dx = L / (r0.n_samples * max(1, int(round(r)))) if r >= 0.5 else d
    return {"period_x": L, "spacing": (dx, d, d)}


def conical_twin(scene: ConicalScene, tp, j: int, *, status=None):
    """Twin ``j`` of a conical period: every box conditioned on its records, the scene's lidar, cup and sonic.

    Returns the twin's results (those of :func:`cwlidar_sim.campaign.periods.conical.run_unit`)
    on dimension ``height`` (and ``scan_s``), with ``convection_speed`` and
    ``records_used`` per height.
    """
    import xarray as xr

    from ...turbulence.conditioning import condition_field
    from ..periods.conical import run_unit

    n_boxes = 1 if scene.scan.cycle else len(scene.scan.heights)
    parts = []
    for h in range(n_boxes):
        used, lines, U = conical_unit_records(scene, tp, h)
        sc = conical_twin_scene(scene, tp, h, j, U)
        noise_seed = int(sc.periods[0].seed)

        def condition(box, lines=lines, U=U, noise_seed=noise_seed):
            return condition_field(box, lines, seed=noise_seed, U=U, inplace=True)

        ds = run_unit(sc, 0, status=status, condition=condition, box_options=_conical_box_options(sc, tp, U))
        n = ds.sizes["period"]
        ds["convection_speed"] = (("period",), np.full(n, U), {"units": "m s-1", "long_name": "convection speed "
                                                               "of the box: mean of its records' mean speeds"})
        ds["records_used"] = (("period",), np.array([json.dumps(used)] * n, dtype=object),
                              {"units": "1", "long_name": "indices of the condition_on records the box holds"})
        ds["twin_seed"] = (("period",), np.full(n, noise_seed, np.int64), {"units": "1", "long_name": "twin seed"})
        parts.append(ds)
    out = xr.concat(parts, dim="period", combine_attrs="override") if len(parts) > 1 else parts[0]
    out = out.swap_dims(period="unit_height").drop_vars(["period", "period_name"], errors="ignore")
    out = out.rename(unit_height="height")
    out["height"].attrs.update(units="m", long_name="measurement height")
    return out


def conical_twin_period(scene: ConicalScene, tp, results):
    """The period's Dataset from its twins (:func:`conical_twin`): each twin, their mean and spread, the records."""
    import warnings

    import xarray as xr

    N = len(results)
    twins = xr.concat([r.drop_vars(["records_used"]) for r in results], dim="twin", combine_attrs="override")
    twins = twins.assign_coords(twin=("twin", np.arange(N)))
    dv = {}
    for name, da in twins.data_vars.items():
        if "twin" not in da.dims:
            continue
        attrs = dict(da.attrs)
        long = attrs.get("long_name", name)
        dv[name] = da.assign_attrs(long_name=f"{long}, each twin")
        if name in ("twin_seed",) or not np.issubdtype(da.dtype, np.floating):
            continue
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            m = da.mean("twin", skipna=True)
            s = da.std("twin", skipna=True, ddof=1) if N > 1 else xr.full_like(m, np.nan)
        dv[f"{name}_twin_mean"] = m.assign_attrs(units=attrs.get("units", "1"), long_name=f"{long}, mean over the twins")
        dv[f"{name}_twin_std"] = s.assign_attrs(units=attrs.get("units", "1"),
                                                long_name=f"{long}, std across the twins (ddof 1)")
    ds = xr.Dataset(dv)
    ds["records_used"] = results[0]["records_used"]
    for v in ("mann_alpha_eps", "mann_length_scale", "mann_gamma", "mean_speed", "u_star"):
        if v in ds:
            ds[v] = ds[v].isel(twin=0, drop=True).assign_attrs(dict(twins[v].attrs))
            for suffix in ("_twin_mean", "_twin_std"):
                ds = ds.drop_vars(v + suffix, errors="ignore")
    record_statistics(ds, tp)
    for i, spec in enumerate(scene.turbulence.condition_on):
        ds[f"record{i}_position"] = (("xyz",), np.asarray(spec.position, float),
                                     {"units": "m", "long_name": f"{spec.name}: position in the lidar's frame"})
    ds.attrs = {"scene": scene.name, "scene_kind": "conical", "period": f"P{tp.index:03d}",
                "period_index": tp.index, "n_twins": N, "convection_speed": tp.U, "duration": tp.duration,
                "records": json.dumps([r.spec.name for r in tp.records]),
                "twin_version": TWIN_VERSION, **clock_attrs(tp)}
    return ds
