"""The staring lidar against a sonic (A2012): one period's simulation and its results.

Pipeline of one period
----------------------
1. Field: the cheapest one the sensors need (:func:`cwlidar_sim.campaign.periods.staring_field.choose_field`):
   a line along x when the beam is aligned with the wind and the sonic sits on
   it, a horizontal plane when the beam is horizontal, a box otherwise.  Its
   length covers ``U * duration`` plus the sensors' extent along x, so no
   turbulence is seen twice.
2. Sonic at 32 Hz (total wind, Taylor advection), projected on the beam as
   the speed toward the lidar (the results' sign, each series' ``sign_convention``
   attribute), resampled to 10 Hz by A2012 Eqs. 5-7.  Its
   sampling starts 1/64 s after the lidar's so that both 10 Hz series are
   centred on ``0.05 + 0.1 j`` s.
3. Staring lidar at 50 Hz through the chosen tier, block-averaged by 5 to
   10 Hz; estimates inside a background pause are NaN and flagged PAUSED.
4. Spectra of ``analysis.segment_duration`` segments (A2012: 10 min)
   averaged over the period and log-smoothed on a common wavenumber grid (``k = 2 pi f / U``), both transfer functions
   (A2012 Eqs. 8 and 11), the theory exp(-2 k zR) and the misaligned theory
   of A2012 Eqs. 12-14 with the Mann parameters fitted to the sonic.
5. :func:`period_dataset`: the period as a one-period xarray.Dataset.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ..._seeding import seed_int
from ..._version import __version__
from ...signal.processing import usable_fraction, usable_speeds
from ...turbulence.limits import check_frozen_turbulence
from .._labels import HOMODYNE, TOWARD_LIDAR, duration_phrase
from . import in_situ
from .theory import STARING_PER_DECADE, STARING_RESOLUTION, cached, staring_transfer_theory
from .staring_field import generate_field, period_params, plan_field, theory_params
from ..scenes.staring import Scene
from ..scenes.spec import RESULTS_VERSION, entry_label

__all__ = ["run_unit", "estimate_bytes", "estimate_unit", "summarise", "summary", "COST_S_PER_SIM_HOUR", "VARIANT_COST", "period_dataset", "estimator_theory", "fit_probe_length_results", "LIDAR_BLOCK",
           "SONIC_DELAY"]

#: The lidar's 50 Hz estimates are block-averaged by this to 10 Hz (A2012).
LIDAR_BLOCK = 5
#: Sonic sampling starts this late [s] so its 10 Hz centres match the lidar's.
SONIC_DELAY = 1.0 / 64.0
#: Wall time per simulated hour of one period on one idle core of the reference machine [s]
#: (tier 1, 2, 3 with the A2012 scene's line/plane fields; from benchmarks/bench_campaign.py and bench_signal.py).
COST_S_PER_SIM_HOUR = {"los": 10.0, "spectral": 40.0, "signal": 5000.0}
#: Extra cost of each processing variant, as a fraction of the spectral tier's [-].
VARIANT_COST = 0.08


def estimate_bytes(scene) -> float:
    """Rough size of a staring scene's results [bytes]: the raw series dominate.

    Per second of period: sonic 32 Hz x 3 float32, lidar 50 Hz x (float32
    speed + uint8 flags + float32 ideal), 10 Hz series in float64 (sonic,
    three components, lidar, ideal, valid counts, one per processing variant).
    """
    per_s = 32 * 3 * 4 + 50 * (4 + 1 + 4) + 10 * (8 * (6 + len(scene.lidar.variants)) + 2)
    return sum(per_s * scene.period_duration(p) for p in scene.periods) + 1e6


def estimate_unit(scene: Scene, index: int, params=None) -> dict:
    """Estimated wall time [s] on one core and peak memory [bytes] of period ``index``.

    ``scene`` with its automatic settings resolved (:func:`cwlidar_sim.campaign.periods.staring_auto.resolve`)
    and ``params`` its tensor (:func:`cwlidar_sim.campaign.periods.staring_field.scene_params`).
    Time: :data:`COST_S_PER_SIM_HOUR` of the tier per simulated hour, plus
    :data:`VARIANT_COST` per processing variant, plus field generation (about
    30 ns per field point and component).  Memory: the period's field (3
    float32 components, twice for a box's transform) and its raw series in
    float64 (results and analysis copies).
    """
    p = scene.periods[index]
    hours = scene.period_duration(p) / 3600.0
    plan = plan_field(scene, index, params)
    points = math.prod(plan.shape)
    seconds = hours * COST_S_PER_SIM_HOUR[scene.lidar.tier] * (1.0 + VARIANT_COST * len(scene.lidar.variants))
    seconds += 3 * points * 30e-9
    field = 3 * 4 * points * (2.0 if plan.kind == "box" else 1.0)
    series = 3.0 * estimate_bytes(scene.replace(periods=(p,)))
    return {"seconds": seconds, "memory_bytes": field + series}


def _transverse_speed(scene, period, params):
    if scene.lidar.transverse_speed is not None:
        return scene.lidar.transverse_speed
    from ...turbulence import covariances

    c = covariances(params)
    return math.sqrt(c.vv + c.ww + (period.mean_speed * math.sin(math.radians(period.misalignment_deg))) ** 2)


def _lidar(scene, plan, params, period, extra=None):
    from ...sensors import StaringLidar

    spec = scene.lidar
    kw = spec.sensor_kwargs(plan.spacing[0])
    kw["transverse_speed"] = _transverse_speed(scene, period, params)
    return StaringLidar(instrument=spec.build_instrument(extra), position=tuple(float(x) for x in plan.lidar_position),
                        azimuth_deg=180.0 + period.misalignment_deg, elevation_deg=spec.elevation_deg, **kw)


def _subcell_spread(scene, params):
    """The estimator theory's speed spread [m/s]: the tensor's below the field spacing and the line broadening.

    The same quadrature sum the signal chain forms for the run
    (:class:`cwlidar_sim.signal.chain.ChainSettings`, ``line_broadening``).
    """
    from ...turbulence import subcell_variance

    spread = scene.lidar.subcell_spread
    if spread is None:
        spread = math.sqrt(subcell_variance(params, scene.field.dx))
    if scene.lidar.line_broadening == 0.0:
        return spread
    dv = 0.5 * scene.lidar.build_instrument().wavelength * scene.lidar.line_broadening
    return math.sqrt(spread * spread + dv * dv)


def run_unit(scene: Scene, index: int, params=None, *, status=None, make_field=None):
    """Simulate and analyse one period of a staring scene.

    Parameters
    ----------
    scene : Scene
    index : int
        Period index.
    params : MannParameters or None
        Turbulence of the scene's fields; None: each period's own
        (:func:`cwlidar_sim.campaign.periods.staring_field.period_params`, a table whose
        tensor depends on the period's mean speed).
    status : callable, optional
        Called with a short text at each stage (progress display).
    make_field : callable, optional
        ``make_field(plan, seed) -> (plan, field)`` instead of the plan's
        unconditioned field (the virtual twin, :mod:`cwlidar_sim.campaign.twin.run`,
        conditions it on records); the sensors fly through whatever it returns.

    Returns
    -------
    xarray.Dataset
        The period's results with a ``period`` dimension of length 1 (see
        :func:`period_dataset`); picklable, so periods can run on Dask workers.
    """
    from ...analysis import log_bins, transfer_functions
    from ...sensors import Sonic, block_average, measure_staring, resample_a2012, sample_sonic

    say = status or (lambda s: None)
    period = scene.periods[index]
    U = period.mean_speed
    T = scene.period_duration(period)
    scene_tensor, params = params, period_params(scene, index, params)
    # a fitted tensor (turbulence.fit_to) is known only now: the same check as the scene's, before any field
    check_frozen_turbulence(params, U, entry_label("period", index, period.name))
    if scene.lidar.tier == "signal":
        from ...signal.chain import SIGNAL_MAX_ESTIMATES

        longest = SIGNAL_MAX_ESTIMATES / scene.lidar.build_instrument().estimate_rate
        if T > longest:
            raise ValueError(f"lidar.tier = 'signal' simulates every 50 MHz sample; {entry_label('period', index, period.name)} lasts "
                             f"{T} s, allowed: <= {longest:g} s (use 'spectral' for campaigns)")
    seeds = np.random.SeedSequence(scene.unit_seed(index)).spawn(3)
    s_field, s_sonic, s_lidar = (seed_int(s) for s in seeds)
    t0 = time.perf_counter()
    plan = plan_field(scene, index, params)
    say(f"{period.name}: {plan.kind} field {plan.shape}")
    if make_field is None:
        if scene.turbulence.condition_on:
            raise ValueError(f"scene {scene.name!r} names records in [turbulence] condition_on: its periods are the "
                             f"records' and its fields are conditioned on them; run it with 'cwlidar-sim twin' "
                             f"(cwlidar_sim.campaign.twin.run.run_twin)")
        field = generate_field(plan, params, s_field)
    else:
        plan, field = make_field(plan, s_field)
    t_field = time.perf_counter() - t0

    # --- sonic: 32 Hz, 16-sample partitions -> 10 Hz ---------------------
    n10 = int(math.floor(T / 0.5 + 1e-9)) * 5
    n32 = n10 // 5 * 16
    t32 = SONIC_DELAY + np.arange(n32) / 32.0
    sonic = Sonic(position=tuple(float(x) for x in plan.sonic_position), rate=32.0, noise_std=scene.sonic.noise_std)
    say(f"{period.name}: sonic")
    vel_tc = sample_sonic(field, sonic, t32, U, seed=s_sonic, wrap=plan.wrap)
    vs32 = -(vel_tc @ plan.direction)
    # the variance below the field's grid the sonic's beam-projected 32-Hz series misses (periods.in_situ)
    sonic_sub = in_situ.field_subgrid_variance(field, sonic.position, params, U, n32 / 32.0,
                                               direction=tuple(plan.direction), sample_interval=1.0 / 32.0)
    sonic_note = in_situ.subgrid_unavailable(field)
    vs10 = resample_a2012(vs32)
    comp10_tc = resample_a2012(vel_tc)

    # --- lidar: 50 Hz -> 10 Hz -------------------------------------------
    n50 = n10 * LIDAR_BLOCK
    t50 = (np.arange(n50) + 0.5) / 50.0
    lidar = _lidar(scene, plan, params, period)
    variants = [dict(v) for v in scene.lidar.variants]
    say(f"{period.name}: lidar ({scene.lidar.tier})")
    t1 = time.perf_counter()
    # the background drifts from its last calibration (the 3-h schedule counted from the campaign start)
    rec = measure_staring(field, lidar, t50, U, s_lidar, variants=variants or None, wrap=plan.wrap,
                          calibration_time=period.start)
    t_lidar = time.perf_counter() - t1
    del field
    # the background's pauses (lidar.background_pause) are the signal chain's: NaN flagged PAUSED

    def lidar_series(speed_e, flags_e):
        speed = np.array(speed_e, dtype=np.float64)
        flags = np.array(flags_e, dtype=np.uint8)
        # an unusable estimate (NaN, or finite but NEAR_ZERO / NEAR_NYQUIST) never enters the 10 Hz mean
        mean10, nvalid10, flags10 = block_average(usable_speeds(speed, flags), LIDAR_BLOCK, flags)
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
        sp50, fl50, v10, _, _ = lidar_series(sp, fl)
        var_out[v["name"]] = {"tf": tf(v10), "lidar_10hz": v10, "flag_counts": _flag_counts(fl50),
                              "availability": usable_fraction(sp50, fl50)}
    fit = None
    if a.fit:
        from ...analysis import component_spectra, fit_mann

        say(f"{period.name}: fitting the tensor to the sonic")
        kf = log_bins(a.k_min, min(a.k_max, math.pi * 10.0 / U), a.per_decade)
        u10 = comp10_tc[:, 0]
        ks, F11, F22, F33, F13, nk = component_spectra(u10, comp10_tc[:, 1], comp10_tc[:, 2], fs=10.0, U=U,
                                                       k_edges=kf, segment_duration=a.segment_duration)
        # n_k gives chi-square-based uncertainties (the residual-variance ones understate Gamma's 2.5-fold)
        fit = fit_mann(ks, F11, F22, F33, F13, n_k=nk)
    result = {
        "index": index, "name": period.name, "U": U, "theta": period.misalignment_deg, "duration": T,
        "plan": plan, "field_seed": s_field,
        "sonic_velocity": vel_tc.astype(np.float32), "sonic_10hz": vs10, "sonic_components_10hz": comp10_tc,
        "lidar_speed": speed50.astype(np.float32), "lidar_flags": flags50, "lidar_ideal": ideal50.astype(np.float32),
        "lidar_10hz": vr10, "lidar_10hz_valid": nvalid10, "lidar_10hz_flags": flags10, "ideal_10hz": ideal10,
        "tf": main, "tf_ideal": ideal, "variants": var_out, "fit": fit,
        "sonic_std": float(vs32.std(ddof=1)), "sonic_subgrid_variance": sonic_sub, "sonic_subgrid_note": sonic_note,
        "flag_counts": _flag_counts(flags50), "availability": usable_fraction(speed50, flags50),
        "availability_10hz": float(np.mean(np.isfinite(vr10))),
        "lidar_info": dict(rec.info), "timing": {"field": t_field, "lidar": t_lidar,
                                                  "total": time.perf_counter() - t0},
    }
    return period_dataset(scene, scene_tensor, result)


def summarise(ds):
    """The joined periods as they are (every variable is per period already)."""
    return ds


def summary(scene: Scene, ds) -> dict:
    """The CLI's short report: the Rayleigh length and each period's availability."""
    return {"rayleigh_length_m": ds.attrs["rayleigh_length"],
            "availability": {str(p): round(float(a), 4) for p, a in zip(ds.period.values, ds.availability.values)}}


def _empty_transfer(k_edges, U, n10, segment_duration):
    """All-NaN transfer functions of a period with no usable segment (every one gapped)."""
    from ...analysis import TransferEstimate

    nk = len(k_edges) - 1
    nan = np.full(nk, np.nan)
    e = np.asarray(k_edges)
    return TransferEstimate(k_k=np.sqrt(e[:-1] * e[1:]), k_edges=e, F_r_k=nan, F_s_k=nan, chi_k=nan + 0j,
                            transfer_ratio_k=nan, transfer_cross_k=nan, coherence_k=nan, n_k=np.zeros(nk),
                            transfer_ratio_sigma_k=nan, transfer_cross_sigma_k=nan,
                            n_segments=0, n_rejected=int(n10 // round(segment_duration * 10.0)), n_interpolated=0,
                            U=U)


def _flag_counts(flags):
    from ...signal.processing import Flag

    return {f.name: int(np.count_nonzero(flags & np.uint8(f.value))) for f in Flag}


def _readings():
    """The 10 Hz readings as weighted samples about their times: ``(lidar_average, sonic_average)`` ``(t_j [s], a_j)``.

    The lidar's: the :data:`LIDAR_BLOCK` 50 Hz looks of its block; the
    sonic's: A2012 Eqs. 5-7's weights on the 32 Hz samples (from
    :data:`SONIC_DELAY`) about each output's 10 Hz time, averaged over the
    five outputs of a 16-sample partition (their own filters differ by a
    few ms of delay: below 1e-3 of the spectra under 2 Hz).
    """
    from ...sensors import resample_a2012

    t_l = (np.arange(LIDAR_BLOCK) + 0.5) / 50.0 - 0.5 / 10.0
    w_os = resample_a2012(np.eye(16))
    dt_os = (SONIC_DELAY + np.arange(16) / 32.0)[None, :] - (0.05 + 0.1 * np.arange(w_os.shape[0]))[:, None]
    m = w_os != 0.0
    return (t_l, np.full(LIDAR_BLOCK, 1.0 / LIDAR_BLOCK)), (dt_os[m], w_os[m] / w_os.shape[0])


def _linear_theory_variables(scene, r, params, PK, pk):
    """``transfer_ratio_theory``, ``transfer_cross_theory``: the general linear theory of the period's own geometry.

    :func:`cwlidar_sim.campaign.periods.theory.staring_transfer_theory` of
    the period's lidar (its beam at the period's misalignment, range cells,
    weighting), the sonic's position, both readings' 10 Hz filters
    (:func:`_readings`) and the period's field tensor ``params``, binned on
    the results' k grid as the simulated transfer functions are.
    """
    period, plan, a = scene.periods[r["index"]], r["plan"], scene.analysis
    lidar = _lidar(scene, plan, params, period)
    la, sa = _readings()
    th = staring_transfer_theory(lidar, plan.sonic_position, params, period.mean_speed, r["tf"].k_edges,
                                 segment_duration=a.segment_duration, sample_rate=10.0, lidar_average=la,
                                 sonic_average=sa, window=a.window)
    how = (f"general linear theory (cwlidar_sim.analysis.linear_theory): frozen Mann continuum of the period's field "
           f"tensor; weighting: the simulated range cells of the '{scene.lidar.weighting}' weighting (span "
           f"{scene.lidar.span:g} zR, tail '{scene.lidar.tail}'), cut at the sub-points' Nyquist; the beam at the "
           f"period's misalignment, the sonic at its position; the lidar's 50 Hz looks block-averaged and the "
           f"sonic's A2012 Eqs. 5-7 taps; the periodogram's expectation (the '{a.window}' window's kernel) "
           f"averaged over each bin; numerics: {STARING_PER_DECADE} k1 per decade, polar quadrature resolution "
           f"{STARING_RESOLUTION:g}; not included: aliasing, the mean's removal (lowest bins), the estimator (tier los's statistic)")
    box = ("continuum (the field's own lines along x move it < 1e-4; a plane's k2 cut-off at pi / dy lowers the "
           "simulated method 1 above ~0.2 rad/m: studies/staring_theory_vs_simulation.py)")
    out = {
        "transfer_ratio_theory": (PK, pk(th["transfer_ratio_k"]), {
            "units": "1", "long_name": "method 1 (F_vr / F_vs), linear theory of the period's geometry",
            "theory": how, "weighting": scene.lidar.weighting, "box": box}),
        "transfer_cross_theory": (PK, pk(th["transfer_cross_k"]), {
            "units": "1", "long_name": "method 2 (Re(chi)^2 / F_vs^2), linear theory of the period's geometry",
            "theory": how, "weighting": scene.lidar.weighting, "box": box}),
    }
    lat, lbox = _lattice_theory(scene, r, params, lidar, th)
    for name, key, what in (("transfer_ratio_theory_lattice", "transfer_ratio_k", "method 1 (F_vr / F_vs)"),
                            ("transfer_cross_theory_lattice", "transfer_cross_k", "method 2 (Re(chi)^2 / F_vs^2)")):
        out[name] = (PK, pk(lat[key]), {
            "units": "1", "long_name": f"{what}, linear theory of the period's geometry on the field's own lattice",
            "theory": how.replace("frozen Mann continuum of", "the generated field's own modes of").replace(
                ", cut at the sub-points' Nyquist", " (each sub-point read as simulated)"),
            "weighting": scene.lidar.weighting, "box": lbox})
    return out


def _lattice_theory(scene, r, params, lidar, th):
    """The period's theory on its field's own modes and the ``box`` attribute naming the field (or why NaN)."""
    plan, a = r["plan"], scene.analysis
    nan = {"transfer_ratio_k": np.full_like(th["transfer_ratio_k"], np.nan),
           "transfer_cross_k": np.full_like(th["transfer_cross_k"], np.nan)}
    if plan.field is not None or scene.turbulence.condition_on:
        return nan, ("NaN: the field is read from a file or conditioned on records, not a plane or line generated "
                     "from the tensor")
    if plan.kind == "line":
        return th, (f"line {plan.shape} at dx = {plan.spacing[0]:g} m: its modes hold the exact one-point spectra "
                    f"at every k1 and the sensors lie on it, so the lattice is the continuum (its lines along x "
                    f"move it < 1e-4)")
    if plan.kind != "plane":
        return nan, "NaN: the lattice theory of a staring box is not built (a plane or a line is)"
    if plan.spacing[0] > r["U"] / 10.0:
        return nan, (f"NaN: the plane's dx = {plan.spacing[0]:g} m exceeds U / (10 Hz) = {r['U'] / 10.0:.4g} m: the "
                     f"aliases of its reading along x fall inside the 10-Hz series' band (not built)")
    la, sa = _readings()
    lat = staring_transfer_theory(lidar, plan.sonic_position, params, r["U"], r["tf"].k_edges,
                                  segment_duration=a.segment_duration, sample_rate=10.0, lidar_average=la,
                                  sonic_average=sa, window=a.window,
                                  plane=(plan.shape, plan.spacing, plan.lidar_position[:2]))
    return lat, (f"plane {plan.shape} at (dx, dy) = {plan.spacing} m (generate_plane: k3 integrated, k2 up to "
                 f"pi / dy), the telescope at ({plan.lidar_position[0]:.4g}, {plan.lidar_position[1]:.6g}) m in it: "
                 f"the sum over its modes on its rows nearest the theory's k1 grid, the range cells' sub-points and "
                 f"the sonic read bilinearly across y at their own fractions of a cell (x on the modes: the "
                 f"reading's gain is common to both)")


def period_dataset(scene: Scene, params, r: dict):
    """One period's results as an xarray.Dataset (see the variables' ``long_name`` and ``units``).

    Dimensions: ``period`` (length 1); ``k`` (wavenumber bin centres
    [rad/m]); ``variant`` (extra processings); ``time_32hz``, ``time_50hz``,
    ``time_10hz`` (sample times within the period [s]); ``component`` (u, v,
    w); ``flag`` (quality flags).  :func:`cwlidar_sim.campaign.execution.store.combine_periods`
    joins the periods of a scene along ``period``.

    ``params``: the scene's tensor (given or fitted), or None where each
    period has its own (then the attributes ``alpha_eps``, ``length_scale``,
    ``gamma`` are the tensor at the mean of the periods' mean speeds, the
    theory's, and ``mann_alpha_eps``, ``mann_length_scale``, ``mann_gamma``
    the period's).
    """
    import xarray as xr

    from ...analysis import misaligned_spectra, transfer_aligned
    from ...signal.processing import Flag

    inst = scene.lidar.build_instrument()
    zR = inst.rayleigh_length
    tf, tf_ideal = r["tf"], r["tf_ideal"]
    k = np.asarray(tf.k_k)
    vnames = [v["name"] for v in scene.lidar.variants]
    flags = [f.name for f in Flag]
    n32, n50, n10 = r["sonic_velocity"].shape[0], r["lidar_speed"].shape[0], r["sonic_10hz"].shape[0]
    coords = {
        "period": ("period", np.array([r["name"]], dtype=object)),
        "k": ("k", k, {"units": "rad m-1", "long_name": "wavenumber k1 = 2 pi f / U (log-bin centre)"}),
        "k_lower": ("k", np.asarray(tf.k_edges)[:-1], {"units": "rad m-1"}),
        "k_upper": ("k", np.asarray(tf.k_edges)[1:], {"units": "rad m-1"}),
        "variant": ("variant", np.array(vnames, dtype=object)),
        "component": ("component", np.array(["u", "v", "w"], dtype=object)),
        "flag": ("flag", np.array(flags, dtype=object)),
        "time_32hz": ("time_32hz", SONIC_DELAY + np.arange(n32) / 32.0, {"units": "s"}),
        "time_50hz": ("time_50hz", (np.arange(n50) + 0.5) / 50.0, {"units": "s"}),
        "time_10hz": ("time_10hz", 0.05 + 0.1 * np.arange(n10), {"units": "s"}),
    }
    spec_units = "m2 s-2 (rad m-1)-1"

    def pk(x, dtype=np.float64):
        """One period's array with the leading ``period`` axis."""
        return np.asarray(x, dtype=dtype)[None]

    # theory with the period's fitted (else its own) parameters
    own, scene_p = period_params(scene, r["index"], params), theory_params(scene, params)
    p = r["fit"].params if r["fit"] is not None and r["fit"].success else own
    F_vs, F_vr, chi = misaligned_spectra(k, p, r["theta"], zR)
    PK = ("period", "k")
    dv = {
        "transfer_ratio": (PK, pk(tf.transfer_ratio_k), {"units": "1", "long_name": "method 1: F_vr / F_vs (A2012 Eq. 8)"}),
        "transfer_cross": (PK, pk(tf.transfer_cross_k),
                           {"units": "1", "long_name": "method 2: Re(chi_vr_vs)^2 / F_vs^2 (A2012 Eq. 11)"}),
        "transfer_ratio_sigma": (PK, pk(tf.transfer_ratio_sigma_k),
                                 {"units": "1", "long_name": "1-sigma sampling uncertainty of transfer_ratio"}),
        "transfer_cross_sigma": (PK, pk(tf.transfer_cross_sigma_k),
                                 {"units": "1", "long_name": "1-sigma sampling uncertainty of transfer_cross"}),
        "transfer_ratio_ideal": (PK, pk(tf_ideal.transfer_ratio_k),
                                 {"units": "1", "long_name": "method 1 with the noise-free tier-1 line-of-sight average"}),
        "transfer_cross_ideal": (PK, pk(tf_ideal.transfer_cross_k),
                                 {"units": "1", "long_name": "method 2 with the noise-free tier-1 line-of-sight average"}),
        "transfer_theory": (("k",), transfer_aligned(k, zR),
                            {"units": "1", "long_name": "exp(-2 k zR) (A2012 Eq. 9), beam along the wind"}),
        "transfer_theory_cells": (("k",), np.abs(_cells(scene).transfer(k)) ** 2,
                                  {"units": "1", "long_name": "|phi_hat(k)|^2 of the simulated probe volume (the "
                                   "lidar's range cells and weights: exact or Lorentzian weighting, clipped at "
                                   "the telescope and the span), beam along the wind"}),
        "transfer_theory_ratio": (PK, pk(F_vr / F_vs),
                                  {"units": "1", "long_name": "F_vr / F_vs at the period's misalignment (A2012 Eqs. 12-13)"}),
        "transfer_theory_cross": (PK, pk(chi**2 / F_vs**2),
                                  {"units": "1", "long_name": "chi^2 / F_vs^2 at the period's misalignment (A2012 Eqs. 12, 14)"}),
        **_linear_theory_variables(scene, r, own, PK, pk),
        "spectrum_sonic": (PK, pk(tf.F_s_k),
                           {"units": spec_units, "long_name": "one-sided wavenumber spectrum of the sonic's radial speed"}),
        "spectrum_lidar": (PK, pk(tf.F_r_k),
                           {"units": spec_units, "long_name": "one-sided wavenumber spectrum of the lidar's speed"}),
        "cross_spectrum_real": (PK, pk(np.real(tf.chi_k)),
                                {"units": spec_units, "long_name": "Re of the lidar x sonic cross-spectrum"}),
        "cross_spectrum_imag": (PK, pk(np.imag(tf.chi_k)),
                                {"units": spec_units, "long_name": "Im of the lidar x sonic cross-spectrum"}),
        "n_segments": (("period",), pk(tf.n_segments, np.int64),
                       {"units": "1", "long_name": f"{duration_phrase(scene.analysis.segment_duration)} segments "
                                                   "used in the lidar-sonic spectra"}),
        "n_segments_rejected": (("period",), pk(tf.n_rejected, np.int64),
                                {"units": "1", "long_name": "segments dropped for gaps (e.g. background pause)"}),
        "n_k": (PK, pk(tf.n_k), {"units": "1", "long_name": "raw periodogram values averaged into each bin"}),
        "mean_speed": (("period",), pk(r["U"]), {"units": "m s-1"}),
        "misalignment": (("period",), pk(r["theta"]),
                         {"units": "degree", "long_name": "mean wind direction minus beam direction"}),
        "duration": (("period",), pk(r["duration"]), {"units": "s"}),
        "field_kind": (("period",), np.array([r["plan"].kind], dtype=object)),
        "field_shape": (("period",), np.array(["x".join(map(str, r["plan"].shape))], dtype=object)),
        "field_seed": (("period",), pk(r["field_seed"], np.int64)),
        "availability": (("period",), pk(r["availability"]),
                         {"units": "1", "long_name": "fraction of usable 50 Hz lidar estimates: finite, with no "
                                                     "failure, NEAR_ZERO or NEAR_NYQUIST flag "
                                                     "(signal.processing.usable_mask)"}),
        "availability_10hz": (("period",), pk(r["availability_10hz"]),
                              {"units": "1", "long_name": "fraction of 10 Hz samples with at least one usable "
                                                          "50 Hz estimate"}),
        "flag_count": (("period", "flag"), pk([r["flag_counts"][f] for f in flags], np.int64),
                       {"units": "1", "long_name": "50 Hz estimates carrying each quality flag"}),
        "correlation_time": (("period",), pk(r["lidar_info"].get("correlation_time", np.nan)),
                             {"units": "s", "long_name": "speckle correlation time"}),
        "sonic_velocity": (("period", "time_32hz", "component"), pk(r["sonic_velocity"], np.float32),
                           {"units": "m s-1", "long_name": "sonic wind (U + u, v, w) at 32 Hz"}),
        "sonic_10hz": (("period", "time_10hz"), pk(r["sonic_10hz"]),
                       {"units": "m s-1", "long_name": "sonic speed toward the lidar, A2012 Eqs. 5-7 to 10 Hz",
                        "sign_convention": TOWARD_LIDAR}),
        "lidar_speed": (("period", "time_50hz"), pk(r["lidar_speed"], np.float32),
                        {"units": "m s-1", "long_name": "lidar speed estimate at 50 Hz (NaN: failed, see lidar_flags)",
                         "sign_convention": HOMODYNE}),
        "lidar_flags": (("period", "time_50hz"), pk(r["lidar_flags"], np.uint8),
                        {"long_name": "quality flags (bit field)", "flag_masks": [int(f.value) for f in Flag],
                         "flag_meanings": " ".join(flags)}),
        "lidar_ideal": (("period", "time_50hz"), pk(r["lidar_ideal"], np.float32),
                        {"units": "m s-1", "long_name": "tier-1 weighted line-of-sight speed toward the lidar (A2012 Eq. 2)",
                         "sign_convention": TOWARD_LIDAR}),
        "lidar_10hz": (("period", "time_10hz"), pk(r["lidar_10hz"]),
                       {"units": "m s-1", "long_name": "lidar speed, 50 Hz block-averaged by 5 over valid estimates",
                        "sign_convention": HOMODYNE}),
        "lidar_10hz_valid": (("period", "time_10hz"), pk(r["lidar_10hz_valid"], np.int16),
                             {"units": "1", "long_name": "valid 50 Hz estimates in each 10 Hz block"}),
    }
    if "sonic_std" in r:  # the sonic's sigma along the beam, raw and with its sub-grid variance (periods.in_situ)
        dv["sonic_std"] = (("period",), pk(r["sonic_std"]), {"units": "m s-1", "long_name": "standard deviation "
                           "(ddof = 1) of the sonic's 32 Hz speed along the beam, its noise included"})
        dv.update(in_situ.sonic_variables(("period",), pk(r["sonic_std"]), pk(r["sonic_subgrid_variance"]),
                                          r["sonic_subgrid_note"], along=" along the beam"))
    if params is None:  # a tensor per period (the scene's table depends on the mean speed)
        for name, units in (("alpha_eps", "m4/3 s-2"), ("length_scale", "m"), ("gamma", "1")):
            dv[f"mann_{name}"] = (("period",), pk(getattr(own, name)),
                                  {"units": units, "long_name": f"Mann {name} of the period's field ([turbulence] at "
                                                                f"its mean speed)"})
    theory = estimator_theory(scene, scene_p)
    if theory is not None:
        coords["estimator"] = ("estimator", np.array(theory.estimators, dtype=object))
        band = f"{theory.band[0]:g}-{theory.band[1]:g} rad/m"
        note = (f"beam along the wind at U = {theory.info['U']:.3g} m/s (mean of the periods), the scene's "
                f"Mann parameters, {theory.info['n_lines']} seeded lines of {theory.info['n_points']} points of "
                "the theory's own (cwlidar_sim.analysis.estimator_transfer), not this run's field")
        dv["transfer_theory_estimator"] = (("estimator", "k"), theory.transfer_cross_ek,
                                           {"units": "1", "long_name": "expected method 2 (Re(chi)^2 / F_vs^2) of "
                                            "each Doppler estimator: " + note})
        dv["transfer_theory_estimator_sigma"] = (("estimator", "k"), theory.transfer_cross_sigma_ek,
                                                 {"units": "1", "long_name": "1-sigma ensemble uncertainty of "
                                                  "transfer_theory_estimator"})
        dv["probe_length_effective"] = (("estimator",), theory.zR_eff_e,
                                        {"units": "m", "long_name": f"zR_eff of the best exp(-2 k zR_eff) to "
                                         f"transfer_theory_estimator over {band}"})
        lm = theory.info["line_mean_log_T2"]
        dv["transfer_theory_estimator_line_scatter"] = (
            ("estimator",), np.std(lm, axis=1, ddof=1) if lm.shape[1] > 1 else np.full(lm.shape[0], np.nan),
            {"units": "1", "long_name": f"standard deviation, line to line ({theory.info['n_points'] * scene.field.dx:g} m "
             f"of field each), of the band mean ({band}) of log transfer_theory_estimator: the realisation scatter "
             "of a record of that length"})
        dv["probe_length_effective_sigma"] = (("estimator",), theory.zR_eff_sigma_e,
                                              {"units": "m", "long_name": "1-sigma uncertainty of probe_length_effective"})
    if vnames:
        var = [r["variants"][n] for n in vnames]
        VPK = ("variant", "period", "k")
        dv["transfer_ratio_variant"] = (VPK, np.stack([pk(v["tf"].transfer_ratio_k) for v in var]),
                                        {"units": "1", "long_name": "method 1 for each processing variant"})
        dv["transfer_cross_variant"] = (VPK, np.stack([pk(v["tf"].transfer_cross_k) for v in var]),
                                        {"units": "1", "long_name": "method 2 for each processing variant"})
        dv["availability_variant"] = (("variant", "period"), np.array([[v["availability"]] for v in var]),
                                      {"units": "1", "long_name": "availability of each processing variant (as "
                                                                "availability)"})
        dv["lidar_10hz_variant"] = (("variant", "period", "time_10hz"), np.stack([pk(v["lidar_10hz"]) for v in var]),
                                    {"units": "m s-1", "long_name": "lidar_10hz of each processing variant",
                                     "sign_convention": HOMODYNE})
    if scene.analysis.fit:
        f = r["fit"]
        for name, units in (("alpha_eps", "m4/3 s-2"), ("length_scale", "m"), ("gamma", "1")):
            dv[f"fit_{name}"] = (("period",), pk(getattr(f.params, name) if f else np.nan),
                                 {"units": units, "long_name": f"Mann {name} fitted to the sonic spectra"})
            dv[f"fit_{name}_std"] = (("period",), pk(f.std[name] if f else np.nan),
                                     {"units": units, "long_name": f"1-sigma uncertainty of fit_{name}"})

    attrs = {
        "title": f"cwlidar_sim campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "sensor": "staring",
        "rayleigh_length": float(zR),
        "rayleigh_length_units": "m",
        "focus": float(inst.focus),
        "lidar_tier": scene.lidar.tier,
        "lidar_estimator": inst.estimator,
        "cnr_db": float(scene.lidar.cnr_db),
        "alpha_eps": scene_p.alpha_eps, "length_scale": scene_p.length_scale, "gamma": scene_p.gamma,
        "scene": json.dumps(scene.as_dict()),
        "variants": json.dumps([dict(v) for v in scene.lidar.variants]),
        "spectrum_convention": "one-sided in k1 = 2 pi f / U: variance = integral of F dk over 0..inf",
        "cwlidar_sim_version": __version__,
        # one period's own (combine_periods gathers them into maps by period name)
        "period_index": int(r["index"]),
        "field_reason": r["plan"].reason,
        "timing": json.dumps(r["timing"]),
    }
    return xr.Dataset(data_vars=dv, coords=coords, attrs=attrs)


def estimator_theory(scene: Scene, params):
    """The estimator-aware theory of a scene (:func:`cwlidar_sim.analysis.estimator_transfer`), or None.

    Computed once per scene and process
    (:func:`~cwlidar_sim.campaign.periods.theory.cached` on the scene's
    lidar, field spacing, analysis grid and turbulence), for tiers 'spectral' and
    'signal' with ``analysis.estimator_theory_lines > 0``: the scene's
    instrument, CNR, weighting, span and cells, the scene's Mann parameters,
    at the mean of the periods' mean speeds, on the analysis's k grid, with
    the theory's own seed (never the run's field).
    """
    from ...analysis import estimator_transfer, log_bins
    from ...analysis.estimator_theory import THEORY_ESTIMATORS

    a, spec = scene.analysis, scene.lidar
    if spec.tier == "los" or a.estimator_theory_lines == 0:
        return None
    U = float(np.mean([p.mean_speed for p in scene.periods]))
    key = json.dumps([spec.as_dict(), scene.field.dx, a.k_min, a.k_max, a.per_decade, a.estimator_theory_lines,
                      params.as_dict(), U], sort_keys=True, default=str)
    return cached(("staring_estimator_theory", key), lambda: estimator_transfer(
        spec.build_instrument(), params, U, estimators=THEORY_ESTIMATORS, k_edges=log_bins(a.k_min, a.k_max,
                                                                                          a.per_decade),
        cnr_db=spec.cnr_db, weighting=spec.weighting, span=spec.span, dx=scene.field.dx,
        cell_length=spec.cell_length or scene.field.dx, cell_growth=spec.cell_growth, tail=spec.tail,
        transverse_speed=spec.transverse_speed, subcell_spread=_subcell_spread(scene, params),
        n_lines=a.estimator_theory_lines, n_points=4096))


def _cells(scene):
    from ...sensors import StaringLidar

    spec = scene.lidar
    return StaringLidar(instrument=spec.build_instrument(), weighting=spec.weighting, span=spec.span,
                        cell_length=spec.cell_length or scene.field.dx, cell_growth=spec.cell_growth,
                        tail=spec.tail).cells()


def fit_probe_length_results(ds, *, estimator=None, **kw):
    """:func:`cwlidar_sim.analysis.fit_probe_length` on a staring scene's results file.

    The periods' method 2 is inverse-variance averaged.

    ``estimator``: the lidar's own (default) or one of its estimator
    variants.  The instrument, turbulence and cells come from the stored
    scene; U is the mean of the periods' mean speeds.  The theory is for the
    beam along the wind: misaligned periods lower method 2 further (A2012
    Eqs. 12-14), which this fit would read as a longer probe.

    Returns
    -------
    cwlidar_sim.analysis.ProbeLengthFit
    """
    from ...analysis.estimator_theory import ProbeLengthError, fit_probe_length

    scene = Scene.from_dict(json.loads(ds.attrs["scene"]))
    main = scene.lidar.build_instrument().estimator
    est = main if estimator is None else estimator
    if est == main:
        T, S = ds.transfer_cross.values, ds.transfer_cross_sigma.values
    else:
        variants = json.loads(ds.attrs.get("variants", "[]"))
        names = [v["name"] for v in variants if v.get("estimator") == est and len(v) == 2]
        if not names:
            have = [main] + [v["estimator"] for v in variants if "estimator" in v]
            raise ProbeLengthError(f"estimator {est!r} is not in these results; available: {have}")
        vi = list(ds.variant.values).index(names[0])
        T, S = ds.transfer_cross_variant.values[vi], ds.transfer_cross_sigma.values
    T, S = np.atleast_2d(T), np.atleast_2d(S)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(np.isfinite(T) & np.isfinite(S) & (S > 0), 1.0 / S**2, 0.0)
        Tm = np.sum(np.where(w > 0, T, 0.0) * w, axis=0) / np.sum(w, axis=0)
        Sm = 1.0 / np.sqrt(np.sum(w, axis=0))
    params = scene.turbulence.params() if scene.turbulence.mode == "explicit" else None
    if params is None:  # fitted, or per period: the theory's tensor (at the mean of the mean speeds), as stored
        from ...turbulence import MannParameters

        params = MannParameters(ds.attrs["alpha_eps"], ds.attrs["length_scale"], ds.attrs["gamma"])
    spec = scene.lidar
    kw.setdefault("cnr_db", spec.cnr_db)
    kw.setdefault("weighting", spec.weighting)
    kw.setdefault("span", spec.span)
    kw.setdefault("dx", scene.field.dx)
    kw.setdefault("transverse_speed", spec.transverse_speed)
    return fit_probe_length(ds.k.values, Tm, Sm, instrument=spec.build_instrument(), params=params,
                            U=float(np.mean(ds.mean_speed.values)), estimator=est, **kw)
