"""Scene files: a virtual measurement campaign described in TOML.

A scene is a tree of frozen, validated dataclasses.  Every table of the TOML
file maps onto one of them; unknown keys are rejected by name, values out of
range are rejected with the field, the value and the allowed range, and
:meth:`Scene.as_dict` / ``Scene.from_dict`` round-trip.

Geometry (A2012's set-up)
-------------------------
The field's frame has x along the mean wind (Taylor advection at the period's
mean speed U along +x), y lateral and z up.  The lidar stares *upwind*: its
beam points along ``-x`` rotated by the period's misalignment angle theta about
z (and tilted by ``lidar.elevation_deg``), so the mean radial speed toward
the lidar is ``U cos(theta)``.  The sonic sits at the focus, shifted by
``sonic.offset``.  Both sensors report the speed *toward the lidar*
(positive for a lidar looking into the wind): the lidar's homodyne
``|v|`` and the sonic's ``-n . u``.

Example
-------
.. code-block:: toml

    name = "a2012"
    seed = 2012
    duration = 3600.0             # s, per period

    [turbulence]                  # or: ti = 0.1 with height = 33.5, ... (turbulence_spec)
    alpha_eps = 0.05
    length_scale = 20.0
    gamma = 3.2

    [lidar]
    preset = "prototype"
    tier = "spectral"
    cnr_db = 10.0
    instrument = { focus = 67.5 }
    variants = [{ name = "raise10", threshold_raise_percent = 10.0 }]

    [sonic]
    noise_std = 0.02

    [[period]]
    name = "C"
    mean_speed = 8.0
    misalignment_deg = 1.2
"""

from __future__ import annotations

import dataclasses

from ..._validation import check_bool, check_choice, check_int, check_real, check_seed, check_str, check_vec3
from ...signal.chain import TIERS
from .lidar_spec import LidarSpecBase, lidar_schema
from ..registry import kind_names
from .spec import (SceneSpec, Spec, Table, check_periods, check_scene_name, entry_label, resolve_path, set_field,
                   spec_table, turbulence_schema)
from .turbulence_spec import TurbulenceSpec

__all__ = [
    "FIELD_KINDS",
    "TurbulenceSpec",
    "LidarSpec",
    "SonicSpec",
    "FieldSpec",
    "AnalysisSpec",
    "PeriodSpec",
    "Scene",
]

FIELD_KINDS = ("auto", "line", "plane", "box")
#: The staring lidar's output rate [Hz] (A2012's 50 Hz; :mod:`cwlidar_sim.campaign.periods.staring` runs on it).
STARING_RATE = 50.0
_set = set_field


@dataclasses.dataclass(frozen=True)
class LidarSpec(LidarSpecBase):
    """The staring lidar: the ``[lidar]`` keys of every scene kind and the beam's elevation.

    Every key of :class:`cwlidar_sim.campaign.scenes.lidar_spec.LidarSpecBase` (the
    instrument, the signal chain, the probe volume and its tail, a cloud,
    processing variants), with ``tier`` also ``'auto'`` (the cheapest tier
    sufficient for what the scene asks, :mod:`cwlidar_sim.campaign.periods.staring_auto`) and
    ``cell_length`` also ``'auto'``; ``cell_length`` None is the field's x
    spacing; ``transverse_speed`` None is ``sqrt(sigma_v^2 + sigma_w^2 + (U sin theta)^2)``
    from the turbulence and the period's misalignment.

    Parameters
    ----------
    elevation_deg : float
        Beam elevation [deg]; in [-89, 89].  Non-zero needs a box field.
    """

    elevation_deg: float = 0.0

    _tiers = TIERS + ("auto",)

    def __post_init__(self):
        super().__post_init__()
        _set(self, "elevation_deg", check_real("lidar.elevation_deg", self.elevation_deg, lo=-89.0, hi=89.0))
        rate = self.build_instrument().estimate_rate
        if rate != STARING_RATE:  # the runner's 50 Hz clock (staring.run_unit): another rate would be mislabelled
            raise ValueError(f"lidar.instrument.estimate_rate={rate:g} Hz: a staring scene samples the lidar at "
                             f"A2012's {STARING_RATE:g} Hz, block-averaged by 5 to the sonic's 10 Hz; allowed: "
                             f"{STARING_RATE:g}")


@dataclasses.dataclass(frozen=True)
class SonicSpec(Spec):
    """The sonic anemometer.

    Parameters
    ----------
    rate : float
        Sampling rate [Hz]; 32 (A2012's Metek USA-1; the 10 Hz resampling of
        A2012 Eqs. 5-7 is defined for 32 Hz only).
    noise_std : float
        White noise on each component [m/s]; in [0, 10].
    offset : (float, float, float)
        Position relative to the lidar's focus [m].
    """

    rate: float = 32.0
    noise_std: float = 0.0
    offset: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        _set(self, "rate", check_real("sonic.rate", self.rate, lo=32.0, hi=32.0))
        _set(self, "noise_std", check_real("sonic.noise_std", self.noise_std, lo=0.0, hi=10.0))
        _set(self, "offset", check_vec3("sonic.offset", self.offset))


