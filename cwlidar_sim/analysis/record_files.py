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

import dataclasses
import hashlib
import inspect
import io
import os
import re
import stat

import numpy as np

from .._times import (TimeColumn, column_unit, find_time_column, float_times, localize_ns, parse_time_cells,
                      split_unit, unit_ns)

__all__ = ["MAX_FILE_BYTES", "MAX_SAMPLES", "MAX_SPEED", "absurd_speeds", "as_table", "check_record_file",
           "file_digest", "parse_speed_units", "parse_time_units", "read_record_file", "RecordTable"]

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
_HEADER_LINE = 1 << 16

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


class RecordTable:
    """A record held in memory (a pandas DataFrame or an xarray Dataset) where a RecordSpec takes a file path.

    Compared by identity (a table's ``==`` is element-wise); its repr is one
    line (messages name it as they name a file).
    """

    __slots__ = ("data", "kind")

    def __init__(self, data, kind):
        self.data, self.kind = data, kind

    def __repr__(self):
        if self.kind == "DataFrame":
            return f"<DataFrame of {len(self.data)} rows x {self.data.shape[1]} columns>"
        return f"<Dataset of {dict(self.data.sizes)}>"

    def __eq__(self, other):
        return self is other or (isinstance(other, RecordTable) and other.data is self.data)

    def __hash__(self):
        return id(self.data)


def as_table(obj):
    """A :class:`RecordTable` of a pandas DataFrame or an xarray Dataset (kept as is if one already); else None."""
    if isinstance(obj, RecordTable):
        return obj
    import pandas as pd
    import xarray as xr

    if isinstance(obj, pd.DataFrame):
        return RecordTable(obj, "DataFrame")
    if isinstance(obj, xr.Dataset):
        return RecordTable(obj, "Dataset")
    return None


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


@dataclasses.dataclass(frozen=True)
class _Layout:
    """Where a CSV's rows are: its column names, the lines before its first data line, the units its file gives."""

    header: list
    data_start: int
    units: dict
    toa5: bool = False


def _split(line, spec):
    """A header line's fields (pandas' tokenizer, the spec's ``sep``; quotes removed, blanks stripped)."""
    import pandas as pd

    if not line.strip():
        return []
    try:
        row = pd.read_csv(io.StringIO(line), sep=spec.sep, header=None, dtype=str, keep_default_na=False,
                          na_filter=False, index_col=False, engine="c").iloc[0]
    except (pd.errors.ParserError, pd.errors.EmptyDataError, IndexError, ValueError):
        return [line.strip()]  # not a header (named as such, never echoed)
    return [str(h).strip() for h in row]


def _layout(spec) -> _Layout:
    """The header rows of a CSV: a plain one (after ``skiprows`` lines and comment lines) or Campbell TOA5's four.

    TOA5 (the file-info line starts with ``TOA5``): line 2 names the
    columns, line 3 gives their units, line 4 the loggers' processing; rows
    from line 5.  Lines are read bounded (65536 characters), UTF-8 with or
    without a BOM.
    """
    count = 0
    with open(spec.path, newline="", encoding="utf-8-sig") as f:
        def line():
            nonlocal count
            try:
                text = f.readline(_HEADER_LINE)
            except UnicodeDecodeError as e:
                raise ValueError(f"{spec.name}: {spec.path!r} is not UTF-8 text (byte {e.start} of its line "
                                 f"{count + 1}); allowed: a UTF-8 CSV (save it as UTF-8)") from None
            count += 1
            if len(text) >= _HEADER_LINE and not text.endswith("\n"):
                raise ValueError(f"{spec.name}: line {count} of {spec.path!r} is longer than 65536 characters; "
                                 f"{_header_text([])}")
            return text

        first = line()
        if first.lstrip().lstrip('"').startswith("TOA5"):
            header = _split(line(), spec)
            units = _split(line(), spec)
            line()
            return _Layout(header, 4, {h: u for h, u in zip(header, units) if u}, toa5=True)
        for _ in range(spec.skiprows):
            first = line()
        while spec.comment and first.lstrip().startswith(spec.comment):
            first = line()
        return _Layout(_split(first, spec), count, {})


