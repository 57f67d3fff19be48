"""The virtual twin of a staring or conical campaign: what this lidar would have measured in these very periods.

A scene names its measured records in ``[turbulence] condition_on`` (each
record's file, kind 'sonic' or 'cup', position [m] relative to the lidar's
focus, noise).  :func:`run_twin` reads them, cuts them into the scene's
periods, and for each period draws ``n_twins`` fields conditioned on the
records (:func:`cwlidar_sim.turbulence.conditioning.condition_field`,
Hoffman & Ribak 1991): every twin holds the eddies the records saw, plus
what they could not see, drawn from the conditional distribution.  The
lidar and the scene's sonic fly through each twin with the normal sensor
code (:func:`cwlidar_sim.campaign.periods.staring.run_unit`); nothing of the
signal chain is new.

Per period (``DIR/<scene>_twin_<period>.nc``): the twins' 10 Hz lidar and
sonic series, their statistics over the period (mean, standard deviation) and the
transfer functions T1, T2 and the coherence of each twin's lidar against the
*record's* radial speed (A2012 Eqs. 8, 11), with the mean and spread of each
across the twins beside the record's own statistics.  Files are written
atomically; a rerun skips every period whose file carries the same identity
(scene, records' contents, twin count) and recomputes the others.

Geometry and clock
------------------
* The field's x runs along the mean wind; the convection speed U of a period
  is the mean of its records' mean speeds (one uniform mean wind: shear
  between the records' heights is not represented).
* The twin's field is periodic in x with length exactly ``U T`` (T the
  period), so each record covers one whole line (the per-k1 method): with
  the scene's spacing dx0, ``nx = n * max(1, round(U / (fs dx0)))`` nodes for
  n samples at fs.  A record is read as periodic: its first and last seconds
  meet.
* Times are kept exact, in integer nanoseconds on the records' clock
  (``cwlidar_sim._times``): a 20 Hz record timed in Unix seconds is 20 Hz,
  not 20.0000191.  The twin's clock starts half a sample before the
  reference sonic record's first sample (without one: at the whole second
  at or before the first sample), plus k T for period k; the file keeps that
  start (``time_origin``, exact decimal seconds, and ``time_origin_ns``).  A
  record whose first sample lies ``d`` seconds after the start is placed at
  ``x - U d`` (the field moves along +x), so that twin and record agree
  sample by sample; with the half-sample start the record's 10 Hz series
  (``record_10hz``) spans the same tenths as the lidar's and the twin's sonic,
  whatever fraction of a second the record starts at.
* T1/T2 and the coherence use the first sonic record's speed toward the
  lidar, ``-(U + u, v, w) . n``, at 10 Hz: A2012's resampling for 32 Hz
  records, block averages for multiples of 10 Hz (any other rate is an
  error before anything is computed).

Conical scenes
--------------
A conical scene's records are positioned relative to the lidar (the cone's
apex) in the lidar's frame (x toward azimuth 0, east; y toward 90 deg,
north; z up) and turned into the field's frame by the period template's
wind direction (``wind_direction_deg`` or ``wind_from_deg``).  Each box of a period (dwell: one per height;
cycle: one) is conditioned on the records inside it
(:func:`conical_unit_records`; a box holding none is an error before
anything is computed), *before* its lateral half is kept (the kept half of
a doubled box has not a periodic box's covariance).  The box's x period is
``U T`` with U the mean of its records' mean speeds (per height in dwell
mode), a node per record sample where the record is no denser than the
scene's spacing; the lidar then sees the periodic image within its circle's
reach of the record's ends (measured by ``studies/twin_edge.py``).  The
scene's cup, sonic, scanning lidar, VAD fits and CS's model run unchanged
(:func:`cwlidar_sim.campaign.periods.conical.run_unit`).  Per period
(``DIR/<scene>_twin_P<k>.nc``, dimensions ``twin``, ``height``, ``scan_s``):
every result of the unit (lidar mean and std, std ratio, TP, radial
variance, cup and sonic statistics, ...) for each twin, with
``*_twin_mean`` and ``*_twin_std`` across the twins, beside the records'
own statistics.  Seeds: ``SeedSequence(scene.seed, spawn_key=(0x7477, k,
h, j))`` for period k, box h, twin j.

Dask and resume
---------------
Every (period, twin) is one task (:func:`twin_task`, plain data in and
out); a period's file is assembled and written when its N twins are done
(:func:`assemble_twin_period`), so a cluster gives the same bits as a local
run.  A rerun reuses a period's file only if its identity (scene, tensor,
the period's records' bytes, twin count, layout version) is unchanged.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from fractions import Fraction

import numpy as np

from ..._seeding import seed_int
from ..._dask import DEFAULT_WORKER_TIMEOUT, completed
from ..._times import ns_text
from .._labels import HOMODYNE, TOWARD_LIDAR, duration_phrase
from ._common import _TWIN_TAG, TWIN_VERSION, clock_attrs, record_statistics
from ..registry import get_kind, kind_names, kind_of
from ..scenes.staring import PeriodSpec, Scene
from .conical import conical_twin, conical_twin_period, conical_twin_scene, conical_unit_records

__all__ = ["TwinPeriod", "twin_periods", "twin_period_scene", "twin_line_records", "focus_coherence",
           "record_radial_10hz", "twin_task", "assemble_twin_period", "run_twin_period", "run_twin", "twin_path",
           "conical_unit_records", "conical_twin_scene", "conical_twin", "TWIN_VERSION", "StaringTwin", "ConicalTwin",
           "twin_of"]



@dataclasses.dataclass(frozen=True, eq=False)
class TwinPeriod:
    """One period of the records: every conditioning record's cleaned :class:`~cwlidar_sim.analysis.records.Record`.

    Attributes
    ----------
    index : int
        Period index in the files.
    records : tuple of Record
        One per ``condition_on`` entry, in order.
    U : float
        Convection speed: the mean of the records' mean speeds [m/s].
    delay : float
        Time of the records' first sample after the twin period's start [s]
        (the reference sonic's, else the first record's).
    origin_ns : int
        The twin period's start on the records' clock [ns] (exact; numbers as
        written in the files, ISO 8601 times since 1970-01-01T00:00).
    """

    index: int
    records: tuple
    U: float
    delay: float
    origin_ns: int = 0

    @property
    def duration(self) -> float:
        return self.records[0].duration


def _reference(scene: Scene) -> int:
    """Index of the first sonic record (the reference of T1/T2), or -1."""
    return next((i for i, r in enumerate(scene.turbulence.condition_on) if r.kind == "sonic"), -1)


def _record_specs(scene: Scene, paths=None):
    specs = list(scene.turbulence.condition_on)
    if not specs:
        raise ValueError(f"scene {scene.name!r}: [turbulence] condition_on names no records; a twin needs at least "
                         f"one (path, kind, position, noise_std)")
    if paths is not None:
        paths = [os.fspath(p) for p in paths]
        if len(paths) != len(specs):
            raise ValueError(f"--records gives {len(paths)} file(s) but the scene's condition_on has {len(specs)} "
                             f"record(s); allowed: one file per record, in order")
        specs = [dataclasses.replace(s, path=p, name=s.name if s.name != os.path.basename(s.path) else
                                     os.path.basename(p)) for s, p in zip(specs, paths)]
        return specs
    return [dataclasses.replace(s, path=scene.resolve(s.path)) for s in specs]


def twin_periods(scene: Scene, paths=None) -> list:
    """Read, clean and check the scene's records as periods of the scene's duration (before any compute).

    Parameters
    ----------
    scene : Scene
        A staring or conical scene with ``[turbulence] condition_on``.
    paths : list of str, optional
        Files replacing the records' paths, in order (the same mast, another
        campaign); default the scene's own (relative to its folder).

    Returns
    -------
    list of TwinPeriod
        Every complete period held by all records.  Raises ValueError (one
        line, naming the file, the period and the problem) for a bad record.
    """
    from ...analysis.records import read_periods

    hooks = twin_of(scene)
    T = scene.period_duration(scene.periods[0])
    specs = _record_specs(scene, paths)
    per = [read_periods(s, T) for s in specs]
    counts = [len(p) for p in per]
    if len(set(counts)) != 1:
        raise ValueError("records hold different numbers of whole periods of "
                         f"{T:g} s: " + ", ".join(f"{s.name}: {c}" for s, c in zip(specs, counts))
                         + "; allowed: records of one campaign covering the same time")
    ref = hooks.reference(scene)
    if ref >= 0:
        fs = per[ref][0].sample_rate
        if not (fs == 32.0 or (fs >= 10.0 and fs / 10.0 == round(fs / 10.0))):
            raise ValueError(f"{specs[ref].name}: T1/T2 against the record need it at 10 Hz: its rate, {fs:.9g} Hz, "
                             f"is neither 32 Hz (A2012's resampling) nor a multiple of 10 Hz (block averages)")
    origin_ns = _clock_origin_ns(per, ref)
    T_ns = round(Fraction(T) * 10**9)
    out = []
    for k in range(counts[0]):
        recs = tuple(p[k] for p in per)
        U = float(np.mean([r.mean_speed for r in recs]))
        if not 1.0 <= U <= 30.0:
            raise ValueError(f"period {k}: the records' mean speed is {U:.3g} m/s; allowed: [1, 30] m/s (Taylor's "
                             f"hypothesis)")
        starts = [r.time0_ns for r in recs]
        if (max(starts) - min(starts)) / 10**9 > 0.5 / recs[0].sample_rate:
            raise ValueError(f"period {k}: the records start at different times "
                             f"{[ns_text(x) for x in starts]} s; allowed: simultaneous records (within half a sample)")
        # the records are placed by the reference's start (the others are within half a sample of it)
        lead = recs[max(ref, 0)]
        out.append(TwinPeriod(k, recs, U, (lead.time0_ns - (origin_ns + k * T_ns)) / 10**9,
                              origin_ns + k * T_ns))
    return out


def _clock_origin_ns(per, ref: int) -> int:
    """The twin's clock's zero [ns on the records' clock] (module notes, Geometry and clock).

    With a reference sonic (staring scenes): half a record sample before its
    first sample, so that the record's 10 Hz blocks (A2012's partitions)
    span the twin's own: its samples then fall where the twin's sonic
    samples (32 Hz: at ``SONIC_DELAY``) and ``record_10hz`` shares the
    lidar's clock, for a record that starts at any fraction of a second.
    Without one: the whole second at or before the first sample.
    """
    if ref >= 0:
        first = per[ref][0]
        return first.time0_ns - round(Fraction(10**9, 2) / Fraction(first.sample_rate))
    return min(p[0].time0_ns for p in per) // 10**9 * 10**9


def twin_period_scene(scene: Scene, tp: TwinPeriod, twin: int) -> Scene:
    """The one-period scene of twin ``twin`` of period ``tp``: the records' U, its own seed.

    The scene's first ``[[period]]`` is the template (misalignment, start
    in the background cycle, advanced by k T); the seed is
    ``SeedSequence(scene.seed, spawn_key=(0x7477, k, twin))``.
    """
    tmpl = scene.periods[0]
    T = tp.duration
    seq = np.random.SeedSequence(scene.seed, spawn_key=(_TWIN_TAG, tp.index, int(twin)))
    seed = seed_int(seq)
    p = PeriodSpec(name=f"P{tp.index:03d}", mean_speed=tp.U, misalignment_deg=tmpl.misalignment_deg, duration=T,
                   start=tmpl.start + tp.index * T, seed=seed)
    return scene.replace(periods=(p,), duration=T)


def _twin_grid(tp, plan):
    """(nx, dx): the field's x nodes, ``n * max(1, round(U / (fs dx0)))``, and their spacing ``U T / nx``."""
    r0 = tp.records[0]
    per_sample = max(1, int(round(tp.U / (r0.sample_rate * plan.spacing[0]))))
    nx = r0.n_samples * per_sample
    return nx, tp.U * tp.duration / nx


