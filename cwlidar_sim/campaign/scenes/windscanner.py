"""WindScanner scene files: three cw lidars with one common focus, the turbulence, the periods (``kind = "windscanner"``).

A WindScanner scene asks how well three line-of-sight speeds measured at
one point give the wind vector there, component by component, against a
sonic at that point.  How it is run is
:mod:`cwlidar_sim.campaign.periods.windscanner`; one unit of work per
period.

Example
-------
.. code-block:: toml

    name = "windscanner"
    kind = "windscanner"
    seed = 31
    duration = 600.0

    [scanner]                       # cwlidar_sim.sensors.windscanner.WindScanner
    azimuths_deg = [186.0, 56.0, 335.0]     # the beams (from +x, the mean wind, toward +y)
    elevations_deg = [56.5, 51.7, 56.4]
    unit_height = 11.0              # every unit's height [m]
    target = [0.0, 0.0, 113.067]    # the common focus [m]: a mean range of 125 m
    pattern = "point"               # or "lissajous" (lissajous_ratio, amplitude, points_per_pattern)
    spacing = 4.0                   # the box [m]
    segment_duration = 60.0         # the transfer functions' segments [s]

    [lidar]                         # the keys of every scene's [lidar]; defaults: the WindScanner preset
    tier = "los"

    [turbulence]
    alpha_eps = 0.05
    length_scale = 33.6
    gamma = 3.9

    [[period]]
    name = "moderate"
    mean_speed = 8.0
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..._validation import check_int, check_real, check_seed, check_str, check_tuple
from .lidar_spec import LidarSpecBase, lidar_schema
from .spec import SceneSpec, Spec, Table, check_periods, check_scene_name, entry_label, set_field, spec_table, \
    turbulence_schema
from .turbulence_spec import TurbulenceSpec

__all__ = ["WindScannerSpec", "WindScannerLidarSpec", "WindScannerTurbulenceSpec", "WindScannerPeriodSpec",
           "WindScannerScene"]

#: [scanner] keys passed to :class:`cwlidar_sim.sensors.windscanner.WindScanner` as they are.
SENSOR_GEOMETRY = ("pattern", "lissajous_ratio", "amplitude", "points_per_pattern", "lissajous_phase_deg",
                   "pattern_plane", "time_offsets", "min_elevation_deg")


@dataclasses.dataclass(frozen=True)
class WindScannerLidarSpec(LidarSpecBase):
    """The ``[lidar]`` table of a WindScanner scene: every scene's keys, the WindScanner's defaults.

    Defaults: ``preset = 'windscanner'``
    (:data:`cwlidar_sim.signal.instrument.WINDSCANNER`), ``tier = 'los'``,
    ``span = 5``, ``speckle = 'independent'``; ``cell_length`` defaults to
    the box spacing (``scanner.spacing``).
    """

    preset: str = "windscanner"
    tier: str = "los"
    span: float = 5.0
    speckle: str = "independent"


@dataclasses.dataclass(frozen=True)
class WindScannerTurbulenceSpec(TurbulenceSpec):
    """The ``[turbulence]`` table of a WindScanner scene: every scene's keys.

    A table picking no way is ``alpha_eps = 0.05``, ``length_scale = 33.6``,
    ``gamma = 3.9``; no ``fit_to`` or ``condition_on``.
    """

    _kind = "windscanner"
    _default = {"alpha_eps": 0.05, "length_scale": 33.6, "gamma": 3.9}
    _takes_fit_to = False
    _takes_condition_on = False


def _triple(name, value, check):
    return check_tuple(name, value, 3, check)


@dataclasses.dataclass(frozen=True)
class WindScannerSpec(Spec):
    """The ``[scanner]`` table: the three units, the common focus, the box and the transfer functions' settings.

    Parameters
    ----------
    azimuths_deg, elevations_deg : tuple of 3 floats
        The beams' azimuths (from +x, the mean wind, toward +y) and
        elevations [deg] from the units to ``target``; the units stand at
        ``unit_height`` (:func:`cwlidar_sim.sensors.windscanner.layout_from_angles`).
    unit_height : float
        Height of every unit [m]; below the target.
    positions : tuple of 3 tuples of 3 floats
        The units' positions [m] instead of the angles; empty (default): from the angles.
    target : tuple of 3 floats
        The common focus, or the pattern's centre [m]; the sonic stands there.
    pattern, lissajous_ratio, amplitude, points_per_pattern, lissajous_phase_deg, pattern_plane, time_offsets, min_elevation_deg
        The focus trajectory and the units' clocks (:class:`cwlidar_sim.sensors.windscanner.WindScanner`).
    spacing : float
        Box spacing [m]; in (0, 50].
    max_condition : float
        Steps whose beams' condition number exceeds it are flagged (NaN); in [1, 1e6].
    segment_duration : float
        Segment length of the spectra [s]; in [5, 3600], at most a third of each period.
    k_min, k_max : float
        Wavenumber range of the transfer functions [rad/m], 0 < k_min < k_max <= 10.
    n_k : int
        Log-spaced wavenumber bins; in [4, 200].
    """

    azimuths_deg: tuple = (186.0, 56.0, 335.0)
    elevations_deg: tuple = (56.5, 51.7, 56.4)
    unit_height: float = 11.0
    positions: tuple = ()
    target: tuple = (0.0, 0.0, 113.067)
    pattern: str = "point"
    lissajous_ratio: tuple = (3, 2)
    amplitude: float = 10.0
    points_per_pattern: int = 512
    lissajous_phase_deg: float = 90.0
    pattern_plane: str = "yz"
    time_offsets: tuple = (0.0, 0.0, 0.0)
    min_elevation_deg: float = 0.0
    spacing: float = 4.0
    max_condition: float = 10.0
    segment_duration: float = 60.0
    k_min: float = 0.005
    k_max: float = 1.0
    n_k: int = 20

    def __post_init__(self):
        set_field(self, "azimuths_deg", _triple("scanner.azimuths_deg", self.azimuths_deg, check_real))
        set_field(self, "elevations_deg", _triple("scanner.elevations_deg", self.elevations_deg,
                                                  lambda n, v: check_real(n, v, lo=0.0, hi=90.0, lo_open=True)))
        set_field(self, "unit_height", check_real("scanner.unit_height", self.unit_height, lo=-1000.0, hi=10000.0))
        set_field(self, "target", _triple("scanner.target", self.target, check_real))
        if tuple(self.positions):
            set_field(self, "positions", _triple("scanner.positions", self.positions,
                                                 lambda n, v: _triple(n, v, check_real)))
        else:
            set_field(self, "positions", ())
            if self.unit_height >= self.target[2]:
                raise ValueError(f"scanner.unit_height={self.unit_height!r} m is not below the target's height "
                                 f"{self.target[2]!r} m: the beams cannot rise to it; allowed: < {self.target[2]!r}")
        set_field(self, "lissajous_ratio", tuple(self.lissajous_ratio))
        set_field(self, "time_offsets", tuple(self.time_offsets))
        set_field(self, "spacing", check_real("scanner.spacing", self.spacing, lo=0.0, hi=50.0, lo_open=True))
        set_field(self, "max_condition", check_real("scanner.max_condition", self.max_condition, lo=1.0, hi=1e6))
        set_field(self, "segment_duration", check_real("scanner.segment_duration", self.segment_duration, lo=5.0,
                                                       hi=3600.0))
        set_field(self, "k_max", check_real("scanner.k_max", self.k_max, lo=0.0, hi=10.0, lo_open=True))
        set_field(self, "k_min", check_real("scanner.k_min", self.k_min, lo=0.0, hi=self.k_max, lo_open=True,
                                            hi_open=True))
        set_field(self, "n_k", check_int("scanner.n_k", self.n_k, lo=4, hi=200))

    def unit_positions(self) -> tuple:
        """The units' positions [m]: given, or from the angles."""
        from ...sensors.windscanner import layout_from_angles

        if self.positions:
            return self.positions
        return layout_from_angles(self.target, self.azimuths_deg, self.elevations_deg, self.unit_height)

    def k_edges(self) -> np.ndarray:
        """Edges of the wavenumber bins [rad/m]."""
        return np.geomspace(self.k_min, self.k_max, self.n_k + 1)

    def as_dict(self) -> dict:
        d = super().as_dict()
        for k in ("azimuths_deg", "elevations_deg", "target", "lissajous_ratio", "time_offsets"):
            d[k] = list(getattr(self, k))
        d["positions"] = [list(p) for p in self.positions]
        return d