def _line_of(spec, layout, row) -> int:
    """The file's line number of data row ``row`` (0 the first): comment lines between rows are counted."""
    if not spec.comment:
        return layout.data_start + 1 + row
    with open(spec.path, newline="", encoding="utf-8-sig", errors="replace") as f:
        n, seen = 0, -1
        for n, text in enumerate(f, start=1):
            if n > layout.data_start and not text.lstrip().startswith(spec.comment):
                seen += 1
                if seen == row:
                    return n
    return layout.data_start + 1 + row


class _NotPlain(Exception):
    """A field the fast path (pandas' numeric parser) does not take: blanks around a word, text."""


def _chunks(spec, names, layout, plain, tcol=None):
    """pandas chunks of the columns ``names`` (rows after the header): float64 (``plain``) or text; one-line errors.

    The plain chunks are parsed by a correctly rounded converter, so a field
    reads exactly as ``float`` reads it.  The time column ``tcol`` is text
    in both (its digits are parsed exactly by ``cwlidar_sim._times``).
    """
    import pandas as pd

    # Every column is parsed (no usecols: with it pandas drops a line's extra fields silently, and a
    # line with a field too many has its values shifted); only the wanted ones are converted.
    nums = [n for n in names if n != tcol]
    tokens = _NA_TOKENS + [w for w in spec.na_values if isinstance(w, str)]
    kw = (dict(dtype={**{n: np.float64 for n in nums}, **({tcol: str} if tcol else {})},
               na_values={n: tokens for n in nums}, keep_default_na=False, decimal=spec.decimal) if plain
          else dict(dtype=str, na_filter=False))
    if plain and int(pd.__version__.split(".")[0]) < 3:
        # Before pandas 3 the default converter is not correctly rounded; "round_trip" is Python's own
        # (pandas 3 deprecates the option: its default agrees with float() on 470 000 test strings).
        kw["float_precision"] = "round_trip"
    try:
        reader = pd.read_csv(spec.path, header=None, names=layout.header, skiprows=layout.data_start, sep=spec.sep,
                             comment=spec.comment, encoding="utf-8-sig", skip_blank_lines=False, index_col=False,
                             engine="c", chunksize=_CHUNK_ROWS, **kw)
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


def _numbers(col, spec, name, line_of):
    """A chunk's column of text as float64 by Python's ``float`` (the fields stripped; missing-value words NaN).

    ``line_of(i)`` is the file's line of the chunk's row ``i`` (for the message).
    """
    if spec.decimal != ".":
        col = col.str.replace(spec.decimal, ".", regex=False)
    try:  # float() itself takes surrounding blanks, nan and inf: the common case needs no string work
        return col.to_numpy(dtype=object).astype(np.float64)
    except ValueError:
        pass
    s = col.str.strip()
    words = [w for w in spec.na_values if isinstance(w, str)]
    s = s.where(~(s.str.lower().isin(_NA_WORDS) | s.isin(words)), "nan").to_numpy(dtype=object)
    try:
        return s.astype(np.float64)
    except ValueError:
        i = next(j for j, c in enumerate(s) if not _is_float(c))
        raise ValueError(f"{spec.name}: column {name!r} of {spec.path!r} is not numeric at line {line_of(i)} "
                         f"({_short(s[i])})") from None


def _fill_values(a, spec):
    """NaN for the spec's numeric ``na_values`` (a logger's -9999 however written: -9999, -9999.0, -9999,00)."""
    fills = [float(w) for w in spec.na_values if not isinstance(w, str)]
    if fills:
        a = np.where(np.isin(a, fills), np.nan, a)
    return a


def _is_float(c):
    try:
        float(c)
        return True
    except ValueError:
        return False


