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

from .._repr import summary_repr
from .._seeding import focus_seeds
from .._validation import check_bool, check_int, check_real, check_tuple
from ..beam.sampling import _prepare_beam, direction_from_angles
from ..signal.chain import FocusGroup, run_chain
from ..signal.instrument import PROTOTYPE_2003, Instrument
from .base import BeamSampler, LidarBase

__all__ = ["StaringLidar", "LidarRecord", "measure_staring"]


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


@dataclasses.dataclass(frozen=True)
class LidarRecord:
    """Output of :func:`measure_staring`.

    Attributes
    ----------
    time_e : ndarray, float64, shape (n_e,)
        Estimate (mid-)times [s].
    vlos_e : ndarray, float64, shape (n_e,)
        Tier-1 probe-volume weighted line-of-sight speed of the total wind
        [m/s], signed (positive away from the lidar): the ideal.
    speed_e : ndarray, float64, shape (n_e,)
        The instrument's speed estimate |v| [m/s] (>= 0); NaN where the
        processing failed.
    flags_e : ndarray, uint8, shape (n_e,)
        :class:`cwlidar_sim.signal.Flag` bit fields.
    variants : dict
        Variant name -> ``(speed_e, flags_e)`` from the same spectra processed
        with that variant's overrides.
    availability : float
        Fraction of finite ``speed_e`` [-].
    info : dict
        Run information: ``tier``, ``n_estimates``, ``n_cells``,
        ``cell_length`` [m], ``span``, ``weighting``, ``tail``,
        ``kept_fraction``, ``truncated_fraction``, ``rayleigh_length`` [m],
        ``focus`` [m], ``direction``, ``cnr_db``, ``transverse_speed`` [m/s]
        and its ``transverse_speed_source``, ``correlation_time`` [s],
        ``m_eff``, ``speckle`` (the model used), ``subcell_spread`` [m/s] and
        its ``subcell_spread_source``, ``background``, ``estimator``,
        ``flag_counts``, ``variant_availability``, with a cloud
        ``cloud_weight`` and ``cloud_fraction``.
    """

    __repr__ = summary_repr

    time_e: np.ndarray
    vlos_e: np.ndarray
    speed_e: np.ndarray
    flags_e: np.ndarray
    variants: dict
    availability: float
    info: dict


def measure_staring(field, lidar: StaringLidar, times_e, U: float, seed=None, *, variants=None, chunk: int = 4096,
                    transverse_speed: float | None = None, wrap: bool = False,
                    calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a staring lidar's record of speed estimates in a turbulence field.

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line field (see :func:`cwlidar_sim.beam.sample_los`);
        u, v, w are fluctuations [m/s], the mean ``U`` is added to u.
    lidar : StaringLidar
    times_e : array_like, shape (n_e,)
        Estimate mid-times [s] (e.g. ``arange(n) / instrument.estimate_rate``).
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u).
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (background, speckle,
        noise): required by them (a ValueError without one: a record is never
        drawn from fresh entropy, the same seed gives the same bits); not used
        by tier 'los', whose record is the field's.
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
    """
    if not isinstance(lidar, StaringLidar):
        raise TypeError(f"lidar must be a StaringLidar, got {type(lidar).__name__}")
    if lidar.tier != "los" and seed is None:
        raise ValueError(f"seed is required for tier {lidar.tier!r}; allowed: an int or a numpy Generator")
    inst = lidar.instrument
    U = check_real("U", U)
    check_int("chunk", chunk, lo=1, hi=10**6)
    wrap = check_bool("wrap", wrap)
    calibration_time = check_real("calibration_time", calibration_time)
    settings = lidar.chain_settings()
    cells = lidar.cells()
    n3 = np.ascontiguousarray(lidar.direction, dtype=np.float64)
    origin, _, time_e, _ = _prepare_beam(lidar.position, n3, times_e, np.maximum(inst.focus + cells.sub_p, 0.0))
    time_e = np.ascontiguousarray(time_e, dtype=np.float64)
    sampler = BeamSampler(field, origin, inst.focus, cells, U, wrap)
    sampler.check_extent(n3)
    ne = time_e.size
    info = {
        "tier": lidar.tier, "n_estimates": ne, "n_cells": cells.n_cells,
        "cell_length": float(cells.edges[1] - cells.edges[0]), "span": lidar.span, "weighting": lidar.weighting,
        "tail": lidar.tail, "cell_growth": lidar.cell_growth,
        "kept_fraction": cells.kept_fraction, "truncated_fraction": cells.truncated_fraction,
        "rayleigh_length": inst.rayleigh_length, "focus": inst.focus, "direction": tuple(float(c) for c in n3),
        "cnr_db": lidar.cnr_db,
    }
    wc = lidar.cloud_weight()
    vel_cl = lidar.cloud_velocity(U)

    def sample(lo, hi):
        vlos_lc, vlos_l = sampler.sample(time_e[lo:hi], np.broadcast_to(n3, (hi - lo, 3)))
        cloud = None if wc == 0.0 else np.full((hi - lo, 1), float(n3 @ vel_cl))
        return vlos_lc[:, None, :], vlos_l, cloud

    vt, src, spread, spread_src = 0.0, None, 0.0, None
    if lidar.tier != "los":
        if transverse_speed is not None:
            vt, src = check_real("transverse_speed", transverse_speed, lo=0.0, hi=1000.0), "argument"
        elif lidar.transverse_speed is not None:
            vt, src = lidar.transverse_speed, "lidar"
        else:
            vel_tsc, vlos_ts = sampler.velocity_at(time_e, np.broadcast_to(n3, (ne, 3)), [inst.focus])
            perp = vel_tsc[:, 0, :] - vlos_ts[:, :1] * n3[None, :]
            vt, src = float(np.sqrt(np.mean(np.sum(perp * perp, axis=1)))), "field rms at the focus"
        spread, spread_src = lidar.subcell_spread_in(field)
    group = FocusGroup(instrument=inst, index_e=np.arange(ne), time_e=time_e, weight_c=cells.weight_c,
                       tail=cells.tail_weight > 0.0, n_looks=1,
                       sample=sample, seed=None if lidar.tier == "los" else focus_seeds(seed, None)[0],
                       transverse_speed=vt, subcell_spread=spread, cloud_weight=wc,
                       calibration_time=calibration_time)
    rec = run_chain(settings, [group], ne, variants=variants, chunk=chunk)
    g = rec.groups[0]
    info.update(estimator=rec.info["estimator"], transverse_speed=vt if lidar.tier != "los" else None,
                transverse_speed_source=src, correlation_time=g["correlation_time"], m_eff=g["m_eff"],
                speckle=g["speckle"], subcell_spread=g["subcell_spread"] if lidar.tier != "los" else None,
                subcell_spread_source=spread_src, background=g["background"],
                flag_counts=rec.info["flag_counts"], variant_availability=rec.info["variant_availability"])
    if lidar.tier != "los":
        info.update(background_gain=g["background_gain"], cnr_db_range=g["cnr_db_range"], n_failed=rec.info["n_failed"])
    else:
        info["note"] = "tier 'los' is the ideal weighted line-of-sight average; speed_e = |vlos_e| with the blind zone"
    if wc > 0.0:
        info.update(cloud_weight=wc, cloud_fraction=wc / (1.0 + wc))
    return LidarRecord(time_e=time_e, vlos_e=rec.vlos_e, speed_e=rec.speed_e, flags_e=rec.flags_e,
                       variants=rec.variants, availability=rec.availability, info=info)

