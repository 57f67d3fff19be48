"""Measured wind records (sonic, cup) for the virtual twin: file -> checked, cleaned, rotated series.

A :class:`RecordSpec` describes one sensor's file; :func:`read_record` reads
it as one period, :func:`read_periods` as consecutive periods of a given
duration.  Everything is checked before anything is computed, and a bad
record gives a one-line ValueError naming the file, the period and what is
wrong.  :meth:`Record.line_record` hands the result to
:mod:`cwlidar_sim.turbulence.conditioning`.

Files
-----
The file itself is read by :mod:`cwlidar_sim.analysis.record_files`, also
the reader of a scene's ``turbulence.fit_to``: it checks that the path is a
regular, non-empty file within 4 GiB and that the record holds at most
2**25 samples before reading it, and names the file (never its contents)
in its errors.  Samples faster than 100 m/s are wrong units or sentinel
values: a few are gaps, more than ``max_filled_fraction`` an error.

* CSV: a header row of column names, then one row per sample; numbers
  (empty, ``nan`` or ``NA`` fields are missing values).  The time column (if
  any: ``time``, or one ``time`` with its unit, ``time_ms``, ``time [ms]``)
  holds numbers or ISO 8601 timestamps, read as text and kept exact in
  integer ns (``cwlidar_sim._times``); its unit is the header's or the
  spec's ``units['time']`` (they must agree), else seconds; without one the
  spec's ``sample_rate`` gives the times.  Velocities in m/s unless the spec's
  ``units`` says otherwise (CSV carries no units of its own).  Read by
  pandas with the spec's ``sep``, ``decimal``, ``skiprows``, ``comment``
  and ``na_values``; a Campbell TOA5 file is recognised by its first line
  (names from line 2, units from line 3).  ISO times with a zone are
  converted to UTC, naive ones are in the spec's ``timezone`` (else UTC);
  ``Record.start_time`` keeps the absolute start in the zone written.
* A pandas DataFrame (a time index or column) or an xarray Dataset in place
  of the path (Python API), read as a CSV's columns or a NetCDF's variables.
* NetCDF (netCDF-4 through h5netcdf, netCDF-3 through scipy; CF-decoded by
  xarray: ``_FillValue``, ``missing_value``, ``scale_factor``, ``add_offset``): variables
  found by the spec's ``columns``, else by CF standard name or name:
  ``eastward_wind``/``northward_wind``/``upward_air_velocity``,
  ``x_wind``/``y_wind`` (sensor axes), plain ``u``/``v``/``w``; a cup's
  ``wind_speed`` or ``speed``.  The ``units`` attribute is parsed (m s-1,
  m/s, cm s-1, km h-1, knots, mph, ft s-1 ...); units that do not parse are
  an error; a variable without units is taken as m s-1.  Time: a ``time``
  coordinate in s, ms, us, ns, min, h or days (``... since DATE`` accepted:
  the numbers are the file's clock, in ns to the floats' resolution), or
  the spec's ``sample_rate``.

Cleaning (per period)
---------------------
1. Times: strictly increasing (else an error naming the first offending
   sample); samples must sit within a quarter step of the regular grid
   ``t0 + i / fs`` (fs inferred from the exact times and snapped to the
   coarsest decimal within their resolution, or the spec's ``sample_rate``;
   an undeclared rate outside ``RECORD_RATES`` is an error naming the time
   unit that would fit); missing grid times become gaps, and a run of them
   longer than ``max_gap`` is an error before the grid is allocated.
2. Despiking: a sample is a spike if it departs from the running median
   (window ``despike_window`` s) by more than ``despike_threshold`` robust
   standard deviations, 1.4826 x the median absolute deviation of the
   departures over the period (Mauder et al. 2013 use q = 7 with the MAD);
   only runs of at most ``spike_max_run`` samples count as spikes (longer
   excursions are kept as real).  A spike in any component removes the
   sample in all.
3. Gaps (missing values, missing times, spikes): a run up to ``max_gap``
   seconds is filled by linear interpolation (held at the period's edges)
   and flagged (bit 1 spike, bit 2 gap); a longer one, or more than
   ``max_filled_fraction`` filled in all, is an error naming the period and
   the gap.
4. Rotation (sonic) into the mean wind: "double" (yaw to zero mean v, then
   pitch to zero mean w, per period), "planar" (Wilczak et al. 2001: the
   plane ``w = b0 + b1 u + b2 v`` fitted to the periods' means, its normal
   as z, then yaw per period; needs >= 3 periods of different directions),
   or "none" (already in the field's frame).  The sensor's axes must be
   right-handed (east, north, up is).  After rotation u is along the mean
   wind, v to its left, w up.
5. Taylor's hypothesis: the period's mean speed must reach
   ``min_mean_speed`` and its turbulence intensity sigma_u / U stay below
   ``max_intensity``.

A cup gives the horizontal speed ``sqrt((U + u)^2 + v^2)``; it is cleaned by
steps 1-3 and 5 and needs no rotation.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from fractions import Fraction
import os

import numpy as np

from .._times import check_timezone, infer_grid, ns_text, start_timestamp
from .._validation import check_choice, check_keys, check_real, check_tuple
from .record_files import (MAX_SAMPLES, absurd_speeds, as_table, parse_speed_units, parse_time_units,
                           read_record_file)

__all__ = ["RecordSpec", "Record", "read_record", "read_periods", "parse_speed_units", "parse_time_units",
           "fit_mann_to_record"]

KINDS = ("sonic", "cup")
ROTATIONS = ("double", "planar", "none")
FLAG_SPIKE = 1
FLAG_GAP = 2
_ROLES = {"sonic": ("u", "v", "w"), "cup": ("speed",)}


@dataclasses.dataclass(frozen=True)
class RecordSpec:
    """Description of one sensor's record file (frozen, validated).

    Parameters
    ----------
    path : str, pandas.DataFrame or xarray.Dataset
        CSV (``.csv``, ``.txt``) or NetCDF (``.nc``, ``.nc4``, ``.cdf``) file,
        or the record itself in memory (kept as a
        ``cwlidar_sim.analysis.record_files.RecordTable``, compared by identity).
    kind : {"sonic", "cup"}
    position : (float, float, float)
        (x, y, z) of the sensor relative to the scene [m] (x along the mean
        wind, y to the left, z up).
    columns : mapping, optional
        Role -> column or variable name; roles "u", "v", "w" (sonic) or
        "speed" (cup), and "time".  Default: the roles' own names (CSV) or
        the CF names of the module notes (NetCDF).
    sample_rate : float, optional
        fs [Hz] in (0, 1e4]; required without a time column, checked
        against it otherwise.
    noise_std : float
        White measurement noise per sample [m/s], in [0, 10].
    units : mapping, optional
        Role -> unit string for CSV columns (default m s-1, time s); for
        NetCDF it overrides missing units attributes only.
    name : str
        Label (default: the file's name).
    rotation : {"double", "planar", "none"}
        Sonic only (module notes); a cup is never rotated.
    despike_threshold : float
        q in robust standard deviations, > 1 (0 turns despiking off).
    despike_window : float
        Running-median window [s], > 0.
    spike_max_run : int
        Longest run of samples that counts as one spike, >= 1.
    max_gap : float
        Longest gap filled [s], >= 0.
    max_filled_fraction : float
        Largest share of filled samples in a period, in [0, 0.5].
    min_mean_speed : float
        Smallest mean speed for Taylor's hypothesis [m/s], > 0.
    max_intensity : float
        Largest sigma_u / U for Taylor's hypothesis, in (0, 2].
    distance_constant : float
        Cup only: l0 [m] in [0, 100] (0: ideal).
    sep : str
        CSV: the field separator, one character (``","``, ``";"``,
        ``"\\t"``, ``"|"``).
    decimal : {".", ","}
        CSV: the decimal mark (``","``: decimal commas, with ``sep=";"``).
    skiprows : int
        CSV: lines before the header row (a logger's preamble), >= 0.  A
        Campbell TOA5 file (first line ``"TOA5",...``) is recognised
        without it: its column names from line 2, units from line 3.
    comment : str, optional
        CSV: one character; lines that begin with it are skipped, and text
        after it on a line is ignored.
    na_values : sequence of str or float
        CSV: more missing-value markers besides empty, ``nan``, ``NA``,
        ``NAN``, ``null``: words (``"-"``) compared as written, numbers
        (``-9999``) compared by value however written (``-9999.0``,
        ``-9999,00``).  They become gaps (flag FLAG_GAP), never numbers.
    timezone : str, optional
        The zone of ISO 8601 times written without one (a logger's local
        clock): an offset (``"+02:00"``) or an IANA name
        (``"Europe/Berlin"``, daylight-saving time included).  Times written
        with their zone are converted by it; naive times without this
        option are taken as UTC.
    """

    path: str
    kind: str = "sonic"
    position: tuple = (0.0, 0.0, 0.0)
    columns: object = None
    sample_rate: float | None = None
    noise_std: float = 0.0
    units: object = None
    name: str = ""
    rotation: str = "double"
    despike_threshold: float = 7.0
    despike_window: float = 5.0
    spike_max_run: int = 3
    max_gap: float = 1.0
    max_filled_fraction: float = 0.05
    min_mean_speed: float = 1.0
    max_intensity: float = 0.5
    distance_constant: float = 0.0
    sep: str = ","
    decimal: str = "."
    skiprows: int = 0
    comment: str | None = None
    na_values: tuple = ()
    timezone: str | None = None

    def __post_init__(self):
        from .._validation import check_int

        table = as_table(self.path)
        if table is not None:
            object.__setattr__(self, "path", table)
        elif not isinstance(self.path, (str, os.PathLike)) or not str(self.path):
            raise TypeError(f"RecordSpec.path must be a file path, a pandas DataFrame or an xarray Dataset, got "
                            f"{self.path!r}")
        else:
            object.__setattr__(self, "path", str(self.path))
        _check_csv_options(self)
        check_choice("RecordSpec.kind", self.kind, KINDS)
        object.__setattr__(self, "position", check_tuple("RecordSpec.position", self.position, 3, check_real))
        roles = _ROLES[self.kind] + ("time",)
        object.__setattr__(self, "columns", _role_map("columns", self.columns, roles))
        object.__setattr__(self, "units", _role_map("units", self.units, roles))
        if self.sample_rate is not None:
            object.__setattr__(self, "sample_rate", check_real("RecordSpec.sample_rate", self.sample_rate, lo=0.0,
                                                               hi=1e4, lo_open=True))
        for f, lo, hi, lo_open in (("noise_std", 0.0, 10.0, False), ("despike_window", 0.0, 3600.0, True),
                                   ("max_gap", 0.0, 3600.0, False), ("max_filled_fraction", 0.0, 0.5, False),
                                   ("min_mean_speed", 0.0, 100.0, True), ("max_intensity", 0.0, 2.0, True),
                                   ("distance_constant", 0.0, 100.0, False)):
            object.__setattr__(self, f, check_real(f"RecordSpec.{f}", getattr(self, f), lo=lo, hi=hi,
                                                   lo_open=lo_open))
        q = check_real("RecordSpec.despike_threshold", self.despike_threshold, lo=0.0, hi=1e3)
        if 0 < q <= 1:
            raise ValueError(f"RecordSpec.despike_threshold={q} is out of range; allowed: 0 (off) or > 1")
        object.__setattr__(self, "despike_threshold", q)
        object.__setattr__(self, "spike_max_run", check_int("RecordSpec.spike_max_run", self.spike_max_run,
                                                            lo=1, hi=1000))
        check_choice("RecordSpec.rotation", self.rotation, ROTATIONS)
        if self.kind == "cup" and self.rotation != "double" and self.rotation != "none":
            raise ValueError(f"RecordSpec.rotation={self.rotation!r} applies to a sonic; a cup has no axes")
        if self.kind == "sonic" and self.distance_constant > 0:
            raise ValueError("RecordSpec.distance_constant applies to a cup (kind='cup')")
        if not isinstance(self.name, str):
            raise TypeError(f"RecordSpec.name must be a str, got {type(self.name).__name__}")
        if not self.name:
            object.__setattr__(self, "name", self.path.kind if table is not None else os.path.basename(self.path))

    def column(self, role: str) -> str | None:
        return dict(self.columns).get(role)

    def unit(self, role: str) -> str | None:
        return dict(self.units).get(role)

    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        d = dataclasses.asdict(self)
        d["position"] = list(self.position)
        d["columns"] = dict(self.columns)
        d["units"] = dict(self.units)
        d["na_values"] = list(self.na_values)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "RecordSpec":
        """Build from a mapping (e.g. a TOML table); unknown keys are rejected by name."""
        check_keys(cls, d, required=["path"])
        return cls(**d)


def _check_csv_options(spec):
    """The CSV options of a RecordSpec: one-character separators and comment, a known decimal mark and zone."""
    from .._validation import check_int

    for f in ("sep", "comment"):
        v = getattr(spec, f)
        if v is None and f == "comment":
            continue
        if not isinstance(v, str) or len(v) != 1 or v in "\r\n\"" or (f == "comment" and v.isspace()):
            raise ValueError(f"RecordSpec.{f}={v!r} is not a field {'separator' if f == 'sep' else 'comment mark'}; "
                             f"allowed: one character other than a quote or a line end (e.g. ',', ';', '\\t')")
    if spec.decimal not in (".", ","):
        raise ValueError(f"RecordSpec.decimal={spec.decimal!r} is not a decimal mark; allowed: '.' or ','")
    if spec.decimal == spec.sep:
        raise ValueError(f"RecordSpec.decimal={spec.decimal!r} is also the separator sep={spec.sep!r}; allowed: "
                         f"different characters (decimal commas go with sep=';')")
    object.__setattr__(spec, "skiprows", check_int("RecordSpec.skiprows", spec.skiprows, lo=0, hi=10_000))
    na = spec.na_values
    if isinstance(na, (str, bytes, numbers.Real)) or not hasattr(na, "__iter__"):
        na = (na,)
    out = []
    for i, w in enumerate(na):
        if isinstance(w, str):
            try:
                x = float(w.replace(spec.decimal, "."))
                w = x if math.isfinite(x) else w  # '-9999' is the number; 'NAN' a word
            except ValueError:
                pass
        if isinstance(w, bool) or not isinstance(w, (str, numbers.Real)) or (not isinstance(w, str)
                                                                             and not math.isfinite(w)):
            raise ValueError(f"RecordSpec.na_values[{i}]={w!r} is not a missing-value marker; allowed: a word "
                             f"('NAN', '-') or a finite number (-9999)")
        out.append(w if isinstance(w, str) else float(w))
    object.__setattr__(spec, "na_values", tuple(out))
    if spec.timezone is not None:
        check_timezone("RecordSpec.timezone", spec.timezone)


def _role_map(field, value, roles):
    if value is None:
        return ()
    if not isinstance(value, dict) and not (isinstance(value, tuple) and all(len(p) == 2 for p in value)):
        raise TypeError(f"RecordSpec.{field} must be a mapping of role -> name, got {value!r}")
    items = dict(value)
    unknown = sorted(set(items) - set(roles))
    if unknown:
        raise ValueError(f"RecordSpec.{field} has unknown role(s) {unknown}; allowed: {list(roles)}")
    for k, v in items.items():
        if not isinstance(v, str) or not v:
            raise TypeError(f"RecordSpec.{field}[{k!r}] must be a non-empty str, got {v!r}")
    return tuple(sorted(items.items()))


# ---------------------------------------------------------------------------
# reading (the file itself: :mod:`.record_files`, shared with a scene's ``fit_to``)
# ---------------------------------------------------------------------------
def _load(spec):
    """(times (TimeColumn) or None, {role: values [m/s]}, {role: units}); samples beyond MAX_SPEED become NaN (gaps)."""
    t, vals, units = read_record_file(spec)
    bad = absurd_speeds(vals, units, spec, spec.max_filled_fraction)
    if bad.any():
        vals = {r: np.where(bad, np.nan, v) for r, v in vals.items()}
    return t, vals, units


#: Plausible rates of a wind record whose rate is not declared [Hz]: a time column in ms read as s
#: (a 20 Hz sonic at 0.02 Hz) or in min/h read as s (a 20 Hz sonic at 1200 or 72 000 Hz) falls outside.
RECORD_RATES = (0.1, 1000.0)


def _regular_grid(t, vals, spec):
    """Place the samples on t0 + i / fs; missing grid times become NaN.  Returns (fs, t0 [s], {role: values}).

    ``t`` is a ``cwlidar_sim._times.TimeColumn`` (exact ns) or None.
    """
    if t is None:
        if spec.sample_rate is None:
            raise ValueError(f"{spec.name}: {spec.path!r} has no time column; give sample_rate [Hz] in the spec")
        return spec.sample_rate, 0.0, vals
    where = t.where or f"{spec.name}: time of {spec.path!r}"
    # a declared rate vouches for the times' unit through the 1 % check; else the rate must be a wind record's
    rates = (0.0, 1e4) if spec.sample_rate is not None else RECORD_RATES
    fs, idx = infer_grid(t, where, sample_rate=spec.sample_rate, rate_range=rates, unit=t.unit, what="wind record")
    # Missing grid times are checked before the grid is allocated: a row far in the future must not
    # allocate the whole span first.  A run longer than max_gap is an error wherever it lies.
    step_i = np.diff(idx)
    max_run = int(math.floor(spec.max_gap * fs + 1e-9))
    j = int(np.argmax(step_i))
    if step_i[j] - 1 > max_run:
        gap = int(step_i[j]) - 1
        raise ValueError(f"{spec.name}: gap of {gap / fs:.6g} s ({gap} samples) in the time column of {spec.path!r} "
                         f"after t = {ns_text(t.ns[j])} s is longer than max_gap = {spec.max_gap:.6g} s")
    m = int(idx[-1]) + 1
    if m > MAX_SAMPLES:
        raise ValueError(f"{spec.name}: the time column of {spec.path!r} spans {m} samples at {fs:.6g} Hz; allowed: "
                         f"at most {MAX_SAMPLES} (MAX_SAMPLES)")
    out = {}
    for r, v in vals.items():
        a = np.full(m, np.nan)
        a[idx] = v
        out[r] = a
    # the file's clock as written (ISO 8601 times from the file's first sample)
    return fs, (0 if t.iso else int(t.ns[0])) / 10**9, out


def _runs(mask):
    """(start, length) of the runs of True in a boolean array."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts = np.nonzero(d == 1)[0]
    ends = np.nonzero(d == -1)[0]
    return list(zip(starts.tolist(), (ends - starts).tolist()))


def _despike(vals, fs, spec):
    """Mask of spike samples (any component), by the running-median / MAD rule of the module notes."""
    from scipy.ndimage import median_filter

    spikes = np.zeros(len(next(iter(vals.values()))), bool)
    if spec.despike_threshold == 0:
        return spikes
    win = max(3, int(round(spec.despike_window * fs)) | 1)
    for v in vals.values():
        ok = np.isfinite(v)
        if ok.sum() < 16:
            continue
        filled = np.interp(np.arange(v.size), np.nonzero(ok)[0], v[ok])
        dev = filled - median_filter(filled, size=win, mode="nearest")
        mad = np.median(np.abs(dev[ok] - np.median(dev[ok])))
        if not mad > 0:
            continue
        out = ok & (np.abs(dev) > spec.despike_threshold * 1.4826 * mad)
        for s, n in _runs(out):
            if n <= spec.spike_max_run:
                spikes[s:s + n] = True
    return spikes


def _fill(vals, fs, spikes, spec, label, t0):
    """Fill short gaps linearly (hold at the edges); flags; error for long gaps."""
    n = spikes.size
    missing = spikes.copy()
    for v in vals.values():
        missing |= ~np.isfinite(v)
    max_run = int(math.floor(spec.max_gap * fs + 1e-9))
    for s, m in _runs(missing):
        if m > max_run:
            raise ValueError(f"{label}: gap of {m / fs:.6g} s ({m} samples) at t = {t0 + s / fs:.6g} s is longer "
                             f"than max_gap = {spec.max_gap:.6g} s")
    frac = missing.mean()
    if frac > spec.max_filled_fraction:
        raise ValueError(f"{label}: {100 * frac:.3g} % of the samples are missing or spikes; allowed: "
                         f"max_filled_fraction = {100 * spec.max_filled_fraction:.3g} %")
    good = np.nonzero(~missing)[0]
    out = {}
    for r, v in vals.items():
        a = v.copy()
        if missing.any():
            a[missing] = np.interp(np.nonzero(missing)[0], good, v[good])
        out[r] = a
    flags = np.zeros(n, np.uint8)
    flags[spikes] |= FLAG_SPIKE
    flags[missing & ~spikes] |= FLAG_GAP
    return out, flags


# ---------------------------------------------------------------------------
# rotation
# ---------------------------------------------------------------------------
def _double_rotation(u, v, w):
    yaw = math.atan2(v.mean(), u.mean())
    u1 = u * math.cos(yaw) + v * math.sin(yaw)
    v1 = -u * math.sin(yaw) + v * math.cos(yaw)
    pitch = math.atan2(w.mean(), u1.mean())
    u2 = u1 * math.cos(pitch) + w * math.sin(pitch)
    w2 = -u1 * math.sin(pitch) + w * math.cos(pitch)
    return (u2, v1, w2), {"yaw_deg": math.degrees(yaw), "pitch_deg": math.degrees(pitch)}


def _planar_fit(means_p3, label):
    """Wilczak et al. (2001): w = b0 + b1 u + b2 v over the periods' means; the plane's unit normal and b0."""
    m = np.asarray(means_p3)
    if m.shape[0] < 3:
        raise ValueError(f"{label}: rotation='planar' needs >= 3 periods, got {m.shape[0]}; use 'double'")
    A = np.column_stack([np.ones(m.shape[0]), m[:, 0], m[:, 1]])
    if np.linalg.matrix_rank(A, tol=1e-6 * max(1.0, np.abs(A).max())) < 3:
        raise ValueError(f"{label}: rotation='planar' needs periods of different wind directions (the fit is "
                         f"singular); use 'double'")
    b, *_ = np.linalg.lstsq(A, m[:, 2], rcond=None)
    k = np.array([-b[1], -b[2], 1.0])
    return k / np.linalg.norm(k), float(b[0]), b


def _planar_rotation(u, v, w, k, b0):
    vel = np.stack([u, v, w - b0])
    mean = vel.mean(axis=1)
    h = mean - (mean @ k) * k
    i = h / np.linalg.norm(h)
    j = np.cross(k, i)
    return (i @ vel, j @ vel, k @ vel), {"yaw_deg": math.degrees(math.atan2(h[1], h[0])),
                                         "tilt_deg": math.degrees(math.acos(min(1.0, k[2]))), "b0": b0}


# ---------------------------------------------------------------------------
# records
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class Record:
    """One period of a sensor's record, cleaned and in the field's frame.

    Attributes
    ----------
    spec : RecordSpec
    period : int
        Index of the period in the file (0 for :func:`read_record`).
    start : float
        Time of the period's first sample from the file's first [s].
    sample_rate : float
        fs [Hz].
    values : dict
        ``{"u", "v", "w"}`` (sonic, rotated: u along the mean wind, mean
        included) or ``{"speed"}`` (cup) [m/s], finite, regular.
    flags : ndarray of uint8
        Per sample: 0 measured, bit 1 (FLAG_SPIKE) despiked and filled, bit 2
        (FLAG_GAP) missing and filled.
    mean_speed : float
        Mean of u (sonic) or speed (cup) [m/s].
    rotation : dict
        The rotation applied (angles [deg]).
    time0 : float
        Time of the period's first sample on the file's clock [s] (seconds
        as written; ISO 8601 times from the file's first; 0 without a time
        column).
    time0_ns : int
        The same, exact, in integer nanoseconds on the file's clock (numbers
        as written, ISO 8601 times since 1970-01-01T00:00); the twin's clock
        is built on it (float seconds near a Unix time of 1.7e9 s step in 2.4e-7 s).
    units : dict
        Role -> the speed units the file's values were read in (converted to
        m/s).
    start_time : pandas.Timestamp or None
        The absolute time of the period's first sample, in the zone the file
        wrote (``+02:00``, a TOA5 logger's ``timezone``, UTC for NetCDF's
        ``... since DATE``; naive when the file says no zone), or None when
        the times are plain numbers (or there is no time column).  The
        samples are at ``start_time + time_s``.
    """

    spec: RecordSpec
    period: int
    start: float
    sample_rate: float
    values: dict
    flags: np.ndarray
    mean_speed: float
    rotation: dict
    time0: float = 0.0
    time0_ns: int = 0
    units: dict = dataclasses.field(default_factory=dict)
    start_time: object = None

    @property
    def n_samples(self) -> int:
        return self.flags.size

    @property
    def time_s(self) -> np.ndarray:
        """The samples' times from the period's first sample [s]: ``arange(n) / fs``."""
        return np.arange(self.n_samples) / self.sample_rate

    @property
    def n_gaps(self) -> int:
        """Samples missing in the file (empty, a missing-value marker, a fill value, a missing time) and filled."""
        return int(np.count_nonzero(self.flags & FLAG_GAP))

    @property
    def duration(self) -> float:
        return self.n_samples / self.sample_rate

    @property
    def n_spikes(self) -> int:
        return int(np.count_nonzero(self.flags & FLAG_SPIKE))

    @property
    def n_filled(self) -> int:
        return int(np.count_nonzero(self.flags))

    def line_record(self, position=None):
        """This record as a :class:`cwlidar_sim.turbulence.conditioning.LineRecord` (position default: the spec's)."""
        from ..turbulence.conditioning import LineRecord

        return LineRecord(self.spec.position if position is None else position, self.sample_rate, self.values,
                          noise_std=self.spec.noise_std, distance_constant=self.spec.distance_constant,
                          name=f"{self.spec.name}[{self.period}]")


def _clean_period(spec, fs, t0, vals, index):
    label = f"{spec.name} period {index} (t = {t0:.6g}-{t0 + len(next(iter(vals.values()))) / fs:.6g} s)"
    spikes = _despike(vals, fs, spec)
    filled, flags = _fill(vals, fs, spikes, spec, label, t0)
    return label, filled, flags


def _taylor_check(label, spec, u_or_speed):
    U = float(np.mean(u_or_speed))
    if not U >= spec.min_mean_speed:
        raise ValueError(f"{label}: mean speed {U:.3g} m/s is below min_mean_speed = {spec.min_mean_speed:.3g} m/s "
                         f"(Taylor's hypothesis)")
    ti = float(np.std(u_or_speed)) / U
    if ti > spec.max_intensity:
        raise ValueError(f"{label}: turbulence intensity sigma_u/U = {ti:.3g} exceeds max_intensity = "
                         f"{spec.max_intensity:.3g} (Taylor's hypothesis)")
    return U


def read_periods(spec: RecordSpec, period_duration: float | None = None) -> list:
    """Read a record as consecutive periods of ``period_duration`` seconds (None: one period).

    An incomplete last period is dropped.  Returns a list of :class:`Record`;
    ``rotation="planar"`` fits the plane to all the periods' means.
    """
    if not isinstance(spec, RecordSpec):
        raise TypeError(f"spec must be a RecordSpec, got {type(spec).__name__}")
    t, raw, units = _load(spec)
    fs, t0, grid = _regular_grid(t, raw, spec)
    t0_ns = 0 if t is None else int(t.ns[0])
    n = len(next(iter(grid.values())))
    if period_duration is None:
        m = n
    else:
        pd = check_real("period_duration", period_duration, lo=0.0, lo_open=True)
        m = int(round(pd * fs))
        if abs(m - pd * fs) > 1e-6 * max(1.0, pd * fs) or m < 16:
            raise ValueError(f"period_duration = {pd} s is not a whole number (>= 16) of samples at {fs:.6g} Hz")
        if m > n:
            raise ValueError(f"{spec.name}: {spec.path!r} holds {n / fs:.6g} s, less than one period of {pd} s")
    periods = []
    for k in range(n // m):
        sl = slice(k * m, (k + 1) * m)
        label, vals, flags = _clean_period(spec, fs, t0 + k * m / fs, {r: v[sl] for r, v in grid.items()}, k)
        periods.append((label, vals, flags, k * m / fs))
    rot_common = None
    if spec.kind == "sonic" and spec.rotation == "planar":
        means = [[vals[c].mean() for c in "uvw"] for _, vals, _, _ in periods]
        rot_common = _planar_fit(means, spec.name)
    out = []
    for k, (label, vals, flags, start) in enumerate(periods):
        if spec.kind == "sonic":
            if spec.rotation == "double":
                (u, v, w), rot = _double_rotation(vals["u"], vals["v"], vals["w"])
            elif spec.rotation == "planar":
                (u, v, w), rot = _planar_rotation(vals["u"], vals["v"], vals["w"], rot_common[0], rot_common[1])
            else:
                (u, v, w), rot = (vals["u"], vals["v"], vals["w"]), {}
            vals = {"u": u, "v": v, "w": w}
            U = _taylor_check(label, spec, u)
        else:
            rot = {}
            U = _taylor_check(label, spec, vals["speed"])
        for a in vals.values():
            a.setflags(write=False)
        flags.setflags(write=False)
        k_ns = t0_ns + round(Fraction(k * m * 10**9) / Fraction(fs))
        out.append(Record(spec, k, start, fs, vals, flags, U, rot, t0 + start, k_ns, dict(units),
                          start_timestamp(t, k_ns)))
    return out


def read_record(spec: RecordSpec) -> Record:
    """Read a whole file as one period (see :func:`read_periods`); planar fit needs several periods."""
    if isinstance(spec, RecordSpec) and spec.kind == "sonic" and spec.rotation == "planar":
        raise ValueError(f"{spec.name}: rotation='planar' needs several periods; use read_periods or 'double'")
    return read_periods(spec)[0]


def fit_mann_to_record(record: Record, *, k_min: float = 1e-3, k_max: float = 2.0, per_decade: int = 5,
                       segment_duration: float = 600.0):
    """Mann parameters fitted to a sonic record's spectra (as a scene's ``fit_to`` does); returns a MannFit."""
    from .fitting import fit_mann
    from .spectra import component_spectra, log_bins

    if not isinstance(record, Record) or record.spec.kind != "sonic":
        raise ValueError("fit_mann_to_record needs a sonic Record (u, v, w)")
    fs, U = record.sample_rate, record.mean_speed
    seg = min(check_real("segment_duration", segment_duration, lo=0.0, lo_open=True), record.duration)
    lo = max(check_real("k_min", k_min, lo=0.0, lo_open=True), 2 * math.pi / (seg * U))
    hi = min(check_real("k_max", k_max, lo=0.0, lo_open=True), math.pi * fs / U)
    if not hi > lo:
        raise ValueError(f"fit_mann_to_record: no wavenumbers between {lo:.3g} and {hi:.3g} rad/m")
    k, F11, F22, F33, F13, nk = component_spectra(record.values["u"], record.values["v"], record.values["w"], fs=fs,
                                                  U=U, k_edges=log_bins(lo, hi, per_decade), segment_duration=seg)
    return fit_mann(k, F11, F22, F33, F13, n_k=nk)
