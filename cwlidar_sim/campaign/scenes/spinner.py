"""SpinnerLidar scene files: DTU's spinner-mounted rosette lidar, the rotor, the turbulence, the periods (``kind = "spinner"``).

A spinner scene asks what a SpinnerLidar (:class:`cwlidar_sim.sensors.spinner.SpinnerLidar`)
tells about the inflow over the rotor disc: per rosette (2 s) a linear
wind field fitted to its 984 line-of-sight speeds
(:func:`cwlidar_sim.analysis.disc_fit.fit_disc`) gives the rotor-effective
wind speed, the vertical and horizontal shear, the veer and the yaw
misalignment, compared with the REWS the rotor then feels.  How it is run is
:mod:`cwlidar_sim.campaign.periods.spinner`.

Units of work: one per period.  A period's box (frozen turbulence) or
boxes (evolving, ``lifetime`` set: the rotor plane's and the focus's) hold
the rotor disc and the rosette's probe volumes.  The ``[turbulence]`` and
``[platform]`` tables are the nacelle scene's
(:mod:`cwlidar_sim.campaign.scenes.nacelle`); a period adds the rotor's speed.

Example
-------
.. code-block:: toml

    name = "spinner"
    kind = "spinner"
    seed = 31
    duration = 600.0

    [scan]                          # the sensor's geometry (cwlidar_sim.sensors.spinner.SpinnerLidar)
    focus_distance = 80.0           # m along the beam: one rotor diameter of an 80-m rotor
    tilt_deg = 5.0
    n_blades = 3                    # blade blockage where the beam crosses them
    rotor_radius = 40.0             # the REWS's disc [m]
    spacing = 4.0                   # the box [m]

    [lidar]                         # the keys of every scene's [lidar]; defaults: the SpinnerLidar preset
    tier = "spectral"
    variants = [{ name = "median", estimator = "median" }]

    [turbulence]
    alpha_eps = 0.1
    length_scale = 33.6
    gamma = 3.9

    [[period]]
    name = "aligned"
    mean_speed = 10.0
    rotor_rpm = 14.0

    [[period]]
    name = "yawed"
    mean_speed = 10.0
    rotor_rpm = 14.0
    yaw_misalignment_deg = 10.0
    lifetime = 20.0                 # evolving turbulence [s]
"""

from __future__ import annotations

import dataclasses

from ..._validation import check_bool, check_int, check_real, check_seed, check_str
from .lidar_spec import LidarSpecBase, lidar_schema
from .nacelle import NacellePeriodSpec, NacellePlatformSpec, NacelleTurbulenceSpec, PLATFORM_DOFS
from .spec import (SceneSpec, Spec, Table, check_periods, check_scene_name, entry_label, set_field, spec_table,
                   turbulence_schema)

__all__ = ["SpinnerScanSpec", "SpinnerLidarSpec", "SpinnerTurbulenceSpec", "SpinnerPeriodSpec", "SpinnerScene"]


@dataclasses.dataclass(frozen=True)
class SpinnerLidarSpec(LidarSpecBase):
    """The ``[lidar]`` table of a spinner scene: every scene's keys, the SpinnerLidar's defaults.

    Defaults: ``preset = 'spinner'`` (:data:`cwlidar_sim.signal.instrument.SPINNER_LIDAR`),
    ``tier = 'los'``, ``span = 5``, ``speckle = 'independent'``;
    ``cell_length`` defaults to half the box spacing (``scan.spacing``).
    """

    preset: str = "spinner"
    tier: str = "los"
    span: float = 5.0
    speckle: str = "independent"


#: [scan] keys passed to :class:`cwlidar_sim.sensors.spinner.SpinnerLidar` as they are.
SENSOR_GEOMETRY = ("focus_distance", "prism_deflection_deg", "prism_rate_hz", "prism_phase_deg",
                   "estimates_per_rosette", "sub_dwells", "tilt_deg", "n_blades", "blade_chord",
                   "blade_plane_distance", "hub_radius", "blade_azimuth0_deg", "blockage_fraction")


