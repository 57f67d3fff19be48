"""Mast files as loggers write them, read through pandas: TOA5, ';' with decimal commas and -9999, zoned times.

Each fixture is written here from one set of samples; each must load into the same record (values, gap
flags, rate and absolute start time), and bad files must fail in one line naming the line and the column.
"""

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from cwlidar_sim.analysis.records import FLAG_GAP, RecordSpec, read_record

FS, N = 20.0, 1200
GAPS = [57, 300, 301, 802]  # samples missing in every file (indices)
START = pd.Timestamp("2024-07-01 12:00:00", tz="+02:00")  # the logger's local clock (CEST)


@pytest.fixture(scope="module")
def samples():
    rng = np.random.default_rng(32)
    out = []
    for s, mean in ((0.8, 8.0), (0.5, 0.0), (0.3, 0.0)):
        x = np.convolve(rng.normal(0, s, N + 15), np.ones(16) / 4.0, mode="valid")
        out.append(np.round(mean + x, 4))  # four decimals, as a sonic logs them
    return dict(zip("uvw", out))


def _local(i):
    """Naive local wall-clock time of sample i, as a logger writes it."""
    return (START.tz_localize(None) + pd.Timedelta(50 * i, "ms")).strftime("%Y-%m-%d %H:%M:%S.%f")[:-4]


def _toa5(path, s):
    lines = ['"TOA5","CR3000","CR3000","1234","CR3000.Std.32","CPU:sonic.CR3","5678","ts_data"',
             '"TIMESTAMP","RECORD","Ux","Uy","Uz","Ts"', '"TS","RN","m/s","m/s","m/s","C"',
             '"","","Smp","Smp","Smp","Smp"']
    for i in range(N):
        cells = ['"NAN"' if i in GAPS else repr(float(s[c][i])) for c in "uvw"]
        lines.append(f'"{_local(i)}",{i},' + ",".join(cells) + ",21.5")
    path.write_text("\n".join(lines) + "\n")
    return RecordSpec(str(path), columns={"u": "Ux", "v": "Uy", "w": "Uz"}, rotation="none", timezone="+02:00")


