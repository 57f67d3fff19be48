"""The Dask path never waits forever: no worker before a run, or none left during it, is a clear error in bounded time.

Loopback only: an in-process cluster (``processes=False``) whose workers are
threads of this process, so a test can take them away.
"""

import json
import os
import signal
import threading
import time

import dask
import distributed
import pytest

from cwlidar_sim._dask import WorkersLostError, check_worker_timeout, completed, connect_scheduler
from cwlidar_sim._preflight import PreflightError, check_scheduler
from cwlidar_sim.campaign import loads_scene, run_scene
from cwlidar_sim.campaign.periods import staring

SCENE = """
name = "w"
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
[[period]]
name = "B"
mean_speed = 9.0
"""

#: Released at the end of a test so that a worker thread stuck in a task may end.
RELEASE = threading.Event()


@pytest.fixture
def alarm():
    """Fail after 60 s instead of hanging the suite, which is what Dask alone does here."""
    def ring(signum, frame):
        raise AssertionError("still waiting after 60 s")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def _slow(x):
    RELEASE.wait(120)
    return x


_REAL_PERIOD = staring.run_unit


def _held_period(scene, index, params, status=None):
    """Period 0 as always; period 1 held until RELEASE (module level: the cluster pickles it by name)."""
    if index == 1:
        RELEASE.wait(120)
    return _REAL_PERIOD(scene, index, params, status=status)


@pytest.fixture
def empty_cluster():
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        yield cluster


def test_a_scheduler_without_workers_is_refused_in_bounded_time(empty_cluster, alarm):
    # the alarm fails the test if the wait does not end: bounded, without timing the refusal
    with pytest.raises(PreflightError, match="has no worker: none arrived in 1 s") as e:
        connect_scheduler(empty_cluster.scheduler_address, worker_timeout=1.0)
    assert empty_cluster.scheduler_address in str(e.value)


def test_a_scheduler_with_a_worker_is_connected(empty_cluster):
    empty_cluster.scale(1)
    client = connect_scheduler(empty_cluster.scheduler_address, worker_timeout=30.0)
    try:
        assert client.submit(sum, [1, 2]).result() == 3
    finally:
        client.close()


@pytest.mark.parametrize("address, match", [
    ("inproc://x", "not an in-process address of this process"),
    ("inproc://127.0.0.1/1/1", "of another process"),
    ("foo://host:1", "protocol 'foo'"),
    ("tcp://127.0.0.1:1", "unreachable"),
])
def test_addresses_that_cannot_work_are_one_line_errors(address, match):
    with pytest.raises(PreflightError, match=match):
        check_scheduler(address)


def test_an_inproc_address_of_this_process_is_accepted(empty_cluster):
    assert empty_cluster.scheduler_address.startswith("inproc://") and f"/{os.getpid()}/" in \
        empty_cluster.scheduler_address
    check_scheduler(empty_cluster.scheduler_address)


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), float("inf"), 1e9, True, "5"])
def test_worker_timeout_is_checked(bad):
    with pytest.raises(ValueError, match="worker_timeout"):
        check_worker_timeout(bad)


def test_run_scene_checks_the_worker_timeout_before_anything(tmp_path, monkeypatch):
    monkeypatch.setattr(staring, "run_unit", None)  # computing anything would fail otherwise
    with pytest.raises(ValueError, match=r"worker_timeout \(--worker-timeout\) -1"):
        run_scene(loads_scene(SCENE), tmp_path / "o", worker_timeout=-1)
    assert not (tmp_path / "o").exists()


def test_losing_the_last_worker_stops_the_wait(alarm):
    RELEASE.clear()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        futures = [client.submit(_slow, i, pure=False) for i in range(2)]
        threading.Timer(0.5, cluster.scale, (0,)).start()
        try:  # the alarm fixture fails the test if the wait never ends
            with pytest.raises(WorkersLostError, match="no worker for 1 s with 2 task"):
                list(completed(client, futures, worker_timeout=1.0, poll=0.2))
        finally:
            RELEASE.set()