def _columns(spec, wanted, layout, tcol, plain):
    """{name: [arrays per chunk]} and the row count, refused as soon as the rows pass MAX_SAMPLES.

    The time column's parts are ``cwlidar_sim._times.TimeColumn`` s (exact ns), parsed chunk by chunk so
    that the text of at most one chunk is held at a time.
    """
    parts = {n: [] for n in wanted}
    rows = 0
    where = f"{spec.name}: time column {tcol!r} of {spec.path!r}"
    unit = column_unit(tcol, spec.unit("time"), where) if tcol else None
    for chunk in _chunks(spec, wanted, layout, plain, tcol):
        first = rows  # the chunk's first data row
        rows += len(chunk)
        if rows > MAX_SAMPLES:
            raise ValueError(f"{spec.name}: {spec.path!r} holds more than {MAX_SAMPLES} rows; allowed: at most "
                             f"{MAX_SAMPLES} samples (MAX_SAMPLES; split the record)")
        for n in wanted:
            if n == tcol:
                cells = chunk[n].to_numpy(dtype=object)
                if spec.decimal != ".":  # '12,5' s, and ISO 8601's own '12:00:00,05'
                    cells = np.array([str(c).replace(spec.decimal, ".") for c in cells], dtype=object)
                parts[n].append(parse_time_cells(cells, unit, where, first, tz=spec.timezone))
            elif plain:
                parts[n].append(_fill_values(chunk[n].to_numpy(dtype=np.float64), spec))
            else:
                parts[n].append(_fill_values(_numbers(chunk[n], spec, n,
                                                      lambda i, f=first: _line_of(spec, layout, f + i)), spec))
    return parts, rows


def _read_csv(spec):
    """(times (TimeColumn) or None, {role: values [m/s]}, {role: units}) of a CSV record, read in chunks of rows."""
    roles = _ROLES[spec.kind]
    layout = _layout(spec)
    header = layout.header
    if not any(header):
        raise ValueError(f"{spec.name}: {spec.path!r} has no header line of column names")
    names = {r: spec.column(r) or r for r in roles}
    # 'time', or one 'time' with its unit ('time_ms', 'time [ms]'): cwlidar_sim._times; TOA5's TIMESTAMP
    tcol = (spec.column("time") or ("TIMESTAMP" if layout.toa5 and "TIMESTAMP" in header else None)
            or find_time_column(header, f"{spec.name}: {spec.path!r}"))
    wanted = list(dict.fromkeys(list(names.values()) + ([tcol] if tcol else [])))
    missing = [n for n in wanted if n not in header]
    if missing:
        raise ValueError(f"{spec.name}: {spec.path!r} lacks column(s) {missing}; {_header_text(header)}")
    if len(set(header)) != len(header):
        raise ValueError(f"{spec.name}: {spec.path!r} names a column twice; {_header_text(header)}")
    # a TOA5 file's units row, as a NetCDF file's units attributes: the spec's units only where it is blank
    units = {r: layout.units.get(names[r]) or spec.unit(r) or "m s-1" for r in roles}
    factors = {}
    for r, u in units.items():
        try:
            factors[r] = parse_speed_units(u)
        except ValueError as e:
            if names[r] not in layout.units:
                raise
            raise ValueError(f"{spec.name}: column {names[r]!r} of {spec.path!r} (line 3): {e}") from None
    try:
        parts, rows = _columns(spec, wanted, layout, tcol, plain=True)
    except _NotPlain:  # some field needs Python's float on stripped text
        parts, rows = _columns(spec, wanted, layout, tcol, plain=False)
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
                      unit=p0.unit, where=p0.where, tz=p0.tz, epoch_ns=p0.epoch_ns)


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
            # CF decoding by xarray (_FillValue, missing_value, scale_factor, add_offset), the times as numbers:
            # they are kept exactly here (cwlidar_sim._times.float_times), their 'since' date as the record's epoch
            return xr.open_dataset(spec.path, engine=engine, decode_times=False, decode_timedelta=False,
                                   mask_and_scale=True, **no_index)
        except Exception as e:  # noqa: BLE001  (either engine may refuse the format; their messages quote the file)
            names.append(f"{engine}: {type(e).__name__}")
    raise ValueError(f"{spec.name}: {spec.path!r} is neither netCDF-4 (HDF5) nor netCDF-3, or is truncated "
                     f"({'; '.join(names)})")


