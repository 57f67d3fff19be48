"""The conically scanning ZephIR against a cup and a sonic (CS): scene, unit of work, results.

A conical scene runs every ``[[period]]`` at every height of ``scan.heights``:
one *unit* is (period, height), a 10-minute record of one Mann box, the
scanning lidar dwelling at that height, a cup and a sonic on the scan axis
(:func:`cwlidar_sim.sensors.conical_period.simulate_conical_period`).  The
1 s and 3 s scans (``scan.scan_revs``) are two evaluations of the same record,
as a ZephIR's two software settings would see the same air.  Units are
independent and seeded from the scene, so they run here or on Dask with the
same bits, are written one by one as they finish, and resume like the
periods of a staring scene.

The scene's results (:func:`summarise`) average the units of each height
over the periods that pass CS's selection (mean points used in the fits
>= 65 % of the maximum), on dimensions ``height`` [m] and ``scan_s`` [s].

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
    tier = "spectral"
    lidar = { cnr_db = -10.0 }     # further ConicalLidar fields

    [turbulence]                   # or alpha_eps, length_scale, gamma for one tensor at every height
    source = "mann1994"            # neutral surface layer at each height (Mann 1994's Kaimal fit)

    [[period]]
    name = "p0"
    mean_speed = 10.0
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from .._validation import check_choice, check_int, check_keys, check_real, check_seed
from .scene import PeriodSpec, _asdict, _check_bool, _check_str

__all__ = ["ScanSpec", "SurfaceTurbulenceSpec", "ConicalScene", "run_unit", "unit_dataset", "summarise"]

#: Scalars of one unit (period x height), with units and meaning.
UNIT_VARS = {
    "cup_mean": ("m s-1", "cup 10-min mean horizontal speed"),
    "cup_std": ("m s-1", "cup 10-min standard deviation"),
    "sonic_std": ("m s-1", "sonic horizontal-speed standard deviation"),
    "sonic_radial_variance": ("m2 s-2", "sonic-equivalent radial variance (point sonic projected on the rotating beam)"),
    "availability": ("1", "fraction of finite line-of-sight estimates"),
    "zero_crossing_loss": ("1", "fraction of estimates flagged NO_SIGNAL or NEAR_ZERO (cross-wind zero crossings)"),
    "second_peak_fraction": ("1", "fraction of estimates flagged SECOND_PEAK (e.g. a cloud return)"),
    "cloud_fraction": ("1", "the cloud's share of the received power (0: clear air)"),
}
#: Per-scan-length results of one unit.
SCAN_VARS = {
    "lidar_mean": ("m s-1", "lidar 10-min mean horizontal speed (VAD fits)"),
    "lidar_std": ("m s-1", "lidar 10-min standard deviation of the VAD horizontal speed"),
    "std_ratio": ("1", "lidar / cup 10-min standard deviation"),
    "mean_speed_bias": ("1", "lidar mean / cup mean - 1"),
    "tp": ("1", "mean turbulence parameter TP (CS Eq. 8)"),
    "radial_variance": ("m2 s-2", "mean (TP U)^2"),
    "radial_variance_ratio": ("1", "radial_variance / sonic_radial_variance"),
    "scan_availability": ("1", "fraction of scans fitted"),
    "points_used_fraction": ("1", "mean fraction of points used in the fits"),
    "selected": ("1", "CS's selection: points_used_fraction >= 0.65"),
    "ambiguity_rate": ("1", "fraction of fitted scans whose direction is > 90 deg from the sonic's"),
    "unresolved_rate": ("1", "fraction of scans whose 180 deg ambiguity stayed unresolved"),
    "l_az": ("m", "CS scan length l_az = D + U (n - 0.5)"),
    "std_ratio_model": ("1", "CS filter model of std_ratio with the Kaimal spectrum (CS Eqs. 4-17)"),
    "std_ratio_model_mann": ("1", "CS filter model of std_ratio with the simulation's Mann spectra"),
    "radial_variance_ratio_model": ("1", "CS filter model of the radial-variance ratio (Kaimal)"),
    "radial_variance_ratio_model_mann": ("1", "CS filter model of the radial-variance ratio (Mann spectra)"),
}
_FROM_SIM = {"scan_availability": "availability", "std_ratio_model": "std_ratio_model_kaimal",
             "radial_variance_ratio_model": "radial_variance_ratio_model_kaimal"}


@dataclasses.dataclass(frozen=True)
class ScanSpec:
    """The scan and the lidar.

    Parameters
    ----------
    heights : tuple of float
        Measurement heights [m] (each run as its own dwell); 1 to 20 distinct values.
    scan_revs : tuple of int
        Revolutions per VAD scan (1: 1 s scans, 3: 3 s scans); each in [1, 60].
    tier : {'los', 'spectral', 'signal'}
        Fidelity tier of the scanning lidar.
    spacing : float
        Box spacing [m]; 0: height / 20 (at least 1 m).
    lateral_doubling : bool
        Generate each box twice as wide and keep half (no periodic image across the circle).
    reference : {'previous', 'vane'}
        How the VAD's 180 deg ambiguity is resolved.
    lidar : dict
        Further :class:`cwlidar_sim.sensors.ConicalLidar` fields (e.g. ``cnr_db``, ``sub_dwells``).
    """

    heights: tuple = (40.0, 60.0, 80.0, 100.0)
    scan_revs: tuple = (1, 3)
    tier: str = "spectral"
    spacing: float = 0.0
    lateral_doubling: bool = True
    reference: str = "previous"
    lidar: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        from ..sensors.conical import TIERS, ConicalLidar

        h = tuple(self.heights)
        if not 1 <= len(h) <= 20:
            raise ValueError(f"scan.heights needs 1 to 20 heights, got {len(h)}")
        h = tuple(check_real(f"scan.heights[{i}]", z, lo=1.0, hi=1000.0) for i, z in enumerate(h))
        if len(set(h)) != len(h):
            raise ValueError(f"scan.heights must be distinct, got {h}")
        object.__setattr__(self, "heights", h)
        r = tuple(self.scan_revs)
        if not r:
            raise ValueError("scan.scan_revs needs at least one scan length, e.g. [1, 3]")
        object.__setattr__(self, "scan_revs", tuple(check_int(f"scan.scan_revs[{i}]", n, lo=1, hi=60)
                                                    for i, n in enumerate(r)))
        check_choice("scan.tier", self.tier, TIERS)
        object.__setattr__(self, "spacing", check_real("scan.spacing", self.spacing, lo=0.0, hi=100.0))
        _check_bool("scan.lateral_doubling", self.lateral_doubling)
        check_choice("scan.reference", self.reference, ("previous", "vane"))
        if not isinstance(self.lidar, dict):
            raise TypeError(f"scan.lidar must be a table of ConicalLidar fields, got {type(self.lidar).__name__}")
        reserved = sorted(set(self.lidar) & {"heights", "tier", "cell_length"})
        if reserved:
            raise ValueError(f"scan.lidar: {reserved} are set by scan.heights, scan.tier and scan.spacing")
        for z in h:  # the lidar's own checks (focus range, half-angle, dwell), named by field
            ConicalLidar.from_dict({**self.lidar, "heights": (z,), "tier": self.tier})

    def as_dict(self) -> dict:
        d = _asdict(self)
        d["heights"], d["scan_revs"] = list(self.heights), list(self.scan_revs)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "ScanSpec":
        check_keys(cls, d)
        return cls(**d)


@dataclasses.dataclass(frozen=True)
class SurfaceTurbulenceSpec:
    """Turbulence with height: a neutral surface layer, or one tensor for every height.

    Parameters
    ----------
    source : {'mann1994', 'iec', 'fixed'}
        'mann1994': Mann's (1994) tensor fit to Kaimal's neutral spectra at
        each height (L = 0.59 z, alpha eps^(2/3) = 3.2 u*^2 z^(-2/3), Gamma = 3.9);
        'iec': IEC 61400-1 at each height; 'fixed': ``alpha_eps``,
        ``length_scale``, ``gamma`` everywhere.
    z0 : float
        Roughness length [m] of the log law giving u*; in (0, 2].
    alpha_eps, length_scale, gamma : float, optional
        The tensor for 'fixed'.
    """

    source: str = "mann1994"
    z0: float = 0.01
    alpha_eps: float | None = None
    length_scale: float | None = None
    gamma: float | None = None

    def __post_init__(self):
        check_choice("turbulence.source", self.source, ("mann1994", "iec", "fixed"))
        object.__setattr__(self, "z0", check_real("turbulence.z0", self.z0, lo=0.0, hi=2.0, lo_open=True))
        given = [self.alpha_eps, self.length_scale, self.gamma]
        if self.source == "fixed":
            if None in given:
                raise ValueError("turbulence.source = 'fixed' needs alpha_eps, length_scale and gamma")
            self.params()
        elif any(g is not None for g in given):
            raise ValueError(f"turbulence: alpha_eps, length_scale, gamma need source = 'fixed' "
                             f"(source is {self.source!r})")

    def params(self, height=None, speed=None):
        """(MannParameters, sigma_u target or None, u* or None) at ``height`` [m] and ``speed`` [m/s]."""
        from ..turbulence.parameters import MannParameters

        if self.source == "fixed":
            return MannParameters(self.alpha_eps, self.length_scale, self.gamma), None, None
        from ..sensors.conical import surface_layer_parameters

        return surface_layer_parameters(height, speed, z0=self.z0, source=self.source)

    def as_dict(self) -> dict:
        return _asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "SurfaceTurbulenceSpec":
        check_keys(cls, d)
        return cls(**d)


@dataclasses.dataclass(frozen=True)
class ConicalScene:
    """A conical campaign: the scan, the turbulence with height, the periods.

    Parameters
    ----------
    name : str
        Used for ``DIR/<name>.nc``; letters, digits, '-', '_'.
    periods : tuple of PeriodSpec
        Each is run at every height (``mean_speed`` at the measurement height;
        ``misalignment_deg`` is the wind direction [deg] from +x).
    scan : ScanSpec
    turbulence : SurfaceTurbulenceSpec
    duration : float
        Default period length [s]; in [10, 3600] (CS: 600).
    seed : int
    description : str
    """

    name: str
    periods: tuple
    scan: ScanSpec = dataclasses.field(default_factory=ScanSpec)
    turbulence: SurfaceTurbulenceSpec = dataclasses.field(default_factory=SurfaceTurbulenceSpec)
    duration: float = 600.0
    seed: int = 0
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    kind = "conical"

    def __post_init__(self):
        _check_str("name", self.name)
        if not all(c.isalnum() or c in "-_" for c in self.name):
            raise ValueError(f"name {self.name!r} may hold only letters, digits, '-' and '_'")
        if not isinstance(self.scan, ScanSpec) or not isinstance(self.turbulence, SurfaceTurbulenceSpec):
            raise TypeError("scan and turbulence must be ScanSpec and SurfaceTurbulenceSpec")
        periods = tuple(self.periods)
        if not periods or not all(isinstance(p, PeriodSpec) for p in periods):
            raise ValueError("a conical scene needs at least one [[period]]")
        names = [p.name for p in periods]
        if len(set(names)) != len(names):
            raise ValueError(f"period names must be unique, got {names}")
        object.__setattr__(self, "periods", periods)
        object.__setattr__(self, "duration", check_real("duration", self.duration, lo=10.0, hi=3600.0))
        object.__setattr__(self, "seed", check_seed("seed", self.seed))
        _check_str("description", self.description, allow_empty=True)
        for p in periods:
            check_real(f"period {p.name!r} duration", self.period_duration(p), lo=10.0, hi=3600.0)
            if p.start:
                raise ValueError(f"period {p.name!r}: start is for staring scenes (background pauses)")

    # -- units of work ----------------------------------------------------
    def period_duration(self, period) -> float:
        return self.duration if period.duration is None else period.duration

    def units(self):
        """(period, height) pairs in run order (period slowest)."""
        return [(p, z) for p in self.periods for z in self.scan.heights]

    def unit_names(self):
        """Names of the units, ``<period>_z<height>``."""
        return [f"{p.name}_z{z:g}" for p, z in self.units()]

    def simulated_hours(self) -> float:
        """Simulated time of all units [h]."""
        return sum(self.period_duration(p) for p in self.periods) * len(self.scan.heights) / 3600.0

    def unit_seed(self, index: int) -> int:
        p, z = self.units()[index]
        if p.seed is not None:
            child = np.random.SeedSequence(p.seed, spawn_key=(self.scan.heights.index(z),))
        else:
            child = np.random.SeedSequence(self.seed, spawn_key=(index,))
        return int(child.generate_state(2, np.uint64)[0] >> np.uint64(1))

    # -- interchange ------------------------------------------------------
    def as_dict(self) -> dict:
        d = _asdict(self)
        d.pop("base_dir", None)
        d["kind"] = "conical"
        d["period"] = d.pop("periods")
        return d

    @classmethod
    def from_dict(cls, d: dict, *, base_dir: str = ".") -> "ConicalScene":
        if not isinstance(d, dict):
            raise TypeError(f"a scene must be a table, got {type(d).__name__}")
        allowed = {"name", "kind", "description", "seed", "duration", "period", "scan", "turbulence"}
        unknown = sorted(set(d) - allowed)
        if unknown:
            raise ValueError(f"unknown key(s) in conical scene: {unknown}; allowed: {sorted(allowed)}")
        for key in ("name", "period"):
            if key not in d:
                raise ValueError(f"scene is missing the required key {key!r}")
        kw = {k: d[k] for k in ("name", "description", "seed", "duration") if k in d}
        if "scan" in d:
            kw["scan"] = ScanSpec.from_dict(d["scan"])
        if "turbulence" in d:
            kw["turbulence"] = SurfaceTurbulenceSpec.from_dict(d["turbulence"])
        if not isinstance(d["period"], (list, tuple)):
            raise TypeError("period must be an array of tables ([[period]])")
        kw["periods"] = tuple(PeriodSpec.from_dict(p) for p in d["period"])
        return cls(base_dir=base_dir, **kw)

    def replace(self, **changes) -> "ConicalScene":
        return dataclasses.replace(self, **changes)


#: Wall time per simulated hour of the scanning lidar on one idle core [s], by tier (sub_dwells = 8;
#: measured on the reference machine with the CS reproduction, see benchmarks/bench_cs.py).
COST_S_PER_SIM_HOUR = {"los": 20.0, "spectral": 150.0, "signal": 50000.0}


def _box_points(scene: ConicalScene, index: int) -> tuple:
    """(generated points, spacing [m]) of unit ``index``'s box (as conical_field sizes it, approximately)."""
    from ..sensors.conical_period import default_spacing

    p, z = scene.units()[index]
    d = scene.scan.spacing or default_spacing(z)
    phi = math.radians(float(scene.scan.lidar.get("half_angle_deg", 30.0)))
    tensor = scene.turbulence.params(z, p.mean_speed)[0]
    radius = z * math.tan(phi) + 5.0 * 0.0013 * (z / math.cos(phi)) ** 2 * math.sin(phi)
    ext = 2.0 * tensor.length_scale
    nx = (p.mean_speed * scene.period_duration(p) + 2 * radius + 4 * d) / d
    ny = max(2 * radius + 2 * d, ext) / d * (2 if scene.scan.lateral_doubling else 1)
    nz = max(2 * radius / math.tan(phi) * 0.3 + 2 * d, ext) / d
    return nx * ny * nz, d


