"""Nacelle-mounted forward-looking cw lidar (lidar-assisted turbine control): its geometry, handed to the one chain.

Frame
-----
The field's frame: x along the mean wind (downwind), y to the left looking
downwind, z up (right-handed); the wind is ``(U + u, v, w)`` and a point at
rest sees the frozen field at ``x - U t`` (Taylor).  The lidar sits at
``position`` (on the nacelle, at hub height) and looks upwind.  In the
*nacelle frame* (the turbine's, at rest) a circular scan of half-angle ``a``
points at beam azimuth ``phi`` (from +y toward +z, the convention of
:func:`cwlidar_sim.analysis.rews_theory.circular_scan`) along
``m(phi) = (-cos a, sin a cos phi, sin a sin phi)``.  The nacelle frame is
the field's turned by the yaw misalignment ``gamma`` about z (positive from
+x toward +y): ``n = Rz(gamma) m``, so a uniform wind along +x has the
component ``U cos gamma`` along the rotor axis and ``-U sin gamma`` across
it (nacelle frame).

Scan and schedule
-----------------
One revolution per ``revolution_time`` (1 s), ``estimates_per_rev`` (50)
estimates, each a dwell of ``revolution_time / estimates_per_rev`` while
the beam sweeps ``360 / estimates_per_rev`` deg; the dwell is simulated as
``sub_dwells`` looks at the look's mid-time and mid-azimuth (as the conical
lidar's).  ``beam_azimuths_deg`` replaces the circle by a few fixed beams
of the same optics taking turns (estimate j on beam ``j mod n_beams``, no
sweep).  Several ``focus_distances``: ``revs_per_focus`` revolutions at
each in turn, ``refocus_time`` lost between them (the scanner keeps
turning); each focus is one :class:`~cwlidar_sim.signal.chain.FocusGroup`
of the chain (its seed the focus's child of the record's seed).

Line of sight and the platform
------------------------------
A prescribed platform motion (:class:`PlatformMotion`: the lidar's own
displacement ``d(t)`` = surge, sway, heave along x, y, z of the field frame
[m], lever arms included, and the nacelle's attitude roll, pitch, yaw about
x, y, z [deg]) moves and turns the beams: the look's direction is
``n = Rz(gamma + yaw) Ry(pitch) Rx(roll) m`` from ``position + d(t)``, and the
Doppler shift is of the wind relative to the moving lidar,
``v_los = n . (u(p) - d'(t))`` (the turning moves the focus across the beam,
which shifts nothing).  d and the angles are interpolated linearly between
the given samples; d' is the central difference of the samples
(``numpy.gradient``), interpolated linearly: the one velocity both the
Doppler shift and the motion sensor see.

From speeds to the wind
-----------------------
The homodyne instrument reports ``|v_los|``; looking into the wind the
lidar assumes ``v_los = -speed`` (the chain flags estimates near the blind
zone, :func:`cwlidar_sim.signal.chain.homodyne_flags`, where the sign and
the speed are unreliable: near the cone's edge in yawed flow with
``a + gamma`` near 90 deg).  Its estimate of the line-of-sight wind is
``los_e = -speed_e`` without correction, and with ``motion_correction``
(an ideal motion sensor: it knows d' and the attitude)
``los_e = -speed_e + n . d'``, referred to the look's known direction
``m_e`` in the nacelle frame at rest (``Ry(pitch) Rx(roll)`` and yaw
applied); uncorrected, the lidar refers it to its nominal direction.  The
record carries each estimate's direction as the mean of its looks'
directions (not unit: it is what a dwell-averaged line-of-sight speed
projects the wind on), so a fit of ``(u, v, w)`` over a revolution returns
a uniform wind exactly from tier 1 (:func:`cwlidar_sim.analysis.rews.fit_uvw`).

Blade blockage
--------------
With ``rotor_rpm > 0`` the rotor (``n_blades`` blades of chord
``blade_chord`` [m] where the beams cross them, turning at ``rotor_rpm``
from ``blade_azimuth0_deg`` at t = 0, the beams' azimuth convention) sits
``rotor_plane_distance`` upwind of the lidar, which is on the rotor axis:
a look at azimuth phi crosses the rotor plane at radius
``rho = rotor_plane_distance tan a`` and is blocked while the crossing
point lies on a blade, a strip of width ``chord`` along the blade's axis:
``cos(phi - psi_k) > 0`` and ``rho |sin(phi - psi_k)| < chord / 2`` (blade k
at azimuth psi_k).  An estimate with more
than ``blockage_fraction`` of its looks blocked is lost: NaN flagged
:attr:`cwlidar_sim.signal.Flag.BLOCKED` like any lost estimate; with less, the estimate stands (the chain does not
model the blocked looks' power loss: a stated limit).

Speckle: the focal spot moves at ``2 pi r sin a / revolution_time`` on a
circle (the speckle's transverse speed, as for the conical lidar), at the
wind's cross component ``U sin a`` for fixed beams.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_bool, check_int, check_real, check_tuple
from ..beam.geometry import ConicalScanGeometry
from ..signal.instrument import CS_SERIES, Instrument
from ..signal.processing import Flag, usable_fraction
from ..turbulence.cover import Region
from .base import BeamSampler, LidarBase
from .protocol import Focus, LidarRecord, RecordPlan, measure
from .platform import PlatformMotion, rotation_matrices

__all__ = ["NacelleLidar", "measure_nacelle", "NACELLE_HALF_ANGLE_RANGE",
           "NACELLE_FOCUS_RANGE"]

#: Allowed half-angle of the scan cone from the rotor axis [deg].
NACELLE_HALF_ANGLE_RANGE = (0.0, 45.0)
#: Allowed focus distance [m] (cw lidars focus from ~10 m; beyond a few hundred metres the probe volume
#: spans the whole preview range).
NACELLE_FOCUS_RANGE = (10.0, 1000.0)

@dataclasses.dataclass(frozen=True, kw_only=True)
class NacelleLidar(LidarBase):
    """A forward-looking cw lidar on a turbine's nacelle (module notes).

    Geometry fields below; the shared fields (instrument, tier, probe volume,
    chain; no cloud: refused) are :class:`cwlidar_sim.sensors.base.LidarBase`'s, with the
    defaults of a scanning lidar (``instrument = CS_SERIES``, the ZephIR
    optics of the nacelle lidars, ``tier = 'los'``, ``span = 5``,
    ``cell_length = 2`` m, ``speckle = 'independent'``).  The instrument's
    ``focus`` is replaced by each focus distance.

    Parameters
    ----------
    focus_distances : tuple of float
        Focus distances [m] along the beam, in :data:`NACELLE_FOCUS_RANGE`,
        distinct; one: fixed, several: visited in turn.
    half_angle_deg : float
        Half-angle of the cone from the rotor axis [deg]; in
        :data:`NACELLE_HALF_ANGLE_RANGE` (> 0 for a circle).
    revolution_time : float
        One revolution (circle) or one cycle through the beams [s]; in [0.1, 100].
    estimates_per_rev : int
        Estimates per revolution or cycle; in [4, 10000]; a multiple of the
        number of fixed beams.
    beam_azimuths_deg : tuple of float or None
        Fixed beams' azimuths [deg] (from +y toward +z), 1 to 16 distinct;
        None: the circle.
    azimuth0_deg : float
        Circle: the beam azimuth at t = 0 [deg].
    revs_per_focus : int
        Revolutions at each focus before refocusing; in [1, 10000].
    refocus_time : float
        Time lost between focus distances [s]; in [0, 100].
    position : tuple of 3 floats
        Lidar position (x, y, z) [m] in the field frame.
    yaw_misalignment_deg : float
        Yaw of the rotor axis from the mean wind [deg]; in [-45, 45].
    motion : PlatformMotion or None
        The platform's prescribed motion (a dict is accepted by ``from_dict``).
    motion_correction : bool
        Correct the line-of-sight speeds and directions with an ideal motion sensor.
    sub_dwells : int
        Looks simulated per dwell; in [1, 256].
    rotor_rpm : float
        Rotor speed [rpm] for blade blockage; 0: none; in [0, 100].
    n_blades : int
        Blades; in [1, 6].
    blade_chord : float
        Blade chord where the beams cross the rotor plane [m]; in (0, 20].
    rotor_plane_distance : float
        Distance of the rotor plane upwind of the lidar [m]; in (0, 50].
    blade_azimuth0_deg : float
        Azimuth of blade 0 at t = 0 [deg].
    blockage_fraction : float
        An estimate with more than this fraction of its looks blocked is lost; in [0, 1).
    """

    focus_distances: tuple = (80.0,)
    half_angle_deg: float = 15.0
    revolution_time: float = 1.0
    estimates_per_rev: int = 50
    beam_azimuths_deg: tuple | None = None
    azimuth0_deg: float = 0.0
    revs_per_focus: int = 1
    refocus_time: float = 0.0
    position: tuple = (0.0, 0.0, 0.0)
    yaw_misalignment_deg: float = 0.0
    motion: PlatformMotion | None = None
    motion_correction: bool = False
    sub_dwells: int = 4
    rotor_rpm: float = 0.0
    n_blades: int = 3
    blade_chord: float = 2.0
    rotor_plane_distance: float = 3.0
    blade_azimuth0_deg: float = 0.0
    blockage_fraction: float = 0.5
    instrument: Instrument = CS_SERIES
    tier: str = "los"
    span: float = 5.0
    cell_length: float = 2.0
    speckle: str = "independent"

    def __post_init__(self):
        super().__post_init__()
        put = self._put
        lo, hi = NACELLE_HALF_ANGLE_RANGE
        put("half_angle_deg", check_real("half_angle_deg", self.half_angle_deg, lo=lo, hi=hi))
        f = self.focus_distances
        if isinstance(f, (int, float, np.integer, np.floating)) and not isinstance(f, bool):
            f = (f,)
        if isinstance(f, (str, bytes)) or not hasattr(f, "__len__") or not 1 <= len(f) <= 20:
            raise TypeError(f"focus_distances must be 1 to 20 focus distances [m], got {self.focus_distances!r}")
        f = tuple(check_real(f"focus_distances[{i}]", r, lo=NACELLE_FOCUS_RANGE[0], hi=NACELLE_FOCUS_RANGE[1])
                  for i, r in enumerate(f))
        if len(set(f)) != len(f):
            raise ValueError(f"focus_distances must be distinct, got {f}")
        put("focus_distances", f)
        put("revolution_time", check_real("revolution_time", self.revolution_time, lo=0.1, hi=100.0))
        put("estimates_per_rev", check_int("estimates_per_rev", self.estimates_per_rev, lo=4, hi=10000))
        if self.beam_azimuths_deg is not None:
            b = tuple(self.beam_azimuths_deg)
            if not 1 <= len(b) <= 16:
                raise ValueError(f"beam_azimuths_deg needs 1 to 16 beams, got {len(b)}")
            b = tuple(check_real(f"beam_azimuths_deg[{i}]", a) for i, a in enumerate(b))
            if len({round(a % 360.0, 9) for a in b}) != len(b):
                raise ValueError(f"beam_azimuths_deg must be distinct directions, got {b}")
            put("beam_azimuths_deg", b)
            if self.estimates_per_rev % len(b):
                raise ValueError(f"estimates_per_rev={self.estimates_per_rev} must be a multiple of the "
                                 f"{len(b)} fixed beams")
        elif self.half_angle_deg == 0.0:
            raise ValueError("a circular scan needs half_angle_deg > 0; allowed: (0, 45], or one fixed beam "
                             "(beam_azimuths_deg = (0,)) along the axis")
        put("azimuth0_deg", check_real("azimuth0_deg", self.azimuth0_deg))
        put("revs_per_focus", check_int("revs_per_focus", self.revs_per_focus, lo=1, hi=10000))
        put("refocus_time", check_real("refocus_time", self.refocus_time, lo=0.0, hi=100.0))
        put("position", check_tuple("position", self.position, 3, check_real))
        put("yaw_misalignment_deg", check_real("yaw_misalignment_deg", self.yaw_misalignment_deg, lo=-45.0, hi=45.0))
        if self.motion is not None and not isinstance(self.motion, PlatformMotion):
            raise TypeError(f"motion must be a PlatformMotion or None, got {type(self.motion).__name__}")
        put("motion_correction", check_bool("motion_correction", self.motion_correction))
        put("sub_dwells", check_int("sub_dwells", self.sub_dwells, lo=1, hi=256))
        put("rotor_rpm", check_real("rotor_rpm", self.rotor_rpm, lo=0.0, hi=100.0))
        put("n_blades", check_int("n_blades", self.n_blades, lo=1, hi=6))
        put("blade_chord", check_real("blade_chord", self.blade_chord, lo=0.0, hi=20.0, lo_open=True))
        put("rotor_plane_distance", check_real("rotor_plane_distance", self.rotor_plane_distance, lo=0.0, hi=50.0,
                                               lo_open=True))
        put("blade_azimuth0_deg", check_real("blade_azimuth0_deg", self.blade_azimuth0_deg))
        put("blockage_fraction", check_real("blockage_fraction", self.blockage_fraction, lo=0.0, hi=1.0,
                                            hi_open=True))
        inst = self.instrument
        if (self.tier == "signal" or (self.tier == "spectral" and self.speckle == "continuum")) \
                and inst.blocks_per_estimate % self.sub_dwells:
            raise ValueError(f"tier {self.tier!r} with speckle {self.speckle!r} needs sub_dwells={self.sub_dwells} "
                             f"to divide instrument.blocks_per_estimate={inst.blocks_per_estimate}")
        fit = self.dwell_time / inst.block_duration
        if inst.blocks_per_estimate > fit * (1 + 1e-9):
            raise ValueError(f"instrument.blocks_per_estimate={inst.blocks_per_estimate} does not fit in one dwell "
                             f"of {self.dwell_time:g} s; allowed: <= {math.floor(fit + 1e-9)}")
        for r in self.focus_distances:
            check_int("number of range cells", self.cells(r).n_cells, lo=1, hi=100_000)
        if self.cloud_base is not None:
            # a cloud's weight follows the beam's vertical component (sensors.base), which changes look by look
            # around a nacelle lidar's circle and with the platform's attitude: the chain's one cloud weight
            # per focus group cannot hold it, so the field is refused rather than ignored
            raise ValueError(f"cloud_base={self.cloud_base!r}: the nacelle lidar does not model a cloud layer (its "
                             "beams' vertical component, and so the cloud's weight, changes look by look); "
                             "allowed: cloud_base None (no cloud)")

    def as_dict(self) -> dict:
        d = super().as_dict()
        if self.motion is not None:
            d["motion"] = self.motion.as_dict()
        return d

    @classmethod
    def from_dict(cls, d: dict):
        d = dict(d)
        if isinstance(d.get("motion"), dict):
            d["motion"] = PlatformMotion.from_dict(d["motion"])
        return super().from_dict(d)

    # -- derived ---------------------------------------------------------
    @property
    def dwell_time(self) -> float:
        """Duration of one estimate, revolution_time / estimates_per_rev [s]."""
        return self.revolution_time / self.estimates_per_rev

    @property
    def circle(self) -> bool:
        """True for the circular scan, False for fixed beams."""
        return self.beam_azimuths_deg is None

    def instrument_at(self, focus: float) -> Instrument:
        """The instrument focused at ``focus`` [m]."""
        return self.instrument.replace(focus=float(focus))

    def cells(self, focus: float):
        """Range cells at ``focus`` (:class:`cwlidar_sim.beam.cells.ProbeCells`)."""
        return self.probe_cells(self.instrument_at(focus))

    @property
    def geometry(self) -> ConicalScanGeometry:
        """The scan's cone in the nacelle frame (:class:`cwlidar_sim.beam.ConicalScanGeometry`, axis 'upwind')."""
        return ConicalScanGeometry(self.half_angle_deg, "upwind", self.revolution_time, self.azimuth0_deg)

    def preview_distance(self, focus: float) -> float:
        """Upwind distance of the focus from the lidar, ``r cos a`` [m]."""
        return self.geometry.axial_distance(focus)

    def transverse_speed_at(self, focus: float, U: float) -> float:
        """The speckle's transverse speed [m/s] (module notes)."""
        if self.transverse_speed is not None:
            return self.transverse_speed
        if self.circle:
            return self.geometry.spot_speed(focus)
        return max(abs(U) * math.sin(math.radians(self.half_angle_deg)), 1e-3)

    def box_region(self, spacing: float, rotor_radius: float = 0.0) -> Region:
        """The region a box must hold for this lidar (:func:`cwlidar_sim.turbulence.cover.cover_box`) [m].

        Every focus's cells up to the farthest, upwind of ``position``, and a
        rotor disc of radius ``rotor_radius`` [m] on its axis, grown by two
        grid steps ``spacing`` [m] (in (0, 100]), then by the reach of the
        yaw misalignment and of the platform's motion (its largest
        displacements and turns).
        """
        d = check_real("spacing", spacing, lo=0.0, hi=100.0, lo_open=True)
        R = check_real("rotor_radius", rotor_radius, lo=0.0)
        a = math.radians(self.half_angle_deg)
        far = max(r + c.edges[-1] for r, c in ((r, self.cells(r)) for r in self.focus_distances))
        reach = far * math.cos(a) + 2.0 * d
        radius = max(far * math.sin(a), R) + 2.0 * d
        if self.motion is not None:
            m = self.motion
            reach += float(np.abs(m.surge).max())
            radius += float(max(np.abs(m.sway).max(), np.abs(m.heave).max())) + far * math.sin(
                math.radians(float(max(np.abs(m.roll_deg).max(), np.abs(m.pitch_deg).max(), np.abs(m.yaw_deg).max())
                                   + abs(self.yaw_misalignment_deg))))
        elif self.yaw_misalignment_deg:
            radius += far * math.sin(math.radians(abs(self.yaw_misalignment_deg)))
        return Region(x_lo=self.position[0] - reach, length=reach, y_mid=self.position[1], half_width=radius,
                      z_mid=self.position[2], half_height=radius)

    def box_planes(self) -> list:
        """x [m] of the planes of evolving turbulence: the rotor's (the lidar's) and each focus distance's."""
        return [self.position[0]] + [self.position[0] - self.preview_distance(r) for r in self.focus_distances]

    def nacelle_direction(self, azimuth_deg) -> np.ndarray:
        """Unit beam directions in the nacelle frame at rest, shape (..., 3)."""
        return self.geometry.direction(azimuth_deg)

    def yaw_matrix(self) -> np.ndarray:
        """``Rz(gamma)``: the nacelle frame's axes in the field frame."""
        return rotation_matrices(0.0, 0.0, self.yaw_misalignment_deg)

    # -- the Sensor protocol (cwlidar_sim.sensors.protocol) -----------------
    def plan_record(self, field, U: float, *, wrap: bool, duration: float, start: float = 0.0) -> RecordPlan:
        """The dwells over ``[start, start + duration)``, one focus per focus distance (module notes)."""
        nf = len(self.focus_distances)
        fields = list(field) if isinstance(field, (list, tuple)) else [field] * nf
        if len(fields) != nf:
            raise ValueError(f"field: one box per focus distance ({nf}) or one box for all, got {len(fields)}")
        time_e, az_e, fidx_e, rev_e = self.schedule(duration, start)
        ne = time_e.size
        nsub = self.sub_dwells
        off_l = (np.arange(nsub) + 0.5) / nsub - 0.5
        dang = 360.0 / self.estimates_per_rev if self.circle else 0.0
        t_el = time_e[:, None] + off_l[None, :] * self.dwell_time
        az_el = az_e[:, None] + off_l[None, :] * dang
        if self.motion is not None:
            self.motion.check_covers(float(t_el.min()), float(t_el.max()))
        origin0, n_elc, known_elc, ddot_elc = (None if a is None else a.reshape(ne, nsub, 3)
                                               for a in _look_geometry(self, t_el.ravel(), az_el.ravel()))
        blocked_e = _blocked(self, t_el, az_el).mean(axis=1) if ne else np.zeros(0)
        groups, finfo = [], {}
        pos = np.asarray(self.position, dtype=np.float64)
        for i, r in enumerate(self.focus_distances):
            idx = np.flatnonzero(fidx_e == i)
            inst, cells = self.instrument_at(r), self.cells(r)
            sampler = BeamSampler(fields[i], pos, r, cells, U, wrap)
            if origin0 is None:
                sampler.check_extent(n_elc[idx].reshape(-1, 3)[:: max(1, nsub)] if idx.size else n_elc[:0, 0])

            def sample(lo, hi, idx=idx, sampler=sampler):
                sel = idx[lo:hi]
                t_l = t_el[sel].ravel()
                n_lc = np.ascontiguousarray(n_elc[sel].reshape(-1, 3))
                if origin0 is None:
                    vlos_ls, vlos_l = sampler.sample(t_l, n_lc)
                else:
                    vlos_ls, vlos_l = _sample_moving(sampler, origin0[sel].reshape(-1, 3), t_l, n_lc)
                rel = np.einsum("lc,lc->l", n_lc, ddot_elc[sel].reshape(-1, 3))  # the lidar's own speed along n
                vlos_ls -= rel[:, None]
                vlos_l -= rel
                return vlos_ls.reshape(sel.size, nsub, -1), vlos_l.reshape(sel.size, nsub).mean(axis=1), None

            groups.append(Focus(instrument=inst, index_e=idx, time_e=time_e[idx], cells=cells, n_looks=nsub,
                                sample=sample, transverse_speed=self.transverse_speed_at(r, U), field=fields[i]))
            finfo[float(r)] = {"preview_distance": self.preview_distance(r), "rayleigh_length": inst.rayleigh_length,
                               "n_cells": cells.n_cells, "truncated_fraction": cells.truncated_fraction,
                               "transverse_speed": self.transverse_speed_at(r, U), "n_estimates": int(idx.size)}
        extras = {"azimuth_e": az_e, "revolution_e": rev_e, "focus_e": np.asarray(self.focus_distances)[fidx_e]}
        return RecordPlan(time_e=time_e, focus_index_e=fidx_e, foci=self.focus_distances, groups=groups,
                          extras=extras, context={"n_elc": n_elc, "known_elc": known_elc, "ddot_elc": ddot_elc,
                                                  "blocked_e": blocked_e, "focus": finfo})

    def finish_record(self, record: LidarRecord, plan: RecordPlan, chain) -> LidarRecord:
        """Blade blockage, the line-of-sight wind and its directions, the ``info`` (:func:`measure_nacelle`)."""
        ctx = plan.context
        n_elc, ddot_elc, blocked_e = ctx["n_elc"], ctx["ddot_elc"], ctx["blocked_e"]
        ne, nsub = plan.time_e.size, self.sub_dwells
        speed_e, flags_e = chain.speed_e.copy(), chain.flags_e.copy()
        lost = blocked_e > self.blockage_fraction
        speed_e[lost] = np.nan
        flags_e[lost] |= np.uint8(Flag.BLOCKED)
        variants_out = {}
        for name, (s, f) in chain.variants.items():
            s, f = s.copy(), f.copy()
            s[lost] = np.nan
            f[lost] |= np.uint8(Flag.BLOCKED)
            variants_out[name] = (s, f)
        corr_e = np.einsum("elc,elc->e", n_elc, ddot_elc) / nsub if self.motion_correction else np.zeros(ne)
        info = {"tier": self.tier, "sub_dwells": nsub, "n_estimates": ne, "focus": ctx["focus"],
                "flag_counts": {f.name: int(np.count_nonzero(flags_e & f.value)) for f in Flag},
                "n_blocked": int(lost.sum()), "estimator": chain.info["estimator"]}
        extras = dict(record.extras, los_e=-speed_e + corr_e, direction_ec=ctx["known_elc"].mean(axis=1),
                      field_direction_ec=n_elc.mean(axis=1), blocked_e=blocked_e, correction_e=corr_e)
        return dataclasses.replace(record, speed_e=speed_e, flags_e=flags_e, variants=variants_out,
                                   availability=usable_fraction(speed_e, flags_e) if ne else 0.0, info=info,
                                   extras=extras)

    def schedule(self, duration: float, start: float = 0.0):
        """``(time_e, azimuth_e, focus_index_e, revolution_e)`` of the record (module notes)."""
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        if duration < self.revolution_time * (1 - 1e-12):
            raise ValueError(f"duration={duration} s holds no revolution; allowed: >= revolution_time = "
                             f"{self.revolution_time} s")
        epr, dt = self.estimates_per_rev, self.dwell_time
        nf = len(self.focus_distances)
        per_block = self.revs_per_focus * epr
        block_duration = self.revs_per_focus * self.revolution_time + (self.refocus_time if nf > 1 else 0.0)
        nb = int(math.floor((duration + (self.refocus_time if nf > 1 else 0.0)) / block_duration + 1e-9))
        b = np.repeat(np.arange(nb), per_block)
        j = np.tile(np.arange(per_block), nb)
        time_e = start + b * block_duration + (j + 0.5) * dt
        if self.circle:
            az = self.azimuth0_deg + 360.0 * (time_e - start) / self.revolution_time
        else:
            az = np.asarray(self.beam_azimuths_deg)[j % len(self.beam_azimuths_deg)]
        return time_e, az, b % nf, b * self.revs_per_focus + j // epr


