"""Run a scene: field, sensors, 10 Hz series, transfer functions, theory, results file.

Each period is independent and seeded from the scene (see
:meth:`Scene.period_seed`), so a scene gives the same bits whether its periods
run one after the other here or on the workers of a Dask cluster.

Pipeline of one period
----------------------
1. Field: the cheapest one the sensors need (:func:`choose_field`): a line
   along x when the beam is aligned with the wind and the sonic sits on it, a
   horizontal plane when the beam is horizontal, a box otherwise.  Its length
   covers ``U * duration`` plus the sensors' extent along x, so no turbulence
   is seen twice.
2. Sonic at 32 Hz (total wind, Taylor advection), projected on the beam as
   the speed toward the lidar, resampled to 10 Hz by A2012 Eqs. 5-7.  Its
   sampling starts 1/64 s after the lidar's so that both 10 Hz series are
   centred on ``0.05 + 0.1 j`` s.
3. Staring lidar at 50 Hz through the chosen tier, block-averaged by 5 to
   10 Hz; estimates inside a background pause are NaN and flagged PAUSED.
4. Spectra of 10-min segments averaged over the period and log-smoothed on a
   common wavenumber grid (``k = 2 pi f / U``), both transfer functions
   (A2012 Eqs. 8 and 11), the theory exp(-2 k zR) and the misaligned theory
   of A2012 Eqs. 12-14 with the Mann parameters fitted to the sonic.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time

import numpy as np

from .scene import Scene

__all__ = ["FieldPlan", "choose_field", "plan_field", "run_period", "run_scene", "scene_params", "RESULTS_VERSION"]

RESULTS_VERSION = 1
#: The lidar's 50 Hz estimates are block-averaged by this to 10 Hz (A2012).
LIDAR_BLOCK = 5
#: Sonic sampling starts this late [s] so its 10 Hz centres match the lidar's.
SONIC_DELAY = 1.0 / 64.0
#: Background cycle of the prototype: a pause of this length [s] every period [s].
PAUSE_LENGTH, PAUSE_EVERY = 600.0, 10800.0


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
        rec = xr.open_dataset(path)
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


def _generate(plan: FieldPlan, params, seed):
    from ..turbulence import generate_box, generate_line, generate_plane

    if plan.kind == "line":
        return generate_line(params, plan.shape[0], plan.spacing[0], seed)
    if plan.kind == "plane":
        return generate_plane(params, plan.shape, plan.spacing, seed, z=float(plan.lidar_position[2]))
    return generate_box(params, plan.shape, plan.spacing, seed)


def _transverse_speed(scene, period, params):
    if scene.lidar.transverse_speed is not None:
        return scene.lidar.transverse_speed
    from ..turbulence import covariances

    c = covariances(params)
    return math.sqrt(c.vv + c.ww + (period.mean_speed * math.sin(math.radians(period.misalignment_deg))) ** 2)


def _lidar(scene, plan, params, period, extra=None):
    from ..sensors import StaringLidar

    spec = scene.lidar
    inst = spec.build_instrument(extra)
    az = 180.0 + period.misalignment_deg
    return StaringLidar(
        instrument=inst, position=tuple(float(x) for x in plan.lidar_position), azimuth_deg=az,
        elevation_deg=spec.elevation_deg, tier=spec.tier, weighting=spec.weighting, span=spec.span,
        cell_length=spec.cell_length or plan.spacing[0], cnr_db=spec.cnr_db,
        transverse_speed=_transverse_speed(scene, period, params), speckle=spec.speckle,
        exact_background=spec.exact_background,
    )


def run_period(scene: Scene, index: int, params, *, status=None) -> dict:
    """Simulate and analyse one period.

    Parameters
    ----------
    scene : Scene
    index : int
        Period index.
    params : MannParameters
        Turbulence of the field.
    status : callable, optional
        Called with a short text at each stage (progress display).

    Returns
    -------
    dict
        Plain arrays and numbers (see :func:`run_scene` for their meaning);
        picklable, so periods can run on Dask workers.
    """
    from ..analysis import log_bins, transfer_functions
    from ..sensors import Sonic, block_average, measure_staring, resample_a2012, sample_sonic
    from ..signal.processing import Flag

    say = status or (lambda s: None)
    period = scene.periods[index]
    U = period.mean_speed
    T = scene.period_duration(period)
    if scene.lidar.tier == "signal":
        from ..sensors import SIGNAL_MAX_ESTIMATES

        longest = SIGNAL_MAX_ESTIMATES / scene.lidar.build_instrument().estimate_rate
        if T > longest:
            raise ValueError(f"lidar.tier = 'signal' simulates every 50 MHz sample; period {period.name!r} lasts "
                             f"{T} s, allowed: <= {longest:g} s (use 'spectral' for campaigns)")
    seeds = np.random.SeedSequence(scene.period_seed(index)).spawn(3)
    s_field, s_sonic, s_lidar = (int(s.generate_state(1, np.uint64)[0] >> np.uint64(1)) for s in seeds)
    t0 = time.perf_counter()
    plan = plan_field(scene, index, params)
    say(f"{period.name}: {plan.kind} field {plan.shape}")
    field = _generate(plan, params, s_field)
    t_field = time.perf_counter() - t0

    # --- sonic: 32 Hz, 16-sample partitions -> 10 Hz ---------------------
    n10 = int(math.floor(T / 0.5 + 1e-9)) * 5
    n32 = n10 // 5 * 16
    t32 = SONIC_DELAY + np.arange(n32) / 32.0
    sonic = Sonic(position=tuple(float(x) for x in plan.sonic_position), rate=32.0, noise_std=scene.sonic.noise_std)
    say(f"{period.name}: sonic")
    vel_tc = sample_sonic(field, sonic, t32, U, seed=s_sonic, wrap=plan.wrap)
    vs32 = -(vel_tc @ plan.direction)
    vs10 = resample_a2012(vs32)
    comp10_tc = resample_a2012(vel_tc)

    # --- lidar: 50 Hz -> 10 Hz -------------------------------------------
    n50 = n10 * LIDAR_BLOCK
    t50 = (np.arange(n50) + 0.5) / 50.0
    lidar = _lidar(scene, plan, params, period)
    variants = [dict(v) for v in scene.lidar.variants]
    say(f"{period.name}: lidar ({scene.lidar.tier})")
    t1 = time.perf_counter()
    rec = measure_staring(field, lidar, t50, U, s_lidar, variants=variants or None, wrap=plan.wrap)
    t_lidar = time.perf_counter() - t1
    del field
    paused = np.zeros(n50, dtype=bool)
    if scene.lidar.background_pause:
        paused = np.mod(period.start + t50, PAUSE_EVERY) < PAUSE_LENGTH

    def lidar_series(speed_e, flags_e):
        speed = np.array(speed_e, dtype=np.float64)
        flags = np.array(flags_e, dtype=np.uint8)
        speed[paused] = np.nan
        flags[paused] |= np.uint8(Flag.PAUSED)
        mean10, nvalid10, flags10 = block_average(speed, LIDAR_BLOCK, flags)
        return speed, flags, mean10, nvalid10, flags10

    speed50, flags50, vr10, nvalid10, flags10 = lidar_series(rec.speed_e, rec.flags_e)
    ideal50 = -np.asarray(rec.vlos_e, dtype=np.float64)
    ideal10 = block_average(ideal50, LIDAR_BLOCK)[0]

    # --- analysis ----------------------------------------------------------
    say(f"{period.name}: analysis")
    a = scene.analysis
    k_edges = log_bins(a.k_min, a.k_max, a.per_decade)

    def tf(vr):
        try:
            return transfer_functions(vr, vs10, fs=10.0, U=U, k_edges=k_edges, segment_duration=a.segment_duration,
                                      window=a.window, detrend=a.detrend)
        except ValueError as e:
            if "no usable segment" not in str(e):
                raise
            return _empty_transfer(k_edges, U, n10, a.segment_duration)

    main = tf(vr10)
    ideal = tf(ideal10)
    var_out = {}
    for v in variants:
        sp, fl = rec.variants[v["name"]]
        _, fl50, v10, _, _ = lidar_series(sp, fl)
        var_out[v["name"]] = {"tf": tf(v10), "lidar_10hz": v10, "flag_counts": _flag_counts(fl50),
                              "availability": float(np.mean(np.isfinite(v10)))}
    fit = None
    if a.fit:
        from ..analysis import component_spectra, fit_mann

        say(f"{period.name}: fitting the tensor to the sonic")
        kf = log_bins(a.k_min, min(a.k_max, math.pi * 10.0 / U), a.per_decade)
        u10 = comp10_tc[:, 0]
        ks, F11, F22, F33, F13, nk = component_spectra(u10, comp10_tc[:, 1], comp10_tc[:, 2], fs=10.0, U=U,
                                                       k_edges=kf, segment_duration=a.segment_duration)
        # n_k gives chi-square-based uncertainties (the residual-variance ones understate Gamma's 2.5-fold)
        fit = fit_mann(ks, F11, F22, F33, F13, n_k=nk)
    return {
        "index": index, "name": period.name, "U": U, "theta": period.misalignment_deg, "duration": T,
        "plan": plan, "field_seed": s_field,
        "sonic_velocity": vel_tc.astype(np.float32), "sonic_10hz": vs10, "sonic_components_10hz": comp10_tc,
        "lidar_speed": speed50.astype(np.float32), "lidar_flags": flags50, "lidar_ideal": ideal50.astype(np.float32),
        "lidar_10hz": vr10, "lidar_10hz_valid": nvalid10, "lidar_10hz_flags": flags10, "ideal_10hz": ideal10,
        "tf": main, "tf_ideal": ideal, "variants": var_out, "fit": fit,
        "flag_counts": _flag_counts(flags50), "availability": float(np.mean(np.isfinite(speed50))),
        "availability_10hz": float(np.mean(np.isfinite(vr10))),
        "lidar_info": dict(rec.info), "timing": {"field": t_field, "lidar": t_lidar,
                                                  "total": time.perf_counter() - t0},
    }


def _empty_transfer(k_edges, U, n10, segment_duration):
    """All-NaN transfer functions of a period with no usable segment (every one gapped)."""
    from ..analysis import TransferEstimate

    nk = len(k_edges) - 1
    nan = np.full(nk, np.nan)
    e = np.asarray(k_edges)
    return TransferEstimate(k_k=np.sqrt(e[:-1] * e[1:]), k_edges=e, F_r_k=nan, F_s_k=nan, chi_k=nan + 0j, T1_k=nan,
                            T2_k=nan, coherence_k=nan, n_k=np.zeros(nk), sigma_T1_k=nan, sigma_T2_k=nan,
                            n_segments=0, n_rejected=int(n10 // round(segment_duration * 10.0)), n_interpolated=0,
                            U=U)


def _flag_counts(flags):
    from ..signal.processing import Flag

    return {f.name: int(np.count_nonzero(flags & np.uint8(f.value))) for f in Flag}


def run_scene(scene: Scene, out_dir=None, *, client=None, progress: bool = True, log=None):
    """Run every period of a scene and assemble the results.

    Parameters
    ----------
    scene : Scene
    out_dir : str or path, optional
        Folder for ``<scene.name>.nc`` (created); None: write nothing.
    client : dask.distributed.Client, optional
        Run the periods on this cluster (one task per period); default: here,
        one after the other.  The results are identical bit for bit.
    progress : bool
        Show a progress bar (tqdm) over the periods.
    log : callable, optional
        Receives one line per decision (field kind and why, output path).

    Returns
    -------
    xarray.Dataset
        See :func:`assemble`.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a Scene, got {type(scene).__name__}")
    say = log or (lambda s: None)
    t0 = time.perf_counter()
    params, fit_info = scene_params(scene)
    if fit_info is not None:
        say(f"turbulence fitted to {fit_info['path']}: {params}")
    for i, p in enumerate(scene.periods):
        kind, why = choose_field(scene, p)
        say(f"period {p.name}: {kind} field ({why})")
    if client is not None:
        futures = [client.submit(run_period, scene, i, params, pure=False) for i in range(len(scene.periods))]
        results = client.gather(futures)
    else:
        results = []
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(scene.periods), desc=scene.name, unit="period")
        try:
            for i in range(len(scene.periods)):
                status = (lambda s, b=bar: b.set_postfix_str(s, refresh=True)) if bar is not None else None
                results.append(run_period(scene, i, params, status=status))
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    ds = assemble(scene, params, results, fit_info=fit_info, wall_time=time.perf_counter() - t0)
    if out_dir is not None:
        os.makedirs(out_dir, exist_ok=True)
        path = os.path.join(os.fspath(out_dir), f"{scene.name}.nc")
        write_results(ds, path)
        say(f"results written to {path}")
    return ds