def _semicolon(path, s):
    lines = ["# mast M1, sonic at 40 m", "# logger clock: Europe/Berlin", "timestamp;u;v;w"]
    for i in range(N):
        cells = ["-9999" if i in GAPS else repr(float(s[c][i])).replace(".", ",") for c in "uvw"]
        lines.append(f"{_local(i).replace('.', ',')};" + ";".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return RecordSpec(str(path), columns={"time": "timestamp"}, sep=";", decimal=",", na_values=[-9999],
                      comment="#", timezone="Europe/Berlin", rotation="none")


def _zoned(path, s):
    """Times written in UTC-05:00 with their offset (another zone, the same instants); gaps as empty fields."""
    lines = ["time,u,v,w"]
    for i in range(N):
        t = (START + pd.Timedelta(50 * i, "ms")).tz_convert("-05:00").isoformat()
        cells = ["" if i in GAPS else repr(float(s[c][i])) for c in "uvw"]
        lines.append(f"{t}," + ",".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return RecordSpec(str(path), rotation="none")


def _frame(s):
    idx = pd.DatetimeIndex([START + pd.Timedelta(50 * i, "ms") for i in range(N)], name="time")
    df = pd.DataFrame({c: s[c] for c in "uvw"}, index=idx)
    df.iloc[GAPS] = np.nan
    return RecordSpec(df, rotation="none")


def _check_same(a, b, s):
    for c in "uvw":
        np.testing.assert_allclose(b.values[c], a.values[c], rtol=1e-15, atol=0)
        keep = a.flags == 0
        np.testing.assert_array_equal(a.values[c][keep], s[c][keep])
    np.testing.assert_array_equal(b.flags, a.flags)
    assert (a.sample_rate, a.n_samples, a.n_gaps) == (b.sample_rate, b.n_samples, b.n_gaps) == (FS, N, len(GAPS))
    assert b.start_time == a.start_time == START and a.time0_ns == b.time0_ns


def test_toa5_semicolon_decimal_comma_and_zoned_files_load_into_one_record(tmp_path, samples):
    a = read_record(_toa5(tmp_path / "ts_data.dat.csv", samples))
    assert np.array_equal(np.nonzero(a.flags)[0], GAPS) and np.all(a.flags[GAPS] == FLAG_GAP)
    assert a.units == {"u": "m/s", "v": "m/s", "w": "m/s"}  # TOA5's units row
    assert str(a.start_time) == "2024-07-01 12:00:00+02:00" and a.time0_ns == START.value
    for b in (read_record(_semicolon(tmp_path / "m.csv", samples)), read_record(_zoned(tmp_path / "z.csv", samples)),
              read_record(_frame(samples))):
        _check_same(a, b, samples)
    np.testing.assert_allclose(a.time_s[[0, -1]], [0.0, (N - 1) / FS])


def test_a_toa5_units_row_converts_and_a_dataset_reads_as_its_file(tmp_path, samples):
    a = read_record(_toa5(tmp_path / "a.csv", samples))
    p = tmp_path / "b.csv"
    p.write_text(p.parent.joinpath("a.csv").read_text().replace('"m/s","m/s","m/s"', '"cm/s","cm/s","cm/s"'))
    b = read_record(RecordSpec(str(p), columns={"u": "Ux", "v": "Uy", "w": "Uz"}, rotation="none",
                               timezone="+02:00", min_mean_speed=0.01, max_intensity=2.0))
    np.testing.assert_allclose(b.values["u"], a.values["u"] / 100, rtol=1e-14)
    t = pd.DatetimeIndex([START + pd.Timedelta(50 * i, "ms") for i in range(N)]).tz_convert("UTC").tz_localize(None)
    ds = xr.Dataset({c: ("time", np.where(np.isin(np.arange(N), GAPS), np.nan, samples[c]), {"units": "m s-1"})
                     for c in "uvw"}, coords={"time": t.values})
    c = read_record(RecordSpec(ds, rotation="none", timezone="UTC"))
    np.testing.assert_allclose(c.values["u"], a.values["u"], rtol=1e-15)
    assert c.start_time == START and c.n_gaps == len(GAPS) and "Dataset" in c.spec.name


def test_a_packed_netcdf_is_decoded_by_xarray_with_its_since_date(tmp_path, samples):
    """int16 with scale_factor, add_offset and _FillValue (was: the packed integers read as m/s, fills ignored)."""
    p = tmp_path / "p.nc"
    packed = {c: np.where(np.isin(np.arange(N), GAPS), -32768, np.round((samples[c] - 5.0) / 0.001)).astype(np.int16)
              for c in "uvw"}
    xr.Dataset({c: ("time", packed[c], {"units": "m s-1", "scale_factor": 0.001, "add_offset": 5.0,
                                        "_FillValue": np.int16(-32768)}) for c in "uvw"},
               coords={"time": ("time", np.arange(N) / FS, {"units": "seconds since 2024-07-01 10:00:00"})}
               ).to_netcdf(p, engine="h5netcdf", encoding={c: {"dtype": "int16"} for c in "uvw"})
    rec = read_record(RecordSpec(str(p), rotation="none"))
    assert np.array_equal(np.nonzero(rec.flags)[0], GAPS)
    keep = rec.flags == 0
    np.testing.assert_allclose(rec.values["u"][keep], samples["u"][keep], atol=6e-4)
    assert rec.start_time == START and str(rec.start_time.tz) == "UTC" and rec.time0_ns == 0


def test_a_non_numeric_cell_is_named_by_its_line_and_column(tmp_path, samples):
    spec = _semicolon(tmp_path / "m.csv", samples)
    rows = (tmp_path / "m.csv").read_text().splitlines()
    rows[56] = rows[56].replace(";", ";x", 1)  # line 57: the header is line 3 after two comment lines
    rows.insert(40, "# maintenance visit")  # a comment line among the rows shifts the lines after it
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(ValueError, match=r"^m\.csv: column 'u' of .*m\.csv' is not numeric at line 58 \('x") as e:
        read_record(spec)
    assert "\n" not in str(e.value)
    toa5 = _toa5(tmp_path / "t.csv", samples)
    rows = (tmp_path / "t.csv").read_text().splitlines()
    f = rows[56].split(",")
    f[3] = '"oops"'  # Uy
    rows[56] = ",".join(f)
    (tmp_path / "t.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(ValueError, match=r"column 'Uy' of .*t\.csv' is not numeric at line 57 \('oops'\)$"):
        read_record(toa5)


def test_bad_options_and_zones_are_refused_by_name(tmp_path, samples):
    with pytest.raises(ValueError, match=r"RecordSpec.decimal=',' is also the separator sep=','"):
        RecordSpec("a.csv", decimal=",")
    with pytest.raises(ValueError, match=r"RecordSpec.timezone='Mars/Olympus' is not a time zone"):
        RecordSpec("a.csv", timezone="Mars/Olympus")
    with pytest.raises(ValueError, match=r"RecordSpec.na_values\[0\]=nan is not a missing-value marker"):
        RecordSpec("a.csv", na_values=[math.nan])
    with pytest.raises(ValueError, match=r"RecordSpec.sep=';;' is not a field separator"):
        RecordSpec("a.csv", sep=";;")
    s = RecordSpec("a.csv", sep=";", decimal=",", na_values=["-9999", "NAN"], comment="#", skiprows=2,
                   timezone="Europe/Berlin")
    assert s.na_values == (-9999.0, "NAN") and RecordSpec.from_dict(s.as_dict()) == s
    # a fall-back hour's wall-clock times are ambiguous in a named zone
    p = tmp_path / "dst.csv"
    t0 = pd.Timestamp("2024-10-27 02:20:00")
    p.write_text("time,u,v,w\n" + "".join(f"{(t0 + pd.Timedelta(50 * i, 'ms')).isoformat()},{float(samples['u'][i])!r},0,0\n"
                                          for i in range(N)))
    with pytest.raises(ValueError, match=r"time at sample 0 is ambiguous or does not exist in time zone "
                                         r"'Europe/Berlin' \(a daylight-saving change\)"):
        read_record(RecordSpec(str(p), rotation="none", timezone="Europe/Berlin"))


def test_a_preamble_is_skipped_by_skiprows(tmp_path, samples):
    a = read_record(_zoned(tmp_path / "z.csv", samples))
    text = (tmp_path / "z.csv").read_text()
    (tmp_path / "p.csv").write_text("Site: M1\nLogger: X\n" + text)
    b = read_record(RecordSpec(str(tmp_path / "p.csv"), skiprows=2, rotation="none"))
    _check_same(a, b, samples)
    with pytest.raises(ValueError, match=r"lacks column\(s\) \['u', 'v', 'w'\]"):
        read_record(RecordSpec(str(tmp_path / "p.csv"), rotation="none"))
