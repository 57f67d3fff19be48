"""DTU's SpinnerLidar: a cw lidar in a turbine's spinner drawing a rosette with two turning prisms, handed to the one chain.

The instrument (as published: Mikkelsen et al. 2013, Wind Energy 16,
"A spinner-integrated wind lidar for enhanced wind turbine control"; Peña
et al. 2019, "Characterizing the inflow of a wind turbine with a
SpinnerLidar"): a cw coherent lidar (lambda = 1.56 um) mounted in the
spinner, looking upwind along the rotor axis through two wedge prisms that
each deflect the beam by 15.2 deg and turn at 3.5 and 6.5 rev/s (ratio
7:13), so that the beam draws a rosette that repeats every 2 s, with 984
line-of-sight estimates per rosette (492 Hz), reaching 30.4 deg off the
axis.  Its Doppler spectra have 256 bins over 50 MHz (0.152 m/s each):
:data:`cwlidar_sim.signal.instrument.SPINNER_LIDAR`.  Not from those
papers, and so fields with stated defaults: the prisms' senses of rotation
(opposite: the rosette's petals all pass through the centre), their phases,
the telescope radius (the CS series ZephIR's), the blades' geometry where
the beam crosses them.

Frame (the nacelle lidar's, :mod:`cwlidar_sim.sensors.nacelle`)
----------------------------------------------------------------
The field's frame: x downwind, y to the left looking downwind, z up; the
wind is ``(U + u, v, w)``, Taylor-advected.  The lidar sits at ``position``
(the spinner, on the rotor axis) and looks upwind.  Azimuths are measured
about the rotor axis from +y toward +z (clockwise seen from upwind: a
turbine's sense of rotation).

Rosette: the exact composition of two prism deflections
---------------------------------------------------------
A thin wedge prism turns a ray by its deviation ``delta`` in its wedge's
plane, to first order independently of the ray's incidence; the model takes
that as exact: prism k is a rotation by ``delta_k`` about the axis
``w_k = e x u_k`` that turns the rotor axis ``e = (-1, 0, 0)`` toward the
prism's wedge direction ``u_k = (0, cos phi_k, sin phi_k)``, and the beam
is ``m = R(w_2, delta_2) R(w_1, delta_1) e`` (the two rotations composed
exactly, Rodrigues' formula; no small-angle sum).  Its angle off the axis
obeys ``cos theta = cos delta_1 cos delta_2 - sin delta_1 sin delta_2
cos(phi_1 - phi_2)``: ``delta_1 + delta_2`` when the wedges align (30.4
deg), ``|delta_1 - delta_2|`` when opposed.  The small-angle sum of two
rotating vectors ``delta_1 u_1 + delta_2 u_2`` has the same extremes and
differs by up to about 1 % of theta in between (tests).  Not modelled: the
prisms' refractive index and exact Snell refraction (the deviation's
dependence on incidence, second order in the wedge angle), the beam's
lateral offset through the glass (millimetres).

The prisms turn at ``prism_rate_hz`` [rev/s] relative to the spinner, from
``prism_phase_deg`` at t = 0; the spinner turns with the rotor at
``rotor_rpm`` from ``rotor_azimuth0_deg``, so in the nacelle frame
``phi_k(t) = phi_k0 + 360 f_k t + psi(t)``, ``psi(t) = psi_0 + 6 rpm t``
[deg]: the rosette turns with the rotor.  The rosette closes after
``rosette_time = 1 / gcd(f_1, f_2)`` (the rates as ratios of small
integers: 2 s for 3.5 and -6.5 rev/s) in the spinner; ``estimates_per_rosette``
(984) dwells of ``rosette_time / estimates_per_rosette`` each, simulated as
``sub_dwells`` looks at their mid-times (the beam sweeps up to about 2 m at
80 m in a dwell).

Mounting, line of sight, platform
---------------------------------
In the nacelle frame the rotor's axis is tilted up by ``tilt_deg`` (the
shaft tilt: ``Ry(tilt)``, the upwind axis rising for tilt > 0), and the
nacelle frame is the field's turned by the yaw misalignment ``gamma``:
``n = Rz(gamma) A(t) Ry(tilt) m`` with ``A(t)`` the platform's attitude
(:class:`~cwlidar_sim.sensors.platform.PlatformMotion`, as for the nacelle
lidar, whose displacement and velocity enter the same way: ``v_los = n .
(u - d')``).  The lidar knows its direction in the nacelle frame at rest,
``Ry(tilt) m`` (its prisms' and the rotor's encoders), and with
``motion_correction`` the attitude too; the homodyne sign, the motion
correction and the record's line-of-sight wind ``los_e = -speed_e (+ n .
d')`` are the nacelle lidar's (:meth:`NacelleLidar.finish_record
<cwlidar_sim.sensors.nacelle.NacelleLidar.finish_record>`, applied as it
is).

Blade blockage
--------------
``n_blades`` blades of chord ``blade_chord`` cross the beam in a plane
``blade_plane_distance`` upwind of the optics (the spinner's window lies
behind the blade roots): a look at angle theta off the axis and rotor-frame
azimuth phi crosses that plane at radius ``rho = d_b tan theta`` and is
blocked when ``rho >= hub_radius`` (inside, it passes through the spinner's
nose) and the crossing lies on blade k's strip: ``cos(phi - psi_k) > 0`` and
``rho |sin(phi - psi_k)| < chord / 2`` (the nacelle lidar's strip rule), blade
k at azimuth ``psi(t) + blade_azimuth0_deg + 360 k / n_blades``.  The blades
turn with the prisms' mount, so the same points of every rosette are blocked,
whatever the rotor speed.  An estimate with more than ``blockage_fraction`` of
its looks blocked is lost (NaN, :attr:`cwlidar_sim.signal.Flag.BLOCKED`).

Speckle: the focal spot's speed varies along the rosette; the chain takes
one transverse speed per focus, the mean spot speed over a rosette
(``r |dn/dt|`` averaged, the rotor's turning included).
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np

from .._validation import check_bool, check_int, check_real, check_tuple
from ..signal.instrument import SPINNER_LIDAR, Instrument
from ..turbulence.cover import Region
from .base import BeamSampler, LidarBase
from .nacelle import NacelleLidar, _sample_moving
from .platform import PlatformMotion, rotation_matrices
from .protocol import Focus, LidarRecord, RecordPlan, measure

__all__ = ["SpinnerLidar", "measure_spinner", "prism_directions", "rosette_period", "SPINNER_DEFLECTION_RANGE",
           "SPINNER_RATE_RANGE", "SPINNER_MAX_ROSETTE_TIME", "SPINNER_FOCUS_RANGE"]

#: Allowed deviation of each prism [deg]; their sum (the widest look off the axis) at most 45 deg.
SPINNER_DEFLECTION_RANGE = (0.0, 30.0)
#: Allowed prism rates [rev/s] (signed; 0: a prism at rest in the spinner).
SPINNER_RATE_RANGE = (-50.0, 50.0)
#: Longest rosette [s]: rates whose ratio closes the pattern later are refused (an irrational-looking ratio).
SPINNER_MAX_ROSETTE_TIME = 60.0
#: Allowed focus distance [m] (as the nacelle lidar's).
SPINNER_FOCUS_RANGE = (10.0, 1000.0)
#: Largest denominator of a prism rate as a ratio of integers [rev/s].
_MAX_DENOMINATOR = 1000

_AXIS = np.array([-1.0, 0.0, 0.0])


def rosette_period(rates_hz, *, name: str = "prism_rate_hz") -> float:
    """Time after which two prisms turning at ``rates_hz`` [rev/s] repeat their pattern [s].

    Each rate is read as a ratio of integers with a denominator up to 1000
    (3.5 = 7/2); the pattern repeats after ``T = 1 / gcd(f_1, f_2)``.  A
    rate that is no such ratio (to 1e-9), or a period above
    :data:`SPINNER_MAX_ROSETTE_TIME`, is refused by name: the pattern never
    closes within a sane time.
    """
    fr = []
    for i, f in enumerate(rates_hz):
        q = Fraction(f).limit_denominator(_MAX_DENOMINATOR)
        if abs(float(q) - f) > 1e-9 * max(1.0, abs(f)):
            raise ValueError(f"{name}[{i}]={f!r} rev/s is no ratio of integers with a denominator up to "
                             f"{_MAX_DENOMINATOR}: the rosette would never close; allowed: rates such as 3.5 and "
                             f"6.5 (ratio 7:13)")
        fr.append(abs(q))
    if all(q == 0 for q in fr):
        raise ValueError(f"{name}={tuple(rates_hz)}: both prisms at rest draw no pattern; allowed: a nonzero rate")
    num = math.gcd(*(q.numerator * math.prod(p.denominator for p in fr) // q.denominator for q in fr))
    g = Fraction(num, math.prod(p.denominator for p in fr))
    period = float(1 / g)
    if period > SPINNER_MAX_ROSETTE_TIME * (1 + 1e-12):
        raise ValueError(f"{name}={tuple(rates_hz)} rev/s close the rosette only after {period:g} s; allowed: "
                         f"rates whose ratio repeats within {SPINNER_MAX_ROSETTE_TIME:g} s (e.g. 3.5 and 6.5: 2 s)")
    return period


def _rotate(v_lc, axis_lc, angle: float):
    """Rodrigues: ``v`` turned by ``angle`` [rad] about the unit axes ``axis_lc`` (rows)."""
    c, s = math.cos(angle), math.sin(angle)
    return (v_lc * c + np.cross(axis_lc, v_lc) * s
            + axis_lc * (np.einsum("lc,lc->l", axis_lc, v_lc) * (1.0 - c))[:, None])


def prism_directions(phi1_deg, phi2_deg, deflection_deg=(15.2, 15.2)) -> np.ndarray:
    """Unit beam directions behind two prisms at wedge azimuths ``phi1``, ``phi2`` [deg], shape (n, 3) (module notes).

    ``m = R(w_2, delta_2) R(w_1, delta_1) e`` in the rotor frame (the rotor
    axis ``e = (-1, 0, 0)`` upwind, azimuth from +y toward +z),
    ``w_k = e x u_k``, ``u_k = (0, cos phi_k, sin phi_k)``.
    """
    p1, p2 = (np.radians(np.atleast_1d(np.asarray(p, dtype=np.float64))).ravel() for p in (phi1_deg, phi2_deg))
    p1, p2 = np.broadcast_arrays(p1, p2)
    v = np.broadcast_to(_AXIS, (p1.size, 3)).copy()
    for p, d in ((p1, deflection_deg[0]), (p2, deflection_deg[1])):
        w = np.stack([np.zeros_like(p), np.sin(p), -np.cos(p)], axis=-1)  # e x u
        v = _rotate(v, w, math.radians(d))
    return v


@dataclasses.dataclass(frozen=True, kw_only=True)
class SpinnerLidar(LidarBase):
    """DTU's SpinnerLidar in a turbine's spinner (module notes).

    Geometry fields below; the shared fields (instrument, tier, probe
    volume, chain; no cloud: refused) are :class:`cwlidar_sim.sensors.base.LidarBase`'s,
    with the defaults of the nacelle lidar but the instrument
    :data:`~cwlidar_sim.signal.instrument.SPINNER_LIDAR`.  The instrument's
    ``focus`` is replaced by ``focus_distance``.

    Parameters
    ----------
    focus_distance : float
        Focus distance along the beam [m], in :data:`SPINNER_FOCUS_RANGE`;
        its axial distance at the widest look must lie upwind of the blades.
    prism_deflection_deg : tuple of 2 float
        Each prism's deviation [deg], in :data:`SPINNER_DEFLECTION_RANGE`
        (0 excluded), their sum at most 45.
    prism_rate_hz : tuple of 2 float
        Each prism's rate relative to the spinner [rev/s], signed (+: from +y
        toward +z), in :data:`SPINNER_RATE_RANGE`; ratios of small integers
        that close the rosette within :data:`SPINNER_MAX_ROSETTE_TIME`.
    prism_phase_deg : tuple of 2 float
        Each prism's wedge azimuth relative to the spinner at t = 0 [deg].
    estimates_per_rosette : int
        Estimates per rosette; in [4, 100000].
    sub_dwells : int
        Looks simulated per dwell; in [1, 256].
    position : tuple of 3 floats
        The lidar (on the rotor axis, in the spinner) in the field frame [m].
    yaw_misalignment_deg : float
        Yaw of the rotor axis from the mean wind [deg]; in [-45, 45].
    tilt_deg : float
        Shaft tilt: the upwind rotor axis rises by it [deg]; in [-15, 15].
    rotor_rpm : float
        Rotor speed [rpm], turning the spinner and with it the rosette and the blades; in [0, 100].
    rotor_azimuth0_deg : float
        Azimuth of the spinner's reference (the prisms' zero) at t = 0 [deg].
    n_blades : int
        Blades crossing the beam; in [0, 6] (0, the default: no blockage).
    blade_chord : float
        Blade chord where the beam crosses it [m]; in (0, 20].
    blade_plane_distance : float
        Distance upwind of the optics where the beam crosses the blades [m]; in (0, 20].
    hub_radius : float
        Crossings nearer the axis pass through the spinner's nose [m]; in [0, 20].
    blade_azimuth0_deg : float
        Blade 0's azimuth relative to the spinner's reference [deg].
    blockage_fraction : float
        An estimate with more than this fraction of its looks blocked is lost; in [0, 1).
    motion : PlatformMotion or None
        The platform's prescribed motion (a dict is accepted by ``from_dict``).
    motion_correction : bool
        Correct the line-of-sight speeds and directions with an ideal motion sensor.
    """

    focus_distance: float = 80.0
    prism_deflection_deg: tuple = (15.2, 15.2)
    prism_rate_hz: tuple = (3.5, -6.5)
    prism_phase_deg: tuple = (0.0, 0.0)
    estimates_per_rosette: int = 984
    sub_dwells: int = 4
    position: tuple = (0.0, 0.0, 0.0)
    yaw_misalignment_deg: float = 0.0
    tilt_deg: float = 0.0
    rotor_rpm: float = 0.0
    rotor_azimuth0_deg: float = 0.0
    n_blades: int = 0
    blade_chord: float = 1.0
    blade_plane_distance: float = 2.0
    hub_radius: float = 0.8
    blade_azimuth0_deg: float = 0.0
    blockage_fraction: float = 0.5
    motion: PlatformMotion | None = None
    motion_correction: bool = False
    instrument: Instrument = SPINNER_LIDAR
    tier: str = "los"
    span: float = 5.0
    cell_length: float = 2.0
    speckle: str = "independent"

    def __post_init__(self):
        super().__post_init__()
        put = self._put
        lo, hi = SPINNER_DEFLECTION_RANGE
        put("prism_deflection_deg", check_tuple("prism_deflection_deg", self.prism_deflection_deg, 2,
                                                lambda n, v: check_real(n, v, lo=lo, hi=hi, lo_open=True)))
        if sum(self.prism_deflection_deg) > 45.0:
            raise ValueError(f"prism_deflection_deg={self.prism_deflection_deg}: the widest look, their sum "
                             f"{sum(self.prism_deflection_deg):g} deg, is off the spinner's field of view; allowed: a "
                             f"sum up to 45 deg")
        lo, hi = SPINNER_RATE_RANGE
        put("prism_rate_hz", check_tuple("prism_rate_hz", self.prism_rate_hz, 2,
                                         lambda n, v: check_real(n, v, lo=lo, hi=hi)))
        rosette_period(self.prism_rate_hz)
        put("prism_phase_deg", check_tuple("prism_phase_deg", self.prism_phase_deg, 2, check_real))
        put("estimates_per_rosette", check_int("estimates_per_rosette", self.estimates_per_rosette, lo=4, hi=100_000))
        put("sub_dwells", check_int("sub_dwells", self.sub_dwells, lo=1, hi=256))
        put("position", check_tuple("position", self.position, 3, check_real))
        put("yaw_misalignment_deg", check_real("yaw_misalignment_deg", self.yaw_misalignment_deg, lo=-45.0, hi=45.0))
        put("tilt_deg", check_real("tilt_deg", self.tilt_deg, lo=-15.0, hi=15.0))
        put("rotor_rpm", check_real("rotor_rpm", self.rotor_rpm, lo=0.0, hi=100.0))
        put("rotor_azimuth0_deg", check_real("rotor_azimuth0_deg", self.rotor_azimuth0_deg))
        put("n_blades", check_int("n_blades", self.n_blades, lo=0, hi=6))
        put("blade_chord", check_real("blade_chord", self.blade_chord, lo=0.0, hi=20.0, lo_open=True))
        put("blade_plane_distance", check_real("blade_plane_distance", self.blade_plane_distance, lo=0.0, hi=20.0,
                                               lo_open=True))
        put("hub_radius", check_real("hub_radius", self.hub_radius, lo=0.0, hi=20.0))
        put("blade_azimuth0_deg", check_real("blade_azimuth0_deg", self.blade_azimuth0_deg))
        put("blockage_fraction", check_real("blockage_fraction", self.blockage_fraction, lo=0.0, hi=1.0,
                                            hi_open=True))
        if self.motion is not None and not isinstance(self.motion, PlatformMotion):
            raise TypeError(f"motion must be a PlatformMotion or None, got {type(self.motion).__name__}")
        put("motion_correction", check_bool("motion_correction", self.motion_correction))
        lo, hi = SPINNER_FOCUS_RANGE
        put("focus_distance", check_real("focus_distance", self.focus_distance, lo=lo, hi=hi))
        axial = self.focus_distance * math.cos(math.radians(self.max_off_axis_deg))
        if axial <= self.blade_plane_distance:
            raise ValueError(f"focus_distance={self.focus_distance:g} m puts the widest look's focus "
                             f"{axial:.3g} m upwind, behind the blades at blade_plane_distance="
                             f"{self.blade_plane_distance:g} m; allowed: focus_distance > "
                             f"{self.blade_plane_distance / math.cos(math.radians(self.max_off_axis_deg)):.4g} m")
        inst = self.instrument
        if (self.tier == "signal" or (self.tier == "spectral" and self.speckle == "continuum")) \
                and inst.blocks_per_estimate % self.sub_dwells:
            raise ValueError(f"tier {self.tier!r} with speckle {self.speckle!r} needs sub_dwells={self.sub_dwells} "
                             f"to divide instrument.blocks_per_estimate={inst.blocks_per_estimate}")
        fit = self.dwell_time / inst.block_duration
        if inst.blocks_per_estimate > fit * (1 + 1e-9):
            raise ValueError(f"instrument.blocks_per_estimate={inst.blocks_per_estimate} does not fit in one dwell "
                             f"of {self.dwell_time:g} s; allowed: <= {math.floor(fit + 1e-9)}")
        check_int("number of range cells", self.cells().n_cells, lo=1, hi=100_000)
        if self.cloud_base is not None:
            raise ValueError(f"cloud_base={self.cloud_base!r}: the SpinnerLidar does not model a cloud layer (its "
                             "beam's vertical component changes look by look); allowed: cloud_base None (no cloud)")

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
    def rosette_time(self) -> float:
        """Time after which the rosette repeats in the spinner [s] (:func:`rosette_period`)."""
        return rosette_period(self.prism_rate_hz)

    @property
    def dwell_time(self) -> float:
        """Duration of one estimate, rosette_time / estimates_per_rosette [s]."""
        return self.rosette_time / self.estimates_per_rosette

    @property
    def max_off_axis_deg(self) -> float:
        """The widest look off the rotor axis, the prisms' deviations' sum [deg]."""
        return float(sum(self.prism_deflection_deg))

    @property
    def foci(self) -> tuple:
        """The record's one focus distance, as a tuple [m]."""
        return (self.focus_distance,)

    def instrument_at(self, focus: float | None = None) -> Instrument:
        """The instrument focused at ``focus`` [m] (default ``focus_distance``)."""
        return self.instrument.replace(focus=float(self.focus_distance if focus is None else focus))

    def cells(self, focus: float | None = None):
        """Range cells at the focus (:class:`cwlidar_sim.beam.cells.ProbeCells`)."""
        return self.probe_cells(self.instrument_at(focus))

    @property
    def probe_centre(self) -> float:
        """Range of the probe volume's first moment [m]: the focus plus the cells' weighted mean offset.

        A line-of-sight speed of a linear wind field is the field's at this
        range (the tail beyond the span, :mod:`cwlidar_sim.beam.cells`, sees
        the mean wind and is left out): the point a disc fit assigns each
        estimate to (:func:`cwlidar_sim.analysis.disc_fit.fit_disc`).
        """
        c = self.cells()
        per_j = np.repeat(c.weight_s, np.diff(c.ptr_s)) * c.fraction_j
        return float(self.focus_distance + (per_j * c.sub_j).sum() / c.weight_s.sum())

    def rotor_azimuth(self, t) -> np.ndarray:
        """The spinner's azimuth psi(t) [deg] (module notes)."""
        return self.rotor_azimuth0_deg + 6.0 * self.rotor_rpm * np.asarray(t, dtype=np.float64)

    def prism_azimuths(self, t):
        """``(phi_1, phi_2)`` [deg] of the prisms' wedges in the nacelle frame at times ``t`` [s]."""
        t = np.asarray(t, dtype=np.float64)
        psi = self.rotor_azimuth(t)
        return tuple(p0 + 360.0 * f * t + psi for p0, f in zip(self.prism_phase_deg, self.prism_rate_hz))

    def rotor_direction(self, t) -> np.ndarray:
        """Unit beam directions in the rotor frame (before the tilt) at times ``t`` [s], shape (n, 3)."""
        return prism_directions(*self.prism_azimuths(np.ravel(t)), self.prism_deflection_deg)

    def nacelle_direction(self, t) -> np.ndarray:
        """Unit beam directions in the nacelle frame at rest, ``Ry(tilt) m``, at times ``t`` [s], shape (n, 3)."""
        return self.rotor_direction(t) @ rotation_matrices(0.0, self.tilt_deg, 0.0).T

    def yaw_matrix(self) -> np.ndarray:
        """``Rz(gamma)``: the nacelle frame's axes in the field frame."""
        return rotation_matrices(0.0, 0.0, self.yaw_misalignment_deg)

    def spot_speed(self, focus: float | None = None) -> float:
        """Mean speed of the focal spot over one rosette [m/s] (module notes)."""
        n = 64 * self.estimates_per_rosette
        t = (np.arange(n + 1)) * (self.rosette_time / n)
        m = self.rotor_direction(t)
        step = np.linalg.norm(np.diff(m, axis=0), axis=1) / (self.rosette_time / n)
        return float((self.focus_distance if focus is None else focus) * step.mean())

    def transverse_speed_at(self, focus: float | None = None, U: float = 0.0) -> float:
        """The speckle's transverse speed [m/s]: ``transverse_speed`` if set, else :meth:`spot_speed`."""
        if self.transverse_speed is not None:
            return self.transverse_speed
        return max(self.spot_speed(focus), 1e-3)

    def box_region(self, spacing: float, rotor_radius: float = 0.0) -> Region:
        """The region a box must hold for this lidar (:func:`cwlidar_sim.turbulence.cover.cover_box`) [m].

        The probe volume's far end on every look, upwind of ``position``, and
        a rotor disc of radius ``rotor_radius`` [m] on its axis, grown by two
        grid steps ``spacing`` [m] (in (0, 100]) and by the reach of the
        tilt, the yaw misalignment and the platform's motion.
        """
        d = check_real("spacing", spacing, lo=0.0, hi=100.0, lo_open=True)
        R = check_real("rotor_radius", rotor_radius, lo=0.0)
        far = self.focus_distance + self.cells().edges[-1]
        turn = self.max_off_axis_deg + abs(self.tilt_deg) + abs(self.yaw_misalignment_deg)
        reach, grow = far + 2.0 * d, 0.0
        if self.motion is not None:
            m = self.motion
            reach += float(np.abs(m.surge).max())
            grow = float(max(np.abs(m.sway).max(), np.abs(m.heave).max()))
            turn += float(max(np.abs(m.roll_deg).max(), np.abs(m.pitch_deg).max(), np.abs(m.yaw_deg).max()))
        radius = max(far * math.sin(math.radians(min(turn, 90.0))), R) + 2.0 * d + grow
        return Region(x_lo=self.position[0] - reach, length=reach, y_mid=self.position[1], half_width=radius,
                      z_mid=self.position[2], half_height=radius)

    def box_planes(self) -> list:
        """x [m] of the planes of evolving turbulence: the rotor's (the lidar's) and the probe's.

        The probe's plane is its mean upwind position over a rosette, the
        probe volume's first moment (:attr:`probe_centre`) along the looks'
        mean field-frame x (tilt and yaw included): the distance the preview
        ``d / U`` carries to the rotor, as a nacelle lidar's plane is its
        preview distance ``r cos a``, so that the planes' age is the preview.
        """
        t_e, _ = self.schedule(self.rosette_time)
        n_x = float((self.nacelle_direction(t_e) @ self.yaw_matrix().T)[:, 0].mean())
        return [self.position[0], self.position[0] + self.probe_centre * n_x]

    def schedule(self, duration: float, start: float = 0.0):
        """``(time_e, rosette_e)``: the dwells' mid-times [s] of the whole rosettes in ``duration``, and their rosette."""
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        T = self.rosette_time
        nr = int(math.floor(duration / T + 1e-9))
        if nr < 1:
            raise ValueError(f"duration={duration} s holds no rosette; allowed: >= rosette_time = {T:g} s")
        j = np.arange(nr * self.estimates_per_rosette)
        return start + (j + 0.5) * self.dwell_time, j // self.estimates_per_rosette

    def blocked(self, t) -> np.ndarray:
        """Looks at times ``t`` [s] blocked by a blade (module notes), boolean like ``t``."""
        t = np.asarray(t, dtype=np.float64)
        if self.n_blades == 0:
            return np.zeros(t.shape, dtype=bool)
        m = self.rotor_direction(t.ravel())
        theta = np.arccos(np.clip(-m[:, 0], -1.0, 1.0))
        phi = np.arctan2(m[:, 2], m[:, 1])
        rho = self.blade_plane_distance * np.tan(theta)
        psi0 = np.radians(self.rotor_azimuth(t.ravel()) + self.blade_azimuth0_deg)
        out = np.zeros(t.size, dtype=bool)
        for k in range(self.n_blades):
            dphi = phi - psi0 - 2.0 * math.pi * k / self.n_blades
            out |= (np.cos(dphi) > 0.0) & (rho * np.abs(np.sin(dphi)) < 0.5 * self.blade_chord)
        return (out & (rho >= self.hub_radius)).reshape(t.shape)

    def look_geometry(self, t_l):
        """``(origin_lc or None, n_lc, known_lc, ddot_lc)``: field and known directions, the lidar's velocity."""
        m_lc = self.nacelle_direction(t_l)
        yaw = self.yaw_matrix()
        if self.motion is None:
            return None, m_lc @ yaw.T, m_lc, np.zeros_like(m_lc)
        d, v, rot = self.motion.at(t_l)
        att_lc = np.einsum("lij,lj->li", rot, m_lc)
        known = att_lc if self.motion_correction else m_lc
        return np.asarray(self.position) + d, att_lc @ yaw.T, known, v

    # -- the Sensor protocol (cwlidar_sim.sensors.protocol) -----------------
    def plan_record(self, field, U: float, *, wrap: bool, duration: float, start: float = 0.0) -> RecordPlan:
        """The dwells of the whole rosettes in ``[start, start + duration)``, one fixed focus (module notes)."""
        time_e, ros_e = self.schedule(duration, start)
        ne, nsub = time_e.size, self.sub_dwells
        off_l = (np.arange(nsub) + 0.5) / nsub - 0.5
        t_el = time_e[:, None] + off_l[None, :] * self.dwell_time
        if self.motion is not None:
            self.motion.check_covers(float(t_el.min()), float(t_el.max()))
        origin0, n_elc, known_elc, ddot_elc = (None if a is None else a.reshape(ne, nsub, 3)
                                               for a in self.look_geometry(t_el.ravel()))
        blocked_e = self.blocked(t_el).mean(axis=1)
        r = self.focus_distance
        inst, cells = self.instrument_at(), self.cells()
        sampler = BeamSampler(field, np.asarray(self.position, dtype=np.float64), r, cells, U, wrap)
        if origin0 is None:
            sampler.check_extent(n_elc.reshape(-1, 3))

        def sample(lo, hi):
            t_l = t_el[lo:hi].ravel()
            n_lc = np.ascontiguousarray(n_elc[lo:hi].reshape(-1, 3))
            if origin0 is None:
                vlos_ls, vlos_l = sampler.sample(t_l, n_lc)
            else:
                vlos_ls, vlos_l = _sample_moving(sampler, origin0[lo:hi].reshape(-1, 3), t_l, n_lc)
            rel = np.einsum("lc,lc->l", n_lc, ddot_elc[lo:hi].reshape(-1, 3))  # the lidar's own speed along n
            vlos_ls -= rel[:, None]
            vlos_l -= rel
            return vlos_ls.reshape(hi - lo, nsub, -1), vlos_l.reshape(hi - lo, nsub).mean(axis=1), None

        speed = self.transverse_speed_at(r, U)
        group = Focus(instrument=inst, index_e=np.arange(ne), time_e=time_e, cells=cells, n_looks=nsub, sample=sample,
                      transverse_speed=speed, field=field)
        m_mid = self.rotor_direction(time_e)
        extras = {"rosette_e": ros_e, "rotor_azimuth_e": self.rotor_azimuth(time_e),
                  "off_axis_e": np.degrees(np.arccos(np.clip(-m_mid[:, 0], -1.0, 1.0))),
                  "beam_azimuth_e": np.degrees(np.arctan2(m_mid[:, 2], m_mid[:, 1]))}
        finfo = {float(r): {"preview_distance": r, "rayleigh_length": inst.rayleigh_length, "n_cells": cells.n_cells,
                            "truncated_fraction": cells.truncated_fraction, "transverse_speed": speed,
                            "n_estimates": int(ne)}}
        return RecordPlan(time_e=time_e, focus_index_e=np.zeros(ne, dtype=np.int64), foci=self.foci, groups=[group],
                          fixed_focus=True, extras=extras,
                          context={"n_elc": n_elc, "known_elc": known_elc, "ddot_elc": ddot_elc,
                                   "blocked_e": blocked_e, "focus": finfo})

    def finish_record(self, record: LidarRecord, plan: RecordPlan, chain) -> LidarRecord:
        """The nacelle lidar's: blockage, the homodyne sign, the motion correction, ``info``; plus the looks' directions."""
        rec = NacelleLidar.finish_record(self, record, plan, chain)
        info = dict(rec.info, rosette_time=self.rosette_time, estimates_per_rosette=self.estimates_per_rosette,
                    probe_centre=self.probe_centre)
        return dataclasses.replace(rec, info=info, extras=dict(rec.extras, direction_elc=plan.context["known_elc"]))