def _pad(arrs, fill=np.nan):
    """Stack per-period arrays, padding shorter periods (floats with NaN, integers with ``fill`` or 0)."""
    n = max(a.shape[0] for a in arrs)
    dtype = arrs[0].dtype
    if fill is None:
        fill = np.nan if np.issubdtype(dtype, np.floating) else 0
    out = np.full((len(arrs), n) + arrs[0].shape[1:], fill, dtype=dtype)
    for i, a in enumerate(arrs):
        out[i, : a.shape[0]] = a
    return out


def assemble(scene: Scene, params, results, *, fit_info=None, wall_time=float("nan")):
    """Results of all periods as one xarray.Dataset (see the variables' ``long_name`` and ``units``).

    Dimensions: ``period``; ``k`` (wavenumber bin centres [rad/m]);
    ``variant`` (extra processings); ``time_32hz``, ``time_50hz``,
    ``time_10hz`` (sample times within the period [s]; shorter periods are
    padded with NaN); ``component`` (u, v, w); ``flag`` (quality flags).
    """
    import xarray as xr

    from ..analysis import misaligned_spectra, transfer_aligned
    from ..signal.processing import Flag

    results = sorted(results, key=lambda r: r["index"])
    inst = scene.lidar.build_instrument()
    zR = inst.rayleigh_length
    tf0 = results[0]["tf"]
    k = np.asarray(tf0.k_k)
    names = [r["name"] for r in results]
    vnames = [v["name"] for v in scene.lidar.variants]
    flags = [f.name for f in Flag]
    P = len(results)

    def per_k(get):
        return np.stack([np.asarray(get(r), dtype=np.float64) for r in results])

    n32 = max(r["sonic_velocity"].shape[0] for r in results)
    n50 = max(r["lidar_speed"].shape[0] for r in results)
    n10 = max(r["sonic_10hz"].shape[0] for r in results)
    coords = {
        "period": ("period", names),
        "k": ("k", k, {"units": "rad m-1", "long_name": "wavenumber k1 = 2 pi f / U (log-bin centre)"}),
        "k_lower": ("k", np.asarray(tf0.k_edges)[:-1], {"units": "rad m-1"}),
        "k_upper": ("k", np.asarray(tf0.k_edges)[1:], {"units": "rad m-1"}),
        "variant": ("variant", vnames),
        "component": ("component", ["u", "v", "w"]),
        "flag": ("flag", flags),
        "time_32hz": ("time_32hz", SONIC_DELAY + np.arange(n32) / 32.0, {"units": "s"}),
        "time_50hz": ("time_50hz", (np.arange(n50) + 0.5) / 50.0, {"units": "s"}),
        "time_10hz": ("time_10hz", 0.05 + 0.1 * np.arange(n10), {"units": "s"}),
    }
    spec_units = "m2 s-2 (rad m-1)-1"
    theta = np.array([r["theta"] for r in results])
    # theory with each period's fitted (else the scene's) parameters
    th_ratio = np.empty((P, k.size))
    th_cross = np.empty((P, k.size))
    for i, r in enumerate(results):
        p = r["fit"].params if r["fit"] is not None and r["fit"].success else params
        F_vs, F_vr, chi = misaligned_spectra(k, p, r["theta"], zR)
        th_ratio[i] = F_vr / F_vs
        th_cross[i] = chi**2 / F_vs**2
    dv = {
        "transfer_ratio": (("period", "k"), per_k(lambda r: r["tf"].T1_k),
                           {"units": "1", "long_name": "method 1: F_vr / F_vs (A2012 Eq. 8)"}),
        "transfer_cross": (("period", "k"), per_k(lambda r: r["tf"].T2_k),
                           {"units": "1", "long_name": "method 2: Re(chi_vr_vs)^2 / F_vs^2 (A2012 Eq. 11)"}),
        "transfer_ratio_sigma": (("period", "k"), per_k(lambda r: r["tf"].sigma_T1_k),
                                 {"units": "1", "long_name": "1-sigma sampling uncertainty of transfer_ratio"}),
        "transfer_cross_sigma": (("period", "k"), per_k(lambda r: r["tf"].sigma_T2_k),
                                 {"units": "1", "long_name": "1-sigma sampling uncertainty of transfer_cross"}),
        "transfer_ratio_ideal": (("period", "k"), per_k(lambda r: r["tf_ideal"].T1_k),
                                 {"units": "1", "long_name": "method 1 with the noise-free tier-1 line-of-sight average"}),
        "transfer_cross_ideal": (("period", "k"), per_k(lambda r: r["tf_ideal"].T2_k),
                                 {"units": "1", "long_name": "method 2 with the noise-free tier-1 line-of-sight average"}),
        "transfer_theory": (("k",), transfer_aligned(k, zR),
                            {"units": "1", "long_name": "exp(-2 k zR) (A2012 Eq. 9), beam along the wind"}),
        "transfer_theory_cells": (("k",), np.abs(_cells(scene).transfer(k)) ** 2,
                                  {"units": "1", "long_name": "|phi_hat(k)|^2 of the simulated probe volume (the "
                                   "lidar's range cells and weights: exact or Lorentzian weighting, clipped at "
                                   "the telescope and the span), beam along the wind"}),
        "transfer_theory_ratio": (("period", "k"), th_ratio,
                                  {"units": "1", "long_name": "F_vr / F_vs at the period's misalignment (A2012 Eqs. 12-13)"}),
        "transfer_theory_cross": (("period", "k"), th_cross,
                                  {"units": "1", "long_name": "chi^2 / F_vs^2 at the period's misalignment (A2012 Eqs. 12, 14)"}),
        "spectrum_sonic": (("period", "k"), per_k(lambda r: r["tf"].F_s_k),
                           {"units": spec_units, "long_name": "one-sided wavenumber spectrum of the sonic's radial speed"}),
        "spectrum_lidar": (("period", "k"), per_k(lambda r: r["tf"].F_r_k),
                           {"units": spec_units, "long_name": "one-sided wavenumber spectrum of the lidar's speed"}),
        "cross_spectrum_real": (("period", "k"), per_k(lambda r: np.real(r["tf"].chi_k)),
                                {"units": spec_units, "long_name": "Re of the lidar x sonic cross-spectrum"}),
        "cross_spectrum_imag": (("period", "k"), per_k(lambda r: np.imag(r["tf"].chi_k)),
                                {"units": spec_units, "long_name": "Im of the lidar x sonic cross-spectrum"}),
        "n_segments": (("period",), np.array([r["tf"].n_segments for r in results]),
                       {"units": "1", "long_name": "10-min segments used in the lidar-sonic spectra"}),
        "n_segments_rejected": (("period",), np.array([r["tf"].n_rejected for r in results]),
                                {"units": "1", "long_name": "segments dropped for gaps (e.g. background pause)"}),
        "n_k": (("period", "k"), per_k(lambda r: r["tf"].n_k),
                {"units": "1", "long_name": "raw periodogram values averaged into each bin"}),
        "mean_speed": (("period",), np.array([r["U"] for r in results]), {"units": "m s-1"}),
        "misalignment": (("period",), theta, {"units": "degree", "long_name": "mean wind direction minus beam direction"}),
        "duration": (("period",), np.array([r["duration"] for r in results]), {"units": "s"}),
        "field_kind": (("period",), np.array([r["plan"].kind for r in results], dtype=object)),
        "field_shape": (("period",), np.array(["x".join(map(str, r["plan"].shape)) for r in results], dtype=object)),
        "field_seed": (("period",), np.array([r["field_seed"] for r in results], dtype=np.int64)),
        "availability": (("period",), np.array([r["availability"] for r in results]),
                         {"units": "1", "long_name": "fraction of valid 50 Hz lidar estimates"}),
        "availability_10hz": (("period",), np.array([r["availability_10hz"] for r in results]), {"units": "1"}),
        "flag_count": (("period", "flag"), np.array([[r["flag_counts"][f] for f in flags] for r in results]),
                       {"units": "1", "long_name": "50 Hz estimates carrying each quality flag"}),
        "correlation_time": (("period",), np.array([r["lidar_info"].get("correlation_time", np.nan) for r in results],
                                                   dtype=np.float64), {"units": "s", "long_name": "speckle correlation time"}),
        "sonic_velocity": (("period", "time_32hz", "component"), _pad([r["sonic_velocity"] for r in results]),
                           {"units": "m s-1", "long_name": "sonic wind (U + u, v, w) at 32 Hz"}),
        "sonic_10hz": (("period", "time_10hz"), _pad([r["sonic_10hz"] for r in results]),
                       {"units": "m s-1", "long_name": "sonic speed toward the lidar, A2012 Eqs. 5-7 to 10 Hz"}),
        "lidar_speed": (("period", "time_50hz"), _pad([r["lidar_speed"] for r in results]),
                        {"units": "m s-1", "long_name": "lidar speed estimate at 50 Hz (NaN: failed, see lidar_flags)"}),
        "lidar_flags": (("period", "time_50hz"), _pad([r["lidar_flags"] for r in results], fill=None),
                        {"long_name": "quality flags (bit field)", "flag_masks": [int(f.value) for f in Flag],
                         "flag_meanings": " ".join(flags)}),
        "lidar_ideal": (("period", "time_50hz"), _pad([r["lidar_ideal"] for r in results]),
                        {"units": "m s-1", "long_name": "tier-1 weighted line-of-sight speed toward the lidar (A2012 Eq. 2)"}),
        "lidar_10hz": (("period", "time_10hz"), _pad([r["lidar_10hz"] for r in results]),
                       {"units": "m s-1", "long_name": "lidar speed, 50 Hz block-averaged by 5 over valid estimates"}),
        "lidar_10hz_valid": (("period", "time_10hz"), _pad([r["lidar_10hz_valid"].astype(np.int16) for r in results], fill=None),
                             {"units": "1", "long_name": "valid 50 Hz estimates in each 10 Hz block"}),
    }
    if vnames:
        def per_vk(get):
            return np.stack([per_k(lambda r, n=n: get(r["variants"][n])) for n in vnames])

        dv["transfer_ratio_variant"] = (("variant", "period", "k"), per_vk(lambda v: v["tf"].T1_k),
                                        {"units": "1", "long_name": "method 1 for each processing variant"})
        dv["transfer_cross_variant"] = (("variant", "period", "k"), per_vk(lambda v: v["tf"].T2_k),
                                        {"units": "1", "long_name": "method 2 for each processing variant"})
        dv["availability_variant"] = (("variant", "period"),
                                      np.array([[r["variants"][n]["availability"] for r in results] for n in vnames]),
                                      {"units": "1", "long_name": "fraction of valid 10 Hz lidar samples"})
        dv["lidar_10hz_variant"] = (("variant", "period", "time_10hz"),
                                    np.stack([_pad([r["variants"][n]["lidar_10hz"] for r in results]) for n in vnames]),
                                    {"units": "m s-1"})
    fits = [r["fit"] for r in results]
    if any(f is not None for f in fits):
        for name, units in (("alpha_eps", "m4/3 s-2"), ("length_scale", "m"), ("gamma", "1")):
            dv[f"fit_{name}"] = (("period",), np.array([getattr(f.params, name) if f else np.nan for f in fits]),
                                 {"units": units, "long_name": f"Mann {name} fitted to the sonic spectra"})
            dv[f"fit_{name}_std"] = (("period",), np.array([f.std[name] if f else np.nan for f in fits]),
                                     {"units": units, "long_name": f"1-sigma uncertainty of fit_{name}"})
    attrs = {
        "title": f"cwlidar_sim campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "rayleigh_length": float(zR),
        "rayleigh_length_units": "m",
        "focus": float(inst.focus),
        "lidar_tier": scene.lidar.tier,
        "lidar_estimator": inst.estimator,
        "cnr_db": float(scene.lidar.cnr_db),
        "alpha_eps": params.alpha_eps, "length_scale": params.length_scale, "gamma": params.gamma,
        "scene": json.dumps(scene.as_dict()),
        "variants": json.dumps([dict(v) for v in scene.lidar.variants]),
        "field_reasons": json.dumps({r["name"]: r["plan"].reason for r in results}),
        "timing": json.dumps({r["name"]: r["timing"] for r in results}),
        "wall_time": float(wall_time),
        "spectrum_convention": "one-sided in k1 = 2 pi f / U: variance = integral of F dk over 0..inf",
    }
    if fit_info is not None:
        attrs["turbulence_fit"] = json.dumps(fit_info)
    from .. import __version__

    attrs["cwlidar_sim_version"] = __version__
    return xr.Dataset(data_vars=dv, coords=coords, attrs=attrs)


def _cells(scene):
    from ..sensors import StaringLidar

    spec = scene.lidar
    return StaringLidar(instrument=spec.build_instrument(), weighting=spec.weighting, span=spec.span,
                        cell_length=spec.cell_length or scene.field.dx).cells()


def write_results(ds, path):
    """Write a results Dataset to NetCDF (h5netcdf); object arrays are stored as strings."""
    ds = ds.copy()
    for name in ("field_kind", "field_shape", "period", "variant", "component", "flag"):
        if name in ds.variables:
            ds[name] = ds[name].astype(str)
    ds.to_netcdf(path, engine="h5netcdf")


def read_results(path):
    """Read a results file written by :func:`run_scene` (loaded into memory)."""
    import xarray as xr

    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return ds.load()
    except (OSError, ValueError) as e:
        raise ValueError(f"cannot read results file {os.fspath(path)!r}: {e}") from None
