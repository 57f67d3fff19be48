"""The one reader of records (twin and fit_to): units, sizes before allocation, files that are not records."""

import hashlib

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis import record_files
from cwlidar_sim.analysis.record_files import file_digest, parse_speed_units
from cwlidar_sim.analysis.records import RecordSpec, read_record


def _wind(n, seed=1, U=8.0):
    rng = np.random.default_rng(seed)
    x = np.convolve(rng.normal(0, 1, n + 31), np.ones(32) / 6.0, mode="valid")
    return {"u": U + 0.5 * x, "v": 0.3 * rng.normal(size=n), "w": 0.2 * rng.normal(size=n)}


def _csv(path, vals, t=None, header="time,u,v,w"):
    n = len(vals["u"])
    t = np.arange(n) / 10.0 if t is None else t
    with open(path, "w") as f:
        f.write(header + "\n")
        for row in zip(t, vals["u"], vals["v"], vals["w"]):
            f.write(",".join(repr(float(x)) for x in row) + "\n")
    return str(path)


def _nc(path, vals, units="m s-1", scale=1.0):
    n = len(vals["u"])
    xr.Dataset({c: ("time", vals[c] * scale, {"units": units}) for c in "uvw"},
               coords={"time": ("time", np.arange(n) / 10.0, {"units": "s"})}).to_netcdf(path, engine="h5netcdf")
    return str(path)


@pytest.mark.parametrize("units, factor", [("m s-1", 1.0), ("m/s", 1.0), ("cm s-1", 0.01), ("cm s^-1", 0.01),
                                           ("km h-1", 1 / 3.6), ("km/h", 1 / 3.6), ("knots", 1852 / 3600),
                                           ("mph", 1609.344 / 3600), ("ft s-1", 0.3048)])
def test_speed_units_convert_by_the_table(units, factor):
    assert parse_speed_units(units) == pytest.approx(factor, rel=1e-15)


@pytest.mark.parametrize("units", ["furlongs per fortnight", "m", "m s-2", "kg m-3", "", "s m-1"])
def test_speed_units_that_do_not_parse_are_refused_by_name(units):
    with pytest.raises(ValueError, match=r"units .* do not parse as a speed"):
        parse_speed_units(units)


def test_one_record_in_csv_m_s_and_netcdf_cm_s_reads_alike(tmp_path):
    vals = _wind(400)
    a = read_record(RecordSpec(_csv(tmp_path / "a.csv", vals), rotation="none"))
    b = read_record(RecordSpec(_nc(tmp_path / "b.nc", vals, "cm s-1", 100.0), rotation="none"))
    for c in "uvw":
        np.testing.assert_allclose(b.values[c], a.values[c], rtol=1e-13, atol=1e-13)
    assert a.units == {"u": "m s-1", "v": "m s-1", "w": "m s-1"} and b.units["u"] == "cm s-1"
    assert a.sample_rate == b.sample_rate == 10.0  # 1 / median(dt) is 10.000000000000568 Hz here: snapped


def test_a_rate_that_is_not_round_is_kept(tmp_path):
    rec = read_record(RecordSpec(_csv(tmp_path / "a.csv", _wind(500), np.arange(500) * 0.3), rotation="none"))
    assert rec.sample_rate == pytest.approx(1 / 0.3, rel=1e-12) and rec.sample_rate != round(rec.sample_rate, 3)


def test_a_time_gap_is_refused_before_the_grid_is_allocated(tmp_path):
    """A last row 1e9 s later would need a grid of 1e10 samples (80 GB): the gap is refused first.

    (1e15 s, as this test had before exact times, is now refused earlier: beyond int64 nanoseconds.)
    """
    vals = _wind(400)
    t = np.arange(400) / 10.0
    t[-1] = 1e9
    with pytest.raises(ValueError, match=r"gap of 1e\+09 s .* after t = 39\.800000000 s is longer than max_gap = 1 s"):
        read_record(RecordSpec(_csv(tmp_path / "a.csv", vals, t), rotation="none"))


def test_the_declared_length_of_a_netcdf_variable_is_checked_before_reading(tmp_path, monkeypatch):
    monkeypatch.setattr(record_files, "MAX_SAMPLES", 300)

    def no_read(*a, **k):
        raise AssertionError("the variable was read before its length was checked")

    p = _nc(tmp_path / "a.nc", _wind(400))
    monkeypatch.setattr(record_files.np, "asarray", no_read)
    with pytest.raises(ValueError, match=r"variable 'u' of .* declares 400 samples; allowed: at most 300"):
        read_record(RecordSpec(p, rotation="none"))


def test_a_csv_is_read_in_chunks_and_refused_past_the_sample_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(record_files, "MAX_SAMPLES", 300)
    monkeypatch.setattr(record_files, "_CHUNK_ROWS", 100)
    p = _csv(tmp_path / "a.csv", _wind(1000))
    seen = []
    real = record_files._chunks

    def spy(*a, **k):
        for chunk in real(*a, **k):
            seen.append(len(chunk))
            yield chunk

    monkeypatch.setattr(record_files, "_chunks", spy)
    with pytest.raises(ValueError, match=r"holds more than 300 rows"):
        read_record(RecordSpec(p, rotation="none"))
    assert seen == [100, 100, 100, 100]  # refused at the fourth chunk of 100 rows, not after reading 1000


