"""One period of CS's experiment (CS: 10 minutes): field, conical lidar, cup, sonic, VAD fits and CS's model.

:func:`simulate_conical_period` is the unit of work of the CS reproduction
(one height, one seed; the 1 s and 3 s scans come from the same record, as
a ZephIR's two software settings would see the same air);
:func:`simulate_conical_cycle` is one period of a lidar cycling through
several heights in one box.  A period joins the sensors
(:mod:`cwlidar_sim.sensors`) and the analysis (:mod:`cwlidar_sim.analysis.vad`,
:mod:`cwlidar_sim.analysis.cs_model`), so it lives in the campaign layer, next
to the staring period (:mod:`cwlidar_sim.campaign.periods.staring`).

Set-up (choices, each stated)
-----------------------------
* Turbulence: one box per height (:func:`cwlidar_sim.turbulence.cover.cover_box`),
  Mann parameters of a neutral surface layer over flat terrain at that height
  (:func:`cwlidar_sim.turbulence.surface_layer.surface_layer_parameters`: u* from the
  log law with z0 = 0.01 m, then by default Mann's (1994) fit of his tensor
  to Kaimal's neutral spectra, L = 0.59 z, alpha eps^(2/3) = 3.2 u*^2 z^(-2/3),
  Gamma = 3.9; IEC 61400-1 with sigma_u = 2.4 u* as an option), laterally
  doubled by default.  A box per height rather than one spanning all heights:
  each box then needs only its own cone (a spanning box would be as tall as
  the highest cone and as wide as its circle for every height).
* Cycling through heights (:func:`simulate_conical_cycle`): one box spanning
  every height's cone (that is what a cycle needs: the heights share the
  air), with one tensor, that of the surface layer at the mean of the
  heights, and one advection speed; spacing by default that of the lowest
  height.  The cup and the sonic at each height record the whole period
  (the sonic is read at that height's estimate times).
* Wind direction: the field's x axis lies along the mean wind; a wind toward
  ``wind_direction_deg`` in the lidar's frame turns the scan by
  ``-wind_direction_deg`` in the field, and the VAD's and the sonic's
  directions are reported in the lidar's frame.
* Grid spacing: ``height / 20`` by default (2 m at 40 m, 5 m at 100 m), so
  that the circle diameter ``D = 1.155 z`` spans about 23 cells at every
  height and the scan filter (the dominant one, scale ``l_az >= D``) is well
  resolved; the probe filter (``2 z_R = 5.5 m`` at 40 m, 35 m at 100 m) is
  resolved by 1.4-3.5 cells.  The cup and the sonic sample the same grid,
  on its nodes (next item): a paired study (docs/convergence.md) finds the
  ratio within 0.002 of the default's with a half and a third of the
  lateral spacing.
* Sensors on the scan axis, at the grid node nearest ``(0, 0, z)`` across the
  wind (:func:`cwlidar_sim.sensors.nearest_node`: at most half a cell off;
  between nodes a point sensor reads their linear interpolation, an average
  that lowered the cup's sigma by 1.6-2 % and raised the std ratio by up to
  0.016, varying with the box's parity and the height).  CS's mast stood 50 m
  from the lidars; with Taylor's hypothesis an along-wind offset is only a
  delay, a cross-wind one lowers the coherence of the largest scales a little.
* The cup: :class:`cwlidar_sim.sensors.cup.Cup` at 10 Hz, distance constant 2.3 m.
* Direction reference: ``'previous'`` (default): the first scan by the
  sonic's (vane's) mean direction over the period, later scans by the previous
  resolved scan; ``'vane'``: each scan by the sonic's direction over it.
  The ``ambiguity_rate`` is the fraction of fitted scans whose resolved
  direction is more than 90 deg from the sonic's direction over the scan.

Measured results, with their settings: docs/reproductions/cs.md and docs/convergence.md (its last table is
the one these notes held, measured at span 5).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..._seeding import seed_int
from ..._validation import check_choice, check_int, check_real, check_seed, check_tuple
from ...signal.processing import usable_fraction
from ..scenes.conical import default_spacing

__all__ = ["simulate_conical_period", "simulate_conical_cycle", "cycle_reference_height"]


def cycle_reference_height(heights) -> float:
    """Height [m] whose surface layer sets the one tensor of a cycling lidar's box: the mean of the heights."""
    return float(np.mean(np.asarray(heights, dtype=np.float64)))


