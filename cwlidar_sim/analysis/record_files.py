"""Reading a wind record's file: the one reader of the twin's records and of a scene's ``fit_to``.

:func:`read_record_file` turns a CSV or NetCDF file into exact times (a
``cwlidar_sim._times.TimeColumn``: integer ns parsed from a CSV's
digits, read as text, or from NetCDF floats; the unit from the column
header or the spec) and velocities [m/s];
:mod:`cwlidar_sim.analysis.records` cleans them.  Every check that bounds
the work comes before the work:

* the path must name a regular, non-empty file (a directory, a FIFO or a
  device is refused by kind, so that nothing blocks or streams without
  end) no larger than :data:`MAX_FILE_BYTES` (:func:`check_record_file`);
* a record holds at most :data:`MAX_SAMPLES` samples: a NetCDF variable's
  declared length is checked before it is read, a CSV is read in chunks and
  refused as soon as it passes the limit;
* speed units are converted by a table (:func:`parse_speed_units`) and a
  unit that does not parse is refused by name.

Error messages never echo an arbitrary file's bytes: a CSV's column names
are named only when its first line is a header of short names
(``_header_text``), values only as a short, quoted excerpt of a field
the reader expected to be numeric; a file that is not NetCDF is said not to
be, without the libraries' messages (which quote its first bytes).
"""

from __future__ import annotations

import csv
import hashlib
import inspect
import io
import os
import re
import stat

import numpy as np

from .._times import TimeColumn, column_unit, find_time_column, float_times, parse_time_cells, unit_ns

__all__ = ["MAX_FILE_BYTES", "MAX_SAMPLES", "MAX_SPEED", "absurd_speeds", "check_record_file", "file_digest",
           "parse_speed_units", "parse_time_units", "read_record_file"]

#: Largest record file read or hashed [bytes]: 4 GiB (a CSV of 2**25 rows of 4 columns at ~100 characters a row
#: fits; a compressed NetCDF of as many samples is far smaller).
MAX_FILE_BYTES = 4 * 2**30
#: Most samples a record may hold: 2**25 (12 days at 32 Hz; 0.8 GB for three float64 components).
MAX_SAMPLES = 2**25
#: Fastest wind a record may hold [m/s]: above any measured near-surface gust and a sonic's range (about 60 m/s);
#: samples beyond it are wrong units or sentinel values, not wind.
MAX_SPEED = 100.0
_CHUNK_ROWS = 2**20
_HASH_CHUNK = 2**20
_NA_WORDS = ("", "nan", "na", "n/a", "null", "none")
_NA_TOKENS = sorted({f(w) for w in _NA_WORDS for f in (str.lower, str.upper, str.title)} | {"NaN", "N/A"})

_LENGTH = {"m": 1.0, "meter": 1.0, "meters": 1.0, "metre": 1.0, "metres": 1.0, "cm": 0.01, "mm": 1e-3,
           "km": 1e3, "ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "mi": 1609.344, "mile": 1609.344,
           "miles": 1609.344}
_TIME = {"s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3, "min": 60.0,
         "mins": 60.0, "minute": 60.0, "minutes": 60.0, "h": 3600.0, "hr": 3600.0, "hrs": 3600.0,
         "hour": 3600.0, "hours": 3600.0, "d": 86400.0, "day": 86400.0, "days": 86400.0}
_SPEED_WORDS = {"knot": 1852.0 / 3600.0, "knots": 1852.0 / 3600.0, "kt": 1852.0 / 3600.0,
                "kts": 1852.0 / 3600.0, "kn": 1852.0 / 3600.0, "mph": 1609.344 / 3600.0,
                "kph": 1.0 / 3.6, "kmh": 1.0 / 3.6}