def twin_line_records(scene: Scene, tp: TwinPeriod, plan):
    """The period's records as LineRecords at their positions in the field of ``plan`` (see the module notes)."""
    focus = np.asarray(plan.lidar_position) + scene.lidar.build_instrument().focus * np.asarray(plan.direction)
    out = []
    for spec, rec in zip(scene.turbulence.condition_on, tp.records):
        pos = focus + np.asarray(spec.position)
        pos[0] -= tp.U * tp.delay
        out.append(rec.line_record(tuple(float(x) for x in pos)))
    return out


def _make_field(scene, tp, params, plans):
    from ...turbulence.conditioning import condition_field
    from ..periods.staring_field import generate_field

    def make(plan, seed):
        nx, dx = _twin_grid(tp, plan)
        plan = dataclasses.replace(plan, shape=(nx,) + tuple(plan.shape[1:]), spacing=(dx,) + tuple(plan.spacing[1:]))
        field = generate_field(plan, params, seed)
        field = condition_field(field, twin_line_records(scene, tp, plan), seed=seed, U=tp.U, params=params,
                                inplace=True)
        plans.append(plan)
        return plan, field

    return make


def focus_coherence(scene: Scene, tp: TwinPeriod, plan, params, k_edges):
    """Theory: squared coherence gamma^2 of u at the lidar's focus with the records, on log bins.

    Per bin ``1 - sum(posterior) / sum(prior)`` over the field's k1 modes in
    it (spectrum-weighted, as the bin-averaged estimates are).  For a beam
    along the wind in a line field the lidar reads a filter of that very
    line, so this is also the coherence of the lidar with the records; the
    twin's lidar against the truth's lidar then has squared coherence
    ``(sum(gamma^2 prior) / sum(prior))^2`` (returned second).  Elsewhere
    (lateral averaging across a misaligned beam) it is an upper bound.
    """
    from ...turbulence import generate_line
    from ...turbulence.conditioning import conditional_variance
    from ..periods.staring_field import generate_field

    if plan.kind == "line":
        tmpl = generate_line(params, plan.shape[0], plan.spacing[0], 0)
    else:
        tmpl = generate_field(plan, params, 0)
    focus = np.asarray(plan.lidar_position) + scene.lidar.build_instrument().focus * np.asarray(plan.direction)
    cv = conditional_variance(tmpl, twin_line_records(scene, tp, plan), [tuple(focus)], U=tp.U, params=params)
    k = cv.k1_k
    pr, po = cv.prior_ktc[:, 0, 0], cv.posterior_ktc[:, 0, 0]
    edges = np.asarray(k_edges)
    g2 = np.full(edges.size - 1, np.nan)
    g4 = np.full(edges.size - 1, np.nan)
    for b in range(edges.size - 1):
        sel = (k >= edges[b]) & (k < edges[b + 1]) & (k > 0)
        if np.any(sel) and pr[sel].sum() > 0:
            g2[b] = 1.0 - po[sel].sum() / pr[sel].sum()
            g4[b] = g2[b] ** 2
    return g2, g4