def test_a_run_whose_workers_die_stops_and_resumes(tmp_path, monkeypatch, alarm):
    """Period A finishes on the cluster, then the last worker goes: a clear error; the rerun reuses A."""
    RELEASE.clear()
    scene = loads_scene(SCENE)
    monkeypatch.setattr(staring, "run_unit", _held_period)
    out = tmp_path / "out"
    stored = out / "w.periods"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        def take_workers_away():  # once period A is on disk
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not any(p.name.startswith("000_") for p in stored.glob("*.nc")):
                time.sleep(0.1)
            cluster.scale(0)

        threading.Thread(target=take_workers_away, daemon=True).start()
        try:
            with pytest.raises(WorkersLostError, match="no worker for 1 s"):
                run_scene(scene, out, client=client, progress=False, worker_timeout=1.0)
        finally:
            RELEASE.set()
    assert [p.name[:4] for p in stored.glob("*.nc")] == ["000_"]
    ds = run_scene(scene, out, progress=False)
    assert ds.attrs["periods_reused"] == '["A"]'


def _held_cnr12(scene, index, params, status=None):
    """Every unit as always but the CNR -12 dB task's, held until RELEASE."""
    if scene.lidar.cnr_db == -12.0:
        RELEASE.wait(120)
    return _REAL_PERIOD(scene, index, params, status=status)


def test_a_campaign_whose_workers_die_stops_and_resumes(tmp_path, monkeypatch, alarm):
    """One task finishes on the cluster, then the last worker goes: a clear error; the rerun reuses that task."""
    from cwlidar_sim.campaign.execution import batch
    from cwlidar_sim.campaign.execution.sweep import loads_campaign

    RELEASE.clear()
    (tmp_path / "base.toml").write_text(SCENE.split("[[period]]\nname = \"B\"")[0])
    spec = loads_campaign('name = "c"\nseed = 3\nbase = "base.toml"\npaired = false\n'
                          '[[sweep]]\n"lidar.cnr_db" = [-10.0, -12.0]', base_dir=str(tmp_path))
    monkeypatch.setattr(staring, "run_unit", _held_cnr12)
    out = tmp_path / "out"

    def done_tasks():
        try:
            entries = json.loads((out / "index.json").read_text())["tasks"].values()
        except (OSError, ValueError):
            return []
        return [e["values"]["lidar.cnr_db"] for e in entries if e["status"] == "done"]

    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        def take_workers_away():  # once the -10 dB task is recorded
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not done_tasks():
                time.sleep(0.1)
            cluster.scale(0)

        threading.Thread(target=take_workers_away, daemon=True).start()
        try:
            with pytest.raises(WorkersLostError, match="no worker for 1 s with 1 task"):
                batch.run_campaign(spec, out, client=client, progress=False, worker_timeout=1.0)
        finally:
            RELEASE.set()
    assert done_tasks() == [-10.0]
    s = batch.run_campaign(spec, out, local=True, progress=False)
    assert s["reused"] == 1 and s["computed"] == 1 and not s["failed"]


def test_losing_the_scheduler_stops_with_its_reason(alarm):
    """The client loses its scheduler: the pending futures come back cancelled, which is said in one error."""
    RELEASE.clear()
    # short reconnect attempts: closing what is left of the cluster would otherwise wait 30 s
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}), \
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://",
                                     host="127.0.0.1", dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        with distributed.Client(address) as client:
            futures = [client.submit(_slow, i, pure=False) for i in range(2)]
            threading.Timer(0.5, cluster.sync, (cluster.scheduler.close,)).start()
            try:
                with pytest.raises(WorkersLostError, match=f"dask scheduler {address} lost task .*cancelled"):
                    list(completed(client, futures, worker_timeout=30.0, address=address, poll=0.2))
            finally:
                RELEASE.set()
