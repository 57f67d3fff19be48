"""Nacelle scene files: a turbine's forward-looking lidar, the rotor, the turbulence, the periods (``kind = "nacelle"``).

A nacelle scene describes lidar-assisted control's question: how well a
nacelle lidar's estimate of the rotor-effective wind speed (REWS),
shifted by its preview time, matches the REWS the rotor feels, per focus
distance.  How it is run is :mod:`cwlidar_sim.campaign.periods.nacelle`.

Units of work: one per period.  A period's box (frozen turbulence) or boxes
(evolving turbulence, ``lifetime`` set: one per plane, the rotor's and each
focus distance's) hold the rotor disc and every focus distance; the lidar
measures each focus distance as its own fixed-focus record on that one
turbulence, so the focus distances are compared on the same air.

Example
-------
.. code-block:: toml

    name = "nacelle"
    kind = "nacelle"
    seed = 20
    duration = 600.0

    [scan]                          # the sensor's geometry (cwlidar_sim.sensors.NacelleLidar)
    focus_distances = [50.0, 100.0, 150.0]
    half_angle_deg = 15.0
    rotor_radius = 60.0             # the REWS's disc [m], uniform weight (rotor_exponent = 0)
    spacing = 4.0                   # the box [m]
    segment_duration = 60.0         # the coherence's segments [s]

    [lidar]                         # the keys of every scene's [lidar]; defaults: the CS series instrument
    tier = "spectral"
    variants = [{ name = "median", estimator = "median" }]

    [turbulence]                    # the keys of every scene's [turbulence] (turbulence_spec): or
    alpha_eps = 0.1                 # ti = 0.12 (or iec_class = "B") with height = 90.0, the hub's
    length_scale = 33.6
    gamma = 3.9

    [[period]]
    name = "frozen"
    mean_speed = 12.0

    [[period]]
    name = "evolving"
    mean_speed = 12.0
    lifetime = 20.0                 # eddy-lifetime evolution (cwlidar_sim.turbulence.evolution) [s]
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from ..._validation import check_bool, check_int, check_real, check_seed, check_str
from .lidar_spec import LidarSpecBase, lidar_schema
from .turbulence_spec import TurbulenceSpec
from .spec import (SceneSpec, Spec, Table, check_distinct_reals, check_periods, check_scene_name, entry_label,
                   resolve_path, set_field, spec_table, turbulence_schema)

__all__ = ["NacelleScanSpec", "NacelleTurbulenceSpec", "NacellePeriodSpec", "NacelleLidarSpec",
           "NacellePlatformSpec", "PLATFORM_DOFS", "NacelleScene"]


@dataclasses.dataclass(frozen=True)
class NacelleLidarSpec(LidarSpecBase):
    """The ``[lidar]`` table of a nacelle scene: every scene's keys, the scanning instrument's defaults.

    Defaults: ``preset = 'cs'`` (the ZephIR optics of the nacelle lidars),
    ``tier = 'los'``, ``span = 5``, ``speckle = 'independent'``;
    ``cell_length`` defaults to the box spacing (``scan.spacing``).
    """

    preset: str = "cs"
    tier: str = "los"
    span: float = 5.0
    speckle: str = "independent"


#: [scan] keys passed to :class:`cwlidar_sim.sensors.NacelleLidar` as they are.
SENSOR_GEOMETRY = ("half_angle_deg", "revolution_time", "estimates_per_rev", "azimuth0_deg", "sub_dwells",
                   "rotor_rpm", "n_blades", "blade_chord", "rotor_plane_distance", "blade_azimuth0_deg",
                   "blockage_fraction")


@dataclasses.dataclass(frozen=True)
class NacelleScanSpec(Spec):
    """The lidar's geometry, the rotor disc, the box and the coherence's settings.

    Parameters
    ----------
    focus_distances : tuple of float
        Focus distances [m], 1 to 10 distinct, each its own record (module notes).
    half_angle_deg, revolution_time, estimates_per_rev, azimuth0_deg, sub_dwells
        The scan (:class:`cwlidar_sim.sensors.NacelleLidar`).
    beam_azimuths_deg : tuple of float
        Fixed beams instead of the circle [deg]; empty: the circle.
    rotor_rpm, n_blades, blade_chord, rotor_plane_distance, blade_azimuth0_deg, blockage_fraction
        Blade blockage (``rotor_rpm = 0``: none).
    rotor_radius : float
        Radius of the REWS's disc [m]; in (0, 200].
    rotor_exponent : float
        Per-area weight ``(r / R)^p`` of the REWS (:class:`cwlidar_sim.analysis.rews.RotorDisc`); in [0, 10].
    spacing : float
        Box spacing [m]; in (0, 50].
    lateral_doubling : bool
        Generate each box twice as wide and keep half.
    segment_duration : float
        Segment length of the coherence [s]; in [10, 3600], at most a third of each period.
    k_min, k_max : float
        Wavenumber range of the reported coherence [rad/m], 0 < k_min < k_max <= 2.
    n_k : int
        Log-spaced wavenumber bins; in [4, 200].
    theory_beams : int
        Point beams of the analytic coherence over a revolution; in [0, 64]
        (0: no theory; its cost grows like the square).
    """

    focus_distances: tuple = (50.0, 100.0, 150.0)
    half_angle_deg: float = 15.0
    revolution_time: float = 1.0
    estimates_per_rev: int = 50
    azimuth0_deg: float = 0.0
    sub_dwells: int = 2
    beam_azimuths_deg: tuple = ()
    rotor_rpm: float = 0.0
    n_blades: int = 3
    blade_chord: float = 2.0
    rotor_plane_distance: float = 3.0
    blade_azimuth0_deg: float = 0.0
    blockage_fraction: float = 0.5
    rotor_radius: float = 60.0
    rotor_exponent: float = 0.0
    spacing: float = 4.0
    lateral_doubling: bool = True
    segment_duration: float = 60.0
    k_min: float = 0.004
    k_max: float = 0.3
    n_k: int = 24
    theory_beams: int = 8

    def __post_init__(self):
        set_field(self, "focus_distances", check_distinct_reals("scan.focus_distances", self.focus_distances,
                                                                count=(1, 10), noun="focus distances", lo=10.0, hi=1000.0))
        b = tuple(check_real(f"scan.beam_azimuths_deg[{i}]", a) for i, a in enumerate(self.beam_azimuths_deg))
        set_field(self, "beam_azimuths_deg", b)
        set_field(self, "rotor_radius", check_real("scan.rotor_radius", self.rotor_radius, lo=0.0, hi=200.0,
                                                   lo_open=True))
        set_field(self, "rotor_exponent", check_real("scan.rotor_exponent", self.rotor_exponent, lo=0.0, hi=10.0))
        set_field(self, "spacing", check_real("scan.spacing", self.spacing, lo=0.0, hi=50.0, lo_open=True))
        set_field(self, "lateral_doubling", check_bool("scan.lateral_doubling", self.lateral_doubling))
        set_field(self, "segment_duration", check_real("scan.segment_duration", self.segment_duration, lo=10.0,
                                                       hi=3600.0))
        set_field(self, "k_max", check_real("scan.k_max", self.k_max, lo=0.0, hi=2.0, lo_open=True))
        set_field(self, "k_min", check_real("scan.k_min", self.k_min, lo=0.0, hi=self.k_max, lo_open=True,
                                            hi_open=True))
        set_field(self, "n_k", check_int("scan.n_k", self.n_k, lo=4, hi=200))
        set_field(self, "theory_beams", check_int("scan.theory_beams", self.theory_beams, lo=0, hi=64))

    def k_edges(self) -> np.ndarray:
        """Edges of the wavenumber bins [rad/m]."""
        return np.geomspace(self.k_min, self.k_max, self.n_k + 1)

    def geometry(self) -> dict:
        """The :class:`cwlidar_sim.sensors.NacelleLidar` geometry fields (not the focus distances)."""
        g = {k: getattr(self, k) for k in SENSOR_GEOMETRY}
        g["beam_azimuths_deg"] = self.beam_azimuths_deg or None
        return g

    def as_dict(self) -> dict:
        d = super().as_dict()
        d["focus_distances"], d["beam_azimuths_deg"] = list(self.focus_distances), list(self.beam_azimuths_deg)
        return d


@dataclasses.dataclass(frozen=True)
class NacelleTurbulenceSpec(TurbulenceSpec):
    """The ``[turbulence]`` table of a nacelle scene: every scene's keys, at hub height.

    The keys, the ways they set the tensor and the refusals are
    :class:`cwlidar_sim.campaign.scenes.turbulence_spec.TurbulenceSpec`'s; here a
    table picking no way, and the explicit keys it leaves out, are
    ``alpha_eps = 0.1``, ``length_scale = 33.6`` (IEC's 0.8 x 42 m above 60 m),
    ``gamma = 3.9``.  The scene has no hub height of its own: ``height`` [m]
    is needed where the tensor depends on it (the surface layer, and
    ``ti`` / ``sigma_u`` / ``iec_class`` without ``length_scale``).  A
    period's mean speed is the hub height's; ``ti`` and ``iec_class`` give
    each period its own tensor (:meth:`NacelleScene.period_params`).
    No ``fit_to`` or ``condition_on``.
    """

    _kind = "nacelle"
    _default = {"alpha_eps": 0.1, "length_scale": 33.6, "gamma": 3.9}
    _takes_fit_to = False
    _takes_condition_on = False


@dataclasses.dataclass(frozen=True)
class NacellePeriodSpec(Spec):
    """One period of a nacelle scene.

    Parameters
    ----------
    name : str
    mean_speed : float
        Mean wind at hub height [m/s]; in [3, 40].
    yaw_misalignment_deg : float
        Yaw of the rotor axis from the wind [deg]; in [-45, 45].  The analytic
        coherence is for an aligned rotor only (NaN otherwise).
    lifetime : float, optional
        Eddy-lifetime scale T [s] of evolving turbulence
        (:class:`cwlidar_sim.turbulence.evolution.EddyLifetimeEvolution`); None: frozen.
    duration : float, optional
        Length [s]; default the scene's; in [30, 7200].
    seed : int, optional
        Seed of the period's box; default derived from the scene seed.
    """

    name: str
    mean_speed: float
    yaw_misalignment_deg: float = 0.0
    lifetime: float | None = None
    duration: float | None = None
    seed: int | None = None

    _required = ("name", "mean_speed")

    def __post_init__(self):
        # bare key names: the scene names the entry, period[0] ('frozen') (spec.periods_from_dict)
        check_str("name", self.name)
        set_field(self, "mean_speed", check_real("mean_speed", self.mean_speed, lo=3.0, hi=40.0))
        set_field(self, "yaw_misalignment_deg", check_real("yaw_misalignment_deg", self.yaw_misalignment_deg,
                                                           lo=-45.0, hi=45.0))
        if self.lifetime is not None:
            set_field(self, "lifetime", check_real("lifetime", self.lifetime, lo=0.0, hi=1e6, lo_open=True))
        if self.duration is not None:
            set_field(self, "duration", check_real("duration", self.duration, lo=30.0, hi=7200.0))
        if self.seed is not None:
            set_field(self, "seed", check_seed("seed", self.seed))


#: Degrees of freedom of the ``[platform]`` table (those of :class:`cwlidar_sim.sensors.PlatformMotion`).
PLATFORM_DOFS = ("surge", "sway", "heave", "roll_deg", "pitch_deg", "yaw_deg")


@dataclasses.dataclass(frozen=True)
class NacellePlatformSpec(Spec):
    """The ``[platform]`` table: a prescribed motion of the lidar's platform, and the correction.

    Either sinusoids, ``x(t) = A sin(2 pi t / period + phase)`` per degree of
    freedom, or a CSV time series (``csv``; not both): a header row naming
    ``time`` [s] and any of the degrees of freedom, one sample per row,
    spanning every period; the path is resolved relative to the scene file.
    Example::

        [platform]
        period = 7.0                  # s
        surge = 1.5                   # m (amplitude)
        pitch_deg = 3.0               # deg (amplitude)
        phase_deg = { pitch_deg = 90.0 }
        correction = true             # an ideal motion sensor

    Parameters
    ----------
    period : float
        Period of the sinusoids [s]; in [0.5, 3600].
    surge, sway, heave : float
        Amplitudes of the lidar's displacement along x, y, z [m]; in [0, 50].
    roll_deg, pitch_deg, yaw_deg : float
        Amplitudes of the nacelle's attitude [deg]; in [0, 20].
    phase_deg : dict
        Phase per degree of freedom [deg] (keys among :data:`PLATFORM_DOFS`); default 0.
    csv : str
        Path of a time series instead of the sinusoids; "" (default): none.
        Its time column is ``time`` [s] or names its unit (``time_ms``,
        ``time [ms]``; :func:`cwlidar_sim.sensors.platform.read_platform_csv`).
    max_gap : float, optional
        Longest step between the csv's samples [s], in (0, 3600]; default
        (None) 1 s.  A longer hole is refused, not interpolated across.
    correction : bool
        Correct the line-of-sight speeds with an ideal motion sensor
        (:class:`cwlidar_sim.sensors.NacelleLidar` ``motion_correction``).
    """

    period: float = 10.0
    surge: float = 0.0
    sway: float = 0.0
    heave: float = 0.0
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0
    phase_deg: dict = dataclasses.field(default_factory=dict)
    csv: str = ""
    correction: bool = False
    max_gap: float | None = None  # None keeps a scene's identity (as_dict drops it)

    def __post_init__(self):
        set_field(self, "period", check_real("platform.period", self.period, lo=0.5, hi=3600.0))
        for k in PLATFORM_DOFS:
            hi = 20.0 if k.endswith("_deg") else 50.0
            set_field(self, k, check_real(f"platform.{k}", getattr(self, k), lo=0.0, hi=hi))
        if not isinstance(self.phase_deg, dict):
            raise TypeError(f"platform.phase_deg must be a table of phases [deg], got {type(self.phase_deg).__name__}")
        unknown = sorted(set(self.phase_deg) - set(PLATFORM_DOFS))
        if unknown:
            raise ValueError(f"unknown key(s) in platform.phase_deg: {unknown}; allowed: {list(PLATFORM_DOFS)}")
        set_field(self, "phase_deg", {k: check_real(f"platform.phase_deg.{k}", v, lo=-360.0, hi=360.0)
                                      for k, v in self.phase_deg.items()})
        check_str("platform.csv", self.csv, allow_empty=True)
        set_field(self, "correction", check_bool("platform.correction", self.correction))
        if self.max_gap is not None:
            set_field(self, "max_gap", check_real("platform.max_gap", self.max_gap, lo=0.0, hi=3600.0, lo_open=True))
            if not self.csv:
                raise ValueError("platform.max_gap applies to a csv series; the sinusoids have no gaps")
        if self.csv and any(getattr(self, k) for k in PLATFORM_DOFS):
            raise ValueError("platform: give either amplitudes (sinusoids) or csv, not both")

    def motion(self, duration: float, base_dir: str = "."):
        """The :class:`cwlidar_sim.sensors.PlatformMotion` over ``[0, duration]`` [s] (None: no motion)."""
        from ...sensors.platform import PLATFORM_MAX_GAP, PlatformMotion, read_platform_csv

        if self.csv:
            path = resolve_path(base_dir, self.csv)
            if not os.path.isfile(path):
                raise ValueError(f"platform.csv: no file {path!r} (resolved relative to the scene file)")
            gap = PLATFORM_MAX_GAP if self.max_gap is None else self.max_gap
            motion = read_platform_csv(path, max_gap=gap, where="platform.csv")
            motion.check_covers(0.0, duration)
            return motion
        if not any(getattr(self, k) for k in PLATFORM_DOFS):
            return None
        # sampled finely, 1 s beyond the record each side: PlatformMotion's speeds are the samples'
        # central differences, relative error (2 pi h / period)^2 / 6 (8e-6 at the finest period 0.5 s)
        step = min(0.01, self.period / 500.0)
        t = np.arange(-1.0, duration + 1.0 + step, step)
        w = 2.0 * np.pi / self.period
        return PlatformMotion(time=t, **{k: getattr(self, k) * np.sin(w * t + np.radians(self.phase_deg.get(k, 0.0)))
                                         for k in PLATFORM_DOFS if getattr(self, k)})


@dataclasses.dataclass(frozen=True)
class NacelleScene(SceneSpec):
    """A nacelle-lidar campaign (module notes).

    A copy with keys changed: :meth:`~cwlidar_sim.campaign.scenes.spec.SceneSpec.with_values`
    (dotted keys of the file, ``{"lidar.cnr_db": -15.0}``) or :meth:`replace` (fields).

    Parameters
    ----------
    name : str
        Used for ``DIR/<name>.nc``.
    periods : tuple of NacellePeriodSpec
    scan : NacelleScanSpec
    lidar : NacelleLidarSpec
    turbulence : NacelleTurbulenceSpec
    platform : NacellePlatformSpec or None
        The platform's prescribed motion and its correction (the ``[platform]`` table); None: at rest.
    duration : float
        Default period length [s]; in [30, 7200].
    seed : int
    description : str
    """

    name: str
    periods: tuple
    scan: NacelleScanSpec = dataclasses.field(default_factory=NacelleScanSpec)
    lidar: NacelleLidarSpec = dataclasses.field(default_factory=NacelleLidarSpec)
    turbulence: NacelleTurbulenceSpec = dataclasses.field(default_factory=NacelleTurbulenceSpec)
    platform: NacellePlatformSpec | None = None
    duration: float = 600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    kind = "nacelle"

    def __post_init__(self):
        check_scene_name(self.name)
        for key, cls in (("scan", NacelleScanSpec), ("lidar", NacelleLidarSpec),
                         ("turbulence", NacelleTurbulenceSpec)):
            if not isinstance(getattr(self, key), cls):
                raise TypeError(f"{key} must be a {cls.__name__}, got {type(getattr(self, key)).__name__}")
        if self.platform is not None and not isinstance(self.platform, NacellePlatformSpec):
            raise TypeError(f"platform must be a NacellePlatformSpec or None, got {type(self.platform).__name__}")
        periods = check_periods(self.periods, NacellePeriodSpec, "nacelle scene")
        set_field(self, "periods", periods)
        set_field(self, "duration", check_real("duration", self.duration, lo=30.0, hi=7200.0))
        set_field(self, "seed", check_seed("seed", self.seed))
        check_str("description", self.description, allow_empty=True)
        self.turbulence.check_frozen(periods)
        for i, p in enumerate(periods):
            where = entry_label("period", i, p.name)
            dur = self.period_duration(p)
            if dur < 3.0 * self.scan.segment_duration:
                raise ValueError(f"{where} lasts {dur:g} s, shorter than 3 coherence segments of "
                                 f"scan.segment_duration = {self.scan.segment_duration:g} s; allowed: longer "
                                 f"periods or shorter segments")
            try:
                self.sensor(p)
            except (ValueError, TypeError) as e:
                raise type(e)(f"nacelle lidar of {where}: {e}") from None

    def period_params(self, period):
        """The :class:`cwlidar_sim.turbulence.MannParameters` of a period (its mean speed at hub height)."""
        return self.turbulence.params(None, period.mean_speed)

    def sensor(self, period, focus_distances=None):
        """The :class:`cwlidar_sim.sensors.NacelleLidar` of a period (all focus distances, or those given)."""
        from ...sensors.nacelle import NacelleLidar

        kw = self.lidar.sensor_kwargs(self.scan.spacing)
        kw.update(self.scan.geometry(), instrument=self.lidar.build_instrument(),
                  yaw_misalignment_deg=period.yaw_misalignment_deg,
                  focus_distances=tuple(focus_distances or self.scan.focus_distances))
        if self.platform is not None:
            kw.update(motion=self.platform.motion(self.period_duration(period), self.base_dir),
                      motion_correction=self.platform.correction)
        return NacelleLidar(**kw)

    # -- units of work ----------------------------------------------------
    def simulated_hours(self) -> float:
        """Simulated time of all units [h] (each focus distance its own record)."""
        return sum(self.period_duration(p) for p in self.periods) * len(self.scan.focus_distances) / 3600.0

    # -- interchange ------------------------------------------------------
    def as_dict(self) -> dict:
        d = super().as_dict()
        d.pop("base_dir", None)
        d["kind"] = "nacelle"
        d["period"] = d.pop("periods")
        return d

    #: The scene file's tables and the spec class of each.
    _tables = {"scan": NacelleScanSpec, "lidar": NacelleLidarSpec, "turbulence": NacelleTurbulenceSpec,
               "platform": NacellePlatformSpec}
    _period_spec = NacellePeriodSpec
    _what = "nacelle scene"

    @classmethod
    def schema(cls) -> dict:
        """TOML path of each table of the scene file -> its keys (:func:`cwlidar_sim.campaign.scenes.spec.check_scene_keys`)."""
        out = {"": Table(("name", "kind", "description", "seed", "duration", "period", *cls._tables)),
               "scan": spec_table(NacelleScanSpec)}
        out.update(lidar_schema(cls._tables["lidar"]))
        out.update(turbulence_schema(cls._tables["turbulence"]))
        out.update({"platform": spec_table(NacellePlatformSpec), "platform.phase_deg": Table(PLATFORM_DOFS),
                    "period[]": spec_table(NacellePeriodSpec)})
        return out
