"""Virtual conically scanning cw lidar (the series ZephIR of CS): its geometry, handed to the one signal chain.

Geometry
--------
The telescope at ``position`` looks up a cone of half-angle Phi from the
vertical (30 deg) that it sweeps at a constant rate, one revolution per
``revolution_time`` (1 s), counter-clockwise seen from above (azimuth from
+x, the mean wind, toward +y).  For a measurement height z the focus is
``r = z / cos Phi`` and the scanned circle has diameter ``D = 2 z tan Phi``
(115 m at 100 m).  Beam direction at azimuth theta:
``n = (sin Phi cos theta, sin Phi sin theta, cos Phi)``, so a radial speed is
positive away from the telescope and the total wind ``(U + u, v, w)`` gives
``v_r = sin Phi [(U + u) cos theta + v sin theta] + cos Phi w``.

Estimates and the sweep within a dwell
--------------------------------------
Each revolution holds ``estimates_per_rev`` (50) estimates; estimate ``e``
averages the spectra of one dwell of ``revolution_time / estimates_per_rev``
(20 ms, CS: 4000 spectra) while the beam sweeps ``360 / estimates_per_rev``
degrees (7.2 deg).  The sweep is simulated: the dwell is cut into
``sub_dwells`` equal looks, look ``j`` at the look's mid-time and mid-azimuth
(``(j + 1/2) / sub_dwells`` through the dwell), each look's cells sampled
from the field (:mod:`cwlidar_sim.beam.cells`: the probe volume's cells and
the mean-wind tail cell).  The looks go to the signal chain
(:mod:`cwlidar_sim.signal.chain`), which averages them (tier 1), averages
their spectra (tier 2: the sweep broadens the Doppler line; near the
cross-wind azimuths v_r changes by ``U sin Phi 2 pi / 50``, 0.63 m/s or 4
bins of the CS instrument at 10 m/s, within one dwell) or synthesises
their signals in turn (tier 3).

Speckle while scanning (derived)
--------------------------------
The focal spot moves at ``v_spot = 2 pi r sin Phi / revolution_time``
(363 m/s at z = 100 m), far faster than the wind carries aerosols across the
waist ``w0 = lambda r / (pi a0)`` (2.9 mm at r = 115 m for the CS optics), so
the speckle's transverse speed is the spot's (``transverse_speed = None``;
the wind's few m/s across the beam are neglected beside v_spot): the
correlation time ``tau_c = w0 / v_spot`` (8 us at 100 m), and an M-block
average holds ``M_eff = speckle_looks(M, T_b, tau_c)`` independent looks
(:func:`cwlidar_sim.signal.speckle_looks`): about 2200 of CS's 4000 blocks
of 5 us -- not the handful of a staring beam -- at every height (w0 and
v_spot both grow like r, so tau_c does not depend on the height).
``tau_c`` also broadens each look's line (AR(1) amplitude, about
``1 / (2 pi tau_c)`` = 20 kHz, a tenth of a bin).

Homodyne folding and the zero crossing
--------------------------------------
The instrument loses the sign of v_r.  Twice per revolution, near the
cross-wind azimuths, |v_r| falls into the low-frequency blind zone of the
instrument (relative-intensity noise, ``blind_zone_speed``): tier 2's
processing returns NaN flagged ``NO_SIGNAL`` or an estimate flagged
``NEAR_ZERO`` (:class:`cwlidar_sim.signal.Flag`); tier 1 applies the same
rule to the ideal (:func:`cwlidar_sim.signal.chain.homodyne_flags`).
The VAD fits (:func:`cwlidar_sim.analysis.vad.fit_record`) leave flagged
points out.

Clouds
------
A cloud layer above the cone (:mod:`cwlidar_sim.sensors.base`) is crossed
between ranges ``[z_b, z_b + dz] / cos Phi``; it is one more cell of every
look, moving at the cloud's radial speed, the same look by look as the beam
sweeps.

Heights
-------
One height: the lidar dwells there.  Several heights: it cycles, measuring
``revs_per_height`` revolutions at each height in turn and losing
``refocus_time`` between heights (the scanner keeps turning); each height
then gets its share of the record, and is one focus group of the chain
(its seed the height's child of the record's seed, in height order).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._repr import summary_repr
from .._seeding import focus_seeds
from .._validation import check_bool, check_int, check_real, check_tuple
from ..beam.geometry import ConicalScanGeometry
from ..signal.chain import FocusGroup, run_chain
from ..signal.instrument import CS_SERIES, Instrument
from ..signal.spectral import speckle_looks
from .base import BeamSampler, LidarBase

__all__ = [
    "conical_box_yz",
    "ConicalLidar",
    "ConicalRecord",
    "ScanSchedule",
    "measure_conical",
    "conical_field",
    "HALF_ANGLE_RANGE",
    "FOCUS_RANGE",
]

#: Allowed cone half-angle from the vertical [deg]: the VAD needs both sin Phi
#: (horizontal speed) and cos Phi (vertical speed) well away from zero.
HALF_ANGLE_RANGE = (10.0, 60.0)
#: Allowed focus distance r = z / cos Phi [m] (ZephIR: measurement heights 10-200 m,
#: and the telescope cannot focus much closer than 10 m).
FOCUS_RANGE = (10.0, 1000.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ConicalLidar(LidarBase):
    """A conically scanning cw lidar (CS's series ZephIR by default).

    Geometry fields below; the shared fields (instrument, tier, probe volume,
    chain, cloud) are those of :class:`cwlidar_sim.sensors.base.LidarBase`,
    with the defaults of the scanning instrument (``instrument = CS_SERIES``,
    ``tier = 'los'``, ``span = 5``, ``cell_length = 2`` m, ``speckle =
    'independent'``).  The sensor's span 5 keeps unit-level boxes small; it
    is not converged for the 10-min std ratio (0.07 low at 40 m): scenes
    default to span 30 (:class:`cwlidar_sim.campaign.scenes.lidar_spec.ConicalLidarSpec`,
    docs/convergence.md).  The instrument's ``focus`` is replaced by each
    height's ``z / cos Phi``.

    Parameters
    ----------
    heights : tuple of float
        Measurement heights z above the telescope [m]; one height: dwell,
        several: cycle (module notes).  Each needs a focus ``z / cos Phi`` in
        :data:`FOCUS_RANGE`.
    half_angle_deg : float
        Cone half-angle Phi from the vertical [deg]; in :data:`HALF_ANGLE_RANGE`.
    revolution_time : float
        Time of one revolution [s]; in [0.1, 100].
    estimates_per_rev : int
        Estimates per revolution; in [4, 10000].  The instrument's
        ``blocks_per_estimate`` must fit in one dwell.
    revs_per_height : int
        Revolutions at each height before refocusing (cycle mode); in [1, 10000].
    refocus_time : float
        Time lost between heights in cycle mode [s]; in [0, 100].
    azimuth0_deg : float
        Beam azimuth at t = 0 [deg], from +x toward +y.
    position : tuple of 3 floats
        Telescope position (x, y, z) [m].
    sub_dwells : int
        Looks simulated per dwell (the sweep); in [1, 256].
    """

    heights: tuple = (100.0,)
    instrument: Instrument = CS_SERIES
    half_angle_deg: float = 30.0
    revolution_time: float = 1.0
    estimates_per_rev: int = 50
    revs_per_height: int = 1
    refocus_time: float = 0.0
    azimuth0_deg: float = 0.0
    position: tuple = (0.0, 0.0, 0.0)
    tier: str = "los"
    span: float = 5.0
    cell_length: float = 2.0
    sub_dwells: int = 8
    speckle: str = "independent"

    def __post_init__(self):
        super().__post_init__()
        put = self._put
        phi = check_real("half_angle_deg", self.half_angle_deg, lo=HALF_ANGLE_RANGE[0], hi=HALF_ANGLE_RANGE[1])
        put("half_angle_deg", phi)
        h = self.heights
        if isinstance(h, (int, float, np.integer, np.floating)) and not isinstance(h, bool):
            h = (h,)
        if isinstance(h, (str, bytes)) or not hasattr(h, "__len__") or len(h) < 1:
            raise TypeError(f"heights must be a non-empty sequence of heights [m], got {self.heights!r}")
        c = math.cos(math.radians(phi))
        lo_z, hi_z = FOCUS_RANGE[0] * c, FOCUS_RANGE[1] * c
        hs = []
        for i, z in enumerate(h):
            z = check_real(f"heights[{i}]", z)
            if not lo_z <= z <= hi_z:
                raise ValueError(
                    f"heights[{i}]={z!r} m needs focus r = z / cos({phi:g} deg) = {z / c:.4g} m, outside the "
                    f"focus range {FOCUS_RANGE} m; allowed heights: [{lo_z:.4g}, {hi_z:.4g}] m")
            hs.append(z)
        if len(set(hs)) != len(hs):
            raise ValueError(f"heights must be distinct, got {tuple(hs)}")
        put("heights", tuple(hs))
        put("revolution_time", check_real("revolution_time", self.revolution_time, lo=0.1, hi=100.0))
        put("estimates_per_rev", check_int("estimates_per_rev", self.estimates_per_rev, lo=4, hi=10000))
        put("revs_per_height", check_int("revs_per_height", self.revs_per_height, lo=1, hi=10000))
        put("refocus_time", check_real("refocus_time", self.refocus_time, lo=0.0, hi=100.0))
        put("azimuth0_deg", check_real("azimuth0_deg", self.azimuth0_deg))
        put("position", check_tuple("position", self.position, 3, check_real))
        put("sub_dwells", check_int("sub_dwells", self.sub_dwells, lo=1, hi=256))
        inst = self.instrument
        if (self.tier == "signal" or (self.tier == "spectral" and self.speckle == "continuum")) \
                and inst.blocks_per_estimate % self.sub_dwells:
            raise ValueError(f"tier {self.tier!r} with speckle {self.speckle!r} needs sub_dwells={self.sub_dwells} "
                             f"to divide instrument.blocks_per_estimate={inst.blocks_per_estimate}; allowed: its "
                             "divisors")
        fit = self.dwell_time / inst.block_duration
        if inst.blocks_per_estimate > fit * (1 + 1e-9):
            raise ValueError(
                f"instrument.blocks_per_estimate={inst.blocks_per_estimate} does not fit in one dwell of "
                f"{self.dwell_time:g} s (revolution_time / estimates_per_rev); allowed: <= {math.floor(fit + 1e-9)}")
        for z in self.heights:
            check_int("number of range cells", self.cells(z).n_cells, lo=1, hi=100_000)
            self.check_cloud_beyond(self.instrument_at(z), self.cells(z), math.cos(self._phi))

    def as_dict(self) -> dict:
        d = super().as_dict()
        d["heights"] = tuple(self.heights)
        return d

    # -- derived ---------------------------------------------------------
    @property
    def dwell_time(self) -> float:
        """Duration of one estimate, revolution_time / estimates_per_rev [s] (20 ms)."""
        return self.revolution_time / self.estimates_per_rev

    @property
    def dwell_angle_deg(self) -> float:
        """Azimuth swept during one estimate, 360 / estimates_per_rev [deg] (7.2 deg)."""
        return 360.0 / self.estimates_per_rev

    @property
    def _phi(self) -> float:
        return math.radians(self.half_angle_deg)

    @property
    def geometry(self) -> ConicalScanGeometry:
        """The scan's cone (:class:`cwlidar_sim.beam.ConicalScanGeometry`, axis 'up')."""
        return ConicalScanGeometry(self.half_angle_deg, "up", self.revolution_time, self.azimuth0_deg)

    def focus(self, height: float) -> float:
        """Focus distance r = z / cos Phi [m]."""
        return self.geometry.focus_at(height)

    def circle_diameter(self, height: float) -> float:
        """Diameter of the scanned circle D = 2 z tan Phi [m]."""
        return self.geometry.circle_diameter(height)

    def instrument_at(self, height: float) -> Instrument:
        """The instrument focused at height z."""
        return self.instrument.replace(focus=self.focus(height))

    def spot_speed(self, height: float) -> float:
        """Speed of the focal spot along the circle, 2 pi r sin Phi / revolution_time [m/s]."""
        return self.geometry.spot_speed(self.focus(height))

    def transverse_speed_at(self, height: float) -> float:
        """The speckle's transverse speed at height z [m/s]: ``transverse_speed`` or the spot's speed."""
        return self.spot_speed(height) if self.transverse_speed is None else self.transverse_speed

    def speckle_time(self, height: float) -> float:
        """Speckle correlation time while scanning, w0 / v_spot [s] (module notes)."""
        return self.instrument_at(height).speckle_time(self.transverse_speed_at(height))

    def speckle_looks(self, height: float) -> float:
        """Independent speckle looks M_eff of one estimate while scanning [-]."""
        inst = self.instrument_at(height)
        return speckle_looks(inst.blocks_per_estimate, inst.block_duration, self.speckle_time(height))

    def cells(self, height: float):
        """Range cells, weights and tail at height z (:class:`cwlidar_sim.beam.cells.ProbeCells`)."""
        return self.probe_cells(self.instrument_at(height))

    def cloud_weight(self, height: float) -> float:
        """Weight of the cloud relative to the aerosol probe volume at height z, ``w_c`` [-] (0 without a cloud)."""
        return self.cloud_weight_at(self.instrument_at(height), math.cos(self._phi))

    def cloud_fraction(self, height: float) -> float:
        """Fraction of the received power from the cloud at height z, ``w_c / (1 + w_c)`` [-]."""
        w = self.cloud_weight(height)
        return w / (1.0 + w)

    def beam_extent(self, height: float) -> dict:
        """Horizontal radius and height range [m] that the simulated cells reach at height z."""
        cells = self.cells(height)
        r = self.focus(height)
        r_lo = max(r + cells.edges[0], 0.0)
        r_hi = r + cells.edges[-1]
        s, c = math.sin(self._phi), math.cos(self._phi)
        return {"radius": r_hi * s, "z_lo": self.position[2] + r_lo * c,
                "z_hi": self.position[2] + r_hi * c}

    def direction(self, azimuth_deg) -> np.ndarray:
        """Unit beam directions at the given azimuths [deg], shape (..., 3)."""
        return self.geometry.direction(azimuth_deg)

    def schedule(self, duration: float, start: float = 0.0) -> "ScanSchedule":
        """Estimate times, azimuths and heights over ``[start, start + duration)`` (module notes).

        Parameters
        ----------
        duration : float
            Record length [s]; > 0 and holding at least one revolution.
        start : float
            Start time [s]; the azimuth is ``azimuth0 + 360 t / revolution_time`` at any t.
        """
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        if duration < self.revolution_time * (1 - 1e-12):
            raise ValueError(f"duration={duration} s holds no revolution; allowed: >= revolution_time = "
                             f"{self.revolution_time} s")
        epr, dt = self.estimates_per_rev, self.dwell_time
        nh = len(self.heights)
        if nh == 1:
            n = int(math.floor(duration / dt + 1e-9))
            n -= n % epr
            j = np.arange(n)
            time_e = start + (j + 0.5) * dt
            hidx = np.zeros(n, dtype=np.int64)
            scan_e = j // epr
        else:
            block_n = self.revs_per_height * epr
            block_t = self.revs_per_height * self.revolution_time + self.refocus_time
            nb = int(math.floor((duration + self.refocus_time) / block_t + 1e-9))
            if nb < 1:
                raise ValueError(f"duration={duration} s holds no complete height block of {block_t:g} s")
            b = np.repeat(np.arange(nb), block_n)
            j = np.tile(np.arange(block_n), nb)
            time_e = start + b * block_t + (j + 0.5) * dt
            hidx = b % nh
            scan_e = b * self.revs_per_height + j // epr
        az = self.geometry.azimuth_at(time_e)
        return ScanSchedule(time_e=time_e, azimuth_e=az, height_index_e=hidx, revolution_e=scan_e,
                            heights=self.heights)


@dataclasses.dataclass(frozen=True)
class ScanSchedule:
    """Estimates of a conical scan.

    Attributes
    ----------
    time_e : ndarray, shape (n_e,)
        Dwell mid-times [s].
    azimuth_e : ndarray, shape (n_e,)
        Beam azimuth at the dwell's mid-time [deg] (unwrapped, increasing).
    height_index_e : ndarray of int, shape (n_e,)
        Index into ``heights`` of each estimate.
    revolution_e : ndarray of int, shape (n_e,)
        Revolution number of each estimate (consecutive within a height block).
    heights : tuple of float
        Heights [m].
    """

    time_e: np.ndarray
    azimuth_e: np.ndarray
    height_index_e: np.ndarray
    revolution_e: np.ndarray
    heights: tuple


@dataclasses.dataclass(frozen=True)
class ConicalRecord:
    """Output of :func:`measure_conical`.

    Attributes
    ----------
    time_e, azimuth_e, height_index_e, revolution_e : ndarray
        The :class:`ScanSchedule` of the record.
    height_e : ndarray, shape (n_e,)
        Height of each estimate [m].
    vlos_e : ndarray, shape (n_e,)
        Tier-1 dwell-averaged weighted line-of-sight speed [m/s], signed: the ideal.
    speed_e : ndarray, shape (n_e,)
        The instrument's estimate |v_r| [m/s]; NaN where it failed.
    flags_e : ndarray, uint8, shape (n_e,)
        :class:`cwlidar_sim.signal.Flag` bits.
    availability : float
        Fraction of finite ``speed_e``.
    info : dict
        Per height: focus, circle diameter, Rayleigh length, cells, truncated
        fraction, spot speed, speckle time and looks (with a cloud also
        ``cloud_range`` [m], ``cloud_weight`` w_c and ``cloud_fraction``
        w_c / (1 + w_c)); tier, sub_dwells, flag counts.
    variants : dict
        Variant name -> ``(speed_e, flags_e)`` (processing variants of the same spectra).
    """

    __repr__ = summary_repr

    time_e: np.ndarray
    azimuth_e: np.ndarray
    height_index_e: np.ndarray
    revolution_e: np.ndarray
    height_e: np.ndarray
    vlos_e: np.ndarray
    speed_e: np.ndarray
    flags_e: np.ndarray
    availability: float
    info: dict
    variants: dict = dataclasses.field(default_factory=dict)

    def select(self, height: float) -> dict:
        """Arrays of the estimates at one height: time, azimuth, speed, flags, vlos, revolution."""
        m = self.height_e == float(height)
        if not m.any():
            raise ValueError(f"height={height!r} is not in the record; allowed: {sorted(set(self.height_e))}")
        return {"time_e": self.time_e[m], "azimuth_e": self.azimuth_e[m], "speed_e": self.speed_e[m],
                "flags_e": self.flags_e[m], "vlos_e": self.vlos_e[m], "revolution_e": self.revolution_e[m]}


def measure_conical(field, lidar: ConicalLidar, duration: float, U: float, seed=None, *, start: float = 0.0,
                    wrap: bool = False, variants=None, chunk: int = 4096,
                    calibration_time: float = 0.0) -> ConicalRecord:
    """Simulate a conically scanning lidar's record of radial-speed estimates in a turbulence field.

    Parameters
    ----------
    field : xarray.Dataset
        Box field (see :func:`cwlidar_sim.beam.sample_los`) holding every cell
        of the cone (:func:`conical_field` builds one); u, v, w fluctuations [m/s].
    lidar : ConicalLidar
    duration : float
        Record length [s] (:meth:`ConicalLidar.schedule`).
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u).
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (background, speckle,
        noise): required by them (a ValueError without one: a record is never
        drawn from fresh entropy, the same seed gives the same bits); not used
        by tier 'los', whose record is the field's.
    start : float
        Start time [s].
    wrap : bool
        Treat y and z as periodic.
    variants : list of dict, optional
        Extra processing of the same spectra (:data:`cwlidar_sim.signal.chain.VARIANT_KEYS`).
    chunk : int
        Estimates processed at a time (memory only); in [1, 10**6].
    calibration_time : float
        Time of t = 0 on the background-calibration clock [s].

    Returns
    -------
    ConicalRecord
    """
    if not isinstance(lidar, ConicalLidar):
        raise TypeError(f"lidar must be a ConicalLidar, got {type(lidar).__name__}")
    U = check_real("U", U, lo=-1000.0, hi=1000.0)
    wrap = check_bool("wrap", wrap)
    calibration_time = check_real("calibration_time", calibration_time)
    sch = lidar.schedule(duration, start)
    origin = np.asarray(lidar.position, dtype=np.float64)
    ne = sch.time_e.size
    nsub = lidar.sub_dwells
    height_e = np.asarray(lidar.heights)[sch.height_index_e]
    settings = lidar.chain_settings()
    info = {"tier": lidar.tier, "sub_dwells": nsub, "n_estimates": ne, "heights": {}}
    if lidar.tier != "los":
        if seed is None:
            raise ValueError(f"seed is required for tier {lidar.tier!r}; allowed: an int or a numpy Generator")
        height_seqs = focus_seeds(seed, len(lidar.heights))
    spread, _ = lidar.subcell_spread_in(field)
    # look offsets within a dwell, in units of the dwell: (j + 1/2) / nsub - 1/2
    off_j = (np.arange(nsub) + 0.5) / nsub - 0.5
    ring = lidar.direction(np.linspace(0.0, 360.0, 73))
    vel_cl = lidar.cloud_velocity(U)
    groups, hinfos = [], []
    for ih, z in enumerate(lidar.heights):
        idx = np.flatnonzero(sch.height_index_e == ih)
        inst = lidar.instrument_at(z)
        cells = lidar.cells(z)
        sampler = BeamSampler(field, origin, inst.focus, cells, U, wrap)
        sampler.check_extent(ring)  # every azimuth at the extreme ranges
        wc = lidar.cloud_weight(z)
        hinfo = {"focus": inst.focus, "circle_diameter": lidar.circle_diameter(z),
                 "rayleigh_length": inst.rayleigh_length, "n_cells": cells.n_cells,
                 "cell_length": float(cells.edges[1] - cells.edges[0]), "truncated_fraction": cells.truncated_fraction,
                 "tail": lidar.tail, "spot_speed": lidar.spot_speed(z), "speckle_time": lidar.speckle_time(z),
                 "m_eff": lidar.speckle_looks(z), "n_estimates": int(idx.size)}
        if lidar.cloud_base is not None:
            hinfo.update(cloud_range=lidar.cloud_base / math.cos(lidar._phi), cloud_weight=wc,
                         cloud_fraction=wc / (1.0 + wc))
        t_e, az_e = sch.time_e[idx], sch.azimuth_e[idx]

        def sample(lo, hi, t_e=t_e, az_e=az_e, sampler=sampler, wc=wc):
            nb = hi - lo
            t_l = (t_e[lo:hi, None] + off_j[None, :] * lidar.dwell_time).ravel()
            az_l = (az_e[lo:hi, None] + off_j[None, :] * lidar.dwell_angle_deg).ravel()
            n_lc = np.ascontiguousarray(lidar.direction(az_l))
            vlos_lc, vlos_l = sampler.sample(t_l, n_lc)
            cloud = None if wc == 0.0 else (n_lc @ vel_cl).reshape(nb, nsub)
            return vlos_lc.reshape(nb, nsub, -1), vlos_l.reshape(nb, nsub).mean(axis=1), cloud

        groups.append(FocusGroup(instrument=inst, index_e=idx, time_e=t_e, weight_c=cells.weight_c,
                                 tail=cells.tail_weight > 0.0, n_looks=nsub,
                                 sample=sample, seed=None if lidar.tier == "los" else height_seqs[ih],
                                 transverse_speed=lidar.transverse_speed_at(z), subcell_spread=spread,
                                 cloud_weight=wc, calibration_time=calibration_time))
        hinfos.append((float(z), hinfo))
    rec = run_chain(settings, groups, ne, variants=variants, chunk=chunk)
    for (z, hinfo), g in zip(hinfos, rec.groups):
        if hinfo["n_estimates"] == 0:
            continue
        if lidar.tier != "los":
            hinfo.update(background=g["background"], speckle=g["speckle"], subcell_spread=g["subcell_spread"])
        info["heights"][z] = hinfo
    info.update(flag_counts=rec.info["flag_counts"], n_failed=rec.info["n_failed"], estimator=rec.info["estimator"],
                variant_availability=rec.info["variant_availability"])
    return ConicalRecord(time_e=sch.time_e, azimuth_e=sch.azimuth_e, height_index_e=sch.height_index_e,
                         revolution_e=sch.revolution_e, height_e=height_e, vlos_e=rec.vlos_e, speed_e=rec.speed_e,
                         flags_e=rec.flags_e, availability=rec.availability, info=info, variants=rec.variants)


# ---------------------------------------------------------------------------
# turbulence for the cone
# ---------------------------------------------------------------------------
def conical_field(lidar: ConicalLidar, U: float, duration: float, params, seed: int, *, spacing,
                  lateral_doubling: bool = True, min_extent: float | None = None, extent=None,
                  hf_compensation: bool = False, dtype=np.float32, period_x: float | None = None, condition=None):
    """A Mann box holding a conical lidar's cells for a record, placed in the lidar's frame.

    Parameters
    ----------
    lidar : ConicalLidar
        Its heights, cone and span set the region (all heights together).
    U : float
        Mean wind [m/s]; the box's x period must hold ``U duration`` plus the
        circle, so that no part of the field is seen twice.
    duration : float
        Record length [s]; > 0.
    params : MannParameters
    seed : int
    spacing : float or (float, float, float)
        Grid spacing in x, y and z [m] (one value: all three); each in (0, 100].
    lateral_doubling : bool
        Generate the box twice as wide in y and keep one half (hipersim's
        default), so that the far side of the circle is not correlated with
        its periodic image W - D away (see the notes).
    min_extent : float, optional
        Minimum lateral and vertical size of the kept box [m]; default
        ``2 L`` (L the tensor's length scale), so that the lowest resolved
        modes are not much shorter than the energy-containing eddies.
    extent : (float, float, float), optional
        Physical size (Lx, Ly, Lz) [m] of the kept box, at least what the
        record and the cone need (checked).  With it the box's shape is
        :func:`cwlidar_sim.turbulence.grids.grid_for_extent` of it and the
        spacing (the spacing then ``L_i / N_i``), so boxes of one extent and
        one seed on other grids hold the same Fourier coefficients at the
        wavenumbers they share: a paired comparison of spacings.  Default:
        sized from the spacing (cells rounded up, x FFT-friendly).
    hf_compensation : bool
        The box's high-frequency compensation
        (:func:`cwlidar_sim.turbulence.generate_box`).
    dtype : float32 or float64
    period_x : float, optional
        The box's x period [m], exactly (exclusive with ``extent``): the
        virtual twin's box, whose period is the records' ``U T`` so that each
        record covers one whole line (:mod:`cwlidar_sim.campaign.twin.run`).
        ``nx`` is ``period_x / spacing[0]`` where that is a whole number
        (the twin's choice: a node per record sample), else the smallest
        FFT-friendly count with ``period_x / nx <= spacing[0]``; dx is
        ``period_x / nx``.  Shorter than ``U duration``
        plus the circle, so the lidar sees the periodic image within the
        circle's reach (a few seconds) of the record's ends.
    condition : callable, optional
        ``condition(box) -> box`` applied to the generated box (all of it,
        both lateral halves, in the lidar's frame) before one half is kept:
        the twin conditions it there on the records, since the kept half of
        a doubled box does not have a periodic box's covariance.

    Returns
    -------
    xarray.Dataset
        u, v, w [m/s] on x, y, z; y centred on the lidar, z from below the
        lowest cell; attrs hold the generation settings (``period_x``,
        ``lateral_doubling``, ``generated_shape``) and those ``condition``
        adds.

    Notes
    -----
    Lateral periodicity: a periodic box of width W correlates y with
    y + W, so points at the two ends of a circle diameter D (y = +-D/2) are
    only ``W - D`` apart through the periodic image; for W close to D the far
    sides of the circle are nearly the same air.  Generating ``2 W`` and
    keeping ``W`` makes the kept box's two lateral ends ``W`` apart through
    the image as well (the generated box's correlation at lag ``2W - D``
    instead of ``W - D``); the price is twice the generation cost.  Kept
    boxes are not periodic in y, so sampling uses ``wrap=False``.
    """
    import xarray as xr

    from ..turbulence.box import generate_box, keep_lateral_rows
    from ..turbulence.parameters import MannParameters

    if not isinstance(lidar, ConicalLidar):
        raise TypeError(f"lidar must be a ConicalLidar, got {type(lidar).__name__}")
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be MannParameters, got {type(params).__name__}")
    U = check_real("U", U, lo=0.0, hi=1000.0)
    duration = check_real("duration", duration, lo=0.0, lo_open=True)
    if isinstance(spacing, (int, float, np.integer, np.floating)) and not isinstance(spacing, bool):
        spacing = (spacing,) * 3
    dx, dy, dz = check_tuple("spacing", spacing, 3, lambda n, v: check_real(n, v, lo=0.0, hi=100.0, lo_open=True))
    lateral_doubling = check_bool("lateral_doubling", lateral_doubling)
    hf_compensation = check_bool("hf_compensation", hf_compensation)
    radius, z_lo, z_hi, width, height = _lateral_needs(lidar, params, dy, dz, min_extent)
    length = U * duration + 2.0 * radius + 4.0 * dx
    if period_x is not None:
        if extent is not None:
            raise ValueError("conical_field: give period_x or extent, not both")
        period_x = check_real("period_x", period_x, lo=0.0, hi=1e7, lo_open=True)
    if extent is None:
        ny = int(math.ceil(width / dy)) + 1
        nz = int(math.ceil(height / dz)) + 1
        if period_x is None:
            nx = _fast_size(int(math.ceil(length / dx)))
        else:
            nx = int(round(period_x / dx))
            if abs(nx * dx - period_x) > 1e-9 * period_x:
                nx = _fast_size(int(math.ceil(period_x / dx * (1 - 1e-12))))
            dx = period_x / nx
    else:
        from ..turbulence.grids import grid_for_extent

        ext3 = check_tuple("extent", extent, 3, lambda n, v: check_real(n, v, lo=0.0, lo_open=True))
        (nx, ny, nz), (dx, dy, dz) = grid_for_extent(ext3, (dx, dy, dz))
        # the kept box spans (N - 1) d between its first and last points; the x period N dx
        for name, have, need in (("extent[0]", nx * dx, length), ("extent[1]", (ny - 1) * dy, width),
                                 ("extent[2]", (nz - 1) * dz, height)):
            if have < need * (1 - 1e-9):
                raise ValueError(f"{name} gives {have:.4g} m, less than the {need:.4g} m the record and the cone "
                                 f"need; allowed: a larger extent")
    ny_gen = 2 * ny if lateral_doubling else ny
    box = generate_box(params, (nx, ny_gen, nz), (dx, dy, dz), seed, hf_compensation=hf_compensation, dtype=dtype)
    zc = 0.5 * (z_lo + z_hi)
    if condition is not None and extent is not None:
        raise ValueError("conical_field: condition needs the default placement (no extent)")
    if extent is None:
        x0 = lidar.position[0] - radius - dx
        y0 = lidar.position[1] - 0.5 * (ny - 1) * dy
        zb = zc - 0.5 * (nz - 1) * dz
    else:  # origins of the physical size, not of the spacing: grids of one extent place their points alike
        x0 = lidar.position[0] - radius - 0.5 * (ext3[0] - length + 4.0 * dx)
        y0 = lidar.position[1] - 0.5 * ext3[1]
        zb = zc - 0.5 * ext3[2]
    if condition is not None:
        box = box.assign_coords(x=x0 + np.arange(nx) * dx, y=y0 + np.arange(ny_gen) * dy, z=zb + np.arange(nz) * dz)
        box = condition(box)
    keep = (lambda a: np.ascontiguousarray(a[:, :ny, :])) if condition is not None else (lambda a: keep_lateral_rows(a, ny))
    data = {c: (("x", "y", "z"), keep(box[c].values)) for c in ("u", "v", "w")}
    attrs = dict(box.attrs)
    attrs.update(period_x=nx * dx, lateral_doubling=int(lateral_doubling), generated_shape=(nx, ny_gen, nz))
    del box
    coords = {"x": x0 + np.arange(nx) * dx, "y": y0 + np.arange(ny) * dy,
              "z": zb + np.arange(nz) * dz}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _lateral_needs(lidar, params, dy, dz, min_extent):
    """(radius, z_lo, z_hi, width, height) [m]: the cone's reach and the kept box's lateral and vertical needs."""
    ext = 2.0 * params.length_scale if min_extent is None else check_real("min_extent", min_extent, lo=0.0)
    radius = max(lidar.beam_extent(z)["radius"] for z in lidar.heights)
    z_lo = min(lidar.beam_extent(z)["z_lo"] for z in lidar.heights)
    z_hi = max(lidar.beam_extent(z)["z_hi"] for z in lidar.heights)
    for z in lidar.heights:  # in-situ sensors at the measurement heights
        z_lo, z_hi = min(z_lo, lidar.position[2] + z), max(z_hi, lidar.position[2] + z)
    return radius, z_lo, z_hi, max(2.0 * radius + 2.0 * dy, ext), max(z_hi - z_lo + 2.0 * dz, ext)


def conical_box_yz(lidar: ConicalLidar, params, *, spacing, lateral_doubling: bool = True,
                   min_extent: float | None = None):
    """The y and z nodes [m] of the box :func:`conical_field` generates (both lateral halves; default placement).

    They do not depend on the wind or the record length: the virtual twin
    uses them to choose the records a box can be conditioned on before it
    sizes the box's x period from those records' mean speed.
    """
    if isinstance(spacing, (int, float, np.integer, np.floating)) and not isinstance(spacing, bool):
        spacing = (spacing,) * 3
    _, dy, dz = check_tuple("spacing", spacing, 3, lambda n, v: check_real(n, v, lo=0.0, hi=100.0, lo_open=True))
    _, z_lo, z_hi, width, height = _lateral_needs(lidar, params, dy, dz, min_extent)
    ny = int(math.ceil(width / dy)) + 1
    nz = int(math.ceil(height / dz)) + 1
    ny_gen = 2 * ny if check_bool("lateral_doubling", lateral_doubling) else ny
    y0 = lidar.position[1] - 0.5 * (ny - 1) * dy
    zb = 0.5 * (z_lo + z_hi) - 0.5 * (nz - 1) * dz
    return y0 + np.arange(ny_gen) * dy, zb + np.arange(nz) * dz


def _fast_size(n: int) -> int:
    """Smallest integer >= n whose prime factors are 2, 3 and 5 (fast FFT lengths)."""
    m = max(2, n)
    while True:
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        if k == 1:
            return m
        m += 1