def estimate_unit(scene: ConicalScene, index: int) -> dict:
    """Estimated wall time [s] on one core and memory [bytes] of one unit (box + scan + fits)."""
    points, _ = _box_points(scene, index)
    p, _ = scene.units()[index]
    hours = scene.period_duration(p) / 3600.0
    seconds = 3 * points * 30e-9 + hours * COST_S_PER_SIM_HOUR[scene.scan.tier]
    return {"seconds": seconds, "memory_bytes": 3 * 4 * points * 2.0 + 50e6}


def estimate_bytes(scene: ConicalScene) -> float:
    """Size of a conical scene's results [bytes]: a few hundred numbers per unit."""
    return 20e3 * len(scene.units()) + 1e6


def run_unit(scene: ConicalScene, index: int, params=None, *, status=None):
    """Simulate unit ``index`` (period x height) and return it as a one-period Dataset.

    ``params`` is ignored (the tensor comes from ``scene.turbulence`` at the
    unit's height); it is accepted for the runner's uniform call.
    """
    import time

    from ..sensors.conical_period import simulate_conical_period

    p, z = scene.units()[index]
    name = scene.unit_names()[index]
    if status is not None:
        status(f"{name}: box, lidar, cup, sonic")
    t0 = time.perf_counter()
    tensor, su, ustar = scene.turbulence.params(z, p.mean_speed)
    s = scene.scan
    lidar = dict(s.lidar)
    if p.misalignment_deg:
        # the wind comes from +x in the field; a wind direction turns the scan's azimuth origin instead
        lidar["azimuth0_deg"] = float(lidar.get("azimuth0_deg", 0.0)) - p.misalignment_deg
    r = simulate_conical_period(z, scene.unit_seed(index), speed=p.mean_speed, duration=scene.period_duration(p),
                                scan_revs=s.scan_revs, tier=s.tier, spacing=s.spacing or None,
                                lateral_doubling=s.lateral_doubling, params=tensor, reference=s.reference,
                                lidar_overrides=lidar)
    r["sigma_u_target"], r["u_star"] = su, ustar
    r["wall_s"] = time.perf_counter() - t0
    return unit_dataset(scene, index, r)


