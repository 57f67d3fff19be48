"""Campaigns: sweep expansion, identity-based seeds, Dask determinism, resume, failures, merging."""

import json
import os

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import PreflightError, read_results
from cwlidar_sim.campaign.execution import batch
from cwlidar_sim.campaign.execution.sweep import expand, loads_campaign
from cwlidar_sim.cli import main

BASE = """
name = "base"
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
name = "P"
mean_speed = 8.0
seed = 99
"""


def campaign(tmp_path, sweep, extra=""):
    (tmp_path / "base.toml").write_text(BASE)
    return loads_campaign(f'name = "c"\nseed = 3\nbase = "base.toml"\n{extra}\n{sweep}', base_dir=str(tmp_path))


SWEEP = """
[[sweep]]
"period.0.mean_speed" = [6.0, 8.0]
"lidar.cnr_db" = [-10.0, -12.0]
[[sweep]]
"lidar.weighting" = ["exact", "lorentzian"]
"""


def test_expansion_zips_within_and_crosses_between_tables(tmp_path):
    tasks = expand(campaign(tmp_path, SWEEP, "replicas = 2"))
    assert len(tasks) == 2 * 2 * 2
    combos = {(t.scene.periods[0].mean_speed, t.scene.lidar.cnr_db, t.scene.lidar.weighting, t.replica) for t in tasks}
    assert (6.0, -10.0, "exact", 1) in combos and (8.0, -12.0, "lorentzian", 0) in combos
    assert (6.0, -12.0, "exact", 0) not in combos  # zipped, not crossed
    # paired: every sweep point of a replica has the same seed; replicas differ; the base's period seed is cleared
    seeds = {t.replica: set() for t in tasks}
    for t in tasks:
        seeds[t.replica].add(t.seed)
        assert t.scene.periods[0].seed is None and t.scene.seed == t.seed
    assert all(len(s) == 1 for s in seeds.values()) and seeds[0] != seeds[1]
    unpaired = expand(campaign(tmp_path, SWEEP, "replicas = 2\npaired = false"))
    assert len({t.seed for t in unpaired}) == 8
    r = expand(campaign(tmp_path, '[[sweep]]\n"lidar.cnr_db" = { start = -20.0, stop = -10.0, step = 5.0 }'))
    assert [t.scene.lidar.cnr_db for t in r] == [-20.0, -15.0, -10.0]


def test_identity_not_position(tmp_path):
    """Adding sweep values leaves the other tasks' ids and seeds (hence results) unchanged."""
    one = expand(campaign(tmp_path, '[[sweep]]\n"lidar.cnr_db" = [-10.0, -12.0]', "paired = false"))
    two = expand(campaign(tmp_path, '[[sweep]]\n"lidar.cnr_db" = [-8.0, -12.0, -10.0]', "paired = false"))
    old = {t.task_id: t.seed for t in one}
    new = {t.task_id: t.seed for t in two}
    assert set(old) < set(new) and all(new[k] == v for k, v in old.items())


@pytest.mark.parametrize("sweep, match", [
    ('[[sweep]]\n"lidar.cnr" = [1.0]', "unknown key.*'cnr'"),
    ('[[sweep]]\n"lidar.cnr_db" = [1.0, 150.0]', "lidar.cnr_db"),
    ('[[sweep]]\n"lidar.cnr_db" = [1.0, 2.0]\n"lidar.span" = [1.0]', "equal lengths"),
    ('[[sweep]]\n"lidar.cnr_db" = { start = 0.0, stop = 1.0 }', "exactly one of num or step"),
    ('[[sweep]]\n"period.3.mean_speed" = [1.0]', "not an index"),
])
def test_bad_sweeps_are_named_errors(tmp_path, sweep, match):
    with pytest.raises(ValueError, match=match):
        expand(campaign(tmp_path, sweep))


def merged_equal(a, b):
    xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    d = tmp_path_factory.mktemp("serial")
    spec = campaign(d, SWEEP)
    out = d / "out"
    s = batch.run_campaign(spec, out, local=True, progress=False)
    assert s["done"] == 4 and not s["failed"]
    return spec, out, batch.merge_campaign(out)


def test_merged_dataset_has_the_sweep_as_coordinates(serial):
    spec, out, merged = serial
    assert {"mean_speed", "weighting", "replica"} <= set(merged.dims)
    assert list(merged.lidar_cnr_db.values) == [-10.0, -12.0]  # the zipped partner rides along
    assert "lidar_speed" not in merged  # raw series stay in the task files
    # the accuracy metric against an independent computation from one task file
    idx = json.loads((out / "index.json").read_text())["tasks"]
    tid, e = next((k, v) for k, v in idx.items() if v["values"]["lidar.weighting"] == "lorentzian"
                  and v["values"]["period.0.mean_speed"] == 8.0)
    ds = read_results(out / e["result"])
    k = ds.k.values
    band = (k >= 0.02) & (k <= 0.6)
    lr = np.log10(ds.transfer_cross.values[0] / ds.transfer_theory_cross.values[0])[band]
    expect = np.sqrt(np.nanmean(lr**2))
    got = merged.t2_log_error.sel(mean_speed=8.0, weighting="lorentzian", replica=0, period="P").item()
    assert got == pytest.approx(expect, rel=1e-12)