def _scan_direction(vel_ec, rev, n_rev):
    from ...analysis.vad import scan_arrays

    u = scan_arrays(vel_ec[:, 0], rev, n_rev).mean(axis=1)
    v = scan_arrays(vel_ec[:, 1], rev, n_rev).mean(axis=1)
    return np.degrees(np.arctan2(v, u))


def _ratio(num: float, den: float) -> float:
    """num / den, NaN where the reference varies not at all (a frozen uniform wind: no ratio to take)."""
    return num / den if den != 0.0 else math.nan


def _wrap180(deg: float) -> float:
    """An angle in [-180, 180) [deg]."""
    return (float(deg) + 180.0) % 360.0 - 180.0


def simulate_conical_period(height: float, seed: int, *, speed: float = 10.0, duration: float = 600.0,
                            scan_revs=(1, 3), tier: str = "los", spacing: float | None = None,
                            lateral_doubling: bool = True, params=None, reference: str = "previous",
                            sub_dwells: int = 8, model: bool = True, lidar_overrides: dict | None = None,
                            excluded_flags: int | None = None, wind_direction_deg: float = 0.0, variants=None,
                            field_span: float | None = None, box_options: dict | None = None,
                            condition=None, field_source=None) -> dict:
    """Simulate one period: a Mann box, the conical lidar, a cup and a sonic at one height.

    Parameters
    ----------
    height : float
        Measurement height z [m].
    seed : int
        Seed of the period (box and lidar streams are spawned from it).
    speed : float
        Mean wind speed at z [m/s]; in (0, 50].
    duration : float
        Period length [s]; in [10, 3600].  CS: 600.
    scan_revs : tuple of int
        Revolutions per VAD scan to evaluate (1: 1 s scans, 3: 3 s scans).
    tier : {'los', 'spectral', 'signal'}
        Lidar tier (:mod:`cwlidar_sim.sensors.conical`).
    spacing : float, optional
        Box spacing [m]; default :func:`~cwlidar_sim.campaign.scenes.conical.default_spacing`.
    lateral_doubling : bool
        Generate the box twice as wide and keep half.
    params : MannParameters, optional
        Tensor; default the neutral surface layer at ``height`` and ``speed``.
    reference : {'previous', 'vane'}
        Resolution of the 180 deg ambiguity (module notes).
    sub_dwells : int
        Looks per 20 ms dwell.
    model : bool
        Also evaluate CS's filter model (Kaimal and Mann spectra).
    lidar_overrides : dict, optional
        Further :class:`~cwlidar_sim.sensors.ConicalLidar` fields (e.g. ``{'cnr_db': -15}``, or a
        cloud: ``{'cloud_base': 1000, 'cloud_strength': 1e4}``).
    excluded_flags : int, optional
        :class:`cwlidar_sim.signal.Flag` bits whose points the VAD fits leave
        out (:func:`cwlidar_sim.analysis.vad.fit_record`); default its own
        (every flag, SECOND_PEAK included).
    wind_direction_deg : float
        Direction the mean wind blows toward in the lidar's frame [deg], from
        its azimuth 0 toward +y; any finite value (module notes).
    variants : list of dict, optional
        Processing variants of the lidar's spectra (:data:`cwlidar_sim.signal.chain.VARIANT_KEYS`):
        each gets its own VAD fits, in ``variants``.
    field_span : float, optional
        Size the box for this span [z_R] instead of the lidar's own (at
        least the lidar's): with it, lidars of different spans measure the
        same turbulence (a paired study of the span).
    box_options : dict, optional
        Numerical settings of the box (a convergence study's knobs), passed
        to :func:`cwlidar_sim.turbulence.cover.cover_box`: ``spacing``
        (one value or (dx, dy, dz) [m]; default ``spacing``, which also sets
        the cells' length), ``extent`` ((Lx, Ly, Lz) [m]: a fixed physical
        size, so that boxes of other spacings and one seed share their
        Fourier coefficients), ``hf_compensation`` (bool), ``min_extent``
        (lateral and vertical minimum [m], default 2 L), ``period_x`` (the
        box's exact x period [m]: the virtual twin's ``U T``).
    condition : callable, optional
        ``condition(box) -> box``: the generated box conditioned on records
        before its lateral half is kept (the virtual twin,
        :mod:`cwlidar_sim.campaign.twin.run`); see
        :func:`cwlidar_sim.turbulence.cover.cover_box`.
    field_source : callable, optional
        ``field_source(region, U, duration) -> Dataset``: a field the user
        has, read and placed instead of the generated box
        (:meth:`cwlidar_sim.campaign.scenes.turbulence_spec.TurbulenceSpec.field_source`).

    Returns
    -------
    dict
        Plain numbers (and a few small dicts): ``height``, ``speed``,
        ``seed``, ``tier``, ``spacing``, ``box_shape``, ``lateral_doubling``,
        ``in_situ_position`` (the cup's and the sonic's (x, y, z) [m], the grid
        node nearest ``(0, 0, height)`` across the wind), ``params`` (dict),
        ``u_star``, ``sigma_u_target``, ``cup_mean``,
        ``cup_std``, ``sonic_std`` (horizontal speed), ``cup_subgrid_variance``,
        ``sonic_subgrid_variance`` (their expected variance below the box's grid,
        :mod:`cwlidar_sim.campaign.periods.in_situ`; NaN for a field from a file),
        ``cup_std_continuum``, ``sonic_std_continuum`` (sigma with it restored), ``sonic_radial_variance``
        [m^2/s^2] (the projected point variance, :mod:`cwlidar_sim.analysis.vad`),
        ``sonic_direction`` (the sonic's mean direction in the lidar's frame
        [deg], in [-180, 180)), ``availability`` (finite estimates),
        ``zero_crossing_loss`` (fraction of estimates flagged NO_SIGNAL or
        NEAR_ZERO), ``second_peak_fraction`` (fraction flagged SECOND_PEAK),
        ``cloud_fraction`` (the cloud's share of the received power, 0
        without a cloud), ``n_estimates``, ``cost_s`` (wall time of the
        stages) and ``scans``: for each n in ``scan_revs`` a dict with
        ``lidar_mean``, ``lidar_std`` [m/s], ``lidar_direction`` (mean VAD
        direction in the lidar's frame [deg], in [-180, 180)), ``std_ratio``
        (lidar/cup), ``std_ratio_cup_continuum`` (over ``cup_std_continuum``), ``mean_speed_bias`` (lidar mean / cup mean - 1), ``tp``
        (mean TP), ``radial_variance`` (mean (TP U)^2),
        ``radial_variance_ratio`` (over ``sonic_radial_variance``),
        ``availability`` (fitted scans), ``points_used_fraction``,
        ``selected`` (CS's 65 % rule), ``ambiguity_rate``,
        ``unresolved_rate``, ``l_az`` [m] and, with ``model``,
        ``std_ratio_model_kaimal``, ``std_ratio_model_mann``,
        ``radial_variance_ratio_model_kaimal``, ``radial_variance_ratio_model_mann``;
        ``variants``: variant name -> the same per-scan dicts (without the model).
    """
    z = check_real("height", height, lo=1.0, hi=1000.0)
    return _simulate((z,), seed, speed=speed, duration=duration, scan_revs=scan_revs, tier=tier, spacing=spacing,
                     lateral_doubling=lateral_doubling, params=params, reference=reference, sub_dwells=sub_dwells,
                     model=model, lidar_overrides=lidar_overrides, excluded_flags=excluded_flags,
                     wind_direction_deg=wind_direction_deg, variants=variants, field_span=field_span,
                     box_options=box_options, condition=condition, field_source=field_source)[0]


