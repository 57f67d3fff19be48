"""Hostile inputs of the readers and of the Dask path: each a named one-line error before compute, never a hang.

Files named like results or scenes that are not (empty, a directory, a FIFO,
another program's HDF5, truncated, nested or large without bound), campaign
folders with foreign files, and Dask schedulers that cannot run anything.
"""

import json
import os

import distributed
import h5py
import numpy as np
import pytest
from conftest import assert_one_line_error, run_cli

SCENE = """name = "h"
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


def foreign_hdf5(path):
    with h5py.File(path, "w") as f:
        f["period"] = np.arange(4.0)
        f["data"] = np.ones((64, 64))
        f.attrs["title"] = "another program's file"


@pytest.fixture
def results_dir(tmp_path):
    d = tmp_path / "res"
    d.mkdir()
    return d


@pytest.mark.parametrize("kind, fragments", [
    ("empty", ("x.nc", "empty (0 bytes)")),
    ("directory", ("x.nc", "is a directory")),
    ("fifo", ("x.nc", "FIFO")),
    ("text", ("x.nc", "no HDF5 signature")),
    ("foreign", ("x.nc", "not a cwlidar_sim results file", "no 'scene' attribute")),
    ("truncated", ("x.nc", "damaged or truncated")),
])
def test_report_on_a_file_that_is_not_results(results_dir, corpus, kind, fragments):
    x = results_dir / "x.nc"
    if kind == "empty":
        x.write_bytes(b"")
    elif kind == "directory":
        x.mkdir()
    elif kind == "fifo":
        os.mkfifo(x)
    elif kind == "text":
        x.write_text("a,b\n1,2\n")
    else:
        foreign_hdf5(x)
        if kind == "truncated":
            data = x.read_bytes()
            x.write_bytes(data[: len(data) // 3])
    child = run_cli(["report", results_dir], cwd=results_dir.parent, timeout=60)
    assert_one_line_error(child, *fragments)
    corpus.record("error", child)


@pytest.mark.parametrize("kind", ["foreign", "fifo"])
def test_probe_length_on_a_file_that_is_not_results(results_dir, corpus, kind):
    x = results_dir / "x.nc"
    if kind == "fifo":
        os.mkfifo(x)
    else:
        foreign_hdf5(x)
    child = run_cli(["probe-length", x], cwd=results_dir.parent, timeout=60)
    assert_one_line_error(child, "x.nc", "no 'scene' attribute" if kind == "foreign" else "FIFO")
    corpus.record("error", child)


@pytest.mark.parametrize("kind, fragments", [
    ("deep_arrays", ("nested deeper than 32 levels",)),
    ("deep_tables", ("nested deeper than 32 levels",)),
    ("huge", ("s.toml", "bytes", "refused before reading")),
    ("fifo", ("s.toml", "FIFO")),
    ("binary", ("s.toml", "not UTF-8")),
])
def test_run_on_a_scene_file_that_is_not_one(tmp_path, corpus, kind, fragments):
    s = tmp_path / "s.toml"
    if kind == "deep_arrays":
        s.write_text('name = "x"\na = ' + "[" * 100000 + "]" * 100000)
    elif kind == "deep_tables":
        s.write_text('name = "x"\nb = ' + "{c = " * 2000 + "1" + "}" * 2000)
    elif kind == "huge":
        s.write_text("#" * (64 << 20))  # 64 MB of comment
    elif kind == "fifo":
        os.mkfifo(s)
    else:
        s.write_bytes(bytes(range(256)) * 4)
    child = run_cli(["run", s, "--out", tmp_path / "o"], cwd=tmp_path, timeout=60)
    assert_one_line_error(child, *fragments)
    assert child.peak_mb < 1000, child.peak_mb  # refused before the file is read whole
    corpus.record("error", child)


def test_campaign_on_a_nested_campaign_file(tmp_path, corpus):
    (tmp_path / "c.toml").write_text('name = "c"\n' + ".".join(["k"] * 60) + " = 1\n")
    child = run_cli(["campaign", "c.toml", "--dry-run"], cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "campaign", "nested deeper than 32 levels (60 levels")
    corpus.record("error", child)


def fake_campaign(folder, task_file_kind):
    """A campaign folder written by hand: campaign.json, index.json, one task file of ``task_file_kind``."""
    tid = "0123456789abcdef"
    (folder / "tasks").mkdir(parents=True)
    (folder / "campaign.json").write_text(json.dumps({
        "campaign": {"name": "c", "sweep": [{"lidar.cnr_db": [-10.0]}]},
        "tasks": [{"task_id": tid, "values": {"lidar.cnr_db": -10.0}, "replica": 0, "seed": 1}]}))
    (folder / "index.json").write_text(json.dumps({"tasks": {tid: {
        "status": "done", "values": {"lidar.cnr_db": -10.0}, "replica": 0, "seed": 1, "key": "k",
        "result": f"tasks/{tid}.nc"}}}))
    path = folder / "tasks" / f"{tid}.nc"
    if task_file_kind == "foreign":
        foreign_hdf5(path)
    elif task_file_kind == "fifo":
        os.mkfifo(path)
    return path


@pytest.mark.parametrize("kind, fragment", [("foreign", "no 'scene' attribute"), ("fifo", "FIFO")])
def test_campaign_report_with_a_foreign_task_file(tmp_path, corpus, kind, fragment):
    fake_campaign(tmp_path / "c", kind)
    child = run_cli(["campaign-report", "c"], cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "task file", "0123456789abcdef.nc", fragment, "delete it")
    corpus.record("error", child)


def test_campaign_report_with_a_task_id_that_leaves_the_folder(tmp_path, corpus):
    fake_campaign(tmp_path / "c", "foreign")
    meta = json.loads((tmp_path / "c" / "campaign.json").read_text())
    meta["tasks"][0]["task_id"] = "../../../etc/passwd"
    (tmp_path / "c" / "campaign.json").write_text(json.dumps(meta))
    child = run_cli(["campaign-report", "c"], cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "campaign.json", "tasks[0] is not a task")
    corpus.record("error", child)


@pytest.mark.parametrize("args", [
    ["run", "s.toml", "--out", "o", "--dask", "inproc://x"],
    ["campaign", "c.toml", "--out", "o", "--dask", "inproc://x"],
])
def test_an_inproc_address_from_the_command_line(tmp_path, corpus, args):
    (tmp_path / "s.toml").write_text(SCENE)
    (tmp_path / "c.toml").write_text('name = "c"\nbase = "s.toml"\n[[sweep]]\n"lidar.cnr_db" = [-10.0]\n')
    child = run_cli(args, cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "inproc://x", "tcp://host:port")
    corpus.record("error", child)


@pytest.mark.parametrize("args", [
    ["run", "s.toml", "--out", "o", "--scheduler", "tcp://127.0.0.1:1"],  # campaign's spelling on run
    ["campaign", "c.toml", "--out", "o", "--dask", "tcp://127.0.0.1:1"],  # run's spelling on campaign
])
def test_both_spellings_of_the_scheduler_option_are_accepted(tmp_path, corpus, args):
    (tmp_path / "s.toml").write_text(SCENE)
    (tmp_path / "c.toml").write_text('name = "c"\nbase = "s.toml"\n[[sweep]]\n"lidar.cnr_db" = [-10.0]\n')
    child = run_cli(args, cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "tcp://127.0.0.1:1", "unreachable")
    corpus.record("error", child)


@pytest.fixture
def workerless_scheduler():
    """A real TCP scheduler on loopback with no worker (as after the last worker died)."""
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp://", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        yield cluster.scheduler_address


@pytest.mark.parametrize("command", ["run", "campaign"])
def test_a_scheduler_without_workers_is_refused_not_waited_on(tmp_path, corpus, workerless_scheduler, command):
    (tmp_path / "s.toml").write_text(SCENE)
    (tmp_path / "c.toml").write_text('name = "c"\nbase = "s.toml"\n[[sweep]]\n"lidar.cnr_db" = [-10.0]\n')
    target = "s.toml" if command == "run" else "c.toml"
    child = run_cli([command, target, "--out", "o", "--dask", workerless_scheduler, "--worker-timeout", "2"],
                    cwd=tmp_path, timeout=60)  # waiting on the scheduler for good fails as "hung"
    assert_one_line_error(child, workerless_scheduler, "has no worker", "2 s")
    assert not (tmp_path / "o" / "h.periods").exists() and not (tmp_path / "o" / "tasks").exists()
    corpus.record("error", child)


def test_a_worker_timeout_out_of_range(tmp_path, corpus):
    (tmp_path / "s.toml").write_text(SCENE)
    child = run_cli(["run", "s.toml", "--out", "o", "--dask", "tcp://127.0.0.1:1", "--worker-timeout", "-5"],
                    cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "--worker-timeout", "-5")
    corpus.record("error", child)


@pytest.fixture(scope="module")
def real_results(tmp_path_factory):
    """A real results file of a tiny scene (written in this process)."""
    from cwlidar_sim.campaign import loads_scene, run_scene

    out = tmp_path_factory.mktemp("real")
    run_scene(loads_scene(SCENE), out, progress=False)
    return out / "h.nc"


@pytest.mark.parametrize("command, drop, missing", [
    ("report", "spectrum_lidar", "spectrum_lidar"),
    ("report", "@rayleigh_length", "rayleigh_length"),
    ("probe-length", "transfer_cross", "transfer_cross"),
])
def test_a_results_file_lacking_what_is_read(tmp_path, corpus, real_results, command, drop, missing):
    """An edited or older file: one line naming the file, what it lacks and the results versions."""
    from cwlidar_sim.campaign import read_results, write_results

    ds = read_results(real_results)
    if drop.startswith("@"):
        del ds.attrs[drop[1:]]
    else:
        ds = ds.drop_vars(drop)
    (tmp_path / "res").mkdir()
    write_results(ds, tmp_path / "res" / "x.nc")
    child = run_cli([command, "res" if command == "report" else "res/x.nc"], cwd=tmp_path, timeout=120)
    assert_one_line_error(child, "x.nc", f"lacks '{missing}'", "results_version")
    corpus.record("error", child)


@pytest.mark.parametrize("kind, fragments", [
    ("fifo", ("campaign.json", "FIFO")),
    ("missing", ("not a campaign folder", "no campaign.json")),
    ("binary", ("campaign.json", "not a cwlidar_sim campaign file")),
])
def test_campaign_report_on_a_folder_whose_campaign_json_is_not_one(tmp_path, corpus, kind, fragments):
    fake_campaign(tmp_path / "c", "foreign")
    meta = tmp_path / "c" / "campaign.json"
    meta.unlink()
    if kind == "fifo":
        os.mkfifo(meta)
    elif kind == "binary":
        meta.write_bytes(bytes(range(256)))
    child = run_cli(["campaign-report", "c"], cwd=tmp_path, timeout=60)
    assert_one_line_error(child, *fragments)
    corpus.record("error", child)