def measure_spinner(field, lidar: SpinnerLidar, duration: float, U: float, seed=None, *, start: float = 0.0,
                    wrap: bool = False, variants=None, chunk: int = 4096,
                    calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a SpinnerLidar's record of whole rosettes in a turbulence field (module notes).

    The public API's form of :func:`cwlidar_sim.sensors.measure` for the
    SpinnerLidar; the arguments are :func:`cwlidar_sim.sensors.measure_nacelle`'s
    (one box: the SpinnerLidar has one focus distance).

    Returns
    -------
    LidarRecord
        One focus (``foci = (focus_distance,)``); ``extras`` (also attributes):

        * ``rosette_e``: the rosette of each estimate; ``rotor_azimuth_e``:
          the spinner's azimuth [deg]; ``off_axis_e``, ``beam_azimuth_e``:
          the beam's angle off the rotor axis and its azimuth in the rotor
          frame at mid-dwell [deg];
        * ``los_e``, ``direction_ec``, ``field_direction_ec``, ``blocked_e``,
          ``correction_e``: as :func:`~cwlidar_sim.sensors.measure_nacelle`'s;
        * ``direction_elc`` (n_e, sub_dwells, 3): the looks' known directions
          in the nacelle frame at rest [-] (what a disc fit averages over the
          dwell, :func:`cwlidar_sim.analysis.disc_fit.fit_disc`, at the range
          ``info['probe_centre']``, :attr:`SpinnerLidar.probe_centre`).
    """
    if not isinstance(lidar, SpinnerLidar):
        raise TypeError(f"lidar must be a SpinnerLidar, got {type(lidar).__name__}")
    return measure(field, lidar, U, seed, variants=variants, chunk=chunk, wrap=wrap, calibration_time=calibration_time,
                   duration=duration, start=start)
