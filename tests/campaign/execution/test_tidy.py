"""Results users can analyse (issue 32): the tidy statistics table, CF attributes, the absolute time axis from a
scene's ``start_time``, and the nacelle preview signal file."""

import datetime
import json

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from cwlidar_sim.campaign import loads_scene, registry, run_scene
from cwlidar_sim.campaign.execution import cf, tidy
from cwlidar_sim.campaign.execution.store import read_results, write_results
from cwlidar_sim.campaign.scenes.start_time import check_start_time, start_datetime

NACELLE = """
name = "nt"
kind = "nacelle"
seed = 3
duration = 60.0
{start}
[scan]
half_angle_deg = 15.0
focus_distances = [40.0, 80.0]
rotor_radius = 20.0
spacing = 8.0
segment_duration = 15.0
k_min = 0.04
k_max = 0.3
n_k = 5
theory_beams = 0
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.1
length_scale = 20.0
gamma = 3.9
[[period]]
name = "p0"
mean_speed = 10.0
"""


def _units_dataset():
    """Four rows: periods a (120 s) and b (scene default, 60 s) at two heights, as a conical scene's units."""
    scene = {"name": "s", "duration": 60.0, "period": [{"name": "a", "duration": 120.0}, {"name": "b"}]}
    t = np.arange(1, 121, dtype=float)  # 1 Hz, seconds from each period's start
    rng = np.random.default_rng(1)
    series = rng.normal(8.0, 1.0, (4, t.size))
    series[2:, 60:] = np.nan  # period b lasts 60 s: padded
    return xr.Dataset(
        {"std_unit": (("period", "scan_s"), rng.random((4, 2)), {"units": "m s-1"}),
         "flag_unit": (("period",), np.array([1, 0, 1, 1], dtype=np.int64), {"units": "1"}),
         "speed": (("period", "time_1hz"), series, {"units": "m s-1"}),
         "label": (("period",), np.array(["x"] * 4, dtype=object))},
        coords={"period": ["a_z40", "a_z80", "b_z40", "b_z80"],
                "period_name": ("period", ["a", "a", "b", "b"]),
                "unit_height": ("period", [40.0, 80.0, 40.0, 80.0], {"units": "m"}),
                "scan_s": ("scan_s", [1.0, 3.0], {"units": "s"}), "time_1hz": ("time_1hz", t, {"units": "s"})},
        attrs={"scene": json.dumps(scene), "sensor": "fake"})


class _Kind:
    name = "fake"

    def statistics(self, ds):
        return {"std_unit": "lidar", "speed": "cup", "flag_unit": "lidar"}


def test_start_time_is_an_instant_kept_as_utc():
    assert check_start_time("2024-05-01T12:00:00+02:00") == "2024-05-01T10:00:00Z"
    assert check_start_time(datetime.datetime(2024, 5, 1, 10, 0, 0, 500, tzinfo=datetime.timezone.utc)) \
        == "2024-05-01T10:00:00.000500Z"
    for bad, err, words in (("2024-05-01T10:00:00", ValueError, "no time zone"), ("noon", ValueError, "ISO 8601"),
                            (5, TypeError, "date-time")):
        with pytest.raises(err, match=f"start_time.*{words}|{words}.*start_time"):
            check_start_time(bad)
    plain = loads_scene(NACELLE.format(start=""))
    assert plain.start_time is None and "start_time" not in plain.as_dict()  # old scenes: the same identity
    toml = loads_scene(NACELLE.format(start="start_time = 2024-05-01T12:00:00+02:00"))  # a TOML date-time
    assert toml.start_time == "2024-05-01T10:00:00Z" == toml.as_dict()["start_time"]
    assert start_datetime(toml) == datetime.datetime(2024, 5, 1, 10)
    assert toml.with_values({"duration": 90.0}).start_time == toml.start_time
    with pytest.raises(ValueError, match="start_time"):
        loads_scene(NACELLE.format(start='start_time = "2024-05-01 10:00"'))


