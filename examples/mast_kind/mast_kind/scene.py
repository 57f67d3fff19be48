"""The mast scene: ``[mast]`` (heights, grid, sonic noise, cup), ``[turbulence]`` (a Mann tensor), ``[[period]]``."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from cwlidar_sim.campaign.scenes.spec import (SceneSpec, Spec, Table, check_periods, check_scene_keys, check_scene_name,
                                       periods_from_dict, spec_table, table_from_dict)


def _real(name, value, lo, hi):
    """``value`` as a float in [lo, hi], else a ValueError naming the TOML key, the value and the range."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise TypeError(f"{name} must be a number, got {value!r}")
    if not lo <= value <= hi:
        raise ValueError(f"{name}={value!r} is out of range; allowed: [{lo:g}, {hi:g}]")
    return float(value)


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


@dataclasses.dataclass(frozen=True)
class MastSpec(Spec):
    """The mast: a sonic and a cup at every height.

    Parameters
    ----------
    heights : tuple of float
        Measurement heights [m]; 1 to 10 distinct values in [2, 200].
    spacing : float
        Grid spacing of the Mann box [m]; in [0.5, 20].
    sonic_rate : float
        Sonic sampling rate [Hz]; in [1, 100].
    sonic_noise_std : float
        Sonic noise per component and sample [m/s]; in [0, 1].
    cup_distance_constant : float
        The cups' distance constant [m]; in [0.1, 20].
    """

    heights: tuple = (10.0, 30.0, 60.0)
    spacing: float = 2.0
    sonic_rate: float = 20.0
    sonic_noise_std: float = 0.0
    cup_distance_constant: float = 2.3

    def __post_init__(self):
        h = tuple(_real(f"mast.heights[{i}]", z, 2.0, 200.0) for i, z in enumerate(self.heights))
        if not 1 <= len(h) <= 10 or len(set(h)) != len(h):
            raise ValueError(f"mast.heights needs 1 to 10 distinct heights, got {list(self.heights)}")
        _set(self, "heights", h)
        _set(self, "spacing", _real("mast.spacing", self.spacing, 0.5, 20.0))
        _set(self, "sonic_rate", _real("mast.sonic_rate", self.sonic_rate, 1.0, 100.0))
        _set(self, "sonic_noise_std", _real("mast.sonic_noise_std", self.sonic_noise_std, 0.0, 1.0))
        _set(self, "cup_distance_constant", _real("mast.cup_distance_constant", self.cup_distance_constant, 0.1, 20.0))


@dataclasses.dataclass(frozen=True)
class MastTurbulenceSpec(Spec):
    """The Mann tensor of every period's box: ``alpha_eps`` [m^(4/3) s^-2], ``length_scale`` [m], ``gamma`` [-]."""

    alpha_eps: float = 0.05
    length_scale: float = 20.0
    gamma: float = 3.2

    def __post_init__(self):
        _set(self, "alpha_eps", _real("turbulence.alpha_eps", self.alpha_eps, 1e-6, 10.0))
        _set(self, "length_scale", _real("turbulence.length_scale", self.length_scale, 1.0, 500.0))
        _set(self, "gamma", _real("turbulence.gamma", self.gamma, 0.0, 10.0))


@dataclasses.dataclass(frozen=True)
class MastPeriodSpec(Spec):
    """One period: ``name``, ``mean_speed`` [m/s] in [1, 30], optional ``seed``."""

    name: str
    mean_speed: float
    seed: int | None = None

    _required = ("name", "mean_speed")

    def __post_init__(self):
        check_scene_name(self.name)
        _set(self, "mean_speed", _real("mean_speed", self.mean_speed, 1.0, 30.0))


@dataclasses.dataclass(frozen=True)
class MastScene(SceneSpec):
    """A mast scene (``kind = "mast"``): one unit of work per period, seeded from the scene.

    Parameters
    ----------
    name : str
    periods : tuple of MastPeriodSpec
    mast : MastSpec
    turbulence : MastTurbulenceSpec
    duration : float
        Length of every period [s]; in [10, 3600].
    seed : int
    description : str
    base_dir : str
        Not stored.
    """

    name: str
    periods: tuple
    mast: MastSpec = dataclasses.field(default_factory=MastSpec)
    turbulence: MastTurbulenceSpec = dataclasses.field(default_factory=MastTurbulenceSpec)
    duration: float = 600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    kind = "mast"
    _tables = {"mast": MastSpec, "turbulence": MastTurbulenceSpec}
    _what = "mast scene"

    def __post_init__(self):
        check_scene_name(self.name)
        _set(self, "periods", check_periods(self.periods, MastPeriodSpec, "mast scene"))
        _set(self, "duration", _real("duration", self.duration, 10.0, 3600.0))

    # -- the members every scene kind's scene provides (cwlidar_sim.campaign.registry.SCENE_MEMBERS) --
    def unit_names(self) -> list:
        return [p.name for p in self.periods]

    def unit_seed(self, index: int) -> int:
        p = self.periods[index]
        if p.seed is not None:
            return p.seed
        child = np.random.SeedSequence(self.seed, spawn_key=(index,))
        return int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))

    def simulated_hours(self) -> float:
        return len(self.periods) * self.duration / 3600.0

    def replace(self, **changes) -> "MastScene":
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict:
        d = super().as_dict()
        d.pop("base_dir", None)
        d["kind"] = "mast"
        d["period"] = d.pop("periods")
        return d

    @classmethod
    def schema(cls) -> dict:
        return {"": Table(("name", "kind", "description", "seed", "duration", "period", *cls._tables)),
                **{key: spec_table(spec) for key, spec in cls._tables.items()}, "period[]": spec_table(MastPeriodSpec)}

    @classmethod
    def from_dict(cls, d: dict, *, base_dir: str = ".") -> "MastScene":
        check_scene_keys(d, cls.schema(), ("name", "period"), cls._what)
        kw = {k: d[k] for k in ("name", "description", "seed", "duration") if k in d}
        for key, spec in cls._tables.items():
            if key in d:
                kw[key] = table_from_dict(spec, d[key], key)
        kw["periods"] = periods_from_dict(d["period"], MastPeriodSpec)
        return cls(base_dir=base_dir, **kw)