@dataclasses.dataclass(frozen=True)
class FieldSpec(Spec):
    """Which turbulence field to generate and its resolution.

    Parameters
    ----------
    kind : {'auto', 'line', 'plane', 'box'}
        'auto' picks the cheapest field the sensors need (see
        :func:`cwlidar_sim.campaign.periods.staring_field.choose_field`); the others force it
        (a forced field that cannot hold the sensors is an error).
    dx : float or 'auto'
        Spacing along the wind [m]; in [0.05, 10]; 'auto': see
        :mod:`cwlidar_sim.campaign.periods.staring_auto`.
    dy, dz : float
        Lateral and vertical spacing of planes and boxes [m]; in [0.1, 50].
        A beam misaligned by theta averages across the wind too: at k1 it
        feels lateral wavenumbers up to about ``k1 / tan(theta)``, so the
        field holds the misaligned transfer function (A2012 Eqs. 12-14) only
        for ``k1 < (pi / dy) tan(theta)`` (0.55 rad/m at 5 deg for 0.5 m).
    ny, nz : int, optional
        Points across; default: a power of two covering the sensors plus
        four length scales (at least 32).
    """

    kind: str = "auto"
    dx: float = 0.5
    dy: float = 0.5
    dz: float = 2.0
    ny: int | None = None
    nz: int | None = None

    def __post_init__(self):
        check_choice("field.kind", self.kind, FIELD_KINDS)
        if self.dx != "auto":
            _set(self, "dx", check_real("field.dx", self.dx, lo=0.05, hi=10.0))
        _set(self, "dy", check_real("field.dy", self.dy, lo=0.1, hi=50.0))
        _set(self, "dz", check_real("field.dz", self.dz, lo=0.1, hi=50.0))
        if self.ny is not None:
            _set(self, "ny", check_int("field.ny", self.ny, lo=2, hi=4096))
        if self.nz is not None:
            _set(self, "nz", check_int("field.nz", self.nz, lo=2, hi=4096))


@dataclasses.dataclass(frozen=True)
class AnalysisSpec(Spec):
    """Spectral analysis settings (A2012 section V).

    Parameters
    ----------
    segment_duration : float
        Length of the segments whose periodograms are averaged [s]; in [10, 86400].
    k_min, k_max : float
        Wavenumber band of the log-smoothed spectra [rad/m]; 0 < k_min < k_max.
    per_decade : int
        Log-spaced bins per decade; in [2, 100].
    fit : bool
        Fit the Mann parameters to each period's sonic spectra (needed for the
        misaligned theory of A2012 Eqs. 12-14; without a fit the scene's own
        parameters are used).
    window : {'hann', 'none'}
        Taper of each segment.  A2012 used none; but then the leakage of the
        strong low-k power of both series swamps the lidar's spectrum where
        it is 1e-3 of the sonic's (method 1 comes out 30 times too high at
        0.7 rad/m for a noise-free lidar), so the default is Hann.
    detrend : {'mean', 'linear'}
        What is removed from each segment.
    estimator_theory_lines : int
        Size of the estimator-aware theory's own ensemble (lines of 4096
        points, :func:`cwlidar_sim.analysis.estimator_transfer`), computed
        once per scene for tiers 'spectral' and 'signal' and stored as
        ``transfer_theory_estimator``; in [0, 1000], 0: not computed.  Cost
        about 1.5 s per line on one core.
    """

    segment_duration: float = 600.0
    k_min: float = 1e-3
    k_max: float = 5.0
    per_decade: int = 10
    fit: bool = True
    window: str = "hann"
    detrend: str = "mean"
    estimator_theory_lines: int = 4

    def __post_init__(self):
        _set(self, "segment_duration", check_real("analysis.segment_duration", self.segment_duration, lo=10.0, hi=86400.0))
        _set(self, "k_min", check_real("analysis.k_min", self.k_min, lo=0.0, hi=100.0, lo_open=True))
        _set(self, "k_max", check_real("analysis.k_max", self.k_max, lo=self.k_min, hi=1000.0, lo_open=True))
        _set(self, "per_decade", check_int("analysis.per_decade", self.per_decade, lo=2, hi=100))
        _set(self, "fit", check_bool("analysis.fit", self.fit))
        check_choice("analysis.window", self.window, ("hann", "none"))
        check_choice("analysis.detrend", self.detrend, ("mean", "linear"))
        _set(self, "estimator_theory_lines",
             check_int("analysis.estimator_theory_lines", self.estimator_theory_lines, lo=0, hi=1000))