def test_periods_follow_one_another_and_rows_of_a_period_share_its_interval():
    ds = _units_dataset()
    start, end, names = cf.period_intervals(ds)
    assert names == ["a", "a", "b", "b"]
    np.testing.assert_array_equal(start, [0.0, 0.0, 120.0, 120.0])
    np.testing.assert_array_equal(end, [120.0, 120.0, 180.0, 180.0])
    # a conical template's later pass takes its template's length
    scene = json.loads(ds.attrs["scene"])
    ds2 = ds.assign_coords(period_name=("period", ["a", "a", "a_1", "a_1"]))
    assert list(cf.period_intervals(ds2)[1]) == [120.0, 120.0, 240.0, 240.0] and scene["period"][0]["duration"] == 120


def test_cf_attributes_change_no_value_and_the_time_axis_is_cf_encoded(tmp_path):
    ds = _units_dataset().rename({"std_unit": "cup_mean_unit"})
    plain = cf.annotate(ds)
    assert plain.attrs["Conventions"] == "CF-1.10" and "time" not in plain.variables
    assert plain["unit_height"].attrs["standard_name"] == "height"
    assert plain["cup_mean_unit"].attrs["standard_name"] == "wind_speed"
    assert plain["cup_mean_unit"].attrs["cell_methods"] == "time: mean"
    for name in ds.variables:
        assert plain[name].equals(ds[name])
        assert set(ds[name].attrs) <= set(plain[name].attrs)
    assert "standard_name" not in ds["unit_height"].attrs  # the input is not changed
    timed = cf.annotate(ds, datetime.datetime(2024, 5, 1, 10))
    write_results(timed, tmp_path / "r.nc")
    back = read_results(tmp_path / "r.nc")
    want = np.array(["2024-05-01T10:00", "2024-05-01T10:00", "2024-05-01T10:02", "2024-05-01T10:02"],
                    dtype="datetime64[ns]")
    np.testing.assert_array_equal(back["time"].values, want)
    np.testing.assert_array_equal(back["time_bounds"].values[:, 1],
                                  want + np.array([120, 120, 60, 60]).astype("timedelta64[s]"))
    assert back["time"].attrs["standard_name"] == "time" and back["time"].attrs["bounds"] == "time_bounds"
    import h5py

    with h5py.File(tmp_path / "r.nc") as f:  # CF on disk: numbers since an epoch, with the calendar
        assert f["time"].attrs["units"].startswith("seconds since 1970-01-01")
        assert f["time"].attrs["calendar"] == "proleptic_gregorian"
        assert f["time"][0] == datetime.datetime(2024, 5, 1, 10, tzinfo=datetime.timezone.utc).timestamp()


def test_the_tidy_table_has_a_row_per_period_height_instrument_and_ten_minute_block():
    ds = cf.annotate(_units_dataset(), datetime.datetime(2024, 5, 1, 10))
    df = tidy.statistics_table(ds, _Kind())
    assert list(df.columns[:len(tidy.COLUMNS)]) == list(tidy.COLUMNS) and "scan_s" in df.columns
    std = df[df.quantity == "std_unit"]
    assert len(std) == 4 * 2 and set(std.statistic) == {"value"}
    row = std[(std.unit == "b_z80") & (std.scan_s == 3.0)].iloc[0]
    assert row.value == ds["std_unit"].values[3, 1] and row.height_m == 80.0 and row.period == "b"
    assert (row.start_s, row.end_s) == (120.0, 180.0)
    assert (row.start_time, row.end_time) == ("2024-05-01T10:02:00.000000Z", "2024-05-01T10:03:00.000000Z")
    # a series: 10-minute blocks of its finite samples; a period shorter than 10 minutes is one block
    sp = df[(df.quantity == "speed") & (df.unit == "b_z40")].set_index("statistic").value
    x = ds["speed"].values[2, :60]
    assert sp["mean"] == pytest.approx(x.mean(), rel=1e-15) and sp["std"] == pytest.approx(x.std(ddof=1), rel=1e-13)
    assert (sp["min"], sp["max"], sp["count"]) == (x.min(), x.max(), 60.0)
    assert set(df[df.quantity == "speed"].instrument) == {"cup"}


