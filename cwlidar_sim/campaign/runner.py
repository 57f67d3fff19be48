"""Run a scene: plan each period's field, run its sensors and analyses, keep every finished period.

The runner is sensor-agnostic: a period task (today the staring lidar
against a sonic, :mod:`cwlidar_sim.campaign.staring`) turns one period of a
scene into a one-period xarray.Dataset; the runner checks before computing
that the results can be written (:func:`cwlidar_sim.campaign.store.preflight`),
reuses the periods an earlier run finished, runs the others here or on a Dask
cluster, writes each as it finishes (:class:`~cwlidar_sim.campaign.store.PeriodStore`)
and assembles the scene's file from the period files.

Each period is independent and seeded from the scene (see
:meth:`Scene.period_seed`), so a scene gives the same bits whether its periods
run one after the other here, on the workers of a Dask cluster, or across an
interrupted run and its resumption.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time

import numpy as np

from .scene import Scene

__all__ = ["FieldPlan", "choose_field", "plan_field", "generate_field", "run_scene", "scene_params",
           "RESULTS_VERSION"]

#: Version of the results layout (part of a stored period's identity).
RESULTS_VERSION = 2


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

    Returns
    -------
    (MannParameters, dict or None)
        The parameters and, for ``fit_to``, the fit's summary.
    """
    p = scene.turbulence.params()
    if p is not None:
        return p, None
    return _fit_record(scene.resolve(scene.turbulence.fit_to), scene)


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


def _sensor(scene):
    """What the runner needs of a scene kind: (unit task, size estimate, finishing step or None).

    The unit task maps (scene, index, params, status=...) to a one-unit
    Dataset (dimension ``period``); the finishing step, if any, turns the
    joined units into the scene's results.
    """
    from .conical import ConicalScene

    if isinstance(scene, ConicalScene):
        from .conical import estimate_bytes, run_unit, summarise

        return run_unit, estimate_bytes, summarise
    if isinstance(scene, Scene):
        from .staring import run_period
        from .store import estimate_bytes

        return run_period, estimate_bytes, None
    raise TypeError(f"scene must be a Scene or a ConicalScene, got {type(scene).__name__}")


def run_scene(scene: Scene, out_dir=None, *, client=None, progress: bool = True, log=None, on_period=None):
    """Run every period of a scene, keep each as it finishes, and assemble the results.

    Parameters
    ----------
    scene : Scene or ConicalScene
        A staring scene (its units are its periods) or a conical one (its
        units are period x height, :mod:`cwlidar_sim.campaign.conical`).
    out_dir : str or path, optional
        Folder for ``<scene.name>.nc`` and the per-period files
        ``<scene.name>.periods/*.nc`` (created); None: write nothing.  Periods
        already stored there for the same scene are reused, not computed.
    client : dask.distributed.Client, optional
        Run the periods on this cluster (one task per period); default: here,
        one after the other.  The results are identical bit for bit.
    progress : bool
        Show a progress bar (tqdm) over the periods.
    log : callable, optional
        Receives one line per decision (field kind and why, periods reused,
        files written).
    on_period : callable, optional
        Called as ``on_period(index, dataset)`` after each period is computed
        and stored (a progress hook; an exception it raises stops the run, the
        stored periods stay).

    Returns
    -------
    xarray.Dataset
        The periods joined along ``period`` (:func:`~cwlidar_sim.campaign.store.combine_periods`);
        ``attrs["periods_reused"]`` lists the periods taken from disk.

    Raises
    ------
    PreflightError
        Before anything is computed, when the results could not be written.
    ResultsWriteError
        When writing a finished period fails (the periods written before stay).
    """
    from .store import PeriodStore, combine_periods, preflight, write_results

    task, estimate_bytes, finalise = _sensor(scene)
    from .auto import resolve

    say = log or (lambda s: None)
    t0 = time.perf_counter()
    auto_why = {}
    if scene.kind == "staring":  # "auto" tier / field.dx / cell_length: the cheapest sufficient setting
        scene, auto_why = resolve(scene)
    for key, why in auto_why.items():
        say(f"{key} = {why}")
    preflight(out_dir, estimate_bytes(scene))
    params = fit_info = None
    if scene.kind == "staring":
        params, fit_info = scene_params(scene)
        if fit_info is not None:
            say(f"turbulence fitted to {fit_info['path']}: {params}")
        for p in scene.periods:
            kind, why = choose_field(scene, p)
            say(f"period {p.name}: {kind} field ({why})")
    names = scene.unit_names()
    store = PeriodStore(out_dir, scene, params) if out_dir is not None else None
    done = {}
    if store is not None:
        for i, name in enumerate(names):
            ds = store.load(i)
            if ds is not None:
                done[i] = ds
                say(f"period {name}: reused {store.path(i)}")
    reused = [names[i] for i in sorted(done)]
    todo = [i for i in range(len(names)) if i not in done]

    def finish(i, ds):
        if store is not None:
            ds = store.save(i, ds)
            say(f"period {names[i]}: written to {store.path(i)}")
        done[i] = ds
        if on_period is not None:
            on_period(i, ds)

    if client is not None and todo:
        from dask.distributed import as_completed

        futures = {client.submit(task, scene, i, params, pure=False): i for i in todo}
        try:
            for fut in as_completed(futures):
                finish(futures[fut], fut.result())
        finally:
            for fut in futures:
                fut.cancel()
    elif todo:
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(names), initial=len(done), desc=scene.name, unit="period")
        try:
            for i in todo:
                status = (lambda s, b=bar: b.set_postfix_str(s, refresh=True)) if bar is not None else None
                finish(i, task(scene, i, params, status=status))
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    ds = combine_periods([done[i] for i in range(len(names))])
    if finalise is not None:
        ds = finalise(ds)
    ds.attrs["wall_time"] = float(time.perf_counter() - t0)
    ds.attrs["periods_reused"] = json.dumps(reused)
    ds.attrs["auto_choice"] = json.dumps(auto_why)
    if fit_info is not None:
        ds.attrs["turbulence_fit"] = json.dumps(fit_info)
    if store is not None:
        path = os.path.join(os.fspath(out_dir), f"{scene.name}.nc")
        write_results(ds, path)
        say(f"results written to {path}")
    return ds
