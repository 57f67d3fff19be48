"""Time columns kept exactly: cells -> integer nanoseconds, the unit from the header or the spec, the rate inferred.

Measured records and platform series give their sample times as text
(seconds, milliseconds ..., or ISO 8601) or as floats (NetCDF).  Read as
float64 seconds, a Unix time near 1.7e9 s steps in 2.4e-7 s, so a 20 Hz
record's rate comes out 20.0000191 Hz; here every time is an integer number
of nanoseconds, parsed from the text's decimal digits (:mod:`decimal`,
exact), and the rate is inferred from the exact times.

Units
-----
A column header may carry its unit: ``time_ms``, ``time [ms]``, ``time (ms)``,
``time/ms`` (s, ms, us, ns, min, h, d and their spelled-out forms).  A unit
named by the caller (a spec's ``units``) must agree with the header's.  A
column without a unit is read in seconds; a step that gives a rate outside
the plausible range of the series (the caller's) is refused, naming the
column and the unit under which the rate would be plausible.

Rate
----
The grid step is the median step; each sample's index on the grid is its
time over that step, rounded.  The rate is the last index over the span,
snapped to the coarsest decimal (1, 0.1, 0.01, 0.001 Hz) within the span's
resolution (two quanta of the written times plus the largest departure of a
sample from the grid), so a record written with finite digits has the rate
it was logged at (20.0, 32.0, 12.5 Hz), not one that drifts with the digits.
"""

from __future__ import annotations

import dataclasses
import decimal
import re

import numpy as np

__all__ = ["TimeColumn", "split_unit", "find_time_column", "column_unit", "unit_ns", "parse_time_cells",
           "float_times", "infer_grid", "check_increasing", "check_rate", "ns_text", "check_timezone",
           "localize_ns", "start_timestamp"]

_NS = {
    "ns": 1, "nsec": 1, "nanosecond": 1, "nanoseconds": 1,
    "us": 10**3, "µs": 10**3, "usec": 10**3, "microsecond": 10**3, "microseconds": 10**3,
    "ms": 10**6, "msec": 10**6, "millisecond": 10**6, "milliseconds": 10**6,
    "s": 10**9, "sec": 10**9, "secs": 10**9, "second": 10**9, "seconds": 10**9,
    "min": 60 * 10**9, "mins": 60 * 10**9, "minute": 60 * 10**9, "minutes": 60 * 10**9,
    "h": 3600 * 10**9, "hr": 3600 * 10**9, "hrs": 3600 * 10**9, "hour": 3600 * 10**9, "hours": 3600 * 10**9,
    "d": 86400 * 10**9, "day": 86400 * 10**9, "days": 86400 * 10**9,
}
# 'time [ms]', 'time (ms)', or 'time_ms' / 'time/ms' / 'time ms'
_HEADER = re.compile(r"^\s*(?P<base>.*?)\s*"
                     r"(?:\[\s*(?P<a>[^\]]+?)\s*\]|\(\s*(?P<b>[^)]+?)\s*\)|[_/ ](?P<c>[A-Za-zµ]+))\s*$")
_MISSING = ("", "nan", "na", "n/a", "null", "none")
# an ISO 8601 time with its zone: '...12:00:00.05+02:00', '...T12:00Z', '... 12:00:00 -0500'
_ZONED = re.compile(r"^(?P<body>.*\d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)\s*(?P<tz>Z|UTC|[+-]\d{2}(?::?\d{2})?)$")


@dataclasses.dataclass(frozen=True)
class TimeColumn:
    """Exact sample times: ``ns`` [ns, int64, on the file's clock] and the resolution of the written values.

    ``quantum_ns`` is the smallest step the file can express (1e-3 s for
    times written with three decimals); ``iso`` tells that the times were
    ISO 8601 (nanoseconds since 1970-01-01T00:00 UTC; naive times as UTC
    unless a time zone is named for them); ``unit`` is the unit the numbers
    were read in; ``where`` names the column (file and column) for messages.
    ``tz`` is the zone the times were written in (``'+02:00'``, ``'UTC'``,
    ``'Europe/Berlin'``; None: not said); ``epoch_ns`` is the instant of
    the clock's zero in ns since 1970-01-01T00:00 UTC (0 for ISO times, the
    reference of ``seconds since DATE``; None: the clock is not absolute).
    """

    ns: np.ndarray
    quantum_ns: float
    iso: bool = False
    unit: str = "s"
    where: str = ""
    tz: str | None = None
    epoch_ns: int | None = None