def test_a_series_longer_than_ten_minutes_gives_a_row_per_block():
    t = np.arange(1, 1501, dtype=float)  # 25 min at 1 Hz
    x = np.sin(t / 50.0)
    ds = xr.Dataset({"speed": (("period", "t"), x[None], {"units": "m s-1"})},
                    coords={"period": ["p"], "t": ("t", t, {"units": "s", "axis": "T"})},
                    attrs={"scene": json.dumps({"duration": 1500.0, "period": [{"name": "p"}]})})
    df = tidy.statistics_table(ds, _Kind2())
    means = df[df.statistic == "mean"]
    assert list(means.start_s) == [0.0, 600.0, 1200.0] and list(means.end_s) == [600.0, 1200.0, 1500.0]
    np.testing.assert_allclose(means.value, [x[:600].mean(), x[600:1200].mean(), x[1200:].mean()], rtol=1e-14)
    assert list(df[df.statistic == "count"].value) == [600.0, 600.0, 300.0]


class _Kind2:
    name = "other"

    def statistics(self, ds):
        return {"speed": "lidar"}


def test_a_kind_that_does_not_say_gets_every_numeric_variable_on_period_alone():
    ds = _units_dataset()

    class Bare:  # a plugin kind without the optional member
        name = "bare"

    assert registry.statistics_of(Bare(), ds) == {"flag_unit": ""} == registry.default_statistics(ds)
    assert registry.side_files_of(Bare(), ds, "x") == []
    with pytest.raises(ValueError, match="'nope'"):
        tidy.statistics_table(ds, type("K", (), {"name": "k", "statistics": lambda self, d: {"nope": "x"}})())


def test_parquet_is_written_only_where_an_engine_imports(tmp_path, monkeypatch):
    ds = _units_dataset()
    monkeypatch.setattr(tidy, "parquet_engine", lambda: None)
    assert tidy.write_statistics(ds, _Kind(), str(tmp_path / "s")) == [str(tmp_path / "s.stats.csv")]
    assert not (tmp_path / "s.stats.parquet").exists()
    seen = {}

    def fake_to_parquet(self, path, engine=None, index=None):
        seen["engine"] = engine
        with open(path, "w") as fh:
            fh.write("parquet")

    monkeypatch.setattr(tidy, "parquet_engine", lambda: "pyarrow")
    monkeypatch.setattr(pd.DataFrame, "to_parquet", fake_to_parquet)
    paths = tidy.write_statistics(ds, _Kind(), str(tmp_path / "s"))
    assert paths[1] == str(tmp_path / "s.stats.parquet") and seen["engine"] == "pyarrow"
    assert (tmp_path / "s.stats.parquet").read_text() == "parquet"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left