@dataclasses.dataclass(frozen=True)
class SpinnerScanSpec(Spec):
    """The SpinnerLidar's geometry, the rotor disc, the box and the fit.

    Parameters
    ----------
    focus_distance, prism_deflection_deg, prism_rate_hz, prism_phase_deg, estimates_per_rosette, sub_dwells
        The rosette (:class:`cwlidar_sim.sensors.spinner.SpinnerLidar`; checked there, named ``scan.<key>``).
    tilt_deg : float
        Shaft tilt [deg].
    n_blades, blade_chord, blade_plane_distance, hub_radius, blade_azimuth0_deg, blockage_fraction
        Blade blockage (``n_blades = 0``: none).
    rotor_radius : float
        Radius of the REWS's disc [m]; in (0, 200].
    rotor_exponent : float
        Per-area weight ``(r / R)^p`` of the rotor's REWS (:class:`cwlidar_sim.analysis.rews.RotorDisc`); in [0, 10].
    spacing : float
        Box spacing [m]; in (0, 50].
    lateral_doubling : bool
        Generate each box twice as wide and keep half.
    w_zero : bool
        The disc fit assumes w = 0 (:func:`cwlidar_sim.analysis.disc_fit.fit_disc`).
    """

    focus_distance: float = 80.0
    prism_deflection_deg: tuple = (15.2, 15.2)
    prism_rate_hz: tuple = (3.5, -6.5)
    prism_phase_deg: tuple = (0.0, 0.0)
    estimates_per_rosette: int = 984
    sub_dwells: int = 4
    tilt_deg: float = 0.0
    n_blades: int = 0
    blade_chord: float = 1.0
    blade_plane_distance: float = 2.0
    hub_radius: float = 0.8
    blade_azimuth0_deg: float = 0.0
    blockage_fraction: float = 0.5
    rotor_radius: float = 40.0
    rotor_exponent: float = 0.0
    spacing: float = 4.0
    lateral_doubling: bool = True
    w_zero: bool = True

    def __post_init__(self):
        for k in ("prism_deflection_deg", "prism_rate_hz", "prism_phase_deg"):
            v = getattr(self, k)
            if isinstance(v, (str, bytes)) or not hasattr(v, "__len__"):
                raise TypeError(f"scan.{k} must be a list of 2 numbers, got {v!r}")
            set_field(self, k, tuple(v))
        set_field(self, "rotor_radius", check_real("scan.rotor_radius", self.rotor_radius, lo=0.0, hi=200.0,
                                                   lo_open=True))
        set_field(self, "rotor_exponent", check_real("scan.rotor_exponent", self.rotor_exponent, lo=0.0, hi=10.0))
        set_field(self, "spacing", check_real("scan.spacing", self.spacing, lo=0.0, hi=50.0, lo_open=True))
        set_field(self, "lateral_doubling", check_bool("scan.lateral_doubling", self.lateral_doubling))
        set_field(self, "w_zero", check_bool("scan.w_zero", self.w_zero))
        set_field(self, "estimates_per_rosette", check_int("scan.estimates_per_rosette", self.estimates_per_rosette,
                                                           lo=4, hi=100_000))

    def geometry(self) -> dict:
        """The :class:`cwlidar_sim.sensors.spinner.SpinnerLidar` geometry fields."""
        return {k: getattr(self, k) for k in SENSOR_GEOMETRY}

    def as_dict(self) -> dict:
        d = super().as_dict()
        for k in ("prism_deflection_deg", "prism_rate_hz", "prism_phase_deg"):
            d[k] = list(getattr(self, k))
        return d


@dataclasses.dataclass(frozen=True)
class SpinnerTurbulenceSpec(NacelleTurbulenceSpec):
    """The ``[turbulence]`` table of a spinner scene: the nacelle scene's, at hub height
    (:class:`cwlidar_sim.campaign.scenes.nacelle.NacelleTurbulenceSpec`)."""

    _kind = "spinner"


@dataclasses.dataclass(frozen=True)
class SpinnerPeriodSpec(NacellePeriodSpec):
    """One period of a spinner scene: the nacelle scene's keys and the rotor's speed.

    Parameters
    ----------
    name, mean_speed, yaw_misalignment_deg, lifetime, seed
        As :class:`cwlidar_sim.campaign.scenes.nacelle.NacellePeriodSpec`.
    duration : float, optional
        Length [s]; default the scene's; in [4, 7200].
    rotor_rpm : float
        Rotor speed [rpm]: the spinner, the rosette and the blades turn with it; in [0, 100].
    rotor_azimuth0_deg : float
        The spinner's azimuth at t = 0 [deg].
    """

    rotor_rpm: float = 0.0
    rotor_azimuth0_deg: float = 0.0

    def __post_init__(self):
        duration, self_dur = self.duration, None
        if duration is not None:
            self_dur = check_real("duration", duration, lo=4.0, hi=7200.0)
            set_field(self, "duration", None)  # the nacelle period's own range (>= 30 s) does not apply
        super().__post_init__()
        set_field(self, "duration", self_dur)
        set_field(self, "rotor_rpm", check_real("rotor_rpm", self.rotor_rpm, lo=0.0, hi=100.0))
        set_field(self, "rotor_azimuth0_deg", check_real("rotor_azimuth0_deg", self.rotor_azimuth0_deg))


