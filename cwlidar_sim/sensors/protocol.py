"""One Sensor protocol, one shared :func:`measure`, one record type for every lidar.

A lidar sensor is geometry: where its beam points and focuses, when, which
cells with which weights.  Through the :class:`Sensor` protocol it states
what it plans for a record (:meth:`Sensor.plan_record`: the estimates'
times, their foci, one :class:`Focus` per focus with its instrument, cells,
looks and a ``sample`` callback that samples the field, and the
per-estimate arrays of its own, e.g. the azimuths of a scan), and what it
adds to the chain's output (:meth:`Sensor.finish_record`: its ``info``, a
blade's blockage).  :func:`measure` does the rest once for every sensor:
the checks of the shared arguments, the seeding rule, the sub-cell spread
rule, the hand-over to :func:`cwlidar_sim.signal.chain.run_chain`, and one
:class:`LidarRecord`.

The public ``measure_staring``, ``measure_conical`` and ``measure_nacelle``
are thin wrappers of :func:`measure` that keep each sensor's own way of
saying when (estimate times, or a duration and a start).
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from .._repr import summary_repr
from .._seeding import focus_seeds
from .._validation import check_bool, check_int, check_real
from ..signal.chain import ChainRecord, ChainSettings, FocusGroup, run_chain

__all__ = ["Sensor", "Focus", "RecordPlan", "LidarRecord", "measure"]


@dataclasses.dataclass
class Focus:
    """One focus of a record as a sensor states it (:meth:`Sensor.plan_record`); :func:`measure` seeds it.

    Parameters
    ----------
    instrument : Instrument
        The instrument focused here.
    index_e : ndarray of int, shape (n_e,)
        Positions of the focus's estimates in the record.
    time_e : ndarray, shape (n_e,)
        Their mid-times [s].
    cells : ProbeCells
        The probe volume's cells (their weights, the mean-wind tail).
    n_looks : int
        Looks per estimate.
    sample : callable
        ``sample(lo, hi) -> (vlos_els, vlos_e, cloud_el)`` of the focus's
        estimates ``lo .. hi - 1`` (:class:`cwlidar_sim.signal.chain.FocusGroup`).
    transverse_speed : float
        Speed of the focal spot relative to the aerosols [m/s] (the speckle time).
    field : xarray.Dataset
        The field sampled (its tensor gives the sub-cell spread).
    cloud_weight : float
        A cloud's weight relative to the aerosol probe volume [-] (0: none).
    """

    __repr__ = summary_repr

    instrument: object
    index_e: np.ndarray
    time_e: np.ndarray
    cells: object
    n_looks: int
    sample: Callable
    transverse_speed: float
    field: object
    cloud_weight: float = 0.0


@dataclasses.dataclass
class RecordPlan:
    """What a sensor plans for a record (:meth:`Sensor.plan_record`).

    Parameters
    ----------
    time_e : ndarray, shape (n_e,)
        Estimate mid-times [s].
    focus_index_e : ndarray of int, shape (n_e,)
        Index into ``foci`` of each estimate.
    foci : tuple of float
        The foci by what the sensor calls them [m]: the conical lidar's
        heights, the nacelle lidar's focus distances, the staring lidar's focus.
    groups : list of Focus
        One per entry of ``foci``, in their order.
    fixed_focus : bool
        True for a sensor with one fixed focus (the seeding rule: :func:`measure`).
    extras : dict
        The sensor's own per-estimate arrays (e.g. ``azimuth_e``), name -> array of first dimension n_e.
    context : dict
        Anything else the sensor keeps for :meth:`Sensor.finish_record`.
    """

    __repr__ = summary_repr

    time_e: np.ndarray
    focus_index_e: np.ndarray
    foci: tuple
    groups: list
    fixed_focus: bool = False
    extras: dict = dataclasses.field(default_factory=dict)
    context: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class LidarRecord:
    """A lidar's record of speed estimates, the same type for every lidar (:func:`measure`).

    Attributes
    ----------
    time_e : ndarray, float64, shape (n_e,)
        Estimate (mid-)times [s].
    vlos_e : ndarray, float64, shape (n_e,)
        Tier-1 probe-volume weighted line-of-sight speed [m/s], signed
        (positive away from the lidar; averaged over a dwell's looks): the ideal.
    speed_e : ndarray, float64, shape (n_e,)
        The instrument's speed estimate |v| [m/s] (>= 0); NaN where it failed.
    flags_e : ndarray, uint8, shape (n_e,)
        :class:`cwlidar_sim.signal.Flag` bit fields.
    variants : dict
        Variant name -> ``(speed_e, flags_e)`` from the same spectra processed
        with that variant's overrides.
    availability : float
        Fraction of usable estimates [-] (:func:`cwlidar_sim.signal.processing.usable_fraction`).
    info : dict
        Run information; the sensor says which (e.g.
        :func:`cwlidar_sim.sensors.measure_staring`).
    focus_index_e : ndarray of int, shape (n_e,)
        Index into ``foci`` of each estimate (0 for a fixed focus).
    foci : tuple of float
        The foci [m] (the conical lidar's heights, the nacelle lidar's focus
        distances, the staring lidar's focus).
    extras : dict
        The sensor's own per-estimate arrays, also read as attributes
        (``rec.azimuth_e``): the conical lidar's ``azimuth_e``,
        ``revolution_e``, ``height_e``; the nacelle lidar's ``azimuth_e``,
        ``revolution_e``, ``focus_e``, ``los_e``, ``direction_ec``,
        ``field_direction_ec``, ``blocked_e``, ``correction_e`` (see
        :func:`cwlidar_sim.sensors.measure_conical` and
        :func:`cwlidar_sim.sensors.measure_nacelle`).
    """

    __repr__ = summary_repr

    time_e: np.ndarray
    vlos_e: np.ndarray
    speed_e: np.ndarray
    flags_e: np.ndarray
    variants: dict
    availability: float
    info: dict
    focus_index_e: np.ndarray | None = None
    foci: tuple = ()
    extras: dict = dataclasses.field(default_factory=dict)

    def __getattr__(self, name):
        extras = self.__dict__.get("extras")
        if extras is not None and not name.startswith("__") and name in extras:
            return extras[name]
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    def select(self, focus: float) -> dict:
        """The arrays of the estimates at one focus (a height of the conical lidar, a focus distance of the nacelle
        lidar): ``time_e``, ``vlos_e``, ``speed_e``, ``flags_e`` and the sensor's own per-estimate arrays."""
        f = float(focus)
        if f not in self.foci:
            raise ValueError(f"focus {focus!r} is not in the record; allowed: {sorted(self.foci)}")
        m = self.focus_index_e == self.foci.index(f)
        out = {k: getattr(self, k)[m] for k in ("time_e", "vlos_e", "speed_e", "flags_e")}
        out.update({k: v[m] for k, v in self.extras.items()
                    if isinstance(v, np.ndarray) and v.ndim and v.shape[0] == m.size})
        return out


@runtime_checkable
class Sensor(Protocol):
    """What a lidar gives the shared :func:`measure` (module notes); :class:`~cwlidar_sim.sensors.LidarBase` gives
    ``tier``, ``chain_settings`` and ``subcell_spread_in`` to every lidar."""

    tier: str

    def chain_settings(self) -> ChainSettings:
        """The signal chain's settings."""

    def subcell_spread_in(self, field) -> tuple:
        """``(spread [m/s], source)``: the one sub-cell spread rule (:meth:`.LidarBase.subcell_spread_in`)."""

    def plan_record(self, field, U: float, *, wrap: bool, **when) -> RecordPlan:
        """The record's estimates, foci and :class:`Focus` groups in ``field`` at mean wind ``U``."""

    def finish_record(self, record: LidarRecord, plan: RecordPlan, chain: ChainRecord) -> LidarRecord:
        """The record with the sensor's ``info`` (and anything it changes after the chain)."""


def measure(field, sensor: Sensor, U: float, seed=None, *, variants=None, chunk: int = 4096, wrap: bool = False,
            calibration_time: float = 0.0, **when) -> LidarRecord:
    """Simulate a lidar's record of speed estimates in a turbulence field: the one orchestration of every lidar.

    The sensor plans the record (:meth:`Sensor.plan_record`, with ``when``:
    its estimate times or its duration and start); each of its foci becomes
    one :class:`cwlidar_sim.signal.chain.FocusGroup`, with the sub-cell
    spread of the focus's field (:meth:`cwlidar_sim.sensors.LidarBase.subcell_spread_in`),
    and :func:`cwlidar_sim.signal.chain.run_chain` runs them.

    Seeding, the one rule of every lidar (``cwlidar_sim._seeding.focus_seeds``):
    a sensor with a focus list (the conical lidar's heights, the nacelle
    lidar's focus distances, a list of one included) gives its groups the
    children of the record's root ``SeedSequence`` in list order; a sensor
    with one fixed focus (``RecordPlan.fixed_focus``: the staring lidar)
    gives its one group the root itself.

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line field (:func:`cwlidar_sim.beam.sample_los`) holding
        every cell; u, v, w fluctuations [m/s].
    sensor : Sensor
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u); in [-1000, 1000].
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (background, speckle,
        noise): required by them (a ValueError without one: a record is never
        drawn from fresh entropy, the same seed gives the same bits); not used
        by tier 'los', whose record is the field's.
    variants : list of dict, optional
        Extra processing of the same spectra (:data:`cwlidar_sim.signal.chain.VARIANT_KEYS`).
    chunk : int
        Estimates processed at a time (memory only); in [1, 10**6].
    wrap : bool
        Treat y and z as periodic.
    calibration_time : float
        Time of t = 0 on the background-calibration clock [s] (background gain
        mismatch and drift, the pauses of ``background_pause``).
    **when
        The sensor's schedule arguments (``times_e``; ``duration``, ``start``).

    Returns
    -------
    LidarRecord
    """
    if not isinstance(sensor, Sensor):
        raise TypeError(f"sensor must provide the Sensor protocol (plan_record, finish_record, chain_settings, "
                        f"subcell_spread_in), got {type(sensor).__name__}")
    if sensor.tier != "los" and seed is None:
        raise ValueError(f"seed is required for tier {sensor.tier!r}; allowed: an int or a numpy Generator")
    U = check_real("U", U, lo=-1000.0, hi=1000.0)
    chunk = check_int("chunk", chunk, lo=1, hi=10**6)
    wrap = check_bool("wrap", wrap)
    calibration_time = check_real("calibration_time", calibration_time)
    plan = sensor.plan_record(field, U, wrap=wrap, **when)
    n = len(plan.groups)
    seeds = [None] * n if sensor.tier == "los" else focus_seeds(seed, None if plan.fixed_focus else n)
    groups = [FocusGroup(instrument=f.instrument, index_e=f.index_e, time_e=f.time_e, weight_s=f.cells.weight_tail_s,
                         tail=f.cells.tail_weight > 0.0, n_looks=f.n_looks, sample=f.sample, seed=s,
                         transverse_speed=f.transverse_speed, subcell_spread=sensor.subcell_spread_in(f.field)[0],
                         cloud_weight=f.cloud_weight, calibration_time=calibration_time)
              for f, s in zip(plan.groups, seeds)]
    chain = run_chain(sensor.chain_settings(), groups, plan.time_e.size, variants=variants, chunk=chunk)
    record = LidarRecord(time_e=plan.time_e, vlos_e=chain.vlos_e, speed_e=chain.speed_e, flags_e=chain.flags_e,
                         variants=chain.variants, availability=chain.availability, info={},
                         focus_index_e=plan.focus_index_e, foci=tuple(float(f) for f in plan.foci),
                         extras=dict(plan.extras))
    return sensor.finish_record(record, plan, chain)