def test_without_xarray_s_no_index_option_an_hdf5_file_s_dimensions_are_checked_first(tmp_path):
    import h5netcdf

    p = tmp_path / "a.nc"
    with h5netcdf.File(p, "w") as f:
        f.dimensions = {"time": 2_000_000_000}
        f.create_variable("u", ("time",), float, chunks=(2**16,))
    with pytest.raises(ValueError, match=r"dimension 'time' of .* declares 2000000000 samples"):
        record_files._check_hdf5_dimensions(RecordSpec(str(p)))
    record_files._check_hdf5_dimensions(RecordSpec(_nc(tmp_path / "b.nc", _wind(100))))  # a record passes


def test_a_non_numeric_field_is_named_by_line_with_a_short_excerpt(tmp_path):
    p = tmp_path / "a.csv"
    _csv(p, _wind(100))
    rows = p.read_text().splitlines()
    rows[7] = "0.6," + "9" * 200_000 + "x,0,0"  # over csv.field_size_limit (131072)
    p.write_text("\n".join(rows) + "\n")
    with pytest.raises(ValueError, match=r"column 'u' of .* is not numeric at line 8 \('9{32}\.\.\.'\)$") as e:
        read_record(RecordSpec(str(p), rotation="none"))
    assert len(str(e.value)) < 300