_ROLES = {"sonic": ("u", "v", "w"), "cup": ("speed",)}
_CF_NAMES = {
    "u": ("eastward_wind", "x_wind", "u"),
    "v": ("northward_wind", "y_wind", "v"),
    "w": ("upward_air_velocity", "w"),
    "speed": ("wind_speed", "speed", "ws"),
}
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_ .()\[\]/-]{0,39}")


def _short(text, n=32) -> str:
    """A short, printable excerpt of a value the reader expected (for error messages)."""
    s = "".join(c if c.isprintable() else "?" for c in str(text)[:n])
    return repr(s + ("..." if len(str(text)) > n else ""))


def parse_speed_units(units: str) -> float:
    """Factor from a speed unit string to m/s: ``m s-1``, ``m/s``, ``cm s^-1``, ``km h-1``, ``knots``, ``mph`` ...

    Raises ValueError naming the string when it does not parse.
    """
    if not isinstance(units, str):
        raise TypeError(f"units must be a str, got {type(units).__name__}")
    s = units.strip().lower()
    if s in _SPEED_WORDS:
        return _SPEED_WORDS[s]
    m = (re.fullmatch(r"([a-z]+)\s*(?:/|\s+per\s+)\s*([a-z]+)", s)
         or re.fullmatch(r"([a-z]+)\s*[\s.*·]\s*([a-z]+)\s*(?:\^|\*\*)?\s*-\s*1", s))
    if m and m.group(1) in _LENGTH and m.group(2) in _TIME:
        return _LENGTH[m.group(1)] / _TIME[m.group(2)]
    raise ValueError(f"units {_short(units)} do not parse as a speed; allowed: a length over a time such as 'm s-1', "
                     f"'m/s', 'cm s-1', 'km h-1', or 'knots', 'mph'")


def parse_time_units(units: str) -> float:
    """Factor from a time unit string (``s``, ``ms``, ``seconds since 2020-01-01``, ``min``, ``hours`` ...) to seconds.

    The table is ``cwlidar_sim._times``' (the one the readers use, exact in ns).
    """
    if not isinstance(units, str):
        raise TypeError(f"units must be a str, got {type(units).__name__}")
    return unit_ns(units, "time") / 1e9


def check_record_file(path, label: str) -> int:
    """Size [bytes] of a record file after checking it is a regular, non-empty file within :data:`MAX_FILE_BYTES`.

    Symbolic links are followed (the file they name is checked).  Raises
    ValueError naming ``label``, the path and the problem.
    """
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise ValueError(f"{label}: no such file {os.fspath(path)!r}") from None
    except OSError as e:
        raise ValueError(f"{label}: cannot open {os.fspath(path)!r} ({e.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        kind = ("a directory" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode)
                else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
                else "a socket" if stat.S_ISSOCK(st.st_mode) else "not a regular file")
        raise ValueError(f"{label}: {os.fspath(path)!r} is {kind}; allowed: a regular CSV or NetCDF file")
    if st.st_size == 0:
        raise ValueError(f"{label}: {os.fspath(path)!r} is empty (0 bytes)")
    if not os.access(path, os.R_OK):  # else an OSError mid-read, which the CLI reports as a failed write
        raise ValueError(f"{label}: {os.fspath(path)!r} is not readable (permission denied)")
    if st.st_size > MAX_FILE_BYTES:
        raise ValueError(f"{label}: {os.fspath(path)!r} holds {st.st_size / 2**30:.3g} GiB; allowed: at most "
                         f"{MAX_FILE_BYTES / 2**30:.3g} GiB (MAX_FILE_BYTES; split the record)")
    return int(st.st_size)


def file_digest(path, label: str) -> str:
    """SHA-256 hex digest of a record file, read in 1 MiB chunks (after :func:`check_record_file`)."""
    check_record_file(path, label)
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(_HASH_CHUNK), b""):
            h.update(block)
    return h.hexdigest()


