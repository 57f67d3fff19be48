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

from .._validation import check_int, check_real, check_tuple
from ..beam.geometry import ConicalScanGeometry
from ..signal.instrument import CS_SERIES, Instrument
from ..signal.spectral import speckle_looks
from ..turbulence.cover import Region
from .base import BeamSampler, LidarBase
from .protocol import Focus, LidarRecord, RecordPlan, measure

__all__ = [
    "ConicalLidar",
    "ScanSchedule",
    "measure_conical",
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

    def box_region(self, spacing) -> Region:
        """The region a box must hold for this lidar (:func:`cwlidar_sim.turbulence.cover.cover_box`) [m].

        Every height's cells all round the cone (:meth:`beam_extent`) and the
        in-situ sensors at the measurement heights, grown by one grid step
        ``dy``, ``dz`` across the wind and vertically (``spacing``: one value
        or ``(dx, dy, dz)`` [m]).
        """
        if isinstance(spacing, (int, float, np.integer, np.floating)) and not isinstance(spacing, bool):
            spacing = (spacing,) * 3
        _, dy, dz = check_tuple("spacing", spacing, 3, lambda n, v: check_real(n, v, lo=0.0, hi=100.0, lo_open=True))
        radius = max(self.beam_extent(z)["radius"] for z in self.heights)
        z_lo = min(self.beam_extent(z)["z_lo"] for z in self.heights)
        z_hi = max(self.beam_extent(z)["z_hi"] for z in self.heights)
        for z in self.heights:  # in-situ sensors at the measurement heights
            z_lo, z_hi = min(z_lo, self.position[2] + z), max(z_hi, self.position[2] + z)
        return Region(x_lo=self.position[0] - radius, length=2.0 * radius, y_mid=self.position[1],
                      half_width=radius + dy, z_mid=0.5 * (z_lo + z_hi), half_height=0.5 * (z_hi - z_lo) + dz)

    def direction(self, azimuth_deg) -> np.ndarray:
        """Unit beam directions at the given azimuths [deg], shape (..., 3)."""
        return self.geometry.direction(azimuth_deg)

    # -- the Sensor protocol (cwlidar_sim.sensors.protocol) -----------------
    def plan_record(self, field, U: float, *, wrap: bool, duration: float, start: float = 0.0) -> RecordPlan:
        """The scan's dwells over ``[start, start + duration)``, one focus per height (module notes)."""
        sch = self.schedule(duration, start)
        origin = np.asarray(self.position, dtype=np.float64)
        nsub = self.sub_dwells
        # look offsets within a dwell, in units of the dwell: (l + 1/2) / nsub - 1/2
        off_l = (np.arange(nsub) + 0.5) / nsub - 0.5
        ring = self.direction(np.linspace(0.0, 360.0, 73))
        vel_cl = self.cloud_velocity(U)
        groups, hinfos = [], []
        for ih, z in enumerate(self.heights):
            idx = np.flatnonzero(sch.focus_index_e == ih)
            inst = self.instrument_at(z)
            cells = self.cells(z)
            sampler = BeamSampler(field, origin, inst.focus, cells, U, wrap)
            sampler.check_extent(ring)  # every azimuth at the extreme ranges
            wc = self.cloud_weight(z)
            hinfo = {"focus": inst.focus, "circle_diameter": self.circle_diameter(z),
                     "rayleigh_length": inst.rayleigh_length, "n_cells": cells.n_cells,
                     "cell_length": float(cells.edges[1] - cells.edges[0]),
                     "truncated_fraction": cells.truncated_fraction, "tail": self.tail,
                     "spot_speed": self.spot_speed(z), "speckle_time": self.speckle_time(z),
                     "m_eff": self.speckle_looks(z), "n_estimates": int(idx.size)}
            if self.cloud_base is not None:
                hinfo.update(cloud_range=self.cloud_base / math.cos(self._phi), cloud_weight=wc,
                             cloud_fraction=wc / (1.0 + wc))
            t_e, az_e = sch.time_e[idx], sch.azimuth_e[idx]

            def sample(lo, hi, t_e=t_e, az_e=az_e, sampler=sampler, wc=wc):
                nb = hi - lo
                t_l = (t_e[lo:hi, None] + off_l[None, :] * self.dwell_time).ravel()
                az_l = (az_e[lo:hi, None] + off_l[None, :] * self.dwell_angle_deg).ravel()
                n_lc = np.ascontiguousarray(self.direction(az_l))
                vlos_ls, vlos_l = sampler.sample(t_l, n_lc)
                cloud = None if wc == 0.0 else (n_lc @ vel_cl).reshape(nb, nsub)
                return vlos_ls.reshape(nb, nsub, -1), vlos_l.reshape(nb, nsub).mean(axis=1), cloud

            groups.append(Focus(instrument=inst, index_e=idx, time_e=t_e, cells=cells, n_looks=nsub, sample=sample,
                                transverse_speed=self.transverse_speed_at(z), field=field, cloud_weight=wc))
            hinfos.append(hinfo)
        return RecordPlan(time_e=sch.time_e, focus_index_e=sch.focus_index_e, foci=self.heights, groups=groups,
                          extras={"azimuth_e": sch.azimuth_e, "revolution_e": sch.revolution_e,
                                  "height_e": np.asarray(self.heights)[sch.focus_index_e]},
                          context={"heights": hinfos})

    def finish_record(self, record: LidarRecord, plan: RecordPlan, chain) -> LidarRecord:
        """The record's ``info`` (:func:`measure_conical`)."""
        info = {"tier": self.tier, "sub_dwells": self.sub_dwells, "n_estimates": plan.time_e.size, "heights": {}}
        for z, hinfo, g in zip(self.heights, plan.context["heights"], chain.groups):
            if hinfo["n_estimates"] == 0:
                continue
            if self.tier != "los":
                hinfo.update(background=g["background"], speckle=g["speckle"], subcell_spread=g["subcell_spread"])
            info["heights"][float(z)] = hinfo
        info.update(flag_counts=chain.info["flag_counts"], n_failed=chain.info["n_failed"],
                    estimator=chain.info["estimator"], variant_availability=chain.info["variant_availability"])
        return dataclasses.replace(record, info=info)

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
            per_block = self.revs_per_height * epr
            block_duration = self.revs_per_height * self.revolution_time + self.refocus_time
            nb = int(math.floor((duration + self.refocus_time) / block_duration + 1e-9))
            if nb < 1:
                raise ValueError(f"duration={duration} s holds no complete height block of {block_duration:g} s")
            b = np.repeat(np.arange(nb), per_block)
            j = np.tile(np.arange(per_block), nb)
            time_e = start + b * block_duration + (j + 0.5) * dt
            hidx = b % nh
            scan_e = b * self.revs_per_height + j // epr
        az = self.geometry.azimuth_at(time_e)
        return ScanSchedule(time_e=time_e, azimuth_e=az, focus_index_e=hidx, revolution_e=scan_e,
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
    focus_index_e : ndarray of int, shape (n_e,)
        Index into ``heights`` of each estimate.
    revolution_e : ndarray of int, shape (n_e,)
        Revolution number of each estimate (consecutive within a height block).
    heights : tuple of float
        Heights [m].
    """

    time_e: np.ndarray
    azimuth_e: np.ndarray
    focus_index_e: np.ndarray
    revolution_e: np.ndarray
    heights: tuple


def measure_conical(field, lidar: ConicalLidar, duration: float, U: float, seed=None, *, start: float = 0.0,
                    wrap: bool = False, variants=None, chunk: int = 4096,
                    calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a conically scanning lidar's record of radial-speed estimates in a turbulence field.

    The public API's form of :func:`cwlidar_sim.sensors.measure`
    for a conical lidar (a duration and a start).

    Parameters
    ----------
    field : xarray.Dataset
        Box field (see :func:`cwlidar_sim.beam.sample_los`) holding every cell
        of the cone (:func:`cwlidar_sim.turbulence.cover.cover_box` of
        :meth:`ConicalLidar.box_region` builds one); u, v, w fluctuations [m/s].
    lidar : ConicalLidar
    duration : float
        Record length [s] (:meth:`ConicalLidar.schedule`).
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u).
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (background, speckle,
        noise): required by them (a ValueError without one: a record is never
        drawn from fresh entropy, the same seed gives the same bits); not used
        by tier 'los', whose record is the field's.  Each height draws from
        its child of the root SeedSequence (:func:`cwlidar_sim.sensors.measure`).
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
    LidarRecord
        ``focus_index_e`` the index into ``heights``, ``foci`` the heights;
        ``extras`` (also attributes): ``azimuth_e`` and ``revolution_e`` (the
        :class:`ScanSchedule`), ``height_e`` [m]; ``info``: per height
        (``info['heights'][z]``) the focus, circle diameter, Rayleigh length,
        cells, truncated fraction, spot speed, speckle time and looks (with a
        cloud also ``cloud_range`` [m], ``cloud_weight`` w_c and
        ``cloud_fraction`` w_c / (1 + w_c)); tier, sub_dwells, flag counts.
        ``rec.select(z)`` gives one height's arrays.
    """
    if not isinstance(lidar, ConicalLidar):
        raise TypeError(f"lidar must be a ConicalLidar, got {type(lidar).__name__}")
    return measure(field, lidar, U, seed, variants=variants, chunk=chunk, wrap=wrap, calibration_time=calibration_time,
                   duration=duration, start=start)