def _blocked(lidar: NacelleLidar, t_l, az_l):
    """Looks blocked by a blade (module notes), boolean like ``t_l``."""
    if lidar.rotor_rpm == 0.0 or lidar.half_angle_deg == 0.0:
        return np.zeros(np.shape(t_l), dtype=bool)
    radius = lidar.rotor_plane_distance * math.tan(math.radians(lidar.half_angle_deg))
    omega = 2.0 * math.pi * lidar.rotor_rpm / 60.0
    psi0 = math.radians(lidar.blade_azimuth0_deg) + omega * np.asarray(t_l)
    phi = np.radians(np.asarray(az_l))
    out = np.zeros(np.shape(t_l), dtype=bool)
    for k in range(lidar.n_blades):
        d = phi - psi0 - 2.0 * math.pi * k / lidar.n_blades
        # the crossing point lies on the blade (a strip of width chord along the blade's axis)
        out |= (np.cos(d) > 0.0) & (radius * np.abs(np.sin(d)) < 0.5 * lidar.blade_chord)
    return out


def _look_geometry(lidar: NacelleLidar, t_l, az_l):
    """``(origin_lc or None, n_lc, m_known_lc, ddot_lc)`` of looks: field and known directions, lidar velocity."""
    m_lc = lidar.nacelle_direction(az_l)
    yaw = lidar.yaw_matrix()
    if lidar.motion is None:
        n_lc = m_lc @ yaw.T
        return None, n_lc, m_lc, np.zeros_like(m_lc)
    d, v, rot = lidar.motion.at(t_l)
    att_lc = np.einsum("lij,lj->li", rot, m_lc)  # the turned beam in the nacelle's rest frame
    n_lc = att_lc @ yaw.T
    known = att_lc if lidar.motion_correction else m_lc
    return np.asarray(lidar.position) + d, n_lc, known, v