def split_unit(header: str):
    """``(base, unit)`` of a column header: ``'time_ms'`` -> ``('time', 'ms')``; unit None when none is written."""
    h = str(header).strip()
    m = _HEADER.match(h)
    if m:
        unit = m.group("a") or m.group("b") or m.group("c")
        if unit and unit.strip().lower() in _NS:
            return m.group("base").strip(), unit.strip()
    return h, None


def find_time_column(header, where: str):
    """The time column of a header: 'time', or the one 'time' with a unit ('time_ms', 'time [ms]'); None if none."""
    cands = [h for h in header if split_unit(h)[0].lower() == "time"]
    if len(cands) > 1:
        raise ValueError(f"{where}: several time columns {cands}; allowed: one (or name it: "
                         f"columns = {{ time = ... }})")
    return cands[0] if cands else None


def column_unit(name, declared, where: str) -> str:
    """A time column's unit: its header's (``'time_ms'``) or the ``declared`` one (they must agree), else ``'s'``."""
    hu = split_unit(name)[1] if name else None
    if hu and declared and unit_ns(hu, where) != unit_ns(declared, where):
        raise ValueError(f"{where}: the header says {hu!r} but the declared unit is {declared!r}; allowed: one unit")
    return declared or hu or "s"


def unit_ns(unit: str, where: str) -> int:
    """Nanoseconds per ``unit`` (``'s'``, ``'ms'``, ``'seconds since 2020-01-01'`` ...); ValueError naming ``where``."""
    if not isinstance(unit, str):
        raise TypeError(f"{where}: time units must be a str, got {type(unit).__name__}")
    s = unit.strip().lower().split(" since ")[0].strip()
    if s not in _NS:
        raise ValueError(f"{where}: time units {unit!r} do not parse; allowed: s, ms, us, ns, min, h, d (optionally "
                         f"'... since DATE')")
    return _NS[s]


def _plain_decimal_ns(cells, per: int):
    """``(ns, places)`` of cells that are all plain ASCII decimals (``-12.345``), exactly; None for any other column.

    Vectorised (numpy string functions): a wind record's column of a million
    times costs no :class:`decimal.Decimal` per cell.  Taken only when every
    cell's value in ns is a whole number that fits int64 without rounding
    (``per`` a power of ten, at most as many decimals as it resolves, below
    2**63 ns); else None, and :func:`parse_time_cells` reads the
    cells by :mod:`decimal` (exponents, rounding, minutes, overflow).
    """
    S = getattr(np, "strings", None)  # numpy >= 2.3 (partition); older numpy takes the decimal path
    k = len(str(per)) - 1
    if S is None or not hasattr(S, "partition") or per != 10**k or not cells or "\x00" in "".join(cells):
        return None  # (a NUL: numpy's fixed-width strings would drop it at a cell's end)
    try:
        a = np.array(cells, dtype="S")  # ASCII only (str.isdigit would also take '²' or other scripts' digits)
    except UnicodeEncodeError:
        return None
    body = S.lstrip(a, b"+-")
    if np.any(S.str_len(a) - S.str_len(body) > 1):
        return None
    ip, _, fp = S.partition(body, b".")
    li, lf = S.str_len(ip), S.str_len(fp)
    ok = (S.isdigit(ip) | (li == 0)) & (S.isdigit(fp) | (lf == 0)) & (li + lf > 0)
    if not ok.all() or lf.max() > k:
        return None
    digits = int(S.str_len(S.lstrip(ip, b"0")).max()) + k  # of the ns, leading zeros aside
    if digits > 19:
        return None
    try:
        whole = np.where(li == 0, b"0", ip).astype(np.int64)
    except (OverflowError, ValueError):  # 19 digits beyond int64
        return None
    if digits == 19 and whole.max() > (2**63 - 1 - (10**k - 1)) // per:
        return None
    ns = whole * np.int64(per)
    if k:
        ns += S.ljust(fp, k, b"0").astype(np.int64)
    return np.where(S.startswith(a, b"-"), -ns, ns), int(lf.max())