def _read_netcdf(spec):
    """(times (TimeColumn, exact ns) or None, {role: values [m/s]}, {role: units}) of a NetCDF record."""
    with _open_netcdf(spec) as ds:
        return _read_dataset(ds, spec)


def _read_dataset(ds, spec):
    """The same of an open (CF-decoded) Dataset: variables by name or standard name, units parsed, fills NaN."""
    out, units = {}, {}
    for role in _ROLES[spec.kind]:
        v = _find_variable(ds, role, spec)
        da = ds[v]
        unit = da.attrs.get("units") or spec.unit(role) or "m s-1"
        try:
            factor = parse_speed_units(str(unit))
        except ValueError as e:
            raise ValueError(f"{spec.name}: variable {v!r} of {spec.path!r}: {e}") from None
        out[role] = _fill_values(_numeric_1d(ds, v, spec), spec) * factor
        units[role] = str(unit)
    t = None
    tname = spec.column("time") or ("time" if "time" in ds.variables else None)
    if tname is not None:
        if tname not in ds.variables:
            raise ValueError(f"{spec.name}: {spec.path!r} has no time variable {tname!r}; {_names_text(ds)}")
        where = f"{spec.name}: time variable {tname!r} of {spec.path!r}"
        kind = ds[tname].dtype.kind
        if kind in "Mm":  # a Dataset built in memory, or decoded by the caller
            t = _datetime_times(ds[tname].to_series(), spec, where)
        else:
            tu = str(ds[tname].attrs.get("units", spec.unit("time") or "s"))
            unit_ns(tu, where)  # the unit before the values are read
            t = float_times(_numeric_1d(ds, tname, spec), tu, where)
    return t, out, units


def _datetime_times(series, spec, where):
    """A pandas Series of datetimes (naive or tz-aware) or timedeltas -> a TimeColumn, exact in ns."""
    import pandas as pd

    if series.isna().any():
        raise ValueError(f"{where}: time is missing at sample {int(np.nonzero(series.isna().to_numpy())[0][0])}")
    if pd.api.types.is_timedelta64_dtype(series.dtype):
        return TimeColumn(series.to_numpy().astype("timedelta64[ns]").astype(np.int64), 1.0, unit="s", where=where)
    tz = getattr(series.dtype, "tz", None)
    if tz is not None:
        ns = series.dt.tz_convert("UTC").dt.tz_localize(None).to_numpy().astype("datetime64[ns]").astype(np.int64)
        return TimeColumn(ns, 1.0, iso=True, where=where, tz=str(tz), epoch_ns=0)
    ns = series.to_numpy().astype("datetime64[ns]").astype(np.int64)
    if spec.timezone is not None:
        return TimeColumn(localize_ns(ns, spec.timezone, where), 1.0, iso=True, where=where, tz=spec.timezone,
                          epoch_ns=0)
    return TimeColumn(ns, 1.0, iso=True, where=where, epoch_ns=0)


