"""Nothing computed is lost: checks before a run, per-period files, resuming, clear errors."""

import errno
import json
import os
import sys

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import PreflightError, ResultsWriteError, loads_scene, read_results, run_scene
from cwlidar_sim.campaign.periods import staring
from cwlidar_sim.campaign.execution import store
from cwlidar_sim.cli import main

TEXT = """
name = "st"
seed = 5
duration = 600.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "los"
[analysis]
segment_duration = 300.0
fit = false
[[period]]
name = "A"
mean_speed = 8.0
[[period]]
name = "B"
mean_speed = 6.0
duration = 300.0
[[period]]
name = "C"
mean_speed = 7.0
"""

#: Attributes that describe a run, not its results (they differ between any two runs).
RUN_ATTRS = ("wall_time", "timing", "periods_reused")


class Stop(Exception):
    pass


def counting(monkeypatch):
    """Count the periods actually computed."""
    calls = []
    real = staring.run_unit

    def run_unit(scene, index, params, **kw):
        calls.append(index)
        return real(scene, index, params, **kw)

    monkeypatch.setattr(staring, "run_unit", run_unit)
    return calls


def assert_same_results(a, b):
    xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())
    for name in a.variables:
        assert a[name].attrs.keys() == b[name].attrs.keys(), name
    strip = lambda d: {k: v for k, v in d.attrs.items() if k not in RUN_ATTRS}  # noqa: E731
    assert json.dumps(strip(a), sort_keys=True, default=str) == json.dumps(strip(b), sort_keys=True, default=str)


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    out = tmp_path_factory.mktemp("whole")
    run_scene(loads_scene(TEXT), out, progress=False)
    return read_results(out / "st.nc")


def test_interrupted_run_resumes_with_the_same_bits(tmp_path, monkeypatch, uninterrupted):
    scene = loads_scene(TEXT)

    def stop_after_first(index, ds):
        if index == 0:
            raise Stop

    with pytest.raises(Stop):
        run_scene(scene, tmp_path, progress=False, on_period=stop_after_first)
    # the finished period is on disk, whole and readable; nothing else is
    done = sorted(os.listdir(tmp_path / "st.periods"))
    assert done == ["000_A.nc"]
    assert not (tmp_path / "st.nc").exists()
    first = read_results(tmp_path / "st.periods" / "000_A.nc")
    assert list(first.period.values) == ["A"]

    calls = counting(monkeypatch)
    lines = []
    ds = run_scene(scene, tmp_path, progress=False, log=lines.append)
    assert calls == [1, 2]  # period A was reused, not recomputed
    assert json.loads(ds.attrs["periods_reused"]) == ["A"]
    assert any(line.startswith("period A: reused") for line in lines)
    assert_same_results(read_results(tmp_path / "st.nc"), uninterrupted)
    # periods of different lengths: the shorter one is padded, integers stay integers
    assert uninterrupted.lidar_flags.dtype == np.uint8 and uninterrupted.lidar_10hz_valid.dtype == np.int16
    assert np.all(np.isnan(uninterrupted.lidar_speed.sel(period="B").values[300 * 50:]))
    assert np.all(uninterrupted.lidar_10hz_valid.sel(period="B").values[3000:] == 0)

    # a third run computes nothing
    calls.clear()
    again = run_scene(scene, tmp_path, progress=False)
    assert calls == [] and json.loads(again.attrs["periods_reused"]) == ["A", "B", "C"]


def test_a_changed_scene_recomputes_its_periods(tmp_path, monkeypatch):
    text = TEXT.replace('[[period]]\nname = "C"\nmean_speed = 7.0\n', "").replace("mean_speed = 6.0\nduration = 300.0\n", "mean_speed = 6.0\n")
    run_scene(loads_scene(text), tmp_path, progress=False)
    calls = counting(monkeypatch)
    run_scene(loads_scene(text.replace("seed = 5", "seed = 6")), tmp_path, progress=False)
    assert calls == [0, 1]