def simulate_conical_cycle(heights, seed: int, *, revs_per_height: int, refocus_time: float = 0.0,
                           speed: float = 10.0, duration: float = 600.0, scan_revs=(1,), tier: str = "los",
                           spacing: float | None = None, lateral_doubling: bool = True, params=None,
                           reference: str = "previous", sub_dwells: int = 8, model: bool = True,
                           lidar_overrides: dict | None = None, excluded_flags: int | None = None,
                           wind_direction_deg: float = 0.0, variants=None, field_span: float | None = None,
                           box_options: dict | None = None, condition=None, field_source=None) -> list:
    """Simulate one period of a lidar cycling through several heights in one box (module notes).

    The lidar measures ``revs_per_height`` revolutions at each height in
    turn, losing ``refocus_time`` between heights; each height gets its
    share of the record and its own cup and sonic.

    Parameters
    ----------
    heights : sequence of float
        At least two distinct measurement heights [m].
    revs_per_height : int
        Revolutions at each height before refocusing; in [1, 10000].  Every
        ``scan_revs`` must divide it (a VAD scan cannot span a refocus).
    refocus_time : float
        Time lost between heights [s]; in [0, 100].
    params : MannParameters, optional
        The box's one tensor; default the neutral surface layer at
        :func:`cycle_reference_height` and ``speed``.
    spacing : float, optional
        Box spacing [m]; default :func:`~cwlidar_sim.campaign.scenes.conical.default_spacing` of the lowest height.
    others
        As :func:`simulate_conical_period`.

    Returns
    -------
    list of dict
        One dict per height (in the order of ``heights``), each as
        :func:`simulate_conical_period` returns, the box's keys (``box_shape``,
        ``spacing``, ``params``, ``u_star``, ``sigma_u_target``, ``cost_s``)
        shared.
    """
    if isinstance(heights, (str, bytes)) or not hasattr(heights, "__len__") or len(heights) < 2:
        raise ValueError(f"heights must list at least 2 heights [m] to cycle through, got {heights!r}")
    hs = check_tuple("heights", heights, len(heights), lambda n, v: check_real(n, v, lo=1.0, hi=1000.0))
    if len(set(hs)) != len(hs):
        raise ValueError(f"heights must be distinct, got {hs}")
    revs = check_int("revs_per_height", revs_per_height, lo=1, hi=10000)
    overrides = dict(lidar_overrides or {})
    overrides.update(revs_per_height=revs, refocus_time=check_real("refocus_time", refocus_time, lo=0.0, hi=100.0))
    return _simulate(hs, seed, speed=speed, duration=duration, scan_revs=scan_revs, tier=tier, spacing=spacing,
                     lateral_doubling=lateral_doubling, params=params, reference=reference, sub_dwells=sub_dwells,
                     model=model, lidar_overrides=overrides, excluded_flags=excluded_flags,
                     wind_direction_deg=wind_direction_deg, variants=variants, field_span=field_span,
                     box_options=box_options, condition=condition, field_source=field_source)