# ---------------------------------------------------------------------------
# CSV
# ---------------------------------------------------------------------------
def _header_text(header) -> str:
    """The header's names for a message, or a note that the first line is not a header of column names.

    Names are shown only when every field is a short name (letters, digits,
    ``_ .()[]/-``), so that a file that is not a record is never echoed.
    """
    if 1 <= len(header) <= 64 and all(_NAME.fullmatch(h) for h in header):
        return f"it has {header}"
    return "its first line is not a header of column names (a record's first line names its columns)"


def _first_line(spec):
    """The header row of a CSV (stripped names), with a bounded read; UTF-8 with or without a BOM."""
    try:
        with open(spec.path, newline="", encoding="utf-8-sig") as f:
            line = f.readline(1 << 16)
    except UnicodeDecodeError as e:
        raise ValueError(f"{spec.name}: {spec.path!r} is not UTF-8 text (byte {e.start} of its first line); "
                         f"allowed: a UTF-8 CSV (save it as UTF-8)") from None
    if len(line) >= 1 << 16 and not line.endswith("\n"):
        raise ValueError(f"{spec.name}: the first line of {spec.path!r} is longer than 65536 characters; "
                         f"{_header_text([])}")
    return [h.strip() for h in next(csv.reader(io.StringIO(line)), [])]


class _NotPlain(Exception):
    """A field the fast path (pandas' numeric parser) does not take: blanks around a word, text."""


def _chunks(spec, names, header, plain, tcol=None):
    """pandas chunks of the columns ``names`` (rows after the header): float64 (``plain``) or text; one-line errors.

    The plain chunks are parsed by a correctly rounded converter, so a field
    reads exactly as ``float`` reads it.  The time column ``tcol`` is text
    in both (its digits are parsed exactly by ``cwlidar_sim._times``).
    """
    import pandas as pd

    # Every column is parsed (no usecols: with it pandas drops a line's extra fields silently, and a
    # line with a field too many has its values shifted); only the wanted ones are converted.
    nums = [n for n in names if n != tcol]
    kw = (dict(dtype={**{n: np.float64 for n in nums}, **({tcol: str} if tcol else {})},
               na_values={n: _NA_TOKENS for n in nums}, keep_default_na=False) if plain
          else dict(dtype=str, na_filter=False))
    if plain and int(pd.__version__.split(".")[0]) < 3:
        # Before pandas 3 the default converter is not correctly rounded; "round_trip" is Python's own
        # (pandas 3 deprecates the option: its default agrees with float() on 470 000 test strings).
        kw["float_precision"] = "round_trip"
    try:
        reader = pd.read_csv(spec.path, header=0, names=header, encoding="utf-8-sig",
                             skip_blank_lines=False, index_col=False, engine="c", chunksize=_CHUNK_ROWS, **kw)
        with reader:
            while True:
                try:
                    chunk = next(reader)
                except StopIteration:
                    return
                except (UnicodeDecodeError, pd.errors.ParserError):
                    raise
                except (ValueError, TypeError):
                    if plain:
                        raise _NotPlain() from None
                    raise
                yield chunk[names]
    except UnicodeDecodeError:
        raise ValueError(f"{spec.name}: {spec.path!r} is not UTF-8 text; allowed: a UTF-8 CSV") from None
    except pd.errors.ParserError as e:
        m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(e))
        what = (f"line {m.group(2)} has {m.group(3)} fields, the header {m.group(1)}" if m
                else "it does not parse as CSV")
        raise ValueError(f"{spec.name}: {spec.path!r}: {what}; allowed: one field per column on every line") from None


def _numbers(col, spec, name, first_line):
    """A chunk's column of text as float64 by Python's ``float`` (the fields stripped; missing-value words NaN)."""
    try:  # float() itself takes surrounding blanks, nan and inf: the common case needs no string work
        return col.to_numpy(dtype=object).astype(np.float64)
    except ValueError:
        pass
    s = col.str.strip()
    s = s.where(~s.str.lower().isin(_NA_WORDS), "nan").to_numpy(dtype=object)
    try:
        return s.astype(np.float64)
    except ValueError:
        i = next(j for j, c in enumerate(s) if not _is_float(c))
        raise ValueError(f"{spec.name}: column {name!r} of {spec.path!r} is not numeric at line {first_line + i} "
                         f"({_short(s[i])})") from None


