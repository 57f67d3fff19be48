"""Records' time columns (analysis.records through cwlidar_sim._times): exact times, the unit from the header."""

import numpy as np
import pytest

from cwlidar_sim.analysis.records import RecordSpec, read_record

FS = 20.0
N = 1200


def _vel(seed=1):
    rng = np.random.default_rng(seed)
    x = np.convolve(rng.normal(0, 1, N + 31), np.ones(32) / 6.0, mode="valid")
    return 8.0 + 0.6 * (x - x.mean()) / x.std(), 0.2 * rng.normal(size=N), 0.1 * rng.normal(size=N)


def _csv(path, header, cells, seed=1):
    u, v, w = _vel(seed)
    with open(path, "w") as f:
        f.write(f"{header},u,v,w\n")
        for c, a, b, d in zip(cells, u, v, w):
            f.write(f"{c},{a},{b},{d}\n")
    return str(path)


def test_unix_seconds_give_exactly_20_hz_and_the_exact_start(tmp_path):
    p = _csv(tmp_path / "m.csv", "time", [f"{1_700_000_000.525 + i / FS:.3f}" for i in range(N)])
    rec = read_record(RecordSpec(p, rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0_ns == 1_700_000_000_525_000_000
    assert rec.time0 == 1_700_000_000.525  # the float as before (nearest double)


def test_unix_seconds_as_netcdf_floats_give_exactly_20_hz(tmp_path):
    import xarray as xr

    u, v, w = _vel()
    t = 1_700_000_000.525 + np.arange(N) / FS
    ds = xr.Dataset({"u": ("time", u, {"units": "m s-1"}), "v": ("time", v, {"units": "m s-1"}),
                     "w": ("time", w, {"units": "m s-1"})},
                    coords={"time": ("time", t, {"units": "seconds since 1970-01-01"})})
    ds.to_netcdf(tmp_path / "m.nc", engine="h5netcdf")
    rec = read_record(RecordSpec(str(tmp_path / "m.nc"), rotation="none"))
    assert rec.sample_rate == 20.0
    assert abs(rec.time0_ns - 1_700_000_000_525_000_000) <= 240  # the float's own resolution (2.4e-7 s)


@pytest.mark.parametrize("header, scale, declared", [("time_ms", 1000, None), ("time [us]", 10**6, None),
                                                     ("time", 1000, "ms"), ("time (h)", 1 / 3600, None)])
def test_time_units_from_the_header_or_the_spec(tmp_path, header, scale, declared):
    from decimal import Decimal

    cells = [str(Decimal(i) / Decimal(int(FS)) * Decimal(scale)) if scale >= 1 else repr(i / FS * scale)
             for i in range(N)]
    p = _csv(tmp_path / "m.csv", header, cells)
    rec = read_record(RecordSpec(p, rotation="none", units={"time": declared} if declared else None))
    assert rec.sample_rate == 20.0 and rec.n_samples == N and rec.n_filled == 0


def test_time_in_ms_without_its_unit_is_refused_naming_the_column(tmp_path):
    p = _csv(tmp_path / "m.csv", "time", [str(50 * i) for i in range(N)])
    with pytest.raises(ValueError, match=r"m.csv: time column 'time' of .*m.csv': read in s, the times step by 50 s "
                                         r"\(0.02 Hz\); "
                                         r"allowed: a wind record at 0.1-1000 Hz; read in ms it would be 20 Hz: "
                                         r"name the unit in the header \(e.g. 'time_ms'") as e:
        read_record(RecordSpec(p, rotation="none"))
    assert "\n" not in str(e.value)
    # the header and the spec must not disagree
    p = _csv(tmp_path / "n.csv", "time_ms", [str(50 * i) for i in range(N)])
    with pytest.raises(ValueError, match=r"time column 'time_ms' .* the header says 'ms' but the declared unit is 's'"):
        read_record(RecordSpec(p, rotation="none", units={"time": "s"}))


def test_time_in_hours_without_its_unit_is_refused(tmp_path):
    p = _csv(tmp_path / "m.csv", "time", [repr(i / FS / 3600) for i in range(N)])
    with pytest.raises(ValueError, match=r"\(71999.4 Hz\); allowed: a wind record at 0.1-1000 Hz; read in h it would "
                                         r"be 20 Hz"):
        read_record(RecordSpec(p, rotation="none"))


def test_iso_times_keep_the_epoch_exactly(tmp_path):
    t = np.datetime64("2023-11-14T22:13:20.525") + (np.arange(N) * 50_000_000).astype("timedelta64[ns]")
    rec = read_record(RecordSpec(_csv(tmp_path / "m.csv", "time", [str(x) for x in t]), rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0 == 0.0  # time0: from the file's first sample, as before
    assert rec.time0_ns == 1_700_000_000_525_000_000


def test_negative_times_are_read_as_written(tmp_path):
    p = _csv(tmp_path / "m.csv", "time", [f"{-30 + i / FS:.2f}" for i in range(N)])
    rec = read_record(RecordSpec(p, rotation="none"))
    assert rec.sample_rate == 20.0 and rec.time0_ns == -30 * 10**9 and rec.time0 == -30.0