def test_full_disk_mid_run_keeps_what_was_written(tmp_path, monkeypatch, uninterrupted):
    real = xr.Dataset.to_netcdf
    n = []

    def write(ds, path, **kw):
        n.append(path)
        if len(n) == 2:  # the second period's file: the disk fills half-way through
            if hasattr(path, "write"):  # the atomic writer hands to_netcdf an open file object
                path.write(b"partial")
            else:
                with open(path, "wb") as fh:
                    fh.write(b"partial")
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(ds, path, **kw)

    monkeypatch.setattr(xr.Dataset, "to_netcdf", write)
    with pytest.raises(ResultsWriteError, match="No space left on device"):
        run_scene(loads_scene(TEXT), tmp_path, progress=False)
    assert sorted(os.listdir(tmp_path / "st.periods")) == ["000_A.nc"]  # no temporary file left behind
    monkeypatch.setattr(xr.Dataset, "to_netcdf", real)
    calls = counting(monkeypatch)
    ds = run_scene(loads_scene(TEXT), tmp_path, progress=False)
    assert calls == [1, 2]
    assert_same_results(read_results(tmp_path / "st.nc"), uninterrupted)
    assert ds.attrs["periods_reused"] == '["A"]'


def no_period(monkeypatch):
    def run_unit(*a, **k):
        raise AssertionError("a period was computed before the checks failed")

    monkeypatch.setattr(staring, "run_unit", run_unit)


def test_unwritable_folder_fails_before_computing(tmp_path, monkeypatch, capsys):
    no_period(monkeypatch)
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(PreflightError, match="cannot write to output folder"):
        run_scene(loads_scene(TEXT), blocker / "out", progress=False)
    scene = tmp_path / "s.toml"
    scene.write_text(TEXT)
    assert main(["run", str(scene), "--out", str(blocker / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "cannot write to output folder" in err and "fix:" in err


def test_missing_engine_fails_before_computing(tmp_path, monkeypatch, capsys):
    no_period(monkeypatch)
    monkeypatch.setitem(sys.modules, "h5py", None)  # import h5py now raises ImportError
    with pytest.raises(PreflightError, match="h5py does not import"):
        run_scene(loads_scene(TEXT), tmp_path, progress=False)
    scene = tmp_path / "s.toml"
    scene.write_text(TEXT)
    assert main(["run", str(scene), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "pip install" in err
    assert not os.listdir(tmp_path / "o")


def test_small_disk_fails_before_computing(tmp_path, monkeypatch):
    no_period(monkeypatch)
    import collections
    import shutil

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 1000, 1000))
    need = staring.estimate_bytes(loads_scene(TEXT))
    assert need > 1500 * (32 * 12 + 50 * 9)  # the three periods' raw series
    with pytest.raises(PreflightError, match="not enough disk space"):
        run_scene(loads_scene(TEXT), tmp_path, progress=False)


def test_unreachable_scheduler_is_one_line(tmp_path, monkeypatch, capsys):
    no_period(monkeypatch)
    with pytest.raises(PreflightError, match="unreachable"):
        store.check_scheduler("tcp://127.0.0.1:1")
    for bad in ("tcp://nohost", "", 5):
        with pytest.raises(PreflightError):
            store.check_scheduler(bad)
    scene = tmp_path / "s.toml"
    scene.write_text(TEXT)
    assert main(["run", str(scene), "--out", str(tmp_path / "o"), "--dask", "tcp://127.0.0.1:1", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "dask scheduler tcp://127.0.0.1:1 is unreachable" in err


def test_box_command_checks_before_generating(tmp_path, monkeypatch, capsys):
    import cwlidar_sim.turbulence as turbulence

    monkeypatch.setattr(turbulence, "generate_box", lambda *a, **k: pytest.fail("generated before the checks"))
    blocker = tmp_path / "file"
    blocker.write_text("")
    args = ["box", "--alpha-eps", "1", "--length-scale", "30", "--gamma", "3.9", "--shape", "8", "8", "8",
            "--spacing", "1", "1", "1", "--seed", "1", "--out", str(blocker / "b.nc")]
    assert main(args) == 2
    assert "cannot write to output folder" in capsys.readouterr().err