def _not_times(cells, where: str, first: int) -> str:
    """The message for cells that are not all numbers or all ISO 8601: the first offending cell, a short excerpt."""
    def number(c):
        try:
            return decimal.Decimal(c).is_finite()
        except decimal.InvalidOperation:
            return False

    def iso(c):
        try:
            return not np.isnat(np.datetime64(c, "ns"))
        except ValueError:
            return False

    for i, c in enumerate(cells):
        if not (number(c) or iso(c)):
            text = "".join(ch if ch.isprintable() else "?" for ch in c[:32]) + ("..." if len(c) > 32 else "")
            return f"{where}: holds neither numbers nor ISO 8601 times (sample {first + i}: {text!r})"
    return f"{where}: mixes numbers and ISO 8601 times; allowed: one or the other"


def parse_time_cells(cells, unit: str, where: str, first: int = 0, tz: str | None = None) -> TimeColumn:
    """Text cells (numbers in ``unit``, or ISO 8601 times) -> a :class:`TimeColumn`, exactly.

    A missing cell (empty, ``nan``) is an error naming its sample; so is a
    column that is neither numbers nor ISO 8601 times.  ``first`` is the
    sample number of ``cells[0]`` in its column (a reader parsing a long
    column in chunks names the column's sample, not the chunk's).  ISO times
    with a zone (``+02:00``, ``Z``) are converted to UTC exactly; naive ones
    are in the zone ``tz`` (an offset or a name, DST included; None: UTC).
    """
    cells = [str(c).strip() for c in cells]
    for i, c in enumerate(cells):
        if c.lower() in _MISSING:
            raise ValueError(f"{where}: time is missing at sample {first + i}")
    per = unit_ns(unit, where)
    plain = _plain_decimal_ns(cells, per)
    if plain is not None:  # the usual column, without a Decimal per cell: the same ns, exactly
        ns, places = plain
        return TimeColumn(ns, max(1.0, per * 10.0 ** (-places)), unit=unit, where=where)
    try:
        dec = [decimal.Decimal(c) for c in cells]
    except decimal.InvalidOperation:
        dec = None
    if dec is not None:
        bad = next((i for i, d in enumerate(dec) if not d.is_finite()), None)
        if bad is not None:
            raise ValueError(f"{where}: time is missing at sample {first + bad} ({cells[bad]!r})")
        places = max(-d.as_tuple().exponent for d in dec)
        with decimal.localcontext() as ctx:
            ctx.prec = 60  # Unix ns need 19 digits; any written time fits exactly
            ns = [int((d * per).to_integral_value(rounding=decimal.ROUND_HALF_EVEN)) for d in dec]
        if max(abs(ns[0]), abs(ns[-1]), max(map(abs, ns))) >= 2**63:
            raise ValueError(f"{where}: times beyond +-292 years in ns; allowed: |t| < 9.2e18 ns")
        quantum = max(1.0, per * 10.0 ** (-max(places, 0)))
        return TimeColumn(np.array(ns, dtype=np.int64), quantum, unit=unit, where=where)
    zoned = [_ZONED.match(c) for c in cells]
    n_zoned = sum(z is not None for z in zoned)
    if 0 < n_zoned < len(cells):
        i = next(i for i, z in enumerate(zoned) if (z is None) != (zoned[0] is None))
        raise ValueError(f"{where}: mixes times with and without a time zone (sample {first + i}); allowed: one "
                         f"or the other")
    body = [z.group("body").replace(",", ".") for z in zoned] if n_zoned else cells
    try:
        d = np.array(body, dtype="datetime64[ns]")
    except ValueError:
        raise ValueError(_not_times(cells, where, first)) from None
    if np.any(np.isnat(d)):
        i = int(np.nonzero(np.isnat(d))[0][0])
        raise ValueError(f"{where}: time is missing at sample {first + i}")
    frac = [c.split(".", 1)[1] if "." in c else "" for c in body]
    places = max(len(re.match(r"\d*", f).group(0)) for f in frac)
    ns = d.astype(np.int64)
    if n_zoned:
        offs = [_offset_ns(z.group("tz")) for z in zoned]
        ns = ns - np.array(offs, dtype=np.int64)
        zone = _zone_text(zoned[0].group("tz"))
    elif tz is not None:
        ns, zone = localize_ns(ns, tz, where, first), str(tz)
    else:
        zone = None
    return TimeColumn(ns, max(1.0, 1e9 * 10.0 ** -places), iso=True, where=where, tz=zone, epoch_ns=0)