def record_radial_10hz(scene: Scene, tp: TwinPeriod, direction) -> np.ndarray | None:
    """The reference sonic record's speed toward the lidar at 10 Hz [m/s] (None without a sonic record)."""
    from ...sensors import block_average, resample_a2012

    ref = _reference(scene)
    if ref < 0:
        return None
    rec = tp.records[ref]
    vel = np.stack([rec.values[c] for c in "uvw"], axis=1)
    vs = -(vel @ np.asarray(direction, dtype=np.float64))
    if rec.sample_rate == 32.0:
        return resample_a2012(vs)
    return block_average(vs, int(round(rec.sample_rate / 10.0)))[0]


def _staring_twin(scene: Scene, tp: TwinPeriod, j: int, params, status=None) -> dict:
    """Twin ``j`` of period ``tp`` of a staring scene: its 10 Hz series, seed and field plan (a plain dict)."""
    from ..periods.staring import run_unit

    sc = twin_period_scene(scene, tp, j)
    plans = []
    ds = run_unit(sc, 0, params, make_field=_make_field(sc, tp, params, plans), status=status)
    return {"lidar": np.asarray(ds["lidar_10hz"].values[0], dtype=np.float64),
            "sonic": np.asarray(ds["sonic_10hz"].values[0], dtype=np.float64),
            "seed": int(sc.periods[0].seed), "plan": plans[-1]}