def unit_dataset(scene: ConicalScene, index: int, r: dict):
    """One unit's results as a Dataset with a ``period`` dimension of length 1 (the unit)."""
    import xarray as xr

    from .. import __version__
    from .runner import RESULTS_VERSION

    p, z = scene.units()[index]
    revs = list(scene.scan.scan_revs)
    scan_s = [n * float(scene.scan.lidar.get("revolution_time", 1.0)) for n in revs]
    dv = {}
    for key, (units, long) in UNIT_VARS.items():
        dv[key] = (("period",), np.array([float(r[key])]), {"units": units, "long_name": long})
    for key, (units, long) in SCAN_VARS.items():
        src = _FROM_SIM.get(key, key)
        vals = [float(r["scans"][n].get(src, np.nan)) for n in revs]
        dv[key] = (("period", "scan_s"), np.array([vals]), {"units": units, "long_name": long})
    dv["mean_speed"] = (("period",), np.array([float(p.mean_speed)]), {"units": "m s-1"})
    dv["u_star"] = (("period",), np.array([np.nan if r.get("u_star") is None else float(r["u_star"])]),
                    {"units": "m s-1", "long_name": "friction velocity of the surface layer"})
    for name in ("alpha_eps", "length_scale", "gamma"):
        dv[f"mann_{name}"] = (("period",), np.array([float(r["params"][name])]),
                              {"units": {"alpha_eps": "m4/3 s-2", "length_scale": "m", "gamma": "1"}[name],
                               "long_name": f"Mann {name} of the unit's box"})
    coords = {
        "period": ("period", np.array([scene.unit_names()[index]], dtype=object)),
        "unit_height": ("period", np.array([float(z)]), {"units": "m", "long_name": "measurement height of the unit"}),
        "period_name": ("period", np.array([p.name], dtype=object)),
        "scan_s": ("scan_s", np.array(scan_s), {"units": "s", "long_name": "VAD scan length"}),
        "scan_revs": ("scan_s", np.array(revs), {"units": "1", "long_name": "revolutions per VAD scan"}),
    }
    attrs = {
        "title": f"cwlidar_sim conical campaign {scene.name}",
        "results_version": RESULTS_VERSION,
        "sensor": "conical",
        "lidar_tier": scene.scan.tier,
        "scene": json.dumps(scene.as_dict()),
        "cwlidar_sim_version": __version__,
        "period_index": int(index),
        "field_reason": f"box {'x'.join(map(str, r['box_shape']))} at {r['spacing']:g} m"
                        f"{', laterally doubled' if r['lateral_doubling'] else ''}",
        "timing": json.dumps({k: float(v) for k, v in r["cost_s"].items()} | {"total": r["wall_s"]}),
    }
    return xr.Dataset(dv, coords=coords, attrs=attrs)


