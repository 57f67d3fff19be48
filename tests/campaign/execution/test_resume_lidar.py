"""Resume never reuses stale work after a ``[lidar]`` change: the same scene rerun into its folder.

Every ``[lidar]`` setting is scene-wide (one instrument and chain for every
period), so a change recomputes every period of the scene, and the folder then
holds exactly what a fresh run of the changed scene gives; an unchanged rerun
computes nothing.  In a campaign, a ``[set]`` of a lidar setting recomputes
every task, a changed ``[[sweep]]`` value only the task that has it.
"""

import json

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import loads_scene, read_results, run_scene
from cwlidar_sim.campaign.execution import batch
from cwlidar_sim.campaign.periods import staring
from cwlidar_sim.campaign.execution.sweep import loads_campaign

SCENE = """
name = "rs"
seed = 7
duration = 10.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "{tier}"
cnr_db = {cnr_db}
span = {span}
instrument = {{ focus = 67.5, estimator = "{estimator}" }}
[field]
dx = 1.0
[analysis]
segment_duration = 10.0
fit = false
k_min = 0.05
k_max = 1.0
per_decade = 2
[[period]]
name = "A"
mean_speed = 8.0
[[period]]
name = "B"
mean_speed = 6.0
"""
BASE = dict(tier="spectral", cnr_db=-10.0, span=20.0, estimator="median")


def scene(**change):
    return loads_scene(SCENE.format(**(BASE | change)))


@pytest.fixture
def computed(monkeypatch):
    """Indices of the periods actually computed (not reused), in order."""
    calls = []
    real = staring.run_unit

    def run_unit(sc, index, params, **kw):
        calls.append(index)
        return real(sc, index, params, **kw)

    monkeypatch.setattr(staring, "run_unit", run_unit)
    return calls


def results(sc, folder):
    run_scene(sc, folder, progress=False)
    return read_results(folder / f"{sc.name}.nc")


@pytest.mark.parametrize("change, variable", [
    ({"cnr_db": -20.0}, "lidar_speed"),          # the noise: every estimate
    ({"span": 5.0}, "transfer_theory_cells"),    # the probe volume's cells
    ({"tier": "los"}, "lidar_speed"),            # no spectra at all
    ({"estimator": "centroid"}, "lidar_speed"),  # the processing of the same spectra
], ids=["cnr_db", "span", "tier", "estimator"])
def test_a_lidar_change_recomputes_every_period_and_matches_a_fresh_run(tmp_path, computed, change, variable):
    folder = tmp_path / "out"
    before = results(scene(), folder)
    assert computed == [0, 1]
    computed.clear()
    results(scene(), folder)
    assert computed == []  # unchanged: everything reused
    after = results(scene(**change), folder)
    assert computed == [0, 1]  # scene-wide: every period again, none reused
    assert json.loads(after.attrs["periods_reused"]) == []
    assert not np.array_equal(after[variable].values, before[variable].values, equal_nan=True)
    fresh = results(scene(**change), tmp_path / "fresh")
    xr.testing.assert_identical(after.drop_attrs(), fresh.drop_attrs())  # nothing stale survived


CAMPAIGN_BASE = SCENE.format(**BASE).replace('name = "rs"', 'name = "base"')


@pytest.fixture
def tasks_run(monkeypatch):
    """(lidar.cnr_db, lidar.instrument.estimator, unit index) of each unit a campaign run computes."""
    calls = []
    real = batch._run_unit

    def run_unit(sc, index, params, threads):
        calls.append((sc.lidar.cnr_db, sc.lidar.instrument.get("estimator"), index))
        return real(sc, index, params, threads)

    monkeypatch.setattr(batch, "_run_unit", run_unit)
    return calls


def campaign(folder, sweep, extra=""):
    (folder / "base.toml").write_text(CAMPAIGN_BASE)
    return loads_campaign(f'name = "c"\nseed = 3\nbase = "base.toml"\nperiods = ["A"]\n{extra}\n{sweep}\n',
                          base_dir=str(folder))


def task_files(out):
    idx = json.loads((out / "index.json").read_text())["tasks"]
    return {e["values"]["lidar.cnr_db"]: read_results(out / e["result"]) for e in idx.values() if e["status"] == "done"}


def test_a_campaigns_lidar_set_recomputes_every_task_and_a_sweep_value_only_its_own(tmp_path, tasks_run):
    out = tmp_path / "out"
    sweep = '[[sweep]]\n"lidar.cnr_db" = [-10.0, -15.0]'

    def run(spec):
        tasks_run.clear()
        batch.run_campaign(spec, out, local=True, progress=False)
        return sorted(tasks_run)

    assert run(campaign(tmp_path, sweep)) == [(-15.0, "median", 0), (-10.0, "median", 0)]
    first = task_files(out)
    assert run(campaign(tmp_path, sweep)) == []
    # a new sweep value: its task only, the other reused
    assert run(campaign(tmp_path, '[[sweep]]\n"lidar.cnr_db" = [-10.0, -20.0]')) == [(-20.0, "median", 0)]
    # a [set] of the estimator: every task, and the estimates change with it
    est = '[set]\n"lidar.instrument.estimator" = "centroid"'
    assert run(campaign(tmp_path, sweep, est)) == [(-15.0, "centroid", 0), (-10.0, "centroid", 0)]
    centroid = task_files(out)
    assert not np.array_equal(centroid[-10.0].lidar_speed.values, first[-10.0].lidar_speed.values, equal_nan=True)
    # a [set] of the span: every task again
    assert run(campaign(tmp_path, sweep, est + '\n"lidar.span" = 5.0')) == [(-15.0, "centroid", 0),
                                                                            (-10.0, "centroid", 0)]
    # back to the first campaign: computed again, to its first bits
    assert run(campaign(tmp_path, sweep)) == [(-15.0, "median", 0), (-10.0, "median", 0)]
    xr.testing.assert_identical(task_files(out)[-10.0].drop_attrs(), first[-10.0].drop_attrs())