def _staring_period(scene: Scene, tp: TwinPeriod, rows, params):
    """The period's Dataset from its twins' rows (:func:`_staring_twin`): statistics against the record."""
    from ...analysis import log_bins, transfer_functions
    from ..periods.staring_field import plan_field

    a = scene.analysis
    k_edges = log_bins(a.k_min, a.k_max, a.per_decade)
    rec10 = record_radial_10hz(scene, tp, plan_field(twin_period_scene(scene, tp, 0), 0, params).direction)
    n10 = rows[0]["lidar"].size
    if rec10 is not None and rec10.size != n10:
        raise ValueError(f"period {tp.index}: the record gives {rec10.size} values at 10 Hz, the lidar {n10}")
    rows = [dict(r) for r in rows]
    for row in rows:
        if rec10 is not None:
            tf = transfer_functions(row["lidar"], rec10, fs=10.0, U=tp.U, k_edges=k_edges,
                                    segment_duration=a.segment_duration, window=a.window, detrend=a.detrend)
            with np.errstate(invalid="ignore", divide="ignore"):
                coh = np.abs(tf.chi_k) ** 2 / (tf.F_r_k * tf.F_s_k)
            row.update(T1=np.asarray(tf.transfer_ratio_k), T2=np.asarray(tf.transfer_cross_k), coh=coh, k=np.asarray(tf.k_k))
    out = _dataset(scene, tp, rows, rec10, k_edges)
    if "k" in out.coords:
        g2, g4 = focus_coherence(scene, tp, rows[-1]["plan"], params, k_edges)
        out["coherence_theory"] = (("k",), g2, {"units": "1", "long_name": "theory: squared coherence of u at the "
                                                "focus with the records (twin lidar vs record)"})
        out["coherence_theory_twin_truth"] = (("k",), g4, {"units": "1", "long_name": "theory: squared coherence of "
                                                           "a twin's lidar with the truth's (gamma^2 squared)"})
    return out