def test_two_workers_give_the_bits_of_one(serial, tmp_path):
    pytest.importorskip("dask.distributed")
    spec, _, merged = serial
    for workers in (1, 2):
        out = tmp_path / f"w{workers}"
        s = batch.run_campaign(spec, out, workers=workers, progress=False)
        assert s["computed"] == 4
        merged_equal(batch.merge_campaign(out), merged)


def test_stopped_campaign_resumes_without_recomputing(serial, tmp_path, monkeypatch):
    spec, _, merged = serial
    out = tmp_path / "out"

    class Stop(Exception):
        pass

    def stop(task, status):
        raise Stop

    with pytest.raises(Stop):
        batch.run_campaign(spec, out, local=True, progress=False, on_task=stop)
    assert len([f for f in os.listdir(out / "tasks") if f.endswith(".nc")]) == 1
    calls = []
    real = batch._run_unit
    monkeypatch.setattr(batch, "_run_unit", lambda scene, i, params, threads: calls.append(1) or real(scene, i, params,
                                                                                                   threads))
    s = batch.run_campaign(spec, out, local=True, progress=False)
    assert len(calls) == 3 and s["reused"] == 1 and s["computed"] == 3
    merged_equal(batch.merge_campaign(out), merged)
    calls.clear()
    assert batch.run_campaign(spec, out, local=True, progress=False)["reused"] == 4 and not calls


def test_a_failing_task_is_recorded_and_the_rest_complete(tmp_path, monkeypatch):
    # tier 3 refuses a 300-s period (it simulates every 50 MHz sample): that task fails at run time
    spec = campaign(tmp_path, '[[sweep]]\n"lidar.tier" = ["los", "signal"]')
    s = batch.run_campaign(spec, tmp_path / "out", local=True, progress=False)
    assert s["done"] == 1 and len(s["failed"]) == 1 and "tier = 'signal'" in s["failed"][0]["error"]
    idx = json.loads((tmp_path / "out" / "index.json").read_text())["tasks"]
    assert sorted(e["status"] for e in idx.values()) == ["done", "failed"]
    calls = []
    real = batch._run_unit
    monkeypatch.setattr(batch, "_run_unit", lambda scene, i, params, threads: calls.append(scene.lidar.tier)
                        or real(scene, i, params, threads))
    s = batch.run_campaign(spec, tmp_path / "out", local=True, progress=False)
    assert calls == ["signal"] and s["reused"] == 1  # the failed one is retried, the done one is not


def test_a_task_too_big_for_a_worker_is_refused_before_it_starts(tmp_path, monkeypatch):
    monkeypatch.setattr(batch, "_run_unit", lambda *a: pytest.fail("a refused task was started"))
    spec = campaign(tmp_path, '[[sweep]]\n"lidar.cnr_db" = [-10.0, -11.0]')
    s = batch.run_campaign(spec, tmp_path / "out", local=True, progress=False, memory_limit=1e6)
    assert s["done"] == 0 and len(s["failed"]) == 2
    assert "refused before starting: estimated" in s["failed"][0]["error"] and "0.00 GB" in s["failed"][0]["error"]


def test_unreachable_scheduler_and_cli(tmp_path, capsys):
    spec = campaign(tmp_path, '[[sweep]]\n"lidar.cnr_db" = [-10.0, -11.0]')
    with pytest.raises(PreflightError, match="unreachable"):
        batch.run_campaign(spec, tmp_path / "out", scheduler="tcp://127.0.0.1:1", progress=False)
    f = tmp_path / "c.toml"
    f.write_text('name = "c"\nbase = "base.toml"\n[[sweep]]\n"lidar.cnr_db" = [-10.0, -11.0]\n')
    assert main(["campaign", str(f), "--out", str(tmp_path / "o"), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "unreachable" in err
    assert main(["campaign", str(f), "--dry-run", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["tasks"]
    assert len(rows) == 2 and all(r["est_seconds"] > 0 and r["est_memory_gb"] > 0 for r in rows)


def test_cluster_plan_never_oversubscribes():
    for cores in (1, 2, 8, 16):
        for n in (1, 3, 100):
            p = batch.plan_cluster(n, 1e9, cores=cores, memory=64e9)
            assert p["workers"] * p["threads"] <= cores and p["workers"] <= n
    assert batch.plan_cluster(100, 10e9, cores=16, memory=40e9)["workers"] == 3  # memory-bound
    with pytest.raises(ValueError, match="--workers"):
        batch.plan_cluster(4, 1e9, workers=0, cores=2)
