"""A staring period's field: the Mann parameters of a scene, the cheapest field kind, its size and geometry.

:func:`scene_params` gives the scene's tensor (given, or fitted to a sonic
record); :func:`choose_field` the cheapest field kind that holds the
sensors during a period (a line, a plane or a box) and why;
:func:`plan_field` its size and the sensors' positions; :func:`generate_field`
the seeded field itself.  Used by the staring period
(:mod:`cwlidar_sim.campaign.periods.staring`), the automatic choice and the
campaign's estimates.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import os
import warnings

import numpy as np

from ...analysis.fitting import fit_quality
from ...analysis.record_files import file_digest
from ...analysis.records import RecordSpec, fit_mann_to_record, read_record
from ..scenes.staring import Scene
from .theory import cached

__all__ = ["FieldPlan", "choose_field", "plan_field", "generate_field", "scene_params", "period_params",
           "theory_params", "MEAN_SPEED_TOLERANCE"]


@dataclasses.dataclass(frozen=True)
class FieldPlan:
    """Geometry and field of one period.

    Attributes
    ----------
    kind : str
        'line', 'plane' or 'box'.
    reason : str
        Why this kind (printed by the runner).
    shape : tuple of int
        Field points (Nx[, Ny[, Nz]]).
    spacing : tuple of float
        Field spacing [m].
    lidar_position : ndarray, shape (3,)
        Telescope position [m] in the field's frame.
    direction : ndarray, shape (3,)
        Unit beam direction [-] (upwind, rotated by the misalignment).
    sonic_position : ndarray, shape (3,)
        Sonic position [m].
    wrap : bool
        Whether y and z are periodic for the sampling (planes and boxes).
    field : xarray.Dataset or None
        The field read from ``turbulence.file``, placed (None: generated).
    """

    kind: str
    reason: str
    shape: tuple
    spacing: tuple
    lidar_position: np.ndarray
    direction: np.ndarray
    sonic_position: np.ndarray
    wrap: bool
    field: object = dataclasses.field(default=None, repr=False, compare=False)


#: Largest relative difference between a ``fit_to`` record's mean speed and a period's ``mean_speed``: the
#: fitted tensor is the turbulence at the record's mean wind (its variances, hence the period's turbulence
#: intensity, are the record's), so a period in another wind is refused rather than silently combined.
MEAN_SPEED_TOLERANCE = 0.3


def scene_params(scene: Scene):
    """Mann parameters of a scene: given, or fitted to its sonic record.

    The record (``turbulence.fit_to``) is read by the twin's reader
    (:func:`cwlidar_sim.analysis.records.read_record`, with the file options
    of ``turbulence.fit_to_options``: separator, decimal mark, preamble, time
    zone...; units converted,
    sizes checked before reading, short gaps filled and counted), with u
    along the mean wind (no rotation, no despiking).  A record's fit is kept
    for the process, keyed by the record's contents (a SHA-256 of its bytes,
    read in 1 MiB chunks, not its path or time) and the analysis settings,
    so the tasks of a campaign fitting one record fit it once.

    A fit at a parameter's bound, by a failed optimiser or with a large
    residual (:func:`cwlidar_sim.analysis.fitting.fit_quality`) is warned
    about and marked in the summary (``quality``, ``at_bound``,
    ``quality_reasons``, carried by the results' ``turbulence_fit``
    attribute).  A period whose ``mean_speed`` differs from the record's
    mean by more than :data:`MEAN_SPEED_TOLERANCE` is an error (not for a
    twin's scene, whose periods take the conditioning records' mean).

    A table whose tensor depends on the period's mean speed (``ti``,
    ``iec_class``, the surface layer) has none for the scene: None, each
    period's is :func:`~cwlidar_sim.campaign.periods.staring_field.period_params`'s.

    Returns
    -------
    (MannParameters or None, dict or None)
        The parameters (None: one per period) and, for ``fit_to``, the fit's summary.
    """
    t = scene.turbulence
    if t.fit_to is None:
        return (None if t.depends_on_speed else t.params()), None
    path = scene.resolve(scene.turbulence.fit_to)
    digest = file_digest(path, "turbulence.fit_to")
    key = (os.path.abspath(path), digest, json.dumps(scene.analysis.as_dict(), sort_keys=True),
           json.dumps(t.fit_to_options, sort_keys=True))
    params, info = cached(("staring_fit_to",) + key, lambda: _fit_record(path, scene))
    U = info["mean_speed"]
    if not scene.turbulence.condition_on:
        for per in scene.periods:
            if abs(per.mean_speed - U) > MEAN_SPEED_TOLERANCE * U:
                raise ValueError(f"turbulence.fit_to: the record {path!r} has mean speed {U:.4g} m/s but period "
                                 f"{per.name!r} has mean_speed = {per.mean_speed:g} m/s; allowed: within "
                                 f"{100 * MEAN_SPEED_TOLERANCE:g} % of the record's (the fitted tensor is the "
                                 f"turbulence at the record's mean wind)")
    if info["quality"] != "ok":
        warnings.warn(f"turbulence.fit_to: the fit to {path!r} is suspect: {'; '.join(info['quality_reasons'])}; "
                      f"the results carry quality = 'suspect' in their turbulence_fit attribute", stacklevel=2)
    return params, copy.deepcopy(info)


def period_params(scene: Scene, index: int, params=None):
    """The tensor of period ``index``: ``params`` (the scene's, or its fit) or, when None, the period's own.

    A table whose tensor depends on the period's mean speed (``ti``,
    ``iec_class``, the surface layer: :func:`scene_params` gives None) is
    resolved at the period's ``mean_speed``.
    """
    if params is not None:
        return params
    return scene.turbulence.params(None, scene.periods[index].mean_speed)


def theory_params(scene: Scene, params=None):
    """The tensor of the scene's theory: ``params``, or (None) the table's at the mean of the periods' mean speeds.

    The staring scene's estimator-aware theory
    (:func:`cwlidar_sim.campaign.periods.staring.estimator_theory`) and its results'
    ``alpha_eps``, ``length_scale``, ``gamma`` attributes are one tensor for
    the scene, at that mean speed.
    """
    if params is not None:
        return params
    return scene.turbulence.params(None, float(np.mean([p.mean_speed for p in scene.periods])))


def _fit_record(path, scene):
    """(MannParameters, summary) of the fit to the record at ``path`` with the scene's analysis settings."""
    spec = RecordSpec(path, kind="sonic", rotation="none", despike_threshold=0.0, min_mean_speed=0.5,
                      name="turbulence.fit_to", **(scene.turbulence.fit_to_options or {}))
    rec = read_record(spec)
    if rec.n_samples < 64:
        raise ValueError(f"turbulence.fit_to: {path!r} has {rec.n_samples} samples; allowed: >= 64")
    a = scene.analysis
    fit = fit_mann_to_record(rec, k_min=a.k_min, k_max=a.k_max, per_decade=a.per_decade,
                             segment_duration=a.segment_duration)
    q = fit_quality(fit)
    return fit.params, {"path": os.path.abspath(path), "mean_speed": rec.mean_speed, "std": dict(fit.std),
                        "residual_rms": float(fit.residual_rms), "units": dict(rec.units),
                        "n_samples": rec.n_samples, "n_filled": rec.n_filled, "quality": q["quality"],
                        "at_bound": q["at_bound"], "quality_reasons": q["reasons"]}