def measure_nacelle(field, lidar: NacelleLidar, duration: float, U: float, seed=None, *, start: float = 0.0,
                    wrap: bool = False, variants=None, chunk: int = 4096,
                    calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a nacelle lidar's record in a turbulence field (module notes).

    The public API's form of :func:`cwlidar_sim.sensors.measure`
    for a nacelle lidar (a duration and a start).

    Parameters
    ----------
    field : xarray.Dataset or sequence of them
        A box holding every cell of every focus (:func:`cwlidar_sim.turbulence.cover.cover_box`
        of :meth:`NacelleLidar.box_region`), or one box per focus distance
        (evolving turbulence: the box of the focus's plane,
        :func:`cwlidar_sim.turbulence.evolution.iter_evolving_boxes`);
        u, v, w fluctuations [m/s].
    lidar : NacelleLidar
    duration : float
        Record length [s]; at least one revolution.
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u).
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (background, speckle,
        noise): required by them (a ValueError without one: a record is never
        drawn from fresh entropy, the same seed gives the same bits); not used
        by tier 'los', whose record is the field's.  Each focus distance draws
        from its child of the root SeedSequence (:func:`cwlidar_sim.sensors.measure`).
    start : float
        Start time [s].
    wrap : bool
        Treat y and z as periodic.
    variants : list of dict, optional
        Extra processings of the same spectra (:data:`cwlidar_sim.signal.chain.VARIANT_KEYS`).
    chunk : int
        Estimates processed at a time (memory only); in [1, 10**6].
    calibration_time : float
        Time of t = 0 on the background-calibration clock [s] (background
        gain mismatch and drift, the pauses of ``background_pause``).

    Returns
    -------
    LidarRecord
        ``focus_index_e`` the index into ``focus_distances``, ``foci`` the
        focus distances; ``availability`` counts the blocked estimates as
        lost; ``extras`` (also attributes):

        * ``azimuth_e``: beam azimuths [deg] (nacelle frame);
          ``revolution_e``: revolution (or cycle) number; ``focus_e``: focus distance [m];
        * ``los_e``: the lidar's line-of-sight wind estimate [m/s]:
          ``-speed_e``, plus ``n . d'`` with the motion correction (module notes);
        * ``direction_ec`` (n_e, 3): the direction ``los_e`` refers to in the
          nacelle frame at rest [-] (mean of the looks'; with motion only with
          the correction); ``field_direction_ec``: mean of the looks' true
          directions in the field frame [-];
        * ``blocked_e``: fraction of the dwell's looks blocked by a blade [-];
        * ``correction_e``: the motion correction ``n . d'`` added to
          ``-speed_e`` [m/s] (0 without ``motion_correction``); add it to a
          variant's ``-speed`` or to ``vlos_e`` to correct them alike.

        ``speed_e``, ``flags_e`` and the variants are NaN flagged
        ``BLOCKED`` where a blade blocks the estimate; ``vlos_e`` (tier 1,
        < 0 into the wind) is the wind relative to the lidar.  ``info``: per
        focus (``info['focus'][r]``) the preview distance, Rayleigh length,
        cells, speckle; tier, flag counts, ``n_blocked``.
    """
    if not isinstance(lidar, NacelleLidar):
        raise TypeError(f"lidar must be a NacelleLidar, got {type(lidar).__name__}")
    return measure(field, lidar, U, seed, variants=variants, chunk=chunk, wrap=wrap, calibration_time=calibration_time,
                   duration=duration, start=start)


def _sample_moving(sampler: BeamSampler, origin_lc, t_l, n_lc):
    """The sampler's looks from a moving origin, one look at a time (a moving platform only)."""
    n_l = t_l.size
    vlos_ls = np.empty((n_l, sampler.n_s))
    vlos_l = np.empty(n_l)
    o0 = sampler.origin
    try:
        for i in range(n_l):
            sampler.origin = np.ascontiguousarray(origin_lc[i])
            sampler.check_extent(n_lc[i])
            a, b = sampler.sample(t_l[i:i + 1], n_lc[i:i + 1])
            vlos_ls[i], vlos_l[i] = a[0], b[0]
    finally:
        sampler.origin = o0
    return vlos_ls, vlos_l