def _conical_lidar(heights, tier, cell_length, sub_dwells, lidar_overrides, wind_direction_deg):
    """The ConicalLidar of a period in the field's frame: its scan turned by ``-wind_direction_deg``."""
    from ...sensors.conical import ConicalLidar

    kw = dict(heights=tuple(heights), tier=tier, cell_length=cell_length, sub_dwells=sub_dwells)
    kw.update(lidar_overrides or {})
    if wind_direction_deg:
        # the wind blows along +x in the field; the lidar's azimuth 0 lies at -wind_direction there
        kw["azimuth0_deg"] = float(kw.get("azimuth0_deg", 0.0)) - wind_direction_deg
    return ConicalLidar(**kw)


def _simulate(heights, seed, *, speed, duration, scan_revs, tier, spacing, lateral_doubling, params, reference,
              sub_dwells, model, lidar_overrides, excluded_flags, wind_direction_deg, variants=None,
              field_span=None, box_options=None, condition=None, field_source=None) -> list:
    """The box, the lidar at ``heights`` (one: dwell, several: cycle), cups and sonics, fits: one dict per height."""
    from ...analysis.vad import sonic_radial_variance
    from ...sensors import Cup, Sonic, nearest_node, sample_cup, sample_sonic
    from ...sensors.conical import measure_conical
    from ...turbulence.cover import cover_box
    from .in_situ import continuum_std, field_subgrid_variance
    from ...turbulence.surface_layer import surface_layer_parameters
    from ...signal.processing import Flag
    from ...turbulence.parameters import MannParameters

    seed = check_seed("seed", seed)
    U = check_real("speed", speed, lo=0.0, hi=50.0, lo_open=True)
    duration = check_real("duration", duration, lo=10.0, hi=3600.0)
    if isinstance(scan_revs, (int, np.integer)):
        scan_revs = (scan_revs,)
    scan_revs = tuple(check_int(f"scan_revs[{i}]", n, lo=1, hi=60) for i, n in enumerate(scan_revs))
    if not scan_revs:
        raise ValueError("scan_revs must name at least one scan length (revolutions), e.g. (1, 3)")
    check_choice("reference", reference, ("previous", "vane"))
    wind_direction_deg = check_real("wind_direction_deg", wind_direction_deg)
    cycle = len(heights) > 1
    z_low = min(heights)
    d = default_spacing(z_low) if spacing is None else check_real("spacing", spacing, lo=0.0, hi=100.0, lo_open=True)
    su_target = ustar = None
    if params is None:
        params, su_target, ustar = surface_layer_parameters(cycle_reference_height(heights) if cycle else z_low, U)
    elif not isinstance(params, MannParameters):
        raise TypeError(f"params must be MannParameters, got {type(params).__name__}")
    lidar = _conical_lidar(heights, tier, d, sub_dwells, lidar_overrides, wind_direction_deg)
    if cycle:
        bad = [n for n in scan_revs if lidar.revs_per_height % n]
        if bad:
            raise ValueError(f"scan_revs {bad} must divide revs_per_height = {lidar.revs_per_height} (a VAD scan "
                             f"cannot span a refocus); allowed: its divisors")
    box_seq, lid_seq = np.random.SeedSequence(seed).spawn(2)
    cost = {}
    t0 = time.perf_counter()
    box_lidar = lidar
    if field_span is not None:
        box_lidar = lidar.replace(span=max(lidar.span, check_real("field_span", field_span, lo=0.0, hi=1e4,
                                                                   lo_open=True)), cloud_base=None,
                                  cloud_strength=0.0)
    box_kw = _box_options(box_options, d)
    field = cover_box(box_lidar.box_region(box_kw["spacing"]), U, duration, params,
                          seed_int(box_seq),
                          lateral_doubling=lateral_doubling, condition=condition, source=field_source, **box_kw)
    cost["box"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    rec = measure_conical(field, lidar, duration, U, np.random.default_rng(lid_seq), variants=variants)
    cost["lidar"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    missing = [z for z in heights if not np.any(rec.height_e == z)]
    if missing:
        raise ValueError(f"duration={duration:g} s leaves heights {missing} without a complete block of "
                         f"{lidar.revs_per_height} revolutions; allowed: longer periods or fewer revs_per_height")
    box_shape = tuple(int(field.sizes[c]) for c in ("x", "y", "z"))
    box_spacing = tuple(float(field[c].values[1] - field[c].values[0]) for c in ("x", "y", "z"))
    in_situ = {}
    for z in heights:
        sel = rec.select(z)
        # on the grid's nearest node across the wind: between nodes the cup would read their average
        pos = nearest_node(field, (0.0, 0.0, z))
        cup = Cup(position=pos)
        # the variance below the grid each reads without (analysis.point_subgrid), reported beside the raw sigma
        sub = (field_subgrid_variance(field, pos, params, U, duration, time_constant=cup.distance_constant / U,
                                      sample_interval=1.0 / cup.rate),
               field_subgrid_variance(field, pos, params, U, duration, sample_interval=duration / sel["time_e"].size))
        in_situ[z] = (sel, sample_sonic(field, Sonic(position=pos), sel["time_e"], U),
                      sample_cup(field, cup, cup.times(duration), U), pos, sub)
    cost["in_situ"] = time.perf_counter() - t0
    del field
    out = []
    for z in heights:
        sel, vel_ec, cup_t, pos, (cup_sub, sonic_sub) = in_situ[z]
        sonic_h = np.hypot(vel_ec[:, 0], vel_ec[:, 1])
        flags_e = sel["flags_e"]
        r = {
            "height": z, "speed": U, "seed": seed, "duration": duration, "tier": lidar.tier, "spacing": d,
            "box_shape": box_shape, "box_spacing": box_spacing, "lateral_doubling": bool(lateral_doubling),
            "in_situ_position": pos, "params": params.as_dict(), "u_star": ustar, "sigma_u_target": su_target,
            "cup_mean": float(cup_t.mean()), "cup_std": float(cup_t.std(ddof=1)),
            "sonic_std": float(sonic_h.std(ddof=1)),
            "cup_subgrid_variance": cup_sub, "sonic_subgrid_variance": sonic_sub,
            "cup_std_continuum": continuum_std(cup_t.std(ddof=1), cup_sub),
            "sonic_std_continuum": continuum_std(sonic_h.std(ddof=1), sonic_sub),
            "sonic_radial_variance": sonic_radial_variance(vel_ec, sel["azimuth_e"], lidar.half_angle_deg),
            "availability": usable_fraction(sel["speed_e"], flags_e),
            "zero_crossing_loss": float(np.mean((flags_e & (Flag.NO_SIGNAL | Flag.NEAR_ZERO)) != 0)),
            "second_peak_fraction": float(np.mean((flags_e & Flag.SECOND_PEAK) != 0)),
            "cloud_fraction": float(rec.info["heights"][z].get("cloud_fraction", 0.0)),
            "n_estimates": int(sel["time_e"].size), "scans": {},
        }
        t0 = time.perf_counter()
        _scans(r, rec, lidar, z, U, vel_ec, sel["revolution_e"], params, scan_revs, reference, model, excluded_flags,
               wind_direction_deg)
        r["variants"] = {}
        for name, (sp, fl) in rec.variants.items():
            tmp = {k: r[k] for k in ("cup_std", "cup_mean", "sonic_radial_variance")} | {"scans": {}}
            _scans(tmp, dataclasses.replace(rec, speed_e=sp, flags_e=fl), lidar, z, U, vel_ec, sel["revolution_e"],
                   params, scan_revs, reference, False, excluded_flags, wind_direction_deg)
            r["variants"][name] = tmp["scans"]
        r["cost_s"] = dict(cost, fit_and_model=time.perf_counter() - t0)
        out.append(r)
    return out


def _box_options(options, spacing) -> dict:
    """cover_box's keywords from ``box_options`` (names checked), the spacing defaulting to ``spacing``."""
    allowed = ("spacing", "extent", "hf_compensation", "min_extent", "period_x")
    opts = dict(options or {})
    bad = sorted(set(opts) - set(allowed))
    if bad:
        raise ValueError(f"box_options: unknown keys {bad}; allowed: {list(allowed)}")
    opts.setdefault("spacing", spacing)
    return opts


def _scans(out, rec, lidar, z, U, vel_ec, rev_e, params, scan_revs, reference, model, excluded_flags,
           wind_direction_deg):
    """The VAD fits at height z for each scan length, into ``out['scans']`` (directions in the lidar's frame)."""
    from ...analysis import cs_model
    from ...analysis.vad import ambiguity_rate, fit_record, period_statistics

    # the fits run in the field's frame (the wind along +x); directions are reported in the lidar's
    mean_dir = math.degrees(math.atan2(vel_ec[:, 1].mean(), vel_ec[:, 0].mean()))
    out["sonic_direction"] = _wrap180(mean_dir + wind_direction_deg)
    for n in scan_revs:
        true_dir = _scan_direction(vel_ec, rev_e, n)
        if reference == "vane":
            ref = true_dir
        else:
            ref = np.full(true_dir.shape, np.nan)
            ref[:1] = mean_dir
        fit = fit_record(rec, z, n, half_angle_deg=lidar.half_angle_deg, reference_deg=ref,
                         excluded_flags=excluded_flags)
        st = period_statistics(fit)
        s = {
            "lidar_mean": st["mean_speed"], "lidar_std": st["std_speed"],
            "lidar_direction": _wrap180(st["mean_direction"] + wind_direction_deg),
            "std_ratio": _ratio(st["std_speed"], out["cup_std"]),
            "std_ratio_cup_continuum": _ratio(st["std_speed"], out.get("cup_std_continuum", math.nan)),
            "mean_speed_bias": _ratio(st["mean_speed"], out["cup_mean"]) - 1.0,
            "tp": st["mean_tp"], "radial_variance": st["radial_variance"],
            "radial_variance_ratio": _ratio(st["radial_variance"], out["sonic_radial_variance"]),
            "availability": st["availability"], "points_used_fraction": st["mean_points_used_fraction"],
            "selected": st["selected"], "ambiguity_rate": ambiguity_rate(fit.direction_p, true_dir),
            "unresolved_rate": st["unresolved_rate"], "n_scans": st["n_scans"],
            "l_az": cs_model.scan_length(z, U, n, half_angle_deg=lidar.half_angle_deg,
                                         revolution_time=lidar.revolution_time),
        }
        if model:
            zr = lidar.instrument_at(z).rayleigh_length
            for name, mkw in (("kaimal", {"spectrum": "kaimal"}),
                              ("mann", {"spectrum": "mann", "params": params})):
                m = cs_model.model_ratios(z, U, n, half_angle_deg=lidar.half_angle_deg,
                                          revolution_time=lidar.revolution_time, rayleigh_length=zr, n_k=3000,
                                          **mkw)
                s[f"std_ratio_model_{name}"] = m["std_ratio"]
                s[f"radial_variance_ratio_model_{name}"] = m["radial_variance_ratio"]
        out["scans"][n] = s