def choose_field(scene: Scene, period) -> tuple[str, str]:
    """The cheapest field kind holding the scene's sensors during ``period``, and why.

    * line: beam horizontal and aligned with the wind (misalignment 0) and the
      sonic on the beam's line (offset y = z = 0): every sensor point lies on
      one line along x;
    * plane: beam horizontal and the sonic at the beam's height;
    * box: otherwise.

    A forced ``field.kind`` is checked against the same conditions.
    """
    el = scene.lidar.elevation_deg
    off = scene.sonic.offset
    # the records a twin is conditioned on are sensors too (positions relative to the focus)
    recs = [r.position for r in scene.turbulence.condition_on]
    line_ok = (el == 0.0 and period.misalignment_deg == 0.0 and off[1] == 0.0 and off[2] == 0.0
               and all(p[1] == 0.0 and p[2] == 0.0 for p in recs))
    plane_ok = el == 0.0 and off[2] == 0.0 and all(p[2] == 0.0 for p in recs)
    forced = scene.field.kind
    if forced == "line" and not line_ok:
        raise ValueError(f"field.kind = 'line' cannot hold period {period.name!r}: a line needs a horizontal beam "
                         f"aligned with the wind (misalignment {period.misalignment_deg} deg, elevation {el} deg) "
                         f"and the sonic and the conditioning records on it (offset {off})")
    if forced == "plane" and not plane_ok:
        raise ValueError(f"field.kind = 'plane' cannot hold period {period.name!r}: a plane needs a horizontal beam "
                         f"(elevation {el} deg) and the sonic and the records at its height (offset z = {off[2]} m)")
    if forced != "auto":
        return forced, f"forced by field.kind = {forced!r}"
    if line_ok:
        return "line", "beam aligned with the wind and sonic on the beam: one line along x holds every sensor"
    if plane_ok:
        return "plane", (f"horizontal beam misaligned by {period.misalignment_deg} deg: one horizontal plane holds "
                         f"every sensor")
    return "box", "beam or sonic off a horizontal plane: a 3-D box is needed"


def _pow2_at_least(n, lo=32):
    return 1 << max(int(math.ceil(math.log2(max(n, lo)))), int(math.log2(lo)))


