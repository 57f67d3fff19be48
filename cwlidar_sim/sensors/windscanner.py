"""DTU's short-range WindScanner: three cw lidars whose foci meet at one point, handed to the one chain.

The instrument (Mikkelsen et al. 2012, "A short-range WindScanner system";
Sjöholm et al. 2014 used two of its units for a rotorcraft's downwash):
three double-prism cw scanners, each steering its beam and its focus so
that the three foci coincide, held at one point or drawn together along a
pattern (a 512-point 3:2 Lissajous figure in one published layout).  Each
unit gives an estimate of its line-of-sight speed every 3.1 ms (512-point
spectra, :data:`cwlidar_sim.signal.instrument.WINDSCANNER`); the wind vector
at the common focus follows from the three speeds
(:func:`cwlidar_sim.analysis.reconstruction.reconstruct_uvw`).

Geometry
--------
Unit ``i`` sits at ``positions[i]``; the common focus moves along
``F(k) = target + A (sin(2 pi a k / P + phase) e1 + sin(2 pi b k / P) e2)``
for pattern point ``k = 0 .. P - 1`` (``pattern = 'lissajous'``: ``a : b =
lissajous_ratio``, ``A = amplitude``, ``P = points_per_pattern``, ``e1, e2``
the axes of ``pattern_plane``), or stays at ``target`` (``pattern =
'point'``, P = 1).  Unit i's look at point k points from its own position
to ``F(k)``, ``n_ik = (F(k) - p_i) / |F(k) - p_i|``, and is focused there,
``r_ik = |F(k) - p_i|`` (the instrument's focus replaced by r_ik).  Each
estimate is one look (the 3.1 ms dwell is held at its pattern point; the
sweep between points, at most ``2 pi A max(a, b) / P`` per point, is not
modelled).

Schedule and synchronisation
----------------------------
Estimate ``k`` of the record (0-based) is at pattern point ``k mod P`` and
at the time ``start + (k + 1/2) / estimate_rate + time_offsets[i]`` on
unit i: each unit follows the pattern on its own clock, so a timing offset
makes the three speeds of a point be measured at different times (the
foci still meet, in space).  The record holds the estimates in the order
(k, unit): estimate ``3 k + i`` is unit i's of point k.

Focus groups and seeding
------------------------
Every (unit, pattern point) is one :class:`~cwlidar_sim.sensors.Focus` (its
focus distance, its cells, its one direction), in the order unit 0's points,
unit 1's, unit 2's; their seeds are the record's root SeedSequence's
children in that order (:func:`cwlidar_sim.sensors.measure`).  ``foci`` are
the groups' indices (as floats: two groups may share a focus distance);
the record's ``unit_e``, ``point_e``, ``range_e`` say which is which.

Speckle: the focal spot moves relative to the aerosols at
``dF/dt - (U, 0, 0)``; its component across the beam is the group's
transverse speed (the turbulence left out; at least 1 mm/s), unless
``transverse_speed`` is set.

What is refused, by name, before anything is computed: positions or target
not finite, two units at one place, a pattern point closer to a unit than
the instrument's nearest focus or beyond its collimation distance (the
focus cannot be placed there), a target below a unit's horizon
(``elevation`` below ``min_elevation_deg``: behind the scanner's field of
regard), and a geometry in which the three beams are coplanar or collinear
at some pattern point (``cond(N) > SINGULAR_CONDITION``: no wind vector at
all).  An ill-conditioned but solvable geometry is measured; the
reconstruction flags it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_real, check_tuple
from ..signal.instrument import WINDSCANNER, Instrument
from ..turbulence.cover import Region
from .base import BeamSampler, LidarBase
from .protocol import Focus, LidarRecord, RecordPlan, measure

__all__ = ["WindScanner", "measure_windscanner", "record_steps", "layout_from_angles", "PATTERNS", "PATTERN_PLANES",
           "SINGULAR_CONDITION", "DTU_2012_AZIMUTHS_DEG", "DTU_2012_ELEVATIONS_DEG", "DTU_2012_UNIT_HEIGHT",
           "DTU_2012_RANGE"]

#: Focus trajectories.
PATTERNS = ("point", "lissajous")
#: Planes a Lissajous pattern is drawn in: the axes (e1, e2) of the field frame.
PATTERN_PLANES = {"yz": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), "xz": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                  "xy": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))}
#: Condition number of the beams' matrix above which the geometry has no wind vector (coplanar beams).
SINGULAR_CONDITION = 1e8
#: The published campaign layout (Mikkelsen et al. 2012): the beams' azimuths [deg], taken here from +x (the
#: mean wind) toward +y, their elevations [deg], the units' height above ground [m] and the focus range [m].
DTU_2012_AZIMUTHS_DEG = (186.0, 56.0, 335.0)
DTU_2012_ELEVATIONS_DEG = (56.5, 51.7, 56.4)
DTU_2012_UNIT_HEIGHT = 11.0
DTU_2012_RANGE = 125.0


def layout_from_angles(target, azimuths_deg, elevations_deg, height: float) -> tuple:
    """Unit positions that see ``target`` along the given beam azimuths and elevations from one height.

    Unit i sits at ``target - r_i n_i`` with ``n_i`` the beam direction
    (azimuth from +x toward +y, elevation above the horizontal) and
    ``r_i = (target_z - height) / sin(elevation_i)``, so that every unit is
    at ``height``.

    Parameters
    ----------
    target : sequence of 3 floats
        The common focus (x, y, z) [m].
    azimuths_deg, elevations_deg : sequence of 3 floats
        Beam azimuths [deg] and elevations [deg], each elevation in (0, 90].
    height : float
        Height of every unit [m], below ``target_z``.

    Returns
    -------
    tuple of 3 tuples of 3 floats
        The positions [m].
    """
    t = check_tuple("target", target, 3, check_real)
    az = check_tuple("azimuths_deg", azimuths_deg, 3, check_real)
    el = check_tuple("elevations_deg", elevations_deg, 3,
                     lambda n, v: check_real(n, v, lo=0.0, hi=90.0, lo_open=True))
    h = check_real("height", height, hi=t[2], hi_open=True)
    out = []
    for a, e in zip(az, el):
        a, e = math.radians(a), math.radians(e)
        n = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        r = (t[2] - h) / math.sin(e)
        out.append(tuple(float(c) for c in np.asarray(t) - r * n))
    return tuple(out)


def _default_target():
    inv = float(np.mean(1.0 / np.sin(np.radians(DTU_2012_ELEVATIONS_DEG))))
    return (0.0, 0.0, DTU_2012_UNIT_HEIGHT + DTU_2012_RANGE / inv)


#: The published layout placed around a common target: the units at 11 m, the target's height such that the
#: mean range is 125 m (113.07 m), the ranges 122.4, 130.1 and 122.5 m (docs/windscanner.md).
_DTU_TARGET = _default_target()
_DTU_POSITIONS = layout_from_angles(_DTU_TARGET, DTU_2012_AZIMUTHS_DEG, DTU_2012_ELEVATIONS_DEG, DTU_2012_UNIT_HEIGHT)


@dataclasses.dataclass(frozen=True, kw_only=True)
class WindScanner(LidarBase):
    """Three cw lidars with one common focus, held or drawn along a Lissajous figure (module notes).

    Geometry fields below; the shared fields (instrument, tier, probe volume,
    chain, cloud) are :class:`cwlidar_sim.sensors.base.LidarBase`'s, with the
    defaults ``instrument = WINDSCANNER``, ``tier = 'los'``, ``span = 5``,
    ``cell_length = 2`` m, ``speckle = 'independent'``.  The instrument's
    ``focus`` is replaced by each unit's distance to each pattern point.

    Parameters
    ----------
    positions : tuple of 3 tuples of 3 floats
        The units' telescopes (x, y, z) [m]; distinct.  Default: the
        published layout (:func:`layout_from_angles` of
        :data:`DTU_2012_AZIMUTHS_DEG`, :data:`DTU_2012_ELEVATIONS_DEG` at
        :data:`DTU_2012_UNIT_HEIGHT`).
    target : tuple of 3 floats
        The common focus, or the pattern's centre (x, y, z) [m].
    pattern : {'point', 'lissajous'}
        The foci held at ``target``, or drawn along a Lissajous figure.
    lissajous_ratio : tuple of 2 ints
        ``a : b``, the figure's frequencies along ``e1`` and ``e2``; each in [1, 64].
    amplitude : float
        Half-size of the figure [m]; in (0, 100].
    points_per_pattern : int
        Estimates per figure P; in [4, 100000], at least ``4 max(a, b)``.
    lissajous_phase_deg : float
        Phase of the ``e1`` motion [deg] (90: the 3:2 figure closes on itself).
    pattern_plane : {'yz', 'xz', 'xy'}
        The plane of the figure (:data:`PATTERN_PLANES`; 'yz': across the mean wind).
    time_offsets : tuple of 3 floats
        Each unit's clock offset [s]; in [-10, 10] (module notes).
    min_elevation_deg : float
        Lowest elevation of a beam [deg]; in [-90, 90] (a target below it is refused).
    """

    positions: tuple = _DTU_POSITIONS
    target: tuple = _DTU_TARGET
    pattern: str = "point"
    lissajous_ratio: tuple = (3, 2)
    amplitude: float = 10.0
    points_per_pattern: int = 512
    lissajous_phase_deg: float = 90.0
    pattern_plane: str = "yz"
    time_offsets: tuple = (0.0, 0.0, 0.0)
    min_elevation_deg: float = 0.0
    instrument: Instrument = WINDSCANNER
    tier: str = "los"
    span: float = 5.0
    cell_length: float = 2.0
    speckle: str = "independent"

    def __post_init__(self):
        super().__post_init__()
        put = self._put
        pos = check_tuple("positions", self.positions, 3,
                          lambda n, v: check_tuple(n, v, 3, check_real))
        put("positions", pos)
        put("target", check_tuple("target", self.target, 3, check_real))
        check_choice("pattern", self.pattern, PATTERNS)
        ratio = check_tuple("lissajous_ratio", self.lissajous_ratio, 2,
                            lambda n, v: check_int(n, v, lo=1, hi=64))
        put("lissajous_ratio", ratio)
        put("amplitude", check_real("amplitude", self.amplitude, lo=0.0, hi=100.0, lo_open=True))
        put("points_per_pattern", check_int("points_per_pattern", self.points_per_pattern, lo=4, hi=100_000))
        if self.pattern == "lissajous" and self.points_per_pattern < 4 * max(ratio):
            raise ValueError(f"points_per_pattern={self.points_per_pattern} is too few for lissajous_ratio={ratio}; "
                             f"allowed: >= {4 * max(ratio)} (four points per period of the faster motion)")
        put("lissajous_phase_deg", check_real("lissajous_phase_deg", self.lissajous_phase_deg))
        check_choice("pattern_plane", self.pattern_plane, tuple(PATTERN_PLANES))
        put("time_offsets", check_tuple("time_offsets", self.time_offsets, 3,
                                        lambda n, v: check_real(n, v, lo=-10.0, hi=10.0)))
        put("min_elevation_deg", check_real("min_elevation_deg", self.min_elevation_deg, lo=-90.0, hi=90.0))
        for i in range(3):
            for j in range(i):
                if np.allclose(pos[i], pos[j], rtol=0.0, atol=1e-6):
                    raise ValueError(f"positions[{i}] and positions[{j}] are the same place {pos[i]}; allowed: three "
                                     f"distinct unit positions")
        self._check_geometry()

    def _check_geometry(self) -> None:
        """Every unit can focus on every pattern point, above its horizon, and the beams are never coplanar."""
        focus_kc = self.focus_points()
        far = math.pi * self.instrument.telescope_radius**2 / self.instrument.wavelength
        lo = 10.0  # cwlidar_sim.signal.instrument.FOCUS_MIN
        for i, p in enumerate(self.positions):
            d_kc = focus_kc - np.asarray(p)
            r_k = np.sqrt(np.sum(d_kc**2, axis=1))
            k = int(np.argmin(r_k))
            if r_k[k] < lo:
                raise ValueError(f"positions[{i}] is {r_k[k]:.4g} m from the common focus {tuple(focus_kc[k])} "
                                 f"(pattern point {k}): closer than a cw lidar can focus; allowed: >= {lo:g} m")
            k = int(np.argmax(r_k))
            if r_k[k] >= far:
                raise ValueError(f"target: the common focus {tuple(np.round(focus_kc[k], 3))} (pattern point {k}) is "
                                 f"{r_k[k]:.4g} m from positions[{i}], beyond the telescope's collimation distance "
                                 f"{far:.4g} m: the beams cannot be focused there, they never meet; allowed: a "
                                 f"target nearer than {far:.4g} m to every unit")
            el_k = np.degrees(np.arcsin(np.clip(d_kc[:, 2] / r_k, -1.0, 1.0)))
            k = int(np.argmin(el_k))
            if el_k[k] < self.min_elevation_deg:
                raise ValueError(f"target: unit {i} at {p} would look at {el_k[k]:.4g} deg elevation to reach pattern "
                                 f"point {k}, below min_elevation_deg={self.min_elevation_deg:g} (behind or below "
                                 f"the scanner); allowed: a target above every unit")
            for r in (float(r_k.min()), float(r_k.max())):
                check_int("number of range cells", self.cells(r).n_cells, lo=1, hi=100_000)
        cond_k = np.linalg.cond(self.directions())
        k = int(np.argmax(cond_k))
        if not cond_k[k] <= SINGULAR_CONDITION:
            raise ValueError(f"positions: the three beams are coplanar or collinear at pattern point {k} "
                             f"{tuple(np.round(focus_kc[k], 3))} (condition number {cond_k[k]:.3g} of their "
                             f"directions): three line-of-sight speeds give no wind vector there; allowed: units "
                             f"not in one plane with the focus (condition number <= {SINGULAR_CONDITION:g})")
        if self.cloud_base is not None:
            for i, n_kc in enumerate(np.moveaxis(self.directions(), 1, 0)):
                for k in (int(np.argmin(n_kc[:, 2])), int(np.argmax(n_kc[:, 2]))):
                    r = float(np.linalg.norm(focus_kc[k] - np.asarray(self.positions[i])))
                    self.check_cloud_beyond(self.instrument_at(r), self.cells(r), float(n_kc[k, 2]))

    # -- derived ---------------------------------------------------------
    @property
    def n_points(self) -> int:
        """Pattern points P (1 for a held point)."""
        return 1 if self.pattern == "point" else self.points_per_pattern

    @property
    def pattern_period(self) -> float:
        """Duration of one pattern, P / estimate_rate [s]."""
        return self.n_points / self.instrument.estimate_rate

    def focus_points(self) -> np.ndarray:
        """The common focus at each pattern point, shape (P, 3) [m] (module notes)."""
        t = np.asarray(self.target, dtype=np.float64)
        if self.pattern == "point":
            return t[None, :].copy()
        a, b = self.lissajous_ratio
        ph = 2.0 * np.pi * np.arange(self.points_per_pattern) / self.points_per_pattern
        e1, e2 = (np.asarray(e) for e in PATTERN_PLANES[self.pattern_plane])
        s1 = np.sin(a * ph + math.radians(self.lissajous_phase_deg))
        s2 = np.sin(b * ph)
        return t[None, :] + self.amplitude * (s1[:, None] * e1[None, :] + s2[:, None] * e2[None, :])

    def focus_velocities(self) -> np.ndarray:
        """dF/dt of the common focus at each pattern point, shape (P, 3) [m/s]."""
        if self.pattern == "point":
            return np.zeros((1, 3))
        a, b = self.lissajous_ratio
        w = 2.0 * np.pi / self.pattern_period
        ph = 2.0 * np.pi * np.arange(self.points_per_pattern) / self.points_per_pattern
        e1, e2 = (np.asarray(e) for e in PATTERN_PLANES[self.pattern_plane])
        c1 = a * w * np.cos(a * ph + math.radians(self.lissajous_phase_deg))
        c2 = b * w * np.cos(b * ph)
        return self.amplitude * (c1[:, None] * e1[None, :] + c2[:, None] * e2[None, :])

    def directions(self) -> np.ndarray:
        """Unit look directions, shape (P, 3 units, 3) [-]: from each unit to each pattern point."""
        d = self.focus_points()[:, None, :] - np.asarray(self.positions, dtype=np.float64)[None, :, :]
        return d / np.sqrt(np.sum(d * d, axis=2))[:, :, None]

    def ranges(self) -> np.ndarray:
        """Focus distances, shape (P, 3 units) [m]."""
        d = self.focus_points()[:, None, :] - np.asarray(self.positions, dtype=np.float64)[None, :, :]
        return np.sqrt(np.sum(d * d, axis=2))

    def condition_numbers(self) -> np.ndarray:
        """2-norm condition number of the beams' matrix N (rows the three directions) per pattern point, shape (P,)."""
        return np.linalg.cond(self.directions())

    def instrument_at(self, focus: float) -> Instrument:
        """The instrument focused at ``focus`` [m]."""
        return self.instrument.replace(focus=float(focus))

    def cells(self, focus: float):
        """Range cells at ``focus`` (:class:`cwlidar_sim.beam.cells.ProbeCells`)."""
        return self.probe_cells(self.instrument_at(focus))

    def box_region(self, spacing: float) -> Region:
        """The region a box must hold for every beam's cells [m], grown by two grid steps ``spacing`` (in (0, 100])."""
        d = check_real("spacing", spacing, lo=0.0, hi=100.0, lo_open=True)
        pts = []
        directions = self.directions()
        ranges = self.ranges()
        for i, p in enumerate(self.positions):
            for k in range(self.n_points):
                c = self.cells(ranges[k, i])
                for s in (max(ranges[k, i] + c.edges[0], 0.0), ranges[k, i] + c.edges[-1]):
                    pts.append(np.asarray(p) + s * directions[k, i])
            pts.append(np.asarray(p))
        pts = np.asarray(pts)
        lo, hi = pts.min(axis=0) - 2.0 * d, pts.max(axis=0) + 2.0 * d
        mid = 0.5 * (lo + hi)
        return Region(x_lo=float(lo[0]), length=float(hi[0] - lo[0]), y_mid=float(mid[1]),
                      half_width=float(0.5 * (hi[1] - lo[1])), z_mid=float(mid[2]),
                      half_height=float(0.5 * (hi[2] - lo[2])))

    def schedule(self, duration: float, start: float = 0.0):
        """``(time_k, point_k)``: the pattern's estimate times on the common clock [s] and their pattern points."""
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        rate = self.instrument.estimate_rate
        nk = int(math.floor(duration * rate + 1e-9))
        if nk < 1:
            raise ValueError(f"duration={duration} s holds no estimate; allowed: >= 1 / estimate_rate = "
                             f"{1.0 / rate:.4g} s")
        k = np.arange(nk)
        return start + (k + 0.5) / rate, k % self.n_points

    def transverse_speed_at(self, point: int, unit: int, U: float) -> float:
        """The speckle's transverse speed of unit ``unit`` at pattern point ``point`` [m/s] (module notes)."""
        if self.transverse_speed is not None:
            return self.transverse_speed
        n = self.directions()[point, unit]
        rel = self.focus_velocities()[point] - np.array([U, 0.0, 0.0])
        perp = rel - (rel @ n) * n
        return max(float(np.sqrt(perp @ perp)), 1e-3)

    # -- the Sensor protocol (cwlidar_sim.sensors.protocol) -----------------
    def plan_record(self, field, U: float, *, wrap: bool, duration: float, start: float = 0.0) -> RecordPlan:
        """The estimates over ``[start, start + duration)``, one focus per unit and pattern point (module notes)."""
        time_k, point_k = self.schedule(duration, start)
        nk, P = time_k.size, self.n_points
        directions, ranges = self.directions(), self.ranges()
        unit_e = np.tile(np.arange(3), nk)
        point_e = np.repeat(point_k, 3)
        time_e = np.repeat(time_k, 3) + np.asarray(self.time_offsets)[unit_e]
        focus_index_e = unit_e * P + point_e
        groups = []
        vel_cl = self.cloud_velocity(U)
        for i in range(3):
            origin = np.asarray(self.positions[i], dtype=np.float64)
            for k in range(P):
                idx = np.flatnonzero(focus_index_e == i * P + k)
                r, n3 = float(ranges[k, i]), np.ascontiguousarray(directions[k, i])
                inst, cells = self.instrument_at(r), self.cells(r)
                sampler = BeamSampler(field, origin, r, cells, U, wrap)
                sampler.check_extent(n3)
                wc = self.cloud_weight_at(inst, float(n3[2]))

                def sample(lo, hi, idx=idx, sampler=sampler, n3=n3, wc=wc):
                    sel = idx[lo:hi]
                    vlos_ls, vlos_l = sampler.sample(time_e[sel], np.broadcast_to(n3, (sel.size, 3)))
                    cloud = None if wc == 0.0 else np.full((sel.size, 1), float(n3 @ vel_cl))
                    return vlos_ls[:, None, :], vlos_l, cloud

                groups.append(Focus(instrument=inst, index_e=idx, time_e=time_e[idx], cells=cells, n_looks=1,
                                    sample=sample, transverse_speed=self.transverse_speed_at(k, i, U), field=field,
                                    cloud_weight=wc))
        extras = {"unit_e": unit_e, "point_e": point_e, "range_e": ranges[point_e, unit_e],
                  "direction_ec": directions[point_e, unit_e], "focus_ec": self.focus_points()[point_e]}
        return RecordPlan(time_e=time_e, focus_index_e=focus_index_e, foci=tuple(float(g) for g in range(3 * P)),
                          groups=groups, extras=extras, context={"time_k": time_k})

    def finish_record(self, record: LidarRecord, plan: RecordPlan, chain) -> LidarRecord:
        """The record's ``info`` (:func:`measure_windscanner`)."""
        cond = self.condition_numbers()
        info = {"tier": self.tier, "n_estimates": int(plan.time_e.size), "n_points": self.n_points,
                "pattern": self.pattern, "estimate_rate": self.instrument.estimate_rate,
                "time_offsets": self.time_offsets, "range_min": float(self.ranges().min()),
                "range_max": float(self.ranges().max()), "condition_min": float(cond.min()),
                "condition_max": float(cond.max()), "estimator": chain.info["estimator"],
                "flag_counts": chain.info["flag_counts"]}
        return dataclasses.replace(record, info=info)