def test_the_header_is_named_only_when_it_is_a_header_of_column_names(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/usr/sbin:/usr/sbin/nologin\n")
    with pytest.raises(ValueError, match="not a header of column names") as e:
        read_record(RecordSpec(str(p), rotation="none"))
    assert "root:x" not in str(e.value) and "bash" not in str(e.value)
    q = tmp_path / "b.csv"
    _csv(q, _wind(100), header="time,U,V,W")
    with pytest.raises(ValueError, match=r"lacks column\(s\) \['u', 'v', 'w'\]; it has \['time', 'U', 'V', 'W'\]"):
        read_record(RecordSpec(str(q), rotation="none"))


def test_a_file_that_is_not_netcdf_is_not_quoted(tmp_path):
    p = tmp_path / "a.nc"
    p.write_bytes(b"SECRET-CONTENTS " * 100)
    with pytest.raises(ValueError, match=r"is neither netCDF-4 \(HDF5\) nor netCDF-3") as e:
        read_record(RecordSpec(str(p), rotation="none"))
    assert "SECR" not in str(e.value)
    assert "\n" not in str(e.value) and len(str(e.value)) < 300  # not the libraries' multi-line advice


def test_a_few_absurd_speeds_are_gaps_and_many_are_refused_as_units(tmp_path):
    vals = _wind(400)
    vals["u"][[50, 51]] = -9999.0  # a logger's sentinel
    rec = read_record(RecordSpec(_csv(tmp_path / "a.csv", vals), rotation="none", despike_threshold=0.0))
    assert rec.n_filled == 2 and rec.values["u"].max() < 20
    big = {c: v * 1000 for c, v in _wind(400).items()}
    with pytest.raises(ValueError, match=r"400 of 400 samples .* exceed 100 m/s \(largest 8\d{3} m/s"):
        read_record(RecordSpec(_csv(tmp_path / "b.csv", big), rotation="none"))


def test_the_digest_is_the_file_s_sha256_read_in_chunks(tmp_path, monkeypatch):
    p = tmp_path / "a.nc"
    blob = np.random.default_rng(3).bytes(3 * 2**20 + 17)
    p.write_bytes(blob)
    reads = []
    real_open = open

    class Spy:
        def __init__(self, f):
            self.f = f

        def __enter__(self):
            return self

        def __exit__(self, *a):
            self.f.close()

        def read(self, n=-1):
            reads.append(n)
            return self.f.read(n)

    monkeypatch.setattr("builtins.open", lambda path, mode="r", *a, **k: Spy(real_open(path, mode, *a, **k)))
    assert file_digest(p, "x") == hashlib.sha256(blob).hexdigest()
    assert reads and all(0 < n <= 2**20 for n in reads)
    monkeypatch.setattr(record_files, "MAX_FILE_BYTES", 2**20)
    reads.clear()
    with pytest.raises(ValueError, match=r"x: .* holds 0\.00293 GiB; allowed: at most 0\.000977 GiB"):
        file_digest(p, "x")
    assert reads == []


def test_fields_with_blanks_and_missing_words_read_as_float_reads_them(tmp_path):
    """The fast numeric path and the text path (taken when a field needs it) agree with Python's float."""
    vals = _wind(200)
    plain = _csv(tmp_path / "plain.csv", vals)
    rows = (tmp_path / "plain.csv").read_text().splitlines()
    for i, word in ((3, " NA "), (9, "null"), (15, " nan"), (21, "")):
        f = rows[i].split(",")
        f[1] = word
        rows[i] = ",".join(f)
    rows[30] = ",".join(" " + x + " " for x in rows[30].split(","))
    (tmp_path / "odd.csv").write_text("\n".join(rows) + "\n")
    a = read_record(RecordSpec(plain, rotation="none", despike_threshold=0.0))
    b = read_record(RecordSpec(str(tmp_path / "odd.csv"), rotation="none", despike_threshold=0.0))
    assert b.n_filled == 4 and np.array_equal(np.nonzero(b.flags)[0], [2, 8, 14, 20])  # rows[0] is the header
    keep = b.flags == 0
    np.testing.assert_array_equal(b.values["u"][keep], a.values["u"][keep])  # bit for bit, row 30 included
    expect = [float(x) for x in rows[30].split(",")[1:]]
    assert [b.values[c][29] for c in "uvw"] == expect


def _time_csv(path, cells, vals=None):
    vals = _wind(len(cells)) if vals is None else vals
    with open(path, "w") as f:
        f.write("time,u,v,w\n")
        for c, a, b, d in zip(cells, vals["u"], vals["v"], vals["w"]):
            f.write(f"{c},{float(a)!r},{float(b)!r},{float(d)!r}\n")
    return str(path)


def test_csv_times_are_read_as_text_to_the_nanosecond(tmp_path):
    """A float64 holds a Unix time to 2.4e-7 s: the time column is text, its digits parsed exactly (both paths)."""
    cells = [f"{1_700_000_000 + k}.{f:09d}" for k in range(30) for f in range(1, 10**9, 50_000_000)]
    rec = read_record(RecordSpec(_time_csv(tmp_path / "a.csv", cells), rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0_ns == 1_700_000_000_000_000_001
    rows = (tmp_path / "a.csv").read_text().splitlines()
    rows[5] = rows[5].replace(",", ", ", 1)  # a blank before a number: the text path
    (tmp_path / "b.csv").write_text("\n".join(rows) + "\n")
    rec = read_record(RecordSpec(str(tmp_path / "b.csv"), rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0_ns == 1_700_000_000_000_000_001


def test_csv_times_parsed_in_chunks_name_the_column_s_sample(tmp_path, monkeypatch):
    monkeypatch.setattr(record_files, "_CHUNK_ROWS", 100)
    cells = [f"{1_700_000_000.525 + i / 20:.3f}" for i in range(400)]
    rec = read_record(RecordSpec(_time_csv(tmp_path / "a.csv", cells), rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0_ns == 1_700_000_000_525_000_000 and rec.n_samples == 400
    with pytest.raises(ValueError, match=r"time column 'time' of .*: time is missing at sample 250$"):
        read_record(RecordSpec(_time_csv(tmp_path / "b.csv", cells[:250] + ["nan"] + cells[251:]), rotation="none"))
    with pytest.raises(ValueError, match=r"time column 'time' of .* neither numbers nor ISO 8601 times \(sample 250: "
                                         r"'soon'\)$"):
        read_record(RecordSpec(_time_csv(tmp_path / "e.csv", cells[:250] + ["soon"] + cells[251:]), rotation="none"))
    iso = [str(np.datetime64("2023-11-14T22:13:20.525") + np.timedelta64(50 * i, "ms")) for i in range(400)]
    rec = read_record(RecordSpec(_time_csv(tmp_path / "c.csv", iso), rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0_ns == 1_700_000_000_525_000_000
    with pytest.raises(ValueError, match=r"time column 'time' of .* mixes numbers and ISO 8601 times"):
        read_record(RecordSpec(_time_csv(tmp_path / "d.csv", iso[:200] + cells[200:]), rotation="none"))


def test_a_netcdf_time_unit_that_does_not_parse_is_named(tmp_path):
    p = _nc(tmp_path / "a.nc", _wind(100))
    with xr.open_dataset(p) as ds:
        ds = ds.load()
    ds["time"].attrs["units"] = "fortnights"
    ds.to_netcdf(tmp_path / "b.nc", engine="h5netcdf")
    with pytest.raises(ValueError, match=r"time variable 'time' of .*b.nc': time units 'fortnights' do not parse"):
        read_record(RecordSpec(str(tmp_path / "b.nc"), rotation="none"))


def test_a_netcdf3_record_in_knots_reads_as_its_m_s_twin(tmp_path):
    vals = _wind(300)
    a = read_record(RecordSpec(_nc(tmp_path / "a.nc", vals), rotation="none"))
    p = tmp_path / "b.nc"
    xr.Dataset({c: ("time", vals[c] * 3600 / 1852, {"units": "knots"}) for c in "uvw"},
               coords={"time": ("time", np.arange(300) / 10.0, {"units": "s"})}).to_netcdf(p, engine="scipy")
    b = read_record(RecordSpec(str(p), rotation="none"))
    for c in "uvw":
        np.testing.assert_allclose(b.values[c], a.values[c], rtol=1e-13, atol=1e-13)
    assert b.units["u"] == "knots"