def _is_float(c):
    try:
        float(c)
        return True
    except ValueError:
        return False


def _columns(spec, wanted, header, tcol, plain):
    """{name: [arrays per chunk]} and the row count, refused as soon as the rows pass MAX_SAMPLES.

    The time column's parts are ``cwlidar_sim._times.TimeColumn`` s (exact ns), parsed chunk by chunk so
    that the text of at most one chunk is held at a time.
    """
    parts = {n: [] for n in wanted}
    rows = 0
    where = f"{spec.name}: time column {tcol!r} of {spec.path!r}"
    unit = column_unit(tcol, spec.unit("time"), where) if tcol else None
    for chunk in _chunks(spec, wanted, header, plain, tcol):
        first = rows + 2  # the file's line number of the chunk's first row (the header is line 1)
        rows += len(chunk)
        if rows > MAX_SAMPLES:
            raise ValueError(f"{spec.name}: {spec.path!r} holds more than {MAX_SAMPLES} rows; allowed: at most "
                             f"{MAX_SAMPLES} samples (MAX_SAMPLES; split the record)")
        for n in wanted:
            if n == tcol:
                parts[n].append(parse_time_cells(chunk[n].to_numpy(dtype=object), unit, where, first - 2))
            elif plain:
                parts[n].append(chunk[n].to_numpy(dtype=np.float64))
            else:
                parts[n].append(_numbers(chunk[n], spec, n, first))
    return parts, rows


def _read_csv(spec):
    """(times (TimeColumn) or None, {role: values [m/s]}, {role: units}) of a CSV record, read in chunks of rows."""
    roles = _ROLES[spec.kind]
    header = _first_line(spec)
    if not any(header):
        raise ValueError(f"{spec.name}: {spec.path!r} has no header line of column names")
    names = {r: spec.column(r) or r for r in roles}
    # 'time', or one 'time' with its unit ('time_ms', 'time [ms]'): cwlidar_sim._times
    tcol = spec.column("time") or find_time_column(header, f"{spec.name}: {spec.path!r}")
    wanted = list(dict.fromkeys(list(names.values()) + ([tcol] if tcol else [])))
    missing = [n for n in wanted if n not in header]
    if missing:
        raise ValueError(f"{spec.name}: {spec.path!r} lacks column(s) {missing}; {_header_text(header)}")
    if len(set(header)) != len(header):
        raise ValueError(f"{spec.name}: {spec.path!r} names a column twice; {_header_text(header)}")
    units = {r: spec.unit(r) or "m s-1" for r in roles}
    factors = {r: parse_speed_units(u) for r, u in units.items()}
    try:
        parts, rows = _columns(spec, wanted, header, tcol, plain=True)
    except _NotPlain:  # some field needs Python's float on stripped text
        parts, rows = _columns(spec, wanted, header, tcol, plain=False)
    if rows == 0:
        raise ValueError(f"{spec.name}: {spec.path!r} has a header but no rows")
    out = {r: np.concatenate(parts[n]) * factors[r] for r, n in names.items()}
    t = _join_times(parts[tcol], spec, tcol) if tcol else None
    return t, out, units


def _join_times(parts, spec, tcol):
    """One ``cwlidar_sim._times.TimeColumn`` of the chunks' (the finest resolution of any chunk)."""
    if len({p.iso for p in parts}) > 1:
        raise ValueError(f"{spec.name}: time column {tcol!r} of {spec.path!r} mixes numbers and ISO 8601 times")
    p0 = parts[0]
    return TimeColumn(np.concatenate([p.ns for p in parts]), min(p.quantum_ns for p in parts), iso=p0.iso,
                      unit=p0.unit, where=p0.where)