class StaringTwin:
    """The virtual twin of a staring scene: the staring kind's ``twin`` (:mod:`cwlidar_sim.campaign.registry`).

    Each hook takes the scene first: ``reference`` (the record T1/T2 are
    taken against: the first sonic, -1 for none), ``prepare`` (before
    anything is computed: the tensor shared by the twins), ``task`` (one
    twin, plain data) and ``assemble`` (a period's Dataset from its twins).
    """

    def reference(self, scene) -> int:
        return _reference(scene)

    def prepare(self, scene, tps):
        from ..periods.staring_field import scene_params

        return scene_params(scene)[0]

    def task(self, scene, tp, j, params, *, status=None):
        return _staring_twin(scene, tp, j, params, status=status)

    def assemble(self, scene, tp, results, params):
        return _staring_period(scene, tp, results, params)


class ConicalTwin:
    """The virtual twin of a conical scene: the conical kind's ``twin`` (hooks as :class:`StaringTwin`'s)."""

    def reference(self, scene) -> int:
        return -1

    def prepare(self, scene, tps):
        for tp in tps:  # every box's records before anything is computed
            for h in range(1 if scene.scan.cycle else len(scene.scan.heights)):
                conical_unit_records(scene, tp, h)
        return None

    def task(self, scene, tp, j, params, *, status=None):
        return conical_twin(scene, tp, j, status=status)

    def assemble(self, scene, tp, results, params):
        return conical_twin_period(scene, tp, results)


def twin_of(scene):
    """The twin hooks of a scene's kind; a ValueError naming the kind if it has none."""
    kind = kind_of(scene)
    if kind.twin is None:
        able = [n for n in kind_names() if get_kind(n).twin is not None]
        raise ValueError(f"a {kind.name} scene has no virtual twin (kinds with one: {', '.join(able)})")
    return kind.twin


def twin_task(scene, tp: TwinPeriod, j: int, params=None, status=None):
    """Twin ``j`` of period ``tp``: the unit of work (a Dask task); plain data, the same bits wherever it runs.

    Staring scenes: a dict of the twin's series (:func:`assemble_twin_period`
    turns the N of a period into its Dataset); conical scenes: the twin's
    Dataset on ``height``.
    """
    return twin_of(scene).task(scene, tp, j, params, status=status)


def assemble_twin_period(scene, tp: TwinPeriod, results, params=None):
    """The period's Dataset from its twins' :func:`twin_task` results, in twin order."""
    return twin_of(scene).assemble(scene, tp, list(results), params)


def run_twin_period(scene, tp: TwinPeriod, n_twins: int, params, *, status=None):
    """The ``n_twins`` twins of one period and their statistics against the record, as an xarray.Dataset.

    Staring scenes: dimensions ``twin``, ``time_10hz``, ``k``; conical
    scenes: ``twin``, ``height``, ``scan_s`` (:func:`conical_twin`).  Every
    variable has ``units`` and ``long_name``.  ``*_twin_mean`` /
    ``*_twin_std`` are the mean and the standard deviation (ddof = 1) across
    the twins: the conditional distribution's spread given what the records saw.
    """
    say = status or (lambda s: None)
    rows = []
    for j in range(n_twins):
        say(f"P{tp.index:03d} twin {j + 1}/{n_twins}")
        rows.append(twin_task(scene, tp, j, params))
    return assemble_twin_period(scene, tp, rows, params)


def _stats(x):
    """(mean, std) over time of each row, NaN-aware [same units]."""
    with np.errstate(invalid="ignore"):
        return np.nanmean(x, axis=-1), np.nanstd(x, axis=-1)