@dataclasses.dataclass(frozen=True)
class PeriodSpec(Spec):
    """One averaging period (A2012: four 1-h periods A-D).

    Parameters
    ----------
    name : str
    mean_speed : float
        Mean wind speed U [m/s]; in [1, 30] (Taylor's hypothesis needs a
        mean flow well above the fluctuations).
    misalignment_deg : float
        Mean wind direction relative to the beam [deg]; in [-45, 45].
    duration : float, optional
        Length [s]; default the scene's ``duration``.
    start : float
        Start time within the 3-h background cycle [s]; >= 0.
    seed : int, optional
        Seed of this period's field and noise; default derived from the
        scene seed and the period's index.
    """

    name: str
    mean_speed: float
    misalignment_deg: float = 0.0
    duration: float | None = None
    start: float = 0.0
    seed: int | None = None

    _required = ("name", "mean_speed")

    def __post_init__(self):
        # bare key names: the scene names the entry, period[0] ('A') (spec.periods_from_dict)
        check_str("name", self.name)
        _set(self, "mean_speed", check_real("mean_speed", self.mean_speed, lo=1.0, hi=30.0))
        _set(self, "misalignment_deg", check_real("misalignment_deg", self.misalignment_deg, lo=-45.0, hi=45.0))
        if self.duration is not None:
            _set(self, "duration", check_real("duration", self.duration, lo=10.0, hi=86400.0))
        _set(self, "start", check_real("start", self.start, lo=0.0, hi=1e7))
        if self.seed is not None:
            _set(self, "seed", check_seed("seed", self.seed))


_TABLES = {
    "turbulence": TurbulenceSpec,
    "lidar": LidarSpec,
    "sonic": SonicSpec,
    "field": FieldSpec,
    "analysis": AnalysisSpec,
}


@dataclasses.dataclass(frozen=True)
class Scene(SceneSpec):
    """A virtual campaign: turbulence, instruments, field, analysis and periods.

    A copy with keys changed: :meth:`~cwlidar_sim.campaign.scenes.spec.SceneSpec.with_values`
    (dotted keys of the file, ``{"lidar.cnr_db": -15.0}``) or :meth:`replace` (fields).

    Parameters
    ----------
    name : str
        Used for the results file ``DIR/<name>.nc``; letters, digits, '-', '_'.
    turbulence : TurbulenceSpec
        The ``[turbulence]`` table (:mod:`cwlidar_sim.campaign.scenes.turbulence_spec`).
    periods : tuple of PeriodSpec
        At least one; names unique.
    lidar, sonic, field, analysis : specs
        Defaults when the table is absent.
    duration : float
        Default period length [s]; in [10, 86400].
    seed : int
        Master seed; each period draws from its own child seed.
    description : str
    base_dir : str
        Folder that relative paths (``turbulence.fit_to``) are taken from;
        not stored in :meth:`as_dict`.
    """

    name: str
    turbulence: TurbulenceSpec
    periods: tuple
    lidar: LidarSpec = dataclasses.field(default_factory=LidarSpec)
    sonic: SonicSpec = dataclasses.field(default_factory=SonicSpec)
    field: FieldSpec = dataclasses.field(default_factory=FieldSpec)
    analysis: AnalysisSpec = dataclasses.field(default_factory=AnalysisSpec)
    duration: float = 3600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    _tables = _TABLES
    _period_spec = PeriodSpec
    _required = ("name", "turbulence", "period")

    def __post_init__(self):
        check_scene_name(self.name)
        for key, cls in _TABLES.items():
            if not isinstance(getattr(self, key), cls):
                raise TypeError(f"{key} must be a {cls.__name__}")
        periods = check_periods(self.periods, PeriodSpec, "scene")
        _set(self, "periods", periods)
        _set(self, "duration", check_real("duration", self.duration, lo=10.0, hi=86400.0))
        _set(self, "seed", check_seed("seed", self.seed))
        check_str("description", self.description, allow_empty=True)
        self.turbulence.check_frozen(periods)  # fit_to: checked when the fit is known (staring.run_unit)
        for i, p in enumerate(periods):
            where = entry_label("period", i, p.name)
            dur = self.period_duration(p)
            if dur < self.analysis.segment_duration:
                raise ValueError(f"{where} lasts {dur} s, shorter than analysis.segment_duration = "
                                 f"{self.analysis.segment_duration} s")

    #: The sensor layout (the runner's dispatch key; a conical scene's is 'conical').
    kind = "staring"

    def as_dict(self) -> dict:
        """Plain dict (TOML-shaped; round-trips through ``from_dict``)."""
        d = super().as_dict()
        d.pop("base_dir", None)
        d["period"] = d.pop("periods")
        return d

    @classmethod
    def schema(cls) -> dict:
        """TOML path of each table of the scene file -> its keys (:func:`cwlidar_sim.campaign.scenes.spec.check_scene_keys`)."""
        out = {"": Table(("name", "kind", "description", "seed", "duration", "period", *_TABLES))}
        out.update(turbulence_schema(_TABLES["turbulence"]))
        out.update(lidar_schema(_TABLES["lidar"]))
        out.update({key: spec_table(spec) for key, spec in _TABLES.items() if key not in ("turbulence", "lidar")})
        out["period[]"] = spec_table(PeriodSpec)
        return out

    @classmethod
    def _check_kind(cls, d: dict) -> None:
        if d.get("kind", "staring") != "staring":
            raise ValueError(f"kind = {d['kind']!r} is not a staring scene (load_scene reads every kind: "
                             f"{', '.join(kind_names())})")

    def resolve(self, path: str) -> str:
        """A path of the scene file, relative to the scene's folder."""
        return resolve_path(self.base_dir, path)