def test_a_nacelle_run_writes_its_table_its_time_axis_and_a_preview_signal_that_previews(tmp_path):
    scene = loads_scene(NACELLE.format(start='start_time = "2024-05-01T12:00:00+02:00"'))
    ds = run_scene(scene, tmp_path, progress=False)
    assert ds.attrs["Conventions"] == "CF-1.10" and ds.attrs["start_time"] == "2024-05-01T10:00:00Z"
    assert ds["time"].values[0] == np.datetime64("2024-05-01T10:00:00")
    df = pd.read_csv(tmp_path / "nt.stats.csv")
    assert set(df.instrument) >= {"lidar", "rotor", "scene"}
    assert set(df.start_time) == {"2024-05-01T10:00:00.000000Z"}
    k = df[(df.quantity == "k_half") & (df.estimate == "main")].set_index("focus").value
    np.testing.assert_array_equal(k.values, ds["k_half"].sel(estimate="main").values[0])
    # the lattice theory beside the continuum's, its box named, in the results and the table
    for name in ("lidar_std", "rotor_std", "std_ratio", "correlation"):
        lat = ds[f"{name}_theory_lattice"]
        assert np.all(np.isfinite(lat.values)) and lat.attrs["theory_box"].startswith("lattice: the period's box")
        assert set(df[df.quantity == f"{name}_theory_lattice"].focus) == {40.0, 80.0}
    assert np.all(np.abs(ds["std_ratio_theory_lattice"].values - ds["std_ratio_theory"].values) < 0.1)
    text = (tmp_path / "nt.preview.csv").read_text()
    delays = ds["preview_delay"].values[0]
    assert f"p0 at 40 m: {delays[0]:.6g}" in text and "time_s = estimate_time_s + delay_s" in text
    pv = pd.read_csv(tmp_path / "nt.preview.csv", comment="#")
    assert list(pv.columns[:5]) == ["period", "focus_m", "time_s", "rews_estimate_m_s", "delay_s"]
    for r, d in zip((40.0, 80.0), delays):
        f = pv[pv.focus_m == r].dropna()
        np.testing.assert_allclose(f.time_s - f.estimate_time_s, d, atol=1e-9)
        assert 0.5 * r / 10.0 < d <= r / 10.0  # r cos(a) / U less half a revolution
        # the estimate at the stated delay follows the REWS better than the same estimate undelayed
        at_rotor = np.corrcoef(f.rews_estimate_m_s, f.rews_m_s)[0, 1]
        rews = ds["preview_rews"].values[0]
        i = np.searchsorted(ds["time_preview"].values, f.estimate_time_s.values)
        undelayed = np.corrcoef(f.rews_estimate_m_s, rews[i])[0, 1]
        assert at_rotor > undelayed + 0.05, (r, at_rotor, undelayed)
    assert abs(pv[pv.focus_m == 40.0].dropna().rews_estimate_m_s.mean() - 10.0) < 1.0


def test_a_nacelle_campaign_merges_and_resumes_with_its_lattice_theory(tmp_path):
    """The nacelle's ``*_theory_lattice`` (issue 33) through a campaign's merge and a run's resume, attrs kept."""
    from cwlidar_sim.campaign.execution import batch
    from cwlidar_sim.campaign.execution.sweep import loads_campaign

    (tmp_path / "base.toml").write_text(NACELLE.format(start=""))
    sweep = 'paired = false\n[[sweep]]\n"lidar.cnr_db" = [-5.0, -8.0]'
    spec = loads_campaign(f'name = "c"\nseed = 3\nbase = "base.toml"\n{sweep}', base_dir=str(tmp_path))
    s = batch.run_campaign(spec, tmp_path / "out", local=True, progress=False)
    assert s["done"] == 2 and not s["failed"]
    merged = batch.merge_campaign(tmp_path / "out")
    for name in ("lidar_std", "rotor_std", "std_ratio", "correlation"):
        lat = merged[f"{name}_theory_lattice"]
        assert np.all(np.isfinite(lat.values)) and lat.attrs["theory_box"].startswith("lattice: the period's box")
    # each task its own turbulence (paired = false) over the same geometry: the same lattice, its simulation its own
    sweep = json.loads(merged.attrs["sweep_dims"])[0]
    lat, sim = (merged[v].transpose(sweep, ...).values.reshape(2, -1)
                for v in ("std_ratio_theory_lattice", "std_ratio"))
    assert np.array_equal(lat[0], lat[1]) and not np.array_equal(sim[0], sim[1])
    # a run resumed from its kept period returns the same lattice, bit for bit
    scene = loads_scene(NACELLE.format(start=""))
    first = run_scene(scene, tmp_path / "r", progress=False)
    again = run_scene(scene, tmp_path / "r", progress=False)
    for name in ("std_ratio_theory_lattice", "correlation_theory_lattice"):
        assert first[name].values.tobytes() == again[name].values.tobytes()
        assert first[name].attrs == again[name].attrs