def _dataset(scene, tp, rows, rec10, k_edges):
    import xarray as xr

    n10 = rows[0]["lidar"].size
    N = len(rows)
    lid = np.stack([r["lidar"] for r in rows])
    son = np.stack([r["sonic"] for r in rows])
    TT = ("twin", "time_10hz")
    coords = {"twin": ("twin", np.arange(N)),
              "time_10hz": ("time_10hz", 0.05 + 0.1 * np.arange(n10),
                            {"units": "s", "long_name": "time in the period, from time_origin (every series)"})}
    dv = {"lidar_10hz": (TT, lid.astype(np.float32), {"units": "m s-1", "long_name": "each twin's lidar speed, 10 Hz",
                                                      "sign_convention": HOMODYNE}),
          "sonic_10hz": (TT, son.astype(np.float32),
                         {"units": "m s-1", "long_name": "each twin's sonic speed toward the lidar, 10 Hz",
                          "sign_convention": TOWARD_LIDAR}),
          "seed": (("twin",), np.array([r["seed"] for r in rows], np.int64), {"units": "1", "long_name": "twin seed"})}

    def spread(name, x, units, what):
        import warnings

        dv[name] = (("twin",) + ((), ("k",))[x.ndim - 1], x, {"units": units, "long_name": f"{what}, each twin"})
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # empty bins are NaN for every twin
            m = np.nanmean(x, axis=0)
            s = np.nanstd(x, axis=0, ddof=1) if N > 1 else np.full_like(m, np.nan)
        dims = ((), ("k",))[x.ndim - 1]
        dv[name + "_twin_mean"] = (dims, m, {"units": units, "long_name": f"{what}, mean over the twins"})
        dv[name + "_twin_std"] = (dims, s, {"units": units, "long_name": f"{what}, std across the twins (ddof 1)"})

    m, s = _stats(lid)
    span = duration_phrase(tp.duration)
    spread("lidar_mean", m, "m s-1", f"{span} mean of the lidar speed")
    spread("lidar_std", s, "m s-1", f"{span} std of the lidar speed")
    if rec10 is not None:
        coords["k"] = ("k", rows[0]["k"], {"units": "rad m-1", "long_name": "wavenumber 2 pi f / U (bin centre)"})
        spread("transfer_ratio", np.stack([r["T1"] for r in rows]), "1", "T1 = F_lidar / F_record (A2012 Eq. 8)")
        spread("transfer_cross", np.stack([r["T2"] for r in rows]), "1",
               "T2 = Re(chi_lidar_record)^2 / F_record^2 (A2012 Eq. 11)")
        spread("coherence_record", np.stack([r["coh"] for r in rows]), "1",
               "squared coherence of the lidar with the record")
        rm, rs = _stats(rec10)
        dv["record_10hz"] = (("time_10hz",), rec10, {"units": "m s-1",
                                                     "long_name": "the reference record's speed toward the lidar, 10 Hz",
                                                     "sign_convention": TOWARD_LIDAR})
        dv["record_mean"] = ((), rm, {"units": "m s-1", "long_name": f"{span} mean of record_10hz"})
        dv["record_std"] = ((), rs, {"units": "m s-1", "long_name": f"{span} std of record_10hz"})
    attrs = {"scene": scene.name, "period": f"P{tp.index:03d}", "period_index": tp.index, "n_twins": N,
             "convection_speed": tp.U, "duration": tp.duration, **clock_attrs(tp),
             "records": json.dumps([r.spec.name for r in tp.records]),
             "reference_record": (tp.records[_reference(scene)].spec.name if rec10 is not None else ""),
             "twin_version": TWIN_VERSION}
    out = xr.Dataset(dv, coords=coords, attrs=attrs)
    record_statistics(out, tp)
    return out


def twin_path(out_dir, scene: Scene, index: int) -> str:
    """``DIR/<scene>_twin_P<index>.nc``."""
    return os.path.join(os.fspath(out_dir), f"{scene.name}_twin_P{index:03d}.nc")


def _identity(scene, params, tp, n_twins):
    """Digest of what a period's file depends on: the scene, the tensor, the records' bytes and clock, the twins."""
    h = hashlib.sha256()
    h.update(json.dumps({"scene": scene.as_dict(), "params": params.as_dict() if params is not None else None,
                         "n_twins": n_twins, "version": TWIN_VERSION, "period": tp.index, "delay": tp.delay,
                         "origin_ns": tp.origin_ns},
                        sort_keys=True, default=str).encode())
    for r in tp.records:
        for c in sorted(r.values):
            h.update(np.ascontiguousarray(r.values[c], dtype=np.float64).tobytes())
    return h.hexdigest()[:32]