def summarise(ds):
    """The scene's results on dimensions ``height`` and ``scan_s``, beside the units' own.

    The units' variables (dimension ``period``: one per period x height) are
    renamed ``<name>_unit``.  For each height and scan length the plain
    names hold the mean over the periods that pass CS's selection of
    ``std_ratio``, ``radial_variance_ratio``, ``mean_speed_bias``, ``tp`` and
    ``ambiguity_rate`` (``<name>_sigma``: the standard error over those
    periods), the mean over all periods of ``scan_availability`` and
    ``points_used_fraction``, and the filter model (``std_ratio_model``,
    ``radial_variance_ratio_model``: CS's Kaimal spectrum; ``..._mann``: the
    simulation's Mann spectra); per height ``availability`` (line-of-sight
    estimates), ``zero_crossing_loss``, ``n_periods``; ``n_selected``.
    """
    import xarray as xr

    units = ds.rename({v: f"{v}_unit" for v in ds.data_vars})
    heights = np.unique(ds.unit_height.values)
    out = {}

    def by_height(var, selected):
        mean, err, count = [], [], []
        for z in heights:
            at = ds[var].where(ds.unit_height == z, drop=True)
            if selected:
                keep = (ds["selected"] > 0.5).where(ds.unit_height == z, drop=True)
                at = at.where(keep.astype(bool)) if "scan_s" in at.dims else at
            n = at.notnull().sum("period")
            mean.append(at.mean("period", skipna=True).values)
            err.append((at.std("period", skipna=True, ddof=1) / np.sqrt(n.where(n > 1))).values)
            count.append(n.values)
        return np.array(mean), np.array(err), np.array(count)

    HS = ("height", "scan_s")
    for var, selected in (("std_ratio", True), ("radial_variance_ratio", True), ("mean_speed_bias", True),
                          ("tp", True), ("ambiguity_rate", True), ("scan_availability", False),
                          ("points_used_fraction", False), ("std_ratio_model", False),
                          ("std_ratio_model_mann", False), ("radial_variance_ratio_model", False),
                          ("radial_variance_ratio_model_mann", False)):
        mean, err, n = by_height(var, selected)
        attrs = dict(ds[var].attrs)
        how = "selected periods" if selected else "periods"
        out[var] = (HS, mean, {**attrs, "long_name": f"{attrs.get('long_name', var)} (mean over the {how})"})
        if selected:
            out[f"{var}_sigma"] = (HS, err, {"units": attrs.get("units", "1"), "long_name": f"standard error of {var}"})
        if var == "std_ratio":
            out["n_selected"] = (HS, n.astype(np.int64), {"units": "1", "long_name": "periods passing CS's selection"})
    for var in ("availability", "zero_crossing_loss", "second_peak_fraction", "cloud_fraction"):
        mean, _, n = by_height(var, False)
        out[var] = (("height",), mean, {**ds[var].attrs, "long_name": ds[var].attrs["long_name"] + " (mean over periods)"})
    out["n_periods"] = (("height",), n.astype(np.int64), {"units": "1", "long_name": "periods simulated"})
    res = xr.merge([units, xr.Dataset(out, coords={"height": ("height", heights, {"units": "m"})})],
                   combine_attrs="override")
    res.attrs = dict(ds.attrs)
    return res
