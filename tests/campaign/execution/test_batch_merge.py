"""campaign-report on what a campaign folder may hold: a sweep named like a results dimension, foreign or damaged files."""

import json
import shutil

import h5py
import numpy as np
import pytest

from cwlidar_sim.campaign import read_results
from cwlidar_sim.campaign.execution import batch
from cwlidar_sim.campaign.execution.sweep import loads_campaign
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
tier = "{tier}"
[analysis]
segment_duration = 150.0
fit = false
estimator_theory_lines = {lines}
[[period]]
name = "P"
mean_speed = 8.0
seed = 99
"""


def run(folder, tier, lines, sweep):
    (folder / "base.toml").write_text(BASE.format(tier=tier, lines=lines))
    # paired = false: each task its own turbulence, so that two tasks' numbers differ
    spec = loads_campaign(f'name = "c"\nseed = 3\nbase = "base.toml"\npaired = false\n{sweep}', base_dir=str(folder))
    out = folder / "out"
    s = batch.run_campaign(spec, out, local=True, progress=False)
    assert s["done"] == 2 and not s["failed"]
    return out


def task_file(out, key, value):
    """The result file of the task whose sweep value ``key`` is ``value`` (read from index.json)."""
    idx = json.loads((out / "index.json").read_text())["tasks"]
    tid = next(k for k, v in idx.items() if v["values"][key] == value)
    return tid, out / "tasks" / f"{tid}.nc"


@pytest.fixture(scope="module")
def estimators(tmp_path_factory):
    """A sweep over the estimator with the per-estimator theory on: the results have an 'estimator' dimension too."""
    return run(tmp_path_factory.mktemp("est"), "spectral", 1,
               '[[sweep]]\n"lidar.instrument.estimator" = ["median", "centroid"]')


@pytest.fixture(scope="module")
def speeds(tmp_path_factory):
    return run(tmp_path_factory.mktemp("los"), "los", 0, '[[sweep]]\n"lidar.cnr_db" = [-10.0, -12.0]')


@pytest.fixture
def folder(speeds, tmp_path):
    """A copy of the los campaign folder to damage."""
    return shutil.copytree(speeds, tmp_path / "copy")


def test_a_sweep_dimension_named_like_a_results_dimension_is_renamed(estimators, capsys):
    merged = batch.merge_campaign(estimators)
    assert merged.sizes["sweep_estimator"] == 2 and merged.sizes["estimator"] >= 2
    assert json.loads(merged.attrs["sweep_dims"]) == ["sweep_estimator"]
    # each sweep point holds its own task's numbers, read independently from its file
    for name in ("median", "centroid"):
        _, path = task_file(estimators, "lidar.instrument.estimator", name)
        own = read_results(path)
        got = merged.sel(sweep_estimator=name, replica=0)
        np.testing.assert_array_equal(got.transfer_cross.values, own.transfer_cross.values)
        np.testing.assert_array_equal(got.transfer_theory_estimator.values, own.transfer_theory_estimator.values)
    assert main(["campaign-report", str(estimators)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["dims"]["sweep_estimator"] == 2
    assert any(f.endswith("_sweep_estimator.png") for f in out["figures"])


def test_a_sweep_without_collision_keeps_its_name(speeds):
    merged = batch.merge_campaign(speeds)
    assert json.loads(merged.attrs["sweep_dims"]) == ["cnr_db"]
    assert list(merged.cnr_db.values) == [-12.0, -10.0]


def test_a_foreign_task_file_is_named_with_the_fix(folder):
    _, path = task_file(folder, "lidar.cnr_db", -12.0)
    path.unlink()
    with h5py.File(path, "w") as f:
        f["data"] = np.arange(4)
    with pytest.raises(ValueError, match=f"task file '{path}' is not a cwlidar_sim results file: no 'scene' "
                                         f"attribute; fix: delete it and run 'cwlidar-sim campaign' again"):
        batch.merge_campaign(folder)


def test_an_empty_task_file_is_a_one_line_error(folder, capsys):
    _, path = task_file(folder, "lidar.cnr_db", -10.0)
    path.write_bytes(b"")
    assert main(["campaign-report", str(folder)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "is empty (0 bytes)" in err and str(path) in err


def test_index_json_cannot_point_outside_the_folder(folder, tmp_path):
    """A result path in index.json is not followed: each task's own file is read."""
    tid_a, path_a = task_file(folder, "lidar.cnr_db", -10.0)
    _, path_b = task_file(folder, "lidar.cnr_db", -12.0)
    shutil.copy(path_b, tmp_path / "elsewhere.nc")
    idx = json.loads((folder / "index.json").read_text())
    idx["tasks"][tid_a]["result"] = str(tmp_path / "elsewhere.nc")
    (folder / "index.json").write_text(json.dumps(idx))
    merged = batch.merge_campaign(folder)
    own, other = read_results(path_a), read_results(path_b)
    assert not np.array_equal(own.transfer_cross.values, other.transfer_cross.values)
    np.testing.assert_array_equal(merged.sel(cnr_db=-10.0, replica=0).transfer_cross.values, own.transfer_cross.values)


@pytest.mark.parametrize("damage, match", [
    (lambda m: [], "needs a 'campaign' table and a 'tasks' list"),
    (lambda m: {**m, "tasks": {}}, "needs a 'campaign' table and a 'tasks' list"),
    (lambda m: {**m, "tasks": [{**m["tasks"][0], "task_id": "../../x"}]}, "tasks\\[0\\] is not a task"),
    (lambda m: {**m, "tasks": [{**m["tasks"][0], "values": {}}]}, "tasks\\[0\\] is not a task"),
    (lambda m: {**m, "campaign": {**m["campaign"], "sweep": [{}]}}, "list of non-empty tables"),
])
def test_a_damaged_campaign_json_is_named(folder, damage, match):
    meta = json.loads((folder / "campaign.json").read_text())
    (folder / "campaign.json").write_text(json.dumps(damage(meta)))
    with pytest.raises(ValueError, match=f"campaign.json'.*{match}"):
        batch.merge_campaign(folder)


def test_an_index_that_is_not_a_table_counts_nothing_done(folder):
    (folder / "index.json").write_text("[1, 2]")
    assert batch.CampaignIndex(folder).entries == {}
    with pytest.raises(ValueError, match="no finished task"):
        batch.merge_campaign(folder)
    (folder / "index.json").write_text('{"tasks": {"abc": 3}}')
    assert batch.CampaignIndex(folder).entries == {}


def test_merged_values_are_unchanged_by_the_checks(speeds):
    """The checked reader gives the merge the same bits as the plain one did."""
    merged = batch.merge_campaign(speeds)
    for v in (-10.0, -12.0):
        _, path = task_file(speeds, "lidar.cnr_db", v)
        own = read_results(path)
        for name in ("transfer_cross", "transfer_ratio", "availability", "flag_count"):
            np.testing.assert_array_equal(merged[name].sel(cnr_db=v, replica=0).values, own[name].values)