@dataclasses.dataclass(frozen=True)
class SpinnerScene(SceneSpec):
    """A SpinnerLidar campaign (module notes).

    Parameters
    ----------
    name : str
        Used for ``DIR/<name>.nc``.
    periods : tuple of SpinnerPeriodSpec
    scan : SpinnerScanSpec
    lidar : SpinnerLidarSpec
    turbulence : SpinnerTurbulenceSpec
    platform : NacellePlatformSpec or None
        The platform's prescribed motion and its correction; None: at rest.
    duration : float
        Default period length [s]; in [4, 7200].
    seed : int
    description : str
    """

    name: str
    periods: tuple
    scan: SpinnerScanSpec = dataclasses.field(default_factory=SpinnerScanSpec)
    lidar: SpinnerLidarSpec = dataclasses.field(default_factory=SpinnerLidarSpec)
    turbulence: SpinnerTurbulenceSpec = dataclasses.field(default_factory=SpinnerTurbulenceSpec)
    platform: NacellePlatformSpec | None = None
    duration: float = 600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    kind = "spinner"

    def __post_init__(self):
        check_scene_name(self.name)
        for key, cls in (("scan", SpinnerScanSpec), ("lidar", SpinnerLidarSpec), ("turbulence", SpinnerTurbulenceSpec)):
            if not isinstance(getattr(self, key), cls):
                raise TypeError(f"{key} must be a {cls.__name__}, got {type(getattr(self, key)).__name__}")
        if self.platform is not None and not isinstance(self.platform, NacellePlatformSpec):
            raise TypeError(f"platform must be a NacellePlatformSpec or None, got {type(self.platform).__name__}")
        periods = check_periods(self.periods, SpinnerPeriodSpec, "spinner scene")
        set_field(self, "periods", periods)
        set_field(self, "duration", check_real("duration", self.duration, lo=4.0, hi=7200.0))
        set_field(self, "seed", check_seed("seed", self.seed))
        check_str("description", self.description, allow_empty=True)
        self.turbulence.check_frozen(periods)
        for i, p in enumerate(periods):
            where = entry_label("period", i, p.name)
            try:
                lid = self.sensor(p)
            except (ValueError, TypeError) as e:
                raise type(e)(f"SpinnerLidar of {where}: {_scan_path(str(e))}") from None
            if self.period_duration(p) < lid.rosette_time:
                raise ValueError(f"{where} lasts {self.period_duration(p):g} s, less than one rosette of "
                                 f"{lid.rosette_time:g} s; allowed: at least one rosette")

    def period_params(self, period):
        """The :class:`cwlidar_sim.turbulence.MannParameters` of a period (its mean speed at hub height)."""
        return self.turbulence.params(None, period.mean_speed)

    def sensor(self, period):
        """The :class:`cwlidar_sim.sensors.spinner.SpinnerLidar` of a period."""
        from ...sensors.spinner import SpinnerLidar

        kw = self.lidar.sensor_kwargs(0.5 * self.scan.spacing)
        kw.update(self.scan.geometry(), instrument=self.lidar.build_instrument(),
                  yaw_misalignment_deg=period.yaw_misalignment_deg, rotor_rpm=period.rotor_rpm,
                  rotor_azimuth0_deg=period.rotor_azimuth0_deg)
        if self.platform is not None:
            kw.update(motion=self.platform.motion(self.period_duration(period), self.base_dir),
                      motion_correction=self.platform.correction)
        return SpinnerLidar(**kw)

    # -- interchange ------------------------------------------------------
    def as_dict(self) -> dict:
        d = super().as_dict()
        d.pop("base_dir", None)
        d["kind"] = "spinner"
        d["period"] = d.pop("periods")
        return d

    #: The scene file's tables and the spec class of each.
    _tables = {"scan": SpinnerScanSpec, "lidar": SpinnerLidarSpec, "turbulence": SpinnerTurbulenceSpec,
               "platform": NacellePlatformSpec}
    _period_spec = SpinnerPeriodSpec
    _what = "spinner scene"

    @classmethod
    def schema(cls) -> dict:
        """TOML path of each table of the scene file -> its keys (:func:`cwlidar_sim.campaign.scenes.spec.check_scene_keys`)."""
        out = {"": Table(("name", "kind", "description", "seed", "duration", "period", *cls._tables)),
               "scan": spec_table(SpinnerScanSpec)}
        out.update(lidar_schema(cls._tables["lidar"]))
        out.update(turbulence_schema(cls._tables["turbulence"]))
        out.update({"platform": spec_table(NacellePlatformSpec), "platform.phase_deg": Table(PLATFORM_DOFS),
                    "period[]": spec_table(SpinnerPeriodSpec)})
        return out


def _scan_path(message: str) -> str:
    """The sensor's message with its geometry keys named as the scene file names them (``scan.<key>``)."""
    for k in sorted(SENSOR_GEOMETRY, key=len, reverse=True):
        if message.startswith(k) and not message.startswith("scan."):
            return "scan." + message
    return message