def _offset_ns(text: str) -> int:
    """ns east of UTC of an ISO 8601 zone designator (``Z``, ``+02:00``, ``-0530``, ``+02``)."""
    if text in ("Z", "UTC"):
        return 0
    sign = -1 if text[0] == "-" else 1
    digits = text[1:].replace(":", "")
    return sign * (int(digits[:2]) * 3600 + int(digits[2:4] or 0) * 60) * 10**9


def _zone_text(text: str) -> str:
    """A zone designator as written in a record's ``start_time``: ``'UTC'`` or ``'+02:00'``."""
    if text in ("Z", "UTC"):
        return "UTC"
    digits = text[1:].replace(":", "")
    return f"{text[0]}{digits[:2]}:{digits[2:4] or '00'}"


def check_timezone(name: str, tz) -> str:
    """A time zone as given (``'+02:00'``, ``'UTC'``, ``'Europe/Berlin'``) after checking pandas knows it."""
    import pandas as pd

    if not isinstance(tz, str) or not tz.strip():
        raise TypeError(f"{name} must be a time zone name or offset (e.g. '+02:00', 'Europe/Berlin'), got {tz!r}")
    try:
        pd.Timestamp("2000-01-01").tz_localize(_pandas_zone(tz))
    except Exception:  # noqa: BLE001  (pytz, zoneinfo and dateutil each raise their own)
        raise ValueError(f"{name}={tz!r} is not a time zone; allowed: an offset such as '+02:00' or '-0500', 'UTC', "
                         f"or an IANA name such as 'Europe/Berlin'") from None
    return tz