# ---------------------------------------------------------------------------
# NetCDF
# ---------------------------------------------------------------------------
def _names_text(ds) -> str:
    names = sorted(map(str, ds.variables))
    shown = [n if len(n) <= 40 else n[:40] + "..." for n in names[:20]]
    return f"it has {shown}" + (f" and {len(names) - 20} more" if len(names) > 20 else "")


def _find_variable(ds, role, spec):
    name = spec.column(role)
    if name is not None:
        if name not in ds.variables:
            raise ValueError(f"{spec.name}: {spec.path!r} has no variable {name!r} (columns[{role!r}]); "
                             f"{_names_text(ds)}")
        return name
    by_std = {str(ds[v].attrs.get("standard_name", "")): str(v) for v in ds.variables}
    for cand in _CF_NAMES[role]:
        if cand in by_std:
            return by_std[cand]
        if cand in ds.variables:
            return cand
    raise ValueError(f"{spec.name}: {spec.path!r} has no variable for {role} (tried standard names and names "
                     f"{list(_CF_NAMES[role])}; set columns[{role!r}]); {_names_text(ds)}")


def _numeric_1d(ds, v, spec):
    """A variable's values as float64 after checking its rank, kind and declared length (before reading it)."""
    da = ds[v]
    if da.ndim != 1:
        raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r} has dims {da.dims}; allowed: one")
    if da.size > MAX_SAMPLES:
        raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r} declares {da.size} samples; allowed: at most "
                         f"{MAX_SAMPLES} (MAX_SAMPLES; split the record)")
    if da.dtype.kind not in "fiu":
        raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r} holds {da.dtype} values; allowed: numbers")
    try:
        return np.asarray(da.values, dtype=np.float64)
    except (OSError, RuntimeError, KeyError) as e:
        raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r} cannot be read ({type(e).__name__}: the "
                         f"file is truncated or corrupt)") from None


def _check_hdf5_dimensions(spec):
    """Refuse an HDF5 (netCDF-4) file declaring a dimension longer than MAX_SAMPLES, reading only its metadata."""
    import h5netcdf

    try:
        with h5netcdf.File(spec.path, "r") as f:
            sizes = {str(k): int(d.size) for k, d in f.dimensions.items()}
    except Exception:  # noqa: BLE001  (not HDF5: left to the readers below)
        return
    for k, n in sizes.items():
        if n > MAX_SAMPLES:
            raise ValueError(f"{spec.name}: dimension {k!r} of {spec.path!r} declares {n} samples; allowed: at most "
                             f"{MAX_SAMPLES} (MAX_SAMPLES; split the record)")


def _open_netcdf(spec):
    import xarray as xr

    names = []
    # No default indexes: a dimension coordinate would otherwise be read whole at opening, before its
    # declared length can be checked (a 7 KB netCDF-4 file may declare 2e9 samples).  An xarray without
    # the option gets the HDF5 file's dimensions checked first (netCDF-3 stores its data uncompressed, so
    # its declared sizes are bounded by the file's).
    no_index = {"create_default_indexes": False}
    if "create_default_indexes" not in inspect.signature(xr.open_dataset).parameters:
        no_index = {}
        _check_hdf5_dimensions(spec)
    for engine in ("h5netcdf", "scipy"):
        try:
            return xr.open_dataset(spec.path, engine=engine, decode_times=False, decode_cf=False, **no_index)
        except Exception as e:  # noqa: BLE001  (either engine may refuse the format; their messages quote the file)
            names.append(f"{engine}: {type(e).__name__}")
    raise ValueError(f"{spec.name}: {spec.path!r} is neither netCDF-4 (HDF5) nor netCDF-3, or is truncated "
                     f"({'; '.join(names)})")


