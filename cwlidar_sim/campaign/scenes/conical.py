"""Conical scene files: the scan, the turbulence with height, the periods (``kind = "conical"``).

A conical scene describes CS's experiment: a conically scanning ZephIR, a
cup and a sonic on its axis, at one or several heights, over several
periods.  How the scene is run is :mod:`cwlidar_sim.campaign.periods.conical`.

Units of work
-------------
* Dwell (default, ``scan.cycle = false``): the lidar stays at one height for
  the whole period; one unit is (period, height), each with its own Mann box
  sized for that height's cone.
* Cycle (``scan.cycle = true``): the lidar cycles through the heights,
  ``scan.revs_per_height`` revolutions at each in turn, losing
  ``scan.refocus_time`` between heights (the scanner keeps turning);
  one unit is a period, with ONE box holding every height's cone.  Each
  height gets its share of the record; the cup and the sonic at each height
  record continuously (the sonic is read at that height's estimate times).
  A VAD scan may not span a refocus, so every ``scan.scan_revs`` must divide
  ``revs_per_height``.

Periods per height
------------------
By default every ``[[period]]`` is run at every height.  With
``scan.periods_per_height = [n_1, ..., n_k]`` (one count per height, dwell
mode only) height ``i`` runs ``n_i`` periods that cycle through the
``[[period]]`` tables as templates: its j-th period is template
``j mod T`` (T templates), named ``<template>`` on the first pass and
``<template>_<c>`` on pass ``c >= 1``.  A height's standard errors shrink as
``1 / sqrt(n_i)``, so the heights whose periods scatter most get the most
(the bundled ``cs`` scene).  The units run in the order (j, height), so
where every height runs at least T periods the plan's first T x (heights)
units are the plain scene's, names, seeds and bits; every unit has its own seed (a template with its
own ``seed`` spawns one stream per height and pass).

Wind direction
--------------
The lidar's frame is east-north-up: x (the scan's azimuth 0) east, y
(azimuth 90 deg) north, z up.  A period gives its mean wind's direction one
of two ways, any finite value:

* ``wind_from_deg``: meteorological, where the wind comes *from*, clockwise
  from north (270: a westerly, blowing along +x);
* ``wind_direction_deg``: where the wind blows *toward*, from the lidar's
  azimuth 0 (+x) toward +y (counter-clockwise seen from above, the scan's
  azimuth convention); ``toward = (270 - from) mod 360``.

The field's x axis always lies along the mean wind (Taylor advection); the
scan is turned instead, so the lidar's azimuth 0 lies at ``-toward`` in the
field.  The results give the VAD's and the sonic's directions both ways
(``*_direction``: toward, ``*_wind_from``: meteorological; the attribute
``wind_direction_convention``).

Example
-------
.. code-block:: toml

    name = "cs"
    kind = "conical"
    seed = 35
    duration = 600.0

    [scan]
    heights = [40.0, 60.0, 80.0, 100.0]
    scan_revs = [1, 3]
    sub_dwells = 8                 # the cone and the sweep: half_angle_deg, revolution_time, ...

    [lidar]                        # the keys of every scene's [lidar]; defaults: the CS series instrument
    tier = "spectral"
    cnr_db = -10.0

    [turbulence]                   # the keys of every scene's [turbulence] (turbulence_spec); the default:
    source = "mann1994"            # neutral surface layer at each height (Mann 1994's Kaimal fit); or
                                   # obukhov_length = -200.0 (unstable); or ti = 0.1 / iec_class = "B"
                                   # at each height; or alpha_eps, length_scale, gamma everywhere

    [[period]]
    name = "p0"
    mean_speed = 10.0
    wind_direction_deg = 225.0
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..._seeding import seed_int
from ..._validation import check_bool, check_choice, check_int, check_real, check_seed, check_str
from .._labels import wind_from_toward
from .lidar_spec import ConicalLidarSpec, lidar_schema
from .turbulence_spec import TurbulenceSpec
from .spec import (SceneSpec, Spec, Table, check_distinct_reals, check_periods, check_scene_name, entry_label,
                   resolve_path, set_field, spec_table, turbulence_schema)

__all__ = ["ScanSpec", "SurfaceTurbulenceSpec", "ConicalPeriodSpec", "ConicalScene", "CYCLE_KEYS", "default_spacing"]

#: scan keys that only a cycling lidar uses.
CYCLE_KEYS = ("revs_per_height", "refocus_time")
#: ``[scan] theory``'s spellings (:class:`ScanSpec`).
THEORY_CHOICES = ("none", "continuum", "lattice", "only", "auto")


def default_spacing(height: float) -> float:
    """Grid spacing [m] used by default at height z: z / 20, at least 1 m (the reasons are in
    :mod:`cwlidar_sim.campaign.periods.conical_simulation`)."""
    return max(1.0, float(height) / 20.0)


@dataclasses.dataclass(frozen=True)
class ScanSpec(Spec):
    """The scan: heights, the cone and its schedule, the box, the VAD.

    The lidar's instrument and signal chain are the scene's ``[lidar]`` table
    (:class:`cwlidar_sim.campaign.scenes.lidar_spec.ConicalLidarSpec`: the same keys
    as every scene's); this table is the geometry.

    Parameters
    ----------
    heights : tuple of float
        Measurement heights [m]; 1 to 20 distinct values.
    scan_revs : tuple of int
        Revolutions per VAD scan (1: 1 s scans, 3: 3 s scans); each in [1, 60].
    spacing : float
        Box spacing [m]; 0: the default, height / 20 (at least 1 m) of each
        unit's height, in cycle mode of the lowest height.
    lateral_doubling : bool
        Generate each box twice as wide and keep half (no periodic image across the circle).
    reference : {'previous', 'vane'}
        How the VAD's 180 deg ambiguity is resolved.
    cycle : bool
        False: the lidar dwells at each height, one unit per period and
        height.  True: it cycles through the heights within each period, one
        unit (and one box) per period; needs at least two heights (module notes).
    half_angle_deg, revolution_time, estimates_per_rev, sub_dwells, azimuth0_deg
        The cone and the sweep (:class:`cwlidar_sim.sensors.ConicalLidar`).
    revs_per_height, refocus_time
        The height cycle (``cycle = true`` only): revolutions at each height
        and the time lost refocusing [s].
    periods_per_height : tuple of int
        Empty (default): every period at every height.  Otherwise one count
        per height, each in [1, 10000]: height i runs that many periods,
        cycling through the ``[[period]]`` tables (module notes); dwell mode
        only.
    theory : {None, 'none', 'continuum', 'lattice', 'only', 'auto'}
        The linear theory of the std ratios
        (:mod:`cwlidar_sim.campaign.periods.conical_theory`).  None (default):
        ``"continuum"`` in dwell mode, ``"none"`` in cycle mode or with a
        ``turbulence.file`` (the tensor is not the file's); ``"none"``:
        none; ``"continuum"``: the continuum beside the simulation
        (``*_theory`` variables; a few seconds per distinct height, speed and
        direction, cached, or interpolated in U where a height has many
        speeds); ``"lattice"``: the continuum and the theory over the unit's
        own box beside it (``*_theory_lattice``,
        :mod:`cwlidar_sim.campaign.periods.lattice_theory`: about 20 s more
        per distinct unit); ``"only"``: the continuum instead of the
        simulation, for a tier ``los`` scene without processing variants
        (dwell mode, a generated field); ``"auto"``: ``"only"`` where the
        scene allows it, else ``"continuum"`` (cycle mode: ``"none"``), the
        choice and its reason in the results' ``auto_choice``
        (:meth:`ConicalScene.resolve_theory`).  Until results version 9,
        ``"continuum"`` also carried the lattice variables (now
        ``"lattice"``) and the default was none.
    """

    heights: tuple = (40.0, 60.0, 80.0, 100.0)
    scan_revs: tuple = (1, 3)
    spacing: float = 0.0
    lateral_doubling: bool = True
    reference: str = "previous"
    cycle: bool = False
    half_angle_deg: float = 30.0
    revolution_time: float = 1.0
    estimates_per_rev: int = 50
    sub_dwells: int = 8
    azimuth0_deg: float = 0.0
    revs_per_height: int = 1
    refocus_time: float = 0.0
    periods_per_height: tuple = ()
    theory: str | None = None

    #: Keys :meth:`from_dict` refuses with its own message (they moved to ``[lidar]``).
    _explained_keys = ("lidar", "tier")

    def __post_init__(self):
        set_field(self, "heights", check_distinct_reals("scan.heights", self.heights, count=(1, 20), noun="heights",
                                                        lo=1.0, hi=1000.0))
        r = tuple(self.scan_revs)
        if not r:
            raise ValueError("scan.scan_revs needs at least one scan length, e.g. [1, 3]")
        set_field(self, "scan_revs", tuple(check_int(f"scan.scan_revs[{i}]", n, lo=1, hi=60) for i, n in enumerate(r)))
        set_field(self, "spacing", check_real("scan.spacing", self.spacing, lo=0.0, hi=100.0))
        set_field(self, "lateral_doubling", check_bool("scan.lateral_doubling", self.lateral_doubling))
        check_choice("scan.reference", self.reference, ("previous", "vane"))
        set_field(self, "cycle", check_bool("scan.cycle", self.cycle))
        set_field(self, "half_angle_deg", check_real("scan.half_angle_deg", self.half_angle_deg, lo=10.0, hi=60.0))
        set_field(self, "revolution_time", check_real("scan.revolution_time", self.revolution_time, lo=0.1, hi=100.0))
        set_field(self, "estimates_per_rev", check_int("scan.estimates_per_rev", self.estimates_per_rev, lo=4,
                                                       hi=10000))
        set_field(self, "sub_dwells", check_int("scan.sub_dwells", self.sub_dwells, lo=1, hi=256))
        set_field(self, "azimuth0_deg", check_real("scan.azimuth0_deg", self.azimuth0_deg))
        set_field(self, "revs_per_height", check_int("scan.revs_per_height", self.revs_per_height, lo=1, hi=10000))
        set_field(self, "refocus_time", check_real("scan.refocus_time", self.refocus_time, lo=0.0, hi=100.0))
        if self.cycle:
            if len(self.heights) < 2:
                raise ValueError(f"scan.cycle = true cycles through the heights and needs at least 2, got {list(self.heights)}; "
                                 f"allowed: cycle = false for one height")
            bad = [n for n in self.scan_revs if self.revs_per_height % n]
            if bad:
                raise ValueError(f"scan.scan_revs {bad} must divide scan.revs_per_height = "
                                 f"{self.revs_per_height} in cycle mode (a VAD scan cannot span a refocus); "
                                 f"allowed: divisors of revs_per_height")
        elif self.revs_per_height != 1 or self.refocus_time != 0.0:
            raise ValueError("scan.revs_per_height and scan.refocus_time set the height cycle; they need "
                             "scan.cycle = true")
        plan = self.periods_per_height
        if isinstance(plan, (str, bytes, dict)) or not hasattr(plan, "__len__"):
            raise TypeError(f"scan.periods_per_height must be a list of integers (one per height), got "
                            f"{type(plan).__name__} {plan!r}")
        plan = tuple(check_int(f"scan.periods_per_height[{i}]", n, lo=1, hi=10000) for i, n in enumerate(plan))
        if plan and len(plan) != len(self.heights):
            raise ValueError(f"scan.periods_per_height has {len(plan)} counts for {len(self.heights)} heights "
                             f"{list(self.heights)}; allowed: one count per height, or none (every period at "
                             f"every height)")
        if plan and self.cycle:
            raise ValueError("scan.periods_per_height needs scan.cycle = false (a cycling lidar measures every "
                             "height in each period); allowed: cycle = false, or no periods_per_height")
        set_field(self, "periods_per_height", plan)
        if self.theory is not None:
            check_choice("scan.theory", self.theory, THEORY_CHOICES)
            if self.cycle and self.theory not in ("none", "auto"):
                raise ValueError(f"scan.theory = {self.theory!r} needs scan.cycle = false (the theory takes one "
                                 f"height's scans evenly spaced over the period); allowed: cycle = false")

    def theory_mode(self) -> str:
        """The theory this scan carries: ``theory``, or for None the default (``"continuum"``; cycle: ``"none"``)."""
        if self.theory is not None:
            return self.theory
        return "none" if self.cycle else "continuum"

    def block_time(self) -> float:
        """Cycle mode: the time of one height's block, revolutions plus refocus [s]."""
        return self.revs_per_height * self.revolution_time + self.refocus_time

    def geometry(self) -> dict:
        """The :class:`cwlidar_sim.sensors.ConicalLidar` geometry fields of the scan (not the heights)."""
        g = {k: getattr(self, k) for k in ("half_angle_deg", "revolution_time", "estimates_per_rev",
                                           "azimuth0_deg")}
        if self.cycle:
            g.update(revs_per_height=self.revs_per_height, refocus_time=self.refocus_time)
        return g

    def as_dict(self) -> dict:
        d = super().as_dict()
        d["heights"], d["scan_revs"] = list(self.heights), list(self.scan_revs)
        if self.periods_per_height:
            d["periods_per_height"] = list(self.periods_per_height)
        else:
            d.pop("periods_per_height", None)
        return d

    def plan(self, n_templates: int) -> tuple:
        """Periods run at each height (the plan, or ``n_templates`` at every height)."""
        return self.periods_per_height or (n_templates,) * len(self.heights)

    @classmethod
    def from_dict(cls, d: dict) -> "ScanSpec":
        if isinstance(d, dict) and ("lidar" in d or "tier" in d):
            raise ValueError("scan.lidar and scan.tier moved: the lidar's instrument and signal chain are the "
                             "[lidar] table (the keys of every scene's [lidar]: tier, cnr_db, speckle, span, "
                             "variants, clouds, ...); the cone and its schedule (half_angle_deg, revolution_time, "
                             "estimates_per_rev, sub_dwells, revs_per_height, refocus_time, azimuth0_deg) are "
                             "[scan] keys")
        return super().from_dict(d)


@dataclasses.dataclass(frozen=True)
class SurfaceTurbulenceSpec(TurbulenceSpec):
    """The ``[turbulence]`` table of a conical scene: every scene's keys, the surface layer by default.

    The keys, the ways they set the tensor and the refusals are
    :class:`cwlidar_sim.campaign.scenes.turbulence_spec.TurbulenceSpec`'s; here a
    table picking no way is ``source = "mann1994"`` (with ``z0`` default
    0.01 m: Mann's 1994 fit to Kaimal's neutral spectra at each height,
    ``L = 0.59 z``, ``alpha eps^(2/3) = 3.2 u*^2 z^(-2/3)``, ``Gamma = 3.9``),
    and ``height`` defaults to each unit's (in cycle mode the box's reference
    height), so ``ti``, ``sigma_u``, ``iec_class`` and the surface layer give
    each height and period its own tensor.  ``condition_on``'s ``position``
    [m] is relative to the lidar (the cone's apex) in the lidar's frame.
    """

    _kind = "conical"
    _default = {"source": "mann1994"}
    _has_height = True
    _takes_fit_to = False
    _twin_needs_one_tensor = False


@dataclasses.dataclass(frozen=True)
class ConicalPeriodSpec(Spec):
    """One period of a conical scene.

    Parameters
    ----------
    name : str
    mean_speed : float
        Mean horizontal wind speed at the measurement height [m/s]; in [1, 30]
        (in cycle mode: at every height, the box's one advection speed).
    wind_direction_deg : float, optional
        Direction the mean wind blows toward in the lidar's frame [deg], from
        the lidar's azimuth 0 toward +y (the scan's azimuth convention); any
        finite value (module notes).  Default 0 (a westerly) unless
        ``wind_from_deg`` is given; not both.
    duration : float, optional
        Length [s]; default the scene's ``duration``; in [10, 3600].
    seed : int, optional
        Seed of this period's units; default derived from the scene seed.
    wind_from_deg : float, optional
        Meteorological direction of the mean wind [deg]: where it comes
        from, clockwise from north (the lidar's +y axis); any finite value.
    """

    name: str
    mean_speed: float
    wind_direction_deg: float | None = None
    duration: float | None = None
    seed: int | None = None
    wind_from_deg: float | None = None

    _required = ("name", "mean_speed")
    #: Keys of a staring period that :meth:`from_dict` refuses with its own message.
    _explained_keys = ("misalignment_deg", "start")

    def __post_init__(self):
        # bare key names: the scene names the entry, period[0] ('p0') (spec.periods_from_dict)
        check_str("name", self.name)
        set_field(self, "mean_speed", check_real("mean_speed", self.mean_speed, lo=1.0, hi=30.0))
        if self.wind_from_deg is None:
            set_field(self, "wind_direction_deg", 0.0 if self.wind_direction_deg is None else
                      check_real("wind_direction_deg", self.wind_direction_deg))
        elif self.wind_direction_deg is not None:
            raise ValueError(f"gives both wind_direction_deg={self.wind_direction_deg!r} (toward, "
                             f"in the lidar's frame) and wind_from_deg={self.wind_from_deg!r} (meteorological: from, "
                             f"clockwise from north); allowed: one of them")
        else:
            set_field(self, "wind_from_deg", check_real("wind_from_deg", self.wind_from_deg))
        if self.duration is not None:
            set_field(self, "duration", check_real("duration", self.duration, lo=10.0, hi=3600.0))
        if self.seed is not None:
            set_field(self, "seed", check_seed("seed", self.seed))

    @property
    def toward_deg(self) -> float:
        """Direction the mean wind blows toward in the lidar's frame [deg] (``wind_direction_deg``, or from ``wind_from_deg``)."""
        return self.wind_direction_deg if self.wind_from_deg is None else wind_from_toward(self.wind_from_deg)

    @classmethod
    def from_dict(cls, d: dict) -> "ConicalPeriodSpec":
        if isinstance(d, dict) and "misalignment_deg" in d:
            raise ValueError("misalignment_deg is the staring beam's angle to the wind; a conical period takes "
                             "wind_from_deg (meteorological: from, clockwise from north [deg]) or "
                             "wind_direction_deg (the direction the wind blows toward in the lidar's frame [deg])")
        if isinstance(d, dict) and "start" in d:
            raise ValueError("start is for staring scenes (background pauses)")
        return super().from_dict(d)


@dataclasses.dataclass(frozen=True)
class ConicalScene(SceneSpec):
    """A conical campaign: the scan, the turbulence with height, the periods.

    A copy with keys changed: :meth:`~cwlidar_sim.campaign.scenes.spec.SceneSpec.with_values`
    (dotted keys of the file, ``{"lidar.cnr_db": -15.0}``) or :meth:`replace` (fields).

    Parameters
    ----------
    name : str
        Used for ``DIR/<name>.nc``; letters, digits, '-', '_'.
    periods : tuple of ConicalPeriodSpec
        Each is run at every height, or they are the templates of
        ``scan.periods_per_height`` (module notes).
    scan : ScanSpec
    lidar : ConicalLidarSpec
        The instrument and the signal chain (the keys of every scene's ``[lidar]``).
    turbulence : SurfaceTurbulenceSpec
    duration : float
        Default period length [s]; in [10, 3600] (CS: 600).
    seed : int
    description : str
    """

    name: str
    periods: tuple
    scan: ScanSpec = dataclasses.field(default_factory=ScanSpec)
    lidar: ConicalLidarSpec = dataclasses.field(default_factory=ConicalLidarSpec)
    turbulence: SurfaceTurbulenceSpec = dataclasses.field(default_factory=SurfaceTurbulenceSpec)
    duration: float = 600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    kind = "conical"

    def __post_init__(self):
        check_scene_name(self.name)
        if not isinstance(self.scan, ScanSpec) or not isinstance(self.turbulence, SurfaceTurbulenceSpec):
            raise TypeError("scan and turbulence must be ScanSpec and SurfaceTurbulenceSpec")
        if not isinstance(self.lidar, ConicalLidarSpec):
            raise TypeError(f"lidar must be a ConicalLidarSpec, got {type(self.lidar).__name__}")
        periods = check_periods(self.periods, ConicalPeriodSpec, "conical scene")
        set_field(self, "periods", periods)
        set_field(self, "duration", check_real("duration", self.duration, lo=10.0, hi=3600.0))
        set_field(self, "seed", check_seed("seed", self.seed))
        check_str("description", self.description, allow_empty=True)
        nh = len(self.scan.heights)
        names = self.unit_names()
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"units {dup[:5]} are named twice: scan.periods_per_height names a template's "
                             f"later passes <name>_<pass>; allowed: period names that are not another's "
                             f"<name>_<pass>")
        self.turbulence.check_frozen(periods, self.scan.heights, "scan.heights")
        for i, p in enumerate(periods):
            where = entry_label("period", i, p.name)
            dur = check_real(f"{where}.duration", self.period_duration(p), lo=10.0, hi=3600.0)
            if self.scan.cycle:
                block = self.scan.block_time()
                if (dur + self.scan.refocus_time) < nh * block * (1 - 1e-12):
                    raise ValueError(f"{where} lasts {dur:g} s, shorter than one cycle through the "
                                     f"{nh} heights ({nh} x {block:g} s blocks); allowed: longer periods or fewer "
                                     f"revs_per_height")

        if self.scan.theory_mode() == "only":
            _check_theory_only(self)
        # the lidar's own checks (focus range, dwell, cells, clouds), named by field, at every height
        from ...sensors.conical import ConicalLidar

        for hs in ((self.scan.heights,) if self.scan.cycle else [(z,) for z in self.scan.heights]):
            try:
                ConicalLidar(heights=hs, **self.lidar_fields(self.scan.spacing or default_spacing(min(hs))))
            except (ValueError, TypeError) as e:
                raise type(e)(f"conical lidar at heights {list(hs)} m: {e}") from None

    def lidar_fields(self, spacing: float) -> dict:
        """The :class:`cwlidar_sim.sensors.ConicalLidar` fields of the scene but its heights, for a box spacing [m]."""
        kw = self.lidar.sensor_kwargs(spacing)
        kw.update(self.scan.geometry(), sub_dwells=self.scan.sub_dwells, instrument=self.lidar.build_instrument())
        return kw

    # -- units of work ----------------------------------------------------
    def period_duration(self, period) -> float:
        """Length of a period [s]."""
        return self.duration if period.duration is None else period.duration

    def _plan_units(self):
        """Dwell mode: (period, height, template index, pass) of every unit in run order (module notes)."""
        tpl, hs = self.periods, self.scan.heights
        if not self.scan.periods_per_height:
            return [(p, z, k, 0) for k, p in enumerate(tpl) for z in hs]
        plan = self.scan.periods_per_height
        out = []
        for j in range(max(plan)):
            k, c = j % len(tpl), j // len(tpl)
            p = tpl[k] if c == 0 else dataclasses.replace(tpl[k], name=f"{tpl[k].name}_{c}")
            out.extend((p, z, k, c) for z, n in zip(hs, plan) if j < n)
        return out

    def units(self):
        """The units in run order: (period, height) pairs (period slowest); in cycle mode (period, heights).

        With ``scan.periods_per_height`` the periods are the templates' passes (module notes).
        """
        if self.scan.cycle:
            return [(p, self.scan.heights) for p in self.periods]
        return [(p, z) for p, z, _, _ in self._plan_units()]

    def periods_at(self) -> dict:
        """Height [m] -> number of periods run there."""
        n = len(self.periods)
        return {z: (n if self.scan.cycle else k) for z, k in zip(self.scan.heights, self.scan.plan(n))}

    def unit_names(self):
        """Names of the units, ``<period>_z<height>`` (cycle mode: ``<period>``)."""
        if self.scan.cycle:
            return [p.name for p in self.periods]
        return [f"{p.name}_z{z:g}" for p, z in self.units()]

    def row_names(self, index: int) -> list:
        """Names of the result rows of unit ``index``: ``<period>_z<height>`` for each height it measures."""
        p, z = self.units()[index]
        return [f"{p.name}_z{h:g}" for h in (z if self.scan.cycle else (z,))]

    def simulated_hours(self) -> float:
        """Simulated time of all units [h] (dwell: each height its own record; cycle: one record per period)."""
        if self.scan.cycle:
            return sum(self.period_duration(p) for p in self.periods) / 3600.0
        return sum(self.period_duration(p) for p, _ in self.units()) / 3600.0

    def unit_seed(self, index: int) -> int:
        """Seed of unit ``index``, from the period's own seed or the scene's (distinct across units)."""
        if self.scan.cycle:
            p, _ = self.units()[index]
            child = np.random.SeedSequence(self.seed if p.seed is None else p.seed,
                                           spawn_key=(index,) if p.seed is None else ())
        else:
            p, z, _, c = self._plan_units()[index]
            if p.seed is None:
                child = np.random.SeedSequence(self.seed, spawn_key=(index,))
            else:  # a template with its own seed: one stream per height, and per pass after the first
                child = np.random.SeedSequence(p.seed, spawn_key=(self.scan.heights.index(z),) + ((c,) if c else ()))
        return seed_int(child)

    # -- interchange ------------------------------------------------------
    def as_dict(self) -> dict:
        d = super().as_dict()
        d.pop("base_dir", None)
        d["kind"] = "conical"
        d["period"] = d.pop("periods")
        return d

    #: The scene file's tables and the spec class of each.
    _tables = {"scan": ScanSpec, "lidar": ConicalLidarSpec, "turbulence": SurfaceTurbulenceSpec}
    _period_spec = ConicalPeriodSpec
    _what = "conical scene"

    @classmethod
    def schema(cls) -> dict:
        """TOML path of each table of the scene file -> its keys (:func:`cwlidar_sim.campaign.scenes.spec.check_scene_keys`)."""
        out = {"": Table(("name", "kind", "description", "seed", "duration", "period", *cls._tables)),
               "scan": spec_table(ScanSpec)}
        out.update(lidar_schema(cls._tables["lidar"]))
        out.update(turbulence_schema(cls._tables["turbulence"]))
        out["period[]"] = spec_table(ConicalPeriodSpec)
        return out

    def resolve(self, path: str) -> str:
        """A path of the scene file, relative to the scene's folder."""
        return resolve_path(self.base_dir, path)

    def resolve_theory(self) -> tuple:
        """``scan.theory = "auto"`` chosen: ``(choice, reason)``; any other spelling: itself and ``""``.

        ``"only"`` (the theory alone, in seconds) where the scene asks only
        for what it answers (tier ``los``, no processing variants, a
        generated field, dwell mode); otherwise ``"continuum"`` beside the
        simulation (``"none"`` in cycle mode, which the theory cannot take,
        and for a field file, whose turbulence the ``[turbulence]`` tensor
        does not describe; also the default there).
        """
        if self.scan.theory is None and self.turbulence.file is not None:
            return "none", ("turbulence.file: the [turbulence] tensor is not the file's field, so no theory by "
                            "default (set scan.theory = 'continuum' to have the tensor's beside it)")
        if self.scan.theory != "auto":
            return self.scan.theory_mode(), ""
        if self.scan.cycle:
            return "none", "the lidar cycles through the heights (scan.cycle = true), which the theory cannot take"
        if self.turbulence.file is not None:
            return "none", "simulated without theory: turbulence.file (the [turbulence] tensor is not the file's field)"
        why = _theory_only_blockers(self)
        if why:
            return "continuum", "simulated, the theory beside it: the scene asks for " + "; ".join(why)
        return "only", ("the linear theory alone, no simulation: tier los, no processing variants and a generated "
                        "field, whose lidar/cup std ratios are linear statistics the theory gives exactly to first "
                        "order; set scan.theory = 'continuum' to simulate them")


def _theory_only_blockers(scene) -> list:
    """What a scene asks for that ``scan.theory = "only"`` cannot answer (empty: nothing)."""
    why = []
    if scene.lidar.tier != "los":
        why.append(f"lidar.tier = {scene.lidar.tier!r} (the theory is tier los's answer: no speckle, noise or "
                   f"Doppler estimator)")
    if scene.lidar.variants:
        why.append("lidar.variants (processing variants need the spectra)")
    if scene.turbulence.condition_on:
        why.append("turbulence.condition_on (records to condition a box on)")
    if scene.turbulence.file is not None:
        why.append("turbulence.file (a field, not a tensor)")
    return why


def _check_theory_only(scene) -> None:
    """``scan.theory = "only"``: refused by name where the theory cannot answer what the scene asks."""
    why = _theory_only_blockers(scene)
    if why:
        raise ValueError("scan.theory = 'only' answers the linear statistics (the lidar/cup std ratios) of a tier "
                         "los scene by the theory alone; this scene asks for " + "; ".join(why)
                         + "; allowed: theory = 'continuum' (beside the simulation) or a scene without them")