def _pandas_zone(tz: str):
    """``tz`` as pandas takes it: an offset as a fixed ``datetime.timezone``, a name as is."""
    import datetime

    m = re.fullmatch(r"[+-]\d{2}(?::?\d{2})?", tz.strip())
    if m:
        return datetime.timezone(datetime.timedelta(seconds=_offset_ns(tz.strip()) // 10**9))
    return tz.strip()


def localize_ns(ns, tz: str, where: str, first: int = 0) -> np.ndarray:
    """Naive wall-clock times [ns] in zone ``tz`` -> ns since 1970 UTC (a DST gap or fold is an error naming the sample)."""
    import pandas as pd

    idx = pd.DatetimeIndex(np.asarray(ns, dtype=np.int64).view("datetime64[ns]"))
    try:
        out = idx.tz_localize(_pandas_zone(tz), ambiguous="NaT", nonexistent="NaT")
    except Exception:  # noqa: BLE001
        raise ValueError(f"{where}: time zone {tz!r} is not known") from None
    bad = np.asarray(out.isna())
    if bad.any():
        i = int(np.nonzero(bad)[0][0])
        raise ValueError(f"{where}: time at sample {first + i} is ambiguous or does not exist in time zone {tz!r} "
                         f"(a daylight-saving change); allowed: times with their offset (e.g. +02:00)")
    return np.asarray(out.tz_convert("UTC").as_unit("ns").asi8, dtype=np.int64)


def float_times(values, unit: str, where: str) -> TimeColumn:
    """Float times in ``unit`` (a NetCDF coordinate) -> a :class:`TimeColumn`; the resolution is the floats' own."""
    v = np.asarray(values, dtype=np.float64)
    if v.ndim != 1:
        raise ValueError(f"{where}: time has dims of shape {v.shape}; allowed: one")
    if not np.all(np.isfinite(v)):
        i = int(np.nonzero(~np.isfinite(v))[0][0])
        raise ValueError(f"{where}: time is missing at sample {i}")
    per = unit_ns(unit, where)
    if v.size and np.max(np.abs(v)) * per >= 2**63:
        raise ValueError(f"{where}: times beyond +-292 years in ns; allowed: |t| < 9.2e18 ns")
    # whole units and the fraction apart: both exact in float64, the product of the fraction below 1 unit
    whole = np.trunc(v)
    ns = whole.astype(np.int64) * np.int64(per) + np.rint((v - whole) * per).astype(np.int64)
    quantum = float(np.spacing(np.max(np.abs(v)))) * per if v.size else 1.0
    epoch, zone = _since(unit, where)
    return TimeColumn(ns, max(1.0, quantum), unit=unit, where=where, tz=zone, epoch_ns=epoch)


def _since(unit: str, where: str):
    """(ns since 1970 UTC, zone) of the reference of ``'... since DATE'`` units (CF: a naive DATE is UTC); (None, None)."""
    import pandas as pd

    parts = unit.strip().split(" since ", 1)
    if len(parts) < 2:
        return None, None
    try:
        ref = pd.Timestamp(parts[1].strip())
    except (ValueError, TypeError, OverflowError):
        raise ValueError(f"{where}: time units {unit!r}: the reference date does not parse") from None
    if ref.tzinfo is None:
        return int(ref.as_unit("ns").value), "UTC"
    off = ref.utcoffset()
    zone = "UTC" if not off else _zone_text(f"{'-' if off.total_seconds() < 0 else '+'}"
                                            f"{int(abs(off.total_seconds())) // 3600:02d}:"
                                            f"{int(abs(off.total_seconds())) % 3600 // 60:02d}")
    return int(ref.tz_convert("UTC").as_unit("ns").value), zone


def ns_text(ns: int) -> str:
    """Exact decimal seconds of ``ns`` nanoseconds, e.g. ``'1700000000.525000000'``."""
    ns = int(ns)
    sign = "-" if ns < 0 else ""
    q, r = divmod(abs(ns), 10**9)
    return f"{sign}{q}.{r:09d}"


def _snap(fs_est: float, tol: float) -> float:
    for places in range(4):  # down to 1 mHz: finer "round" rates are not a logger's settings
        c = round(fs_est, places)
        if c > 0 and abs(c - fs_est) <= tol:
            return float(c)
    return fs_est


def check_increasing(tc: TimeColumn, where: str) -> np.ndarray:
    """The times (int64 ns) after checking there are >= 2 and they strictly increase (else the sample is named)."""
    t = np.asarray(tc.ns, dtype=np.int64)
    if t.size < 2:
        raise ValueError(f"{where}: {t.size} time(s); allowed: >= 2")
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.nonzero(d <= 0)[0][0])
        how = "repeats" if d[i] == 0 else "goes back"
        raise ValueError(f"{where}: time is not strictly increasing: sample {i + 1} at t = {ns_text(t[i + 1])} s "
                         f"{how} after t = {ns_text(t[i])} s (duplicated or unsorted times)")
    return t


def check_rate(step_ns: float, where: str, *, rate_range=(0.0, np.inf), unit="s", what="series") -> float:
    """``1 / step`` [Hz] after checking it lies in ``rate_range``; else an error naming the plausible units."""
    lo, hi = rate_range
    fs = 1e9 / step_ns
    if lo <= fs <= hi:
        return fs
    per = _NS.get(unit.strip().lower().split(" since ")[0].strip(), 10**9)
    alt = [(u, fs * per / _NS[u]) for u in ("ns", "us", "ms", "s", "min", "h") if _NS[u] != per]
    # the likeliest first: nearest (in log) to 10 Hz, a usual logging rate of wind and motion records
    alt = sorted([(u, f) for u, f in alt if lo <= f <= hi], key=lambda a: abs(np.log10(a[1] / 10.0)))
    hint = ("; read in " + ", in ".join(f"{u} it would be {f:.4g} Hz" for u, f in alt)
            + f": name the unit in the header (e.g. 'time_{alt[0][0]}' or 'time [{alt[0][0]}]')") if alt else ""
    raise ValueError(f"{where}: read in {unit}, the times step by {step_ns / 1e9:.6g} s ({fs:.6g} Hz); allowed: a "
                     f"{what} at {lo:g}-{hi:g} Hz{hint}")


def infer_grid(tc: TimeColumn, where: str, *, sample_rate=None, rate_range=(0.0, np.inf), unit="s",
               what="series"):
    """``(fs, idx)``: the sampling rate [Hz] and each sample's index on the grid ``t0 + idx / fs``.

    Parameters
    ----------
    tc : TimeColumn
        The exact times.
    where : str
        The column, for messages (file and column name).
    sample_rate : float, optional
        A declared rate [Hz]: must agree with the times' median step within
        1 %; it is then the grid's.
    rate_range : (float, float)
        Plausible rates [Hz] of the series; a rate outside is an error naming
        the unit that would make it plausible (a column in ms read as s).
    unit : str
        The unit the column was read in (for the message).
    what : str
        What the series is (for the message).

    Raises ValueError for fewer than 2 samples, times that do not increase
    (the first offending sample named), a rate out of ``rate_range``, or a
    sample more than a quarter step off the grid.
    """
    t = check_increasing(tc, where)
    step = float(np.median(np.diff(t)))  # ns
    fs_step = check_rate(step, where, rate_range=rate_range, unit=unit, what=what)
    rel = (t - t[0]).astype(np.float64)  # exact below 2**53 ns (104 days)
    idx = np.rint(rel / step).astype(np.int64)
    span = rel[-1]
    if sample_rate is not None:
        if abs(sample_rate * step / 1e9 - 1.0) > 0.01:
            raise ValueError(f"{where}: sample_rate = {sample_rate} Hz but the times step by {step / 1e9:.6g} s "
                             f"({fs_step:.6g} Hz)")
        fs = float(sample_rate)
    else:
        fs_est = idx[-1] * 1e9 / span
        dev = float(np.max(np.abs(rel - idx * (1e9 / fs_est))))
        fs = _snap(fs_est, fs_est * (2.0 * tc.quantum_ns + dev) / span)
    pos = rel * (fs / 1e9)
    idx = np.rint(pos).astype(np.int64)
    off = np.abs(pos - idx)
    if np.any(off > 0.25):
        i = int(np.argmax(off))
        raise ValueError(f"{where}: sample {i} at t = {ns_text(t[i])} s lies {off[i]:.2f} steps off the regular "
                         f"{fs:.9g} Hz grid; allowed: 0.25 (resample irregular series first)")
    if np.any(np.diff(idx) == 0):
        i = int(np.nonzero(np.diff(idx) == 0)[0][0])
        raise ValueError(f"{where}: samples {i} and {i + 1} fall on one time step of the {fs:.9g} Hz grid")
    return fs, idx


def start_timestamp(tc: TimeColumn, ns: int):
    """The absolute time of ``ns`` on ``tc``'s clock as a pandas Timestamp in the zone written (naive when the
    zone is not said), or None for a clock that is not absolute (plain numbers)."""
    import pandas as pd

    if tc is None or tc.epoch_ns is None:
        return None
    t = pd.Timestamp(int(tc.epoch_ns) + int(ns), unit="ns")
    return t if tc.tz is None else t.tz_localize("UTC").tz_convert(_pandas_zone(tc.tz))