def _read_netcdf(spec):
    """(times (TimeColumn, exact ns) or None, {role: values [m/s]}, {role: units}) of a NetCDF record."""
    ds = _open_netcdf(spec)
    with ds:
        out, units = {}, {}
        for role in _ROLES[spec.kind]:
            v = _find_variable(ds, role, spec)
            da = ds[v]
            unit = da.attrs.get("units") or spec.unit(role) or "m s-1"
            try:
                factor = parse_speed_units(str(unit))
            except ValueError as e:
                raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r}: {e}") from None
            a = _numeric_1d(ds, v, spec)
            fill = da.attrs.get("_FillValue", da.attrs.get("missing_value"))
            if fill is not None:
                try:
                    fv = float(np.asarray(fill).ravel()[0])
                except (TypeError, ValueError, IndexError):
                    raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r} has a _FillValue that is not a "
                                     f"number") from None
                a = np.where(a == fv, np.nan, a)
            out[role] = a * factor
            units[role] = str(unit)
        t = None
        tname = spec.column("time") or ("time" if "time" in ds.variables else None)
        if tname is not None:
            if tname not in ds.variables:
                raise ValueError(f"{spec.name}: {spec.path!r} has no time variable {tname!r}; {_names_text(ds)}")
            tu = str(ds[tname].attrs.get("units", spec.unit("time") or "s"))
            where = f"{spec.name}: time variable {tname!r} of {spec.path!r}"
            unit_ns(tu, where)  # the unit before the values are read
            t = float_times(_numeric_1d(ds, tname, spec), tu, where)
    return t, out, units


def read_record_file(spec):
    """(times (TimeColumn) or None, {role: values [m/s]}, {role: units as read}) of a record's file, checked.

    ``spec`` is a :class:`cwlidar_sim.analysis.records.RecordSpec`.  Raises
    ValueError (one line naming the file) for a file that is not a record,
    a record too large, units that do not parse, columns of different
    lengths or fewer than 16 samples.
    """
    check_record_file(spec.path, spec.name)
    ext = os.path.splitext(spec.path)[1].lower()
    if ext in (".csv", ".txt"):
        t, vals, units = _read_csv(spec)
    elif ext in (".nc", ".nc4", ".cdf", ".netcdf"):
        t, vals, units = _read_netcdf(spec)
    else:
        raise ValueError(f"{spec.name}: {spec.path!r} has extension {ext!r}; allowed: .csv, .txt (CSV) or .nc, "
                         f".nc4, .cdf (NetCDF)")
    n = len(next(iter(vals.values())))
    if any(len(v) != n for v in vals.values()) or (t is not None and len(t.ns) != n):
        raise ValueError(f"{spec.name}: columns of {spec.path!r} differ in length")
    if n < 16:
        raise ValueError(f"{spec.name}: {spec.path!r} has {n} samples; allowed: >= 16")
    return t, vals, units


def absurd_speeds(vals, units, spec, max_fraction):
    """Mask of samples faster than :data:`MAX_SPEED` (to be treated as missing); an error when they are many.

    A few such samples are sentinel values or glitches (flagged and filled
    like gaps); more than ``max_fraction`` of them is a record in other
    units than declared, refused with the largest value named.
    """
    bad = np.zeros(len(next(iter(vals.values()))), bool)
    for v in vals.values():
        with np.errstate(invalid="ignore"):
            bad |= np.abs(v) > MAX_SPEED
    if bad.mean() > max_fraction:
        top = max(float(np.nanmax(np.abs(v))) for v in vals.values())
        raise ValueError(f"{spec.name}: {np.count_nonzero(bad)} of {bad.size} samples of {spec.path!r} exceed "
                         f"{MAX_SPEED:g} m/s (largest {top:.4g} m/s read in units {units}); "
                         f"allowed: wind speeds up to {MAX_SPEED:g} m/s (are the units right?)")
    return bad