def measure_windscanner(field, scanner: WindScanner, duration: float, U: float, seed=None, *, start: float = 0.0,
                        wrap: bool = False, variants=None, chunk: int = 4096,
                        calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a WindScanner's record: three units' line-of-sight speeds at their common focus (module notes).

    The public form of :func:`cwlidar_sim.sensors.measure` for the WindScanner
    (a duration and a start).

    Parameters
    ----------
    field : xarray.Dataset
        A box holding every unit's cells (:meth:`WindScanner.box_region`); u, v, w fluctuations [m/s].
    scanner : WindScanner
    duration : float
        Record length [s]; at least one estimate.
    U : float
        Mean wind along +x [m/s].
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal' (required by them); each
        (unit, pattern point) draws from its child of the root SeedSequence.
    start : float
        Start time [s].
    wrap : bool
        Treat y and z as periodic.
    variants : list of dict, optional
        Extra processings of the same spectra (:data:`cwlidar_sim.signal.chain.VARIANT_KEYS`).
    chunk : int
        Estimates processed at a time (memory only).
    calibration_time : float
        Time of t = 0 on the background-calibration clock [s].

    Returns
    -------
    LidarRecord
        Estimates in the order (pattern estimate k, unit); ``vlos_e`` signed
        (positive away from the unit), ``speed_e = |v_los|`` (homodyne).
        ``extras``: ``unit_e`` (0, 1, 2), ``point_e`` (pattern point),
        ``range_e`` [m], ``direction_ec`` (unit look direction, (n_e, 3)),
        ``focus_ec`` (the common focus [m], (n_e, 3)).  ``info``: tier,
        counts, the pattern, the ranges' and condition numbers' extremes,
        the chain's flag counts.
    """
    if not isinstance(scanner, WindScanner):
        raise TypeError(f"scanner must be a WindScanner, got {type(scanner).__name__}")
    return measure(field, scanner, U, seed, variants=variants, chunk=chunk, wrap=wrap,
                   calibration_time=calibration_time, duration=duration, start=start)


def record_steps(record: LidarRecord, variant: str | None = None) -> dict:
    """A WindScanner record's estimates by pattern step: each array reshaped to (n_k, 3 units, ...).

    Parameters
    ----------
    record : LidarRecord
        From :func:`measure_windscanner` (estimates in the order (k, unit)).
    variant : str, optional
        A processing variant's ``speed`` and ``flags`` instead of the main ones.

    Returns
    -------
    dict
        ``time_ki`` [s], ``vlos_ki`` (tier 1, signed) [m/s], ``speed_ki``
        (homodyne) [m/s], ``flags_ki``, ``point_k``, ``direction_kic`` [-],
        ``focus_kc`` [m].
    """
    ne = record.time_e.size
    if ne % 3 or "unit_e" not in record.extras or not np.array_equal(record.unit_e, np.tile(np.arange(3), ne // 3)):
        raise ValueError("record must be a WindScanner's (measure_windscanner): three units per step")
    speed, flags = (record.speed_e, record.flags_e) if variant is None else record.variants[variant]
    return {"time_ki": record.time_e.reshape(-1, 3), "vlos_ki": record.vlos_e.reshape(-1, 3),
            "speed_ki": np.asarray(speed).reshape(-1, 3), "flags_ki": np.asarray(flags).reshape(-1, 3),
            "point_k": record.point_e[::3], "direction_kic": record.direction_ec.reshape(-1, 3, 3),
            "focus_kc": record.focus_ec[::3]}
