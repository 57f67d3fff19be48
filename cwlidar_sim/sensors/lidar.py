"""Virtual staring cw lidar: its geometry, handed to the one signal chain.

Geometry
--------
The lidar at ``position`` stares along ``n`` (:func:`cwlidar_sim.beam.direction_from_angles`:
azimuth from +x toward +y, elevation up from the horizontal; azimuth 0 stares
along the mean wind, so a positive radial speed is away from the lidar),
focused at ``r = instrument.focus``.  Its probe volume is cut into the range
cells of :mod:`cwlidar_sim.beam.cells` (span, cell length and growth, the
tail rule).  Each estimate is one look at its mid-time ``t_e``: the
line-of-sight speed of every cell, ``n . (U + u, v, w)`` at
``position + (r + s) n`` and ``t_e`` (Taylor advection at U along +x,
trilinear interpolation as in :func:`cwlidar_sim.beam.sample_los`), is held
over the estimate (at 50 Hz the wind moves ``U / 50``, 0.2 m at 10 m/s,
during one estimate: less than a cell).  Everything after that -- tiers,
speckle, noise, background, clouds, thresholds, estimators, variants,
seeding -- is :mod:`cwlidar_sim.signal.chain`, the same for every lidar.

The speckle's transverse speed
------------------------------
``transverse_speed = None``: the rms, over the record, of the total wind's
component perpendicular to ``n`` at the focus (for a beam along the mean
wind: the v, w turbulence); it sets the speckle correlation time
``w0 / v_perp`` and ``M_eff``.

Defaults (choices, not facts of the papers)
-------------------------------------------
``cnr_db = -10``: the wideband carrier-to-noise ratio of a shot-noise-limited
1 W cw lidar at 1.55 um, ``CNR ~ eta P beta lambda pi / (h nu B)`` with
efficiency ``eta ~ 0.3``, ``B = 25 MHz`` and a boundary-layer backscatter
``beta ~ 1e-7 .. 1e-6 /m/sr``, is about -13 .. -3 dB.  Neither paper states
a CNR; -10 dB gives a per-bin SNR of ``CNR N / 2`` = 14 dB for a one-bin
line, so the prototype's estimates are essentially always available while
speckle still sets their scatter.
``speckle = 'continuum'`` with ``subcell_spread = None``: the sub-cell spread
from the field's Mann parameters (its attributes ``alpha_eps``,
``length_scale``, ``gamma``, ``dx``), the square root of
:func:`cwlidar_sim.turbulence.subcell_variance` (0.095 m/s for A2012's scene
at 0.5 m); 0 when the field carries no parameters ('independent' speckle
is then used).
``cell_length = 0.5`` m: the spacing of the fields used here; cells should
not be much longer than the field spacing.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._validation import check_int, check_real, check_tuple
from ..beam.sampling import _prepare_beam, direction_from_angles
from ..signal.instrument import PROTOTYPE_2003, Instrument
from .base import BeamSampler, LidarBase
from .protocol import Focus, LidarRecord, RecordPlan, measure

__all__ = ["StaringLidar", "measure_staring"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class StaringLidar(LidarBase):
    """A cw lidar staring in a fixed direction (A2012's prototype by default).

    Geometry fields below; the shared fields (instrument, tier, probe volume,
    chain, cloud) are those of :class:`cwlidar_sim.sensors.base.LidarBase`.

    Parameters
    ----------
    position : tuple of 3 floats
        Telescope position (x, y, z) [m] in the field's frame.
    azimuth_deg : float
        Beam azimuth [deg] from +x (the mean wind) toward +y; finite.
    elevation_deg : float
        Beam elevation above the horizontal [deg]; in [-90, 90].
    """

    instrument: Instrument = PROTOTYPE_2003
    position: tuple = (0.0, 0.0, 0.0)
    azimuth_deg: float = 0.0
    elevation_deg: float = 0.0

    def __post_init__(self):
        super().__post_init__()
        put = self._put
        put("position", check_tuple("position", self.position, 3, check_real))
        put("azimuth_deg", check_real("azimuth_deg", self.azimuth_deg))
        put("elevation_deg", check_real("elevation_deg", self.elevation_deg, lo=-90.0, hi=90.0))
        cells = self.cells()
        check_int("number of range cells", cells.n_cells, lo=1, hi=100_000)
        self.check_cloud_beyond(self.instrument, cells, float(self.direction[2]))

    # -- derived ---------------------------------------------------------
    @property
    def direction(self) -> np.ndarray:
        """Unit beam direction n, shape (3,) [-]."""
        return direction_from_angles(self.azimuth_deg, self.elevation_deg)

    @property
    def n_cells(self) -> int:
        """Number of range cells (the mean-wind tail cell not counted)."""
        return self.cells().n_cells

    def cells(self):
        """Range cells, weights and tail (:class:`cwlidar_sim.beam.cells.ProbeCells`)."""
        return self.probe_cells(self.instrument)

    def cloud_weight(self) -> float:
        """The cloud's weight relative to the aerosol probe volume, ``w_c`` [-] (0 if the beam never reaches it)."""
        return self.cloud_weight_at(self.instrument, float(self.direction[2]))

    # -- the Sensor protocol (cwlidar_sim.sensors.protocol) -----------------
    def plan_record(self, field, U: float, *, wrap: bool, times_e, transverse_speed: float | None = None) -> RecordPlan:
        """One fixed focus, one look per estimate at ``times_e`` [s] (module notes)."""
        inst = self.instrument
        cells = self.cells()
        n3 = np.ascontiguousarray(self.direction, dtype=np.float64)
        origin, _, time_e, _ = _prepare_beam(self.position, n3, times_e, np.maximum(inst.focus + cells.sub_j, 0.0))
        time_e = np.ascontiguousarray(time_e, dtype=np.float64)
        sampler = BeamSampler(field, origin, inst.focus, cells, U, wrap)
        sampler.check_extent(n3)
        ne = time_e.size
        wc = self.cloud_weight()
        vel_cl = self.cloud_velocity(U)

        def sample(lo, hi):
            vlos_ls, vlos_l = sampler.sample(time_e[lo:hi], np.broadcast_to(n3, (hi - lo, 3)))
            cloud = None if wc == 0.0 else np.full((hi - lo, 1), float(n3 @ vel_cl))
            return vlos_ls[:, None, :], vlos_l, cloud

        vt, src = 0.0, None
        if self.tier != "los":
            if transverse_speed is not None:
                vt, src = check_real("transverse_speed", transverse_speed, lo=0.0, hi=1000.0), "argument"
            elif self.transverse_speed is not None:
                vt, src = self.transverse_speed, "lidar"
            else:
                vel_tsc, vlos_ts = sampler.velocity_at(time_e, np.broadcast_to(n3, (ne, 3)), [inst.focus])
                perp = vel_tsc[:, 0, :] - vlos_ts[:, :1] * n3[None, :]
                vt, src = float(np.sqrt(np.mean(np.sum(perp * perp, axis=1)))), "field rms at the focus"
        focus = Focus(instrument=inst, index_e=np.arange(ne), time_e=time_e, cells=cells, n_looks=1, sample=sample,
                      transverse_speed=vt, field=field, cloud_weight=wc)
        return RecordPlan(time_e=time_e, focus_index_e=np.zeros(ne, dtype=np.int64), foci=(inst.focus,),
                          groups=[focus], fixed_focus=True, context={"n3": n3, "transverse_speed_source": src})

    def finish_record(self, record: LidarRecord, plan: RecordPlan, chain) -> LidarRecord:
        """The record's ``info`` (:func:`measure_staring`)."""
        inst, focus = self.instrument, plan.groups[0]
        cells, n3, wc = focus.cells, plan.context["n3"], focus.cloud_weight
        info = {
            "tier": self.tier, "n_estimates": plan.time_e.size, "n_cells": cells.n_cells,
            "cell_length": float(cells.edges[1] - cells.edges[0]), "span": self.span, "weighting": self.weighting,
            "tail": self.tail, "cell_growth": self.cell_growth,
            "kept_fraction": cells.kept_fraction, "truncated_fraction": cells.truncated_fraction,
            "rayleigh_length": inst.rayleigh_length, "focus": inst.focus, "direction": tuple(float(c) for c in n3),
            "cnr_db": self.cnr_db,
        }
        g = chain.groups[0]
        los = self.tier == "los"
        info.update(estimator=chain.info["estimator"], transverse_speed=None if los else focus.transverse_speed,
                    transverse_speed_source=plan.context["transverse_speed_source"],
                    correlation_time=g["correlation_time"], m_eff=g["m_eff"], speckle=g["speckle"],
                    subcell_spread=None if los else g["subcell_spread"],
                    subcell_spread_source=None if los else self.subcell_spread_in(focus.field)[1],
                    background=g["background"], flag_counts=chain.info["flag_counts"],
                    variant_availability=chain.info["variant_availability"])
        if not los:
            info.update(background_gain=g["background_gain"], cnr_db_range=g["cnr_db_range"],
                        n_failed=chain.info["n_failed"])
        else:
            info["note"] = ("tier 'los' is the ideal weighted line-of-sight average; speed_e = |vlos_e| with the "
                            "blind zone")
        if wc > 0.0:
            info.update(cloud_weight=wc, cloud_fraction=wc / (1.0 + wc))
        return dataclasses.replace(record, info=info)


def measure_staring(field, lidar: StaringLidar, times_e, U: float, seed=None, *, variants=None, chunk: int = 4096,
                    transverse_speed: float | None = None, wrap: bool = False,
                    calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a staring lidar's record of speed estimates in a turbulence field.

    The public API's form of :func:`cwlidar_sim.sensors.measure`
    for a staring lidar (its estimate times given).

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line field (see :func:`cwlidar_sim.beam.sample_los`);
        u, v, w are fluctuations [m/s], the mean ``U`` is added to u.
    lidar : StaringLidar
    times_e : array_like, shape (n_e,)
        Estimate mid-times [s] (e.g. ``arange(n) / instrument.estimate_rate``).
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u); in [-1000, 1000].
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (background, speckle,
        noise): required by them (a ValueError without one: a record is never
        drawn from fresh entropy, the same seed gives the same bits); not used
        by tier 'los', whose record is the field's.  The one focus group
        draws from the root SeedSequence (:func:`cwlidar_sim.sensors.measure`).
    variants : list of dict, optional
        Extra processing of the same spectra (:data:`cwlidar_sim.signal.chain.VARIANT_KEYS`), e.g.
        ``{'name': 'raise10', 'threshold_raise_percent': 10}`` or
        ``{'name': 'peak', 'estimator': 'peak'}``.
    chunk : int
        Estimates processed at a time (memory only); in [1, 10**6].
    transverse_speed : float, optional
        Overrides ``lidar.transverse_speed`` [m/s].
    wrap : bool
        Treat y and z as periodic (see :func:`cwlidar_sim.beam.sample_los`).
    calibration_time : float
        Time of ``times_e = 0`` on the background-calibration clock [s]
        (background gain mismatch and drift, pauses); e.g. a campaign
        period's start.

    Returns
    -------
    LidarRecord
        ``focus_index_e`` all 0, ``foci`` the focus; ``info``: ``tier``,
        ``n_estimates``, ``n_cells``, ``cell_length`` [m], ``span``,
        ``weighting``, ``tail``, ``kept_fraction``, ``truncated_fraction``,
        ``rayleigh_length`` [m], ``focus`` [m], ``direction``, ``cnr_db``,
        ``transverse_speed`` [m/s] and its ``transverse_speed_source``,
        ``correlation_time`` [s], ``m_eff``, ``speckle`` (the model used),
        ``subcell_spread`` [m/s] and its ``subcell_spread_source``,
        ``background``, ``estimator``, ``flag_counts``,
        ``variant_availability``, with a cloud ``cloud_weight`` and
        ``cloud_fraction``.
    """
    if not isinstance(lidar, StaringLidar):
        raise TypeError(f"lidar must be a StaringLidar, got {type(lidar).__name__}")
    return measure(field, lidar, U, seed, variants=variants, chunk=chunk, wrap=wrap, calibration_time=calibration_time,
                   times_e=times_e, transverse_speed=transverse_speed)