def _read_frame(df, spec):
    """(times or None, {role: values [m/s]}, {role: units}) of a pandas DataFrame: a time index or time column."""
    import pandas as pd

    if len(df) > MAX_SAMPLES:
        raise ValueError(f"{spec.name}: {spec.path!r} holds {len(df)} rows; allowed: at most {MAX_SAMPLES} samples "
                         f"(MAX_SAMPLES; split the record)")
    header = [str(c) for c in df.columns]
    names = {r: spec.column(r) or r for r in _ROLES[spec.kind]}
    missing = [n for n in names.values() if n not in header]
    if missing:
        raise ValueError(f"{spec.name}: {spec.path!r} lacks column(s) {missing}; {_header_text(header)}")
    cols = {str(c): c for c in df.columns}
    out, units = {}, {}
    for r, n in names.items():
        col = df[cols[n]]
        if col.dtype == object or pd.api.types.is_string_dtype(col.dtype):
            col = col.astype(str)
            words = set(_NA_TOKENS) | {w for w in spec.na_values if isinstance(w, str)}
            col = col.where(~col.str.strip().isin(words), "nan")
            bad = pd.to_numeric(col.str.replace(spec.decimal, ".", regex=False), errors="coerce").isna() \
                & ~col.isin(["nan"])
            if bad.any():
                i = int(np.nonzero(bad.to_numpy())[0][0])
                raise ValueError(f"{spec.name}: column {n!r} of {spec.path!r} is not numeric at row {i} "
                                 f"({_short(col.iloc[i])})")
            col = col.str.replace(spec.decimal, ".", regex=False)
        elif col.dtype.kind not in "fiub":
            raise ValueError(f"{spec.name}: column {n!r} of {spec.path!r} holds {col.dtype} values; allowed: numbers")
        units[r] = spec.unit(r) or "m s-1"
        out[r] = _fill_values(col.to_numpy(dtype=np.float64, na_value=np.nan), spec) * parse_speed_units(units[r])
    where = f"{spec.name}: time of {spec.path!r}"
    tname = spec.column("time") or find_time_column(header, where)
    if tname is not None:
        if tname not in header:
            raise ValueError(f"{spec.name}: {spec.path!r} lacks time column {tname!r}; {_header_text(header)}")
        series = df[cols[tname]]
    elif isinstance(df.index, (pd.DatetimeIndex, pd.TimedeltaIndex)) or (
            df.index.name is not None and split_unit(str(df.index.name))[0].lower() == "time"):
        series, tname = df.index.to_series(), str(df.index.name or "index")
    else:
        return None, out, units
    where = f"{spec.name}: time {tname!r} of {spec.path!r}"
    if series.dtype.kind in "Mm":
        return _datetime_times(series.reset_index(drop=True), spec, where), out, units
    unit = column_unit(tname, spec.unit("time"), where)
    if series.dtype.kind in "fiu":
        return float_times(series.to_numpy(dtype=np.float64), unit, where), out, units
    return parse_time_cells(series.astype(str).to_numpy(dtype=object), unit, where, tz=spec.timezone), out, units


def read_record_file(spec):
    """(times (TimeColumn) or None, {role: values [m/s]}, {role: units as read}) of a record's file, checked.

    ``spec`` is a :class:`cwlidar_sim.analysis.records.RecordSpec`.  Raises
    ValueError (one line naming the file) for a file that is not a record,
    a record too large, units that do not parse, columns of different
    lengths or fewer than 16 samples.
    """
    if isinstance(spec.path, RecordTable):
        if spec.path.kind == "DataFrame":
            t, vals, units = _read_frame(spec.path.data, spec)
        else:
            import xarray as xr

            ds = xr.decode_cf(spec.path.data, decode_times=False, decode_timedelta=False, mask_and_scale=True)
            t, vals, units = _read_dataset(ds, spec)
        return _checked(t, vals, units, spec)
    check_record_file(spec.path, spec.name)
    ext = os.path.splitext(spec.path)[1].lower()
    if ext in (".csv", ".txt"):
        t, vals, units = _read_csv(spec)
    elif ext in (".nc", ".nc4", ".cdf", ".netcdf"):
        t, vals, units = _read_netcdf(spec)
    else:
        raise ValueError(f"{spec.name}: {spec.path!r} has extension {ext!r}; allowed: .csv, .txt (CSV) or .nc, "
                         f".nc4, .cdf (NetCDF)")
    return _checked(t, vals, units, spec)


def _checked(t, vals, units, spec):
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

