"""Results files are checked before they are read: each hostile file is a ValueError naming it and its fault."""

import os
import shutil
import signal

import h5py
import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import loads_scene, read_results, run_scene
from cwlidar_sim.campaign.execution import results_file
from cwlidar_sim.campaign.execution.results_file import HDF5_SIGNATURE, check_results_file, open_results

SCENE = """
name = "r"
seed = 1
duration = 300.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "los"
[analysis]
segment_duration = 150.0
fit = false
[[period]]
name = "A"
mean_speed = 8.0
"""


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    out = tmp_path_factory.mktemp("good")
    run_scene(loads_scene(SCENE), out, progress=False)
    return out / "r.nc"


@pytest.fixture
def alarm():
    """Fail (instead of hanging the suite) if the code under test blocks for 10 s."""
    def ring(signum, frame):
        raise AssertionError("blocked for 10 s")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(10)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def test_a_results_file_reads_as_before(good):
    xr.testing.assert_identical(open_results(good), read_results(good))
    assert open_results(good, sensor="staring").attrs["sensor"] == "staring"


def test_an_empty_file(tmp_path):
    (tmp_path / "x.nc").write_bytes(b"")
    with pytest.raises(ValueError, match="x.nc' is empty \\(0 bytes\\)"):
        open_results(tmp_path / "x.nc")


def test_a_directory(tmp_path):
    (tmp_path / "x.nc").mkdir()
    with pytest.raises(ValueError, match="x.nc' is a directory"):
        open_results(tmp_path / "x.nc")


def test_a_fifo_does_not_block(tmp_path, alarm):
    os.mkfifo(tmp_path / "x.nc")
    with pytest.raises(ValueError, match="x.nc' is a FIFO"):
        open_results(tmp_path / "x.nc")


def test_a_text_file(tmp_path):
    (tmp_path / "x.nc").write_text("time,speed\n0,8.1\n")
    with pytest.raises(ValueError, match="x.nc' is not a NetCDF-4/HDF5 file \\(no HDF5 signature\\)"):
        open_results(tmp_path / "x.nc")


def test_the_signature_after_a_user_block_is_found(tmp_path):
    with h5py.File(tmp_path / "ub.h5", "w", userblock_size=1024) as f:
        f["a"] = np.arange(3)
    with open(tmp_path / "ub.h5", "rb") as fh:
        assert fh.read(8) != HDF5_SIGNATURE  # the signature is not at byte 0
    check_results_file(tmp_path / "ub.h5")


def test_another_programs_hdf5_file(tmp_path):
    with h5py.File(tmp_path / "x.nc", "w") as f:
        f["period"] = np.arange(3)
        f.attrs["title"] = "someone else's data"
    with pytest.raises(ValueError, match="x.nc' is not a cwlidar_sim results file: no 'scene' attribute"):
        open_results(tmp_path / "x.nc")


@pytest.mark.parametrize("attrs, match", [
    ({"scene": "{not json", "sensor": "staring"}, "'scene' attribute is not JSON"),
    ({"scene": "[1, 2]", "sensor": "staring"}, "'scene' attribute is not a table"),
    ({"scene": "{}", "sensor": "radar"}, "'sensor' attribute is 'radar'"),
    ({"scene": "{}", "sensor": "staring"}, "no 'period' dimension"),
    ({"sweep_dims": "[]"}, "campaign's merged file"),
])
def test_a_netcdf_file_that_is_not_ours(tmp_path, attrs, match):
    xr.Dataset({"x": ("k", np.arange(3.0))}, attrs=attrs).to_netcdf(tmp_path / "x.nc", engine="h5netcdf")
    with pytest.raises(ValueError, match=match):
        open_results(tmp_path / "x.nc")


def test_a_truncated_file(good, tmp_path):
    data = good.read_bytes()
    (tmp_path / "x.nc").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="cannot read results file .*x.nc' \\(damaged or truncated\\?\\)"):
        open_results(tmp_path / "x.nc")


def test_another_sensor_is_refused_by_name(good):
    with pytest.raises(ValueError, match="holds a staring scene's results; this needs conical or nacelle results"):
        open_results(good, sensor=("conical", "nacelle"))


def test_a_file_larger_than_the_memory_is_refused_before_loading(good, tmp_path, monkeypatch):
    monkeypatch.setattr(results_file, "_available_memory", lambda: 1e3)
    with pytest.raises(ValueError, match="GB of data, more than 80% of the 0.00 GB of memory available"):
        open_results(good)


def test_a_symlink_to_a_results_file_is_read(good, tmp_path):
    os.symlink(good, tmp_path / "link.nc")
    shutil.copy(good, tmp_path / "copy.nc")
    xr.testing.assert_identical(open_results(tmp_path / "link.nc"), open_results(tmp_path / "copy.nc"))
