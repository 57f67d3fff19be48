"""A staring period's field: the Mann parameters of a scene, the cheapest field kind, its size and geometry.

:func:`scene_params` gives the scene's tensor (given, or fitted to a sonic
record); :func:`choose_field` the cheapest field kind that holds the
sensors during a period (a line, a plane or a box) and why;
:func:`plan_field` its size and the sensors' positions; :func:`generate_field`
the seeded field itself.  Used by the staring period
(:mod:`cwlidar_sim.campaign.staring`), the automatic choice and the
campaign's estimates; the runner (:mod:`cwlidar_sim.campaign.runner`)
re-exports them.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import math
import os

import numpy as np

from .scene import Scene

__all__ = ["FieldPlan", "choose_field", "plan_field", "generate_field", "scene_params"]


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
    """

    kind: str
    reason: str
    shape: tuple
    spacing: tuple
    lidar_position: np.ndarray
    direction: np.ndarray
    sonic_position: np.ndarray
    wrap: bool


def scene_params(scene: Scene):
    """Mann parameters of a scene: given, or fitted to its sonic record.

    A record's fit is kept for the process, keyed by the record's contents
    (a digest of its bytes, not its path or time) and the analysis settings,
    so the tasks of a campaign fitting one record fit it once.

    Returns
    -------
    (MannParameters, dict or None)
        The parameters and, for ``fit_to``, the fit's summary.
    """
    p = scene.turbulence.params()
    if p is not None:
        return p, None
    path = scene.resolve(scene.turbulence.fit_to)
    if not os.path.isfile(path):
        raise ValueError(f"turbulence.fit_to: no such file {path!r}")
    with open(path, "rb") as fh:
        digest = hashlib.sha256(fh.read()).hexdigest()
    key = (os.path.abspath(path), digest, json.dumps(scene.analysis.as_dict(), sort_keys=True))
    if key not in _FIT_CACHE:
        if len(_FIT_CACHE) > 16:
            _FIT_CACHE.clear()
        _FIT_CACHE[key] = _fit_record(path, scene)
    params, info = _FIT_CACHE[key]
    return params, copy.deepcopy(info)


_FIT_CACHE: dict = {}


def _fit_record(path, scene):
    import xarray as xr

    if not os.path.isfile(path):
        raise ValueError(f"turbulence.fit_to: no such file {path!r}")

    from ..analysis import component_spectra, fit_mann, log_bins

    try:
        rec = xr.open_dataset(path, engine="h5netcdf")
    except (OSError, ValueError) as e:
        raise ValueError(f"turbulence.fit_to: cannot read {path!r} as NetCDF: {e}") from None
    with rec:
        missing = [c for c in ("u", "v", "w") if c not in rec]
        if missing or "time" not in rec.coords:
            raise ValueError(f"turbulence.fit_to: {path!r} needs variables u, v, w on a 'time' coordinate [s]; "
                             f"missing: {missing or ['time']}")
        t = np.asarray(rec["time"].values, dtype=np.float64)
        u, v, w = (np.asarray(rec[c].values, dtype=np.float64) for c in ("u", "v", "w"))
    dt = np.diff(t)
    if t.size < 64 or not np.allclose(dt, dt[0], rtol=1e-6):
        raise ValueError(f"turbulence.fit_to: {path!r} needs >= 64 uniformly spaced samples")
    fs = 1.0 / dt[0]
    U = float(np.nanmean(u))
    if not U > 0.5:
        raise ValueError(f"turbulence.fit_to: mean u of {path!r} is {U:.3g} m/s; the fit needs u along a "
                         f"mean wind > 0.5 m/s (Taylor's hypothesis)")
    a = scene.analysis
    seg = min(a.segment_duration, t.size / fs)
    k_edges = log_bins(max(a.k_min, 2 * math.pi / (seg * U)), min(a.k_max, math.pi * fs / U), a.per_decade)
    k, F11, F22, F33, F13, nk = component_spectra(u, v, w, fs=fs, U=U, k_edges=k_edges, segment_duration=seg)
    fit = fit_mann(k, F11, F22, F33, F13, n_k=nk)
    return fit.params, {"path": os.path.abspath(path), "mean_speed": U, "std": dict(fit.std),
                        "residual_rms": float(fit.residual_rms)}


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
    line_ok = el == 0.0 and period.misalignment_deg == 0.0 and off[1] == 0.0 and off[2] == 0.0
    plane_ok = el == 0.0 and off[2] == 0.0
    forced = scene.field.kind
    if forced == "line" and not line_ok:
        raise ValueError(f"field.kind = 'line' cannot hold period {period.name!r}: a line needs a horizontal beam "
                         f"aligned with the wind (misalignment {period.misalignment_deg} deg, elevation {el} deg) "
                         f"and the sonic on it (offset {off})")
    if forced == "plane" and not plane_ok:
        raise ValueError(f"field.kind = 'plane' cannot hold period {period.name!r}: a plane needs a horizontal beam "
                         f"(elevation {el} deg) and the sonic at its height (offset z = {off[2]} m)")
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
    """Field kind, size and sensor geometry of period ``index``."""
    from scipy.fft import next_fast_len

    from ..beam.sampling import direction_from_angles

    period = scene.periods[index]
    kind, reason = choose_field(scene, period)
    inst = scene.lidar.build_instrument()
    r = inst.focus
    zR = inst.rayleigh_length
    reach = scene.lidar.span * zR
    n = np.asarray(direction_from_angles(180.0 + period.misalignment_deg, scene.lidar.elevation_deg), dtype=np.float64)
    r_lo, r_hi = max(0.0, r - reach), r + reach
    off = np.asarray(scene.sonic.offset)
    # Points relative to the telescope: the beam's ends and the sonic.
    rel = np.stack([r_lo * n, r_hi * n, r * n + off, np.zeros(3)])
    lo, hi = rel.min(axis=0), rel.max(axis=0)
    f = scene.field
    U = period.mean_speed
    T = scene.period_duration(period)
    L = params.length_scale
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


def generate_field(plan: FieldPlan, params, seed):
    """The turbulence field of ``plan`` (line, plane or box), seeded."""
    from ..turbulence import generate_box, generate_line, generate_plane

    if plan.kind == "line":
        return generate_line(params, plan.shape[0], plan.spacing[0], seed)
    if plan.kind == "plane":
        return generate_plane(params, plan.shape, plan.spacing, seed, z=float(plan.lidar_position[2]))
    return generate_box(params, plan.shape, plan.spacing, seed)