@dataclasses.dataclass(frozen=True)
class WindScannerPeriodSpec(Spec):
    """One period: ``name``, ``mean_speed`` [m/s] in [1, 40], optional ``duration`` [s] in [10, 7200] and ``seed``."""

    name: str
    mean_speed: float
    duration: float | None = None
    seed: int | None = None

    _required = ("name", "mean_speed")

    def __post_init__(self):
        check_str("name", self.name)
        set_field(self, "mean_speed", check_real("mean_speed", self.mean_speed, lo=1.0, hi=40.0))
        if self.duration is not None:
            set_field(self, "duration", check_real("duration", self.duration, lo=10.0, hi=7200.0))
        if self.seed is not None:
            set_field(self, "seed", check_seed("seed", self.seed))


@dataclasses.dataclass(frozen=True)
class WindScannerScene(SceneSpec):
    """A WindScanner campaign (module notes).

    Parameters
    ----------
    name : str
    periods : tuple of WindScannerPeriodSpec
    scanner : WindScannerSpec
    lidar : WindScannerLidarSpec
    turbulence : WindScannerTurbulenceSpec
    duration : float
        Default period length [s]; in [10, 7200].
    seed : int
    description : str
    """

    name: str
    periods: tuple
    scanner: WindScannerSpec = dataclasses.field(default_factory=WindScannerSpec)
    lidar: WindScannerLidarSpec = dataclasses.field(default_factory=WindScannerLidarSpec)
    turbulence: WindScannerTurbulenceSpec = dataclasses.field(default_factory=WindScannerTurbulenceSpec)
    duration: float = 600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    kind = "windscanner"
    _tables = {"scanner": WindScannerSpec, "lidar": WindScannerLidarSpec, "turbulence": WindScannerTurbulenceSpec}
    _period_spec = WindScannerPeriodSpec
    _what = "windscanner scene"

    def __post_init__(self):
        check_scene_name(self.name)
        for key, cls in self._tables.items():
            if not isinstance(getattr(self, key), cls):
                raise TypeError(f"{key} must be a {cls.__name__}, got {type(getattr(self, key)).__name__}")
        periods = check_periods(self.periods, WindScannerPeriodSpec, "windscanner scene")
        set_field(self, "periods", periods)
        set_field(self, "duration", check_real("duration", self.duration, lo=10.0, hi=7200.0))
        set_field(self, "seed", check_seed("seed", self.seed))
        check_str("description", self.description, allow_empty=True)
        self.turbulence.check_frozen(periods)
        try:
            self.sensor()
        except (ValueError, TypeError) as e:
            raise type(e)(f"windscanner scene: scanner: {e}") from None
        for i, p in enumerate(periods):
            dur = self.period_duration(p)
            if dur < 3.0 * self.scanner.segment_duration:
                raise ValueError(f"{entry_label('period', i, p.name)} lasts {dur:g} s, shorter than 3 segments of "
                                 f"scanner.segment_duration = {self.scanner.segment_duration:g} s; allowed: longer "
                                 f"periods or shorter segments")

    def sensor(self):
        """The :class:`cwlidar_sim.sensors.windscanner.WindScanner` of the scene."""
        from ...sensors.windscanner import WindScanner

        s = self.scanner
        kw = self.lidar.sensor_kwargs(s.spacing)
        kw.update({k: getattr(s, k) for k in SENSOR_GEOMETRY}, instrument=self.lidar.build_instrument(),
                  positions=s.unit_positions(), target=s.target)
        return WindScanner(**kw)

    def period_params(self, period):
        """The :class:`cwlidar_sim.turbulence.MannParameters` of a period."""
        return self.turbulence.params(None, period.mean_speed)

    # -- interchange ------------------------------------------------------
    def as_dict(self) -> dict:
        d = super().as_dict()
        d.pop("base_dir", None)
        d["kind"] = "windscanner"
        d["period"] = d.pop("periods")
        return d

    @classmethod
    def schema(cls) -> dict:
        """TOML path of each table of the scene file -> its keys."""
        out = {"": Table(("name", "kind", "description", "seed", "duration", "period", *cls._tables)),
               "scanner": spec_table(WindScannerSpec)}
        out.update(lidar_schema(cls._tables["lidar"]))
        out.update(turbulence_schema(cls._tables["turbulence"]))
        out["period[]"] = spec_table(WindScannerPeriodSpec)
        return out