def run_twin(scene, out_dir, *, paths=None, n_twins: int = 8, progress=None, periods=None, client=None,
             worker_timeout: float = DEFAULT_WORKER_TIMEOUT) -> list:
    """The twins of every period of the scene's records, one NetCDF per period; resumes.

    Parameters
    ----------
    scene : Scene or ConicalScene
        A staring or conical scene with ``[turbulence] condition_on``.
    out_dir : str or path
        Output folder (created).
    paths : list of str, optional
        Record files replacing the scene's, in order.
    n_twins : int
        Twins per period; in [1, 10000].  Their spread is the conditional
        distribution's: use >= 8 for a std of the spread within 25 %.
    progress : callable, optional
        Called with a line of text per stage (default: silent).
    periods : list of int, optional
        Only these period indices.
    client : dask.distributed.Client, optional
        Run every (period, twin) as a task on this cluster; default: here,
        one after the other.  The files are identical bit for bit (each twin
        is seeded from the scene, the period and its index alone).  Only a
        cluster you trust (see the README's Dask section).
    worker_timeout : float
        With ``client``: the longest the cluster may have no worker while
        twins are pending [s]; then :class:`~cwlidar_sim._dask.WorkersLostError`
        (finished periods stay, a rerun resumes).

    Returns
    -------
    list of str
        The period files, written or found complete, in period order.
    """
    from ..._validation import check_int
    from ..execution.store import read_results, write_results

    n_twins = check_int("n_twins", n_twins, lo=1, hi=10000)
    say = progress or (lambda s: None)
    tps = twin_periods(scene, paths)  # every record checked before anything is computed
    if periods is not None:
        bad = [i for i in periods if not 0 <= int(i) < len(tps)]
        if bad:
            raise ValueError(f"periods {bad} are not in the records' {len(tps)} period(s)")
        tps = [tps[int(i)] for i in periods]
    params = twin_of(scene).prepare(scene, tps)
    os.makedirs(out_dir, exist_ok=True)
    files = {}
    todo = []
    for n, tp in enumerate(tps):
        path = twin_path(out_dir, scene, tp.index)
        key = _identity(scene, params, tp, n_twins)
        if os.path.isfile(path):
            try:
                done = read_results(path).attrs.get("identity") == key
            except ValueError:
                done = False
            if done:
                say(f"[{n + 1}/{len(tps)}] P{tp.index:03d}: done already ({path})")
                files[n] = path
                continue
            say(f"[{n + 1}/{len(tps)}] P{tp.index:03d}: {path} is from other inputs; recomputing")
        todo.append((n, tp, path, key))

    def finish(n, tp, path, key, results):
        ds = assemble_twin_period(scene, tp, results, params)
        ds.attrs["identity"] = key
        write_results(ds, path)
        say(f"[{n + 1}/{len(tps)}] P{tp.index:03d}: wrote {path}")
        files[n] = path

    if client is not None and todo:
        futures, pending = {}, {}
        for n, tp, path, key in todo:
            pending[n] = [None] * n_twins
            for j in range(n_twins):
                futures[client.submit(twin_task, scene, tp, j, params, pure=False)] = (n, j)
        info = {n: (tp, path, key) for n, tp, path, key in todo}
        try:
            # as dask's as_completed, but stops when the cluster has had no worker for worker_timeout s
            for fut in completed(client, futures, worker_timeout=worker_timeout):
                n, j = futures[fut]
                pending[n][j] = fut.result()
                say(f"[{n + 1}/{len(tps)}] P{info[n][0].index:03d} twin {j + 1}/{n_twins} done")
                if all(r is not None for r in pending[n]):
                    finish(n, *info[n], pending.pop(n))
        finally:
            for fut in futures:
                fut.cancel()
    else:
        for n, tp, path, key in todo:
            results = []
            for j in range(n_twins):
                say(f"[{n + 1}/{len(tps)}] P{tp.index:03d} twin {j + 1}/{n_twins}")
                results.append(twin_task(scene, tp, j, params))
            finish(n, tp, path, key, results)
    return [files[n] for n in sorted(files)]