def plan_field(scene: Scene, index: int, params) -> FieldPlan:
    """Field kind, size and sensor geometry of period ``index``.

    ``params`` None: the period's own tensor (:func:`~cwlidar_sim.campaign.periods.staring_field.period_params`).
    """
    from scipy.fft import next_fast_len

    from ...beam.sampling import direction_from_angles

    period = scene.periods[index]
    if scene.turbulence.file is not None:
        return _file_plan(scene, period)
    kind, reason = choose_field(scene, period)
    inst = scene.lidar.build_instrument()
    r = inst.focus
    zR = inst.rayleigh_length
    reach = scene.lidar.span * zR
    n = np.asarray(direction_from_angles(180.0 + period.misalignment_deg, scene.lidar.elevation_deg), dtype=np.float64)
    r_lo, r_hi = max(0.0, r - reach), r + reach
    off = np.asarray(scene.sonic.offset)
    # Points relative to the telescope: the beam's ends and the sonic.
    rel = np.stack([r_lo * n, r_hi * n, r * n + off, np.zeros(3)]
                   + [r * n + np.asarray(rec.position) for rec in scene.turbulence.condition_on])
    lo, hi = rel.min(axis=0), rel.max(axis=0)
    f = scene.field
    U = period.mean_speed
    T = scene.period_duration(period)
    L = period_params(scene, index, params).length_scale
    nx = next_fast_len(int(math.ceil((U * T + (hi[0] - lo[0]) + 4 * f.dx) / f.dx)), real=True)
    shape, spacing = [nx], [f.dx]
    pos = np.zeros(3)
    pos[0] = -lo[0] + 2 * f.dx
    if kind in ("plane", "box"):
        ny = f.ny or _pow2_at_least((hi[1] - lo[1] + 4 * L) / f.dy)
        shape.append(ny)
        spacing.append(f.dy)
        pos[1] = 0.5 * (ny - 1) * f.dy - 0.5 * (hi[1] + lo[1])
    if kind == "box":
        nz = f.nz or _pow2_at_least((hi[2] - lo[2] + 4 * L) / f.dz)
        shape.append(nz)
        spacing.append(f.dz)
        pos[2] = 0.5 * (nz - 1) * f.dz - 0.5 * (hi[2] + lo[2])
    return FieldPlan(kind, reason, tuple(int(s) for s in shape), tuple(spacing), pos, n, pos + r * n + off,
                     kind != "line")


def _sensor_points(scene: Scene, period):
    """Beam direction and the points the sensors reach, relative to the telescope [m]: ``(n, rel)``."""
    from ...beam.sampling import direction_from_angles

    inst = scene.lidar.build_instrument()
    r, reach = inst.focus, scene.lidar.span * inst.rayleigh_length
    n = np.asarray(direction_from_angles(180.0 + period.misalignment_deg, scene.lidar.elevation_deg), dtype=np.float64)
    rel = np.stack([max(0.0, r - reach) * n, (r + reach) * n, r * n + np.asarray(scene.sonic.offset), np.zeros(3)])
    return n, rel


def _file_plan(scene: Scene, period) -> FieldPlan:
    """The plan of a period flown through ``turbulence.file``: the field read and placed, the telescope at 0."""
    from ...turbulence.cover import Region

    n, rel = _sensor_points(scene, period)
    lo, hi = rel.min(axis=0), rel.max(axis=0)
    region = Region(float(lo[0]), float(hi[0] - lo[0]), float(0.5 * (lo[1] + hi[1])), float(0.5 * (hi[1] - lo[1])),
                    float(0.5 * (lo[2] + hi[2])), float(0.5 * (hi[2] - lo[2])))
    field = scene.turbulence.field_source(scene.base_dir)(region, period.mean_speed, scene.period_duration(period))
    shape = tuple(int(field.sizes[a]) for a in ("x", "y", "z"))
    spacing = tuple(float(field.attrs[f"d{a}"]) for a in "xyz")
    what = "time-resolved" if "t" in field.dims else "frozen, advected at the period's mean speed"
    return FieldPlan("box", f"read from turbulence.file {scene.turbulence.file.path!r} ({what})", shape, spacing,
                     np.zeros(3), n, rel[2].copy(), False, field)


def generate_field(plan: FieldPlan, params, seed):
    """The turbulence field of ``plan`` (line, plane or box), seeded; a file's field as read and placed."""
    from ...turbulence import generate_box, generate_line, generate_plane

    if plan.field is not None:
        return plan.field
    if plan.kind == "line":
        return generate_line(params, plan.shape[0], plan.spacing[0], seed)
    if plan.kind == "plane":
        return generate_plane(params, plan.shape, plan.spacing, seed, z=float(plan.lidar_position[2]))
    return generate_box(params, plan.shape, plan.spacing, seed)
