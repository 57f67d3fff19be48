"""Resume inside a campaign task: finished periods are kept, stale work is never reused.

Every test counts the units (periods) a campaign run actually computes, by
task, through the worker function ``batch._run_unit``.
"""

import json
import os

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import read_results
from cwlidar_sim.campaign.execution import batch
from cwlidar_sim.campaign.execution.sweep import expand, loads_campaign

BASE = """
name = "base"
seed = 1
duration = 40.0
[turbulence]
{turbulence}
[lidar]
tier = "los"
[field]
dx = 1.0
[analysis]
segment_duration = 20.0
fit = false
k_min = 0.05
k_max = 1.0
per_decade = 2
[[period]]
name = "P"
mean_speed = 8.0
[[period]]
name = "Q"
mean_speed = 7.0
"""
TENSOR = "alpha_eps = 0.06\nlength_scale = 20.0\ngamma = 3.9"
SWEEP = '[[sweep]]\n"lidar.span" = [10.0, 20.0]'


def write_campaign(folder, sweep=SWEEP, extra="", seed=3, turbulence=TENSOR):
    (folder / "base.toml").write_text(BASE.format(turbulence=turbulence))
    text = f'name = "c"\nseed = {seed}\nbase = "base.toml"\n{extra}\n{sweep}\n'
    return loads_campaign(text, base_dir=str(folder))


@pytest.fixture
def count(monkeypatch):
    """(task label -> indices of the units computed), filled by the runs."""
    calls = []
    real = batch._run_unit

    def run_unit(scene, index, params, threads):
        calls.append((scene.lidar.span, index))
        return real(scene, index, params, threads)

    monkeypatch.setattr(batch, "_run_unit", run_unit)
    return calls


def run(spec, out, **kw):
    return batch.run_campaign(spec, out, local=True, progress=False, **kw)


def task_results(out):
    """task values (span) -> the task's results file, read."""
    idx = json.loads((out / "index.json").read_text())["tasks"]
    return {e["values"].get("lidar.span"): read_results(out / e["result"]) for e in idx.values()
            if e["status"] == "done"}


def same(a, b):
    xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    d = tmp_path_factory.mktemp("whole")
    spec = write_campaign(d)
    out = d / "out"
    assert run(spec, out)["computed"] == 2
    return task_results(out)


def test_an_interrupted_task_keeps_its_finished_periods(tmp_path, count, whole):
    spec = write_campaign(tmp_path)
    out = tmp_path / "out"

    class Stop(Exception):
        pass

    def stop(task, index):
        raise Stop

    with pytest.raises(Stop):
        run(spec, out, on_unit=stop)  # killed after the first period of the first task
    assert count == [(10.0, 0)]
    first = expand(spec)[0]
    kept = sorted(os.listdir(out / "tasks" / first.task_id / "base.periods"))
    assert kept == ["000_P.nc"] and not (out / "tasks" / f"{first.task_id}.nc").exists()
    count.clear()
    s = run(spec, out)
    assert count == [(10.0, 1), (20.0, 0), (20.0, 1)]  # only the missing period of the first task
    assert s["units_reused"] == 1 and s["computed"] == 2
    got = task_results(out)
    for span in (10.0, 20.0):
        same(got[span], whole[span])  # the bits of an uninterrupted run
    assert sorted(os.listdir(out / "tasks")) == sorted(f"{t.task_id}{ext}" for t in expand(spec)  # units cleared
                                                       for ext in (".nc", ".stats.csv"))
    count.clear()
    assert run(spec, out)["reused"] == 2 and count == []


def test_a_change_recomputes_what_it_affects_and_only_that(tmp_path, count):
    out = tmp_path / "out"
    one = 'periods = ["P"]\n'  # one period per task: each run writes and reads few files
    run(write_campaign(tmp_path, extra=one), out)
    before = task_results(out)
    seeds = {e["values"]["lidar.span"]: e["seed"] for e in json.loads((out / "index.json").read_text())["tasks"].values()}
    # a new sweep value: only its task
    count.clear()
    run(write_campaign(tmp_path, '[[sweep]]\n"lidar.span" = [10.0, 30.0]', extra=one), out)
    assert count == [(30.0, 0)]
    # a [set] value: every task, every period, and the results change with it
    count.clear()
    run(write_campaign(tmp_path, extra=one + '[set]\n"sonic.noise_std" = 0.1'), out)
    assert sorted(count) == [(10.0, 0), (20.0, 0)]
    noisy = task_results(out)
    assert not np.array_equal(noisy[10.0].sonic_10hz.values, before[10.0].sonic_10hz.values)
    np.testing.assert_array_equal(noisy[10.0].lidar_speed.values, before[10.0].lidar_speed.values)  # same field
    # the tensor: every task, and the field changes
    count.clear()
    run(write_campaign(tmp_path, extra=one, turbulence=TENSOR.replace("0.06", "0.07")), out)
    assert sorted(count) == [(10.0, 0), (20.0, 0)]
    strong = task_results(out)
    assert strong[10.0].attrs["alpha_eps"] == 0.07
    ratio = np.var(strong[10.0].lidar_speed.values, axis=1) / np.var(before[10.0].lidar_speed.values, axis=1)
    np.testing.assert_allclose(ratio, 0.07 / 0.06, rtol=1e-5)  # same seeds: the same field scaled by sqrt(7/6)
    # the campaign seed: every task, with other task seeds and another field
    count.clear()
    run(write_campaign(tmp_path, extra=one, seed=4), out)
    assert sorted(count) == [(10.0, 0), (20.0, 0)]
    idx = json.loads((out / "index.json").read_text())["tasks"]
    reseeded = {e["values"]["lidar.span"]: e["seed"] for e in idx.values()}
    assert all(reseeded[k] != seeds[k] for k in seeds)
    other = task_results(out)
    assert not np.array_equal(other[10.0].field_seed.values, before[10.0].field_seed.values)
    # and back to the first campaign: computed again (its results were replaced), the same bits as at first
    count.clear()
    run(write_campaign(tmp_path, extra=one), out)
    assert sorted(count) == [(10.0, 0), (20.0, 0)]
    for span in (10.0, 20.0):
        same(task_results(out)[span], before[span])


def test_task_seeds_follow_the_campaign_seed(tmp_path):
    a = expand(write_campaign(tmp_path, extra="replicas = 2"))
    b = expand(write_campaign(tmp_path, extra="replicas = 2", seed=4))
    assert [t.task_id for t in a] == [t.task_id for t in b]  # same identities ...
    assert not {t.seed for t in a} & {t.seed for t in b}  # ... other seeds
    assert len({t.seed for t in a}) == 2  # paired: one seed per replica
    assert {t.scene.unit_seed(i) for t in a for i in range(2)}.isdisjoint(
        {t.scene.unit_seed(i) for t in b for i in range(2)})


def sonic_record(path, seed, U=8.0, fs=10.0, n=2**12):
    from cwlidar_sim.turbulence import MannParameters, generate_line

    line = generate_line(MannParameters(0.06, 20.0, 3.9), n, U / fs, seed, dtype=np.float64)
    rec = xr.Dataset({c: ("time", line[c].values[::-1] + (U if c == "u" else 0.0)) for c in ("u", "v", "w")},
                     coords={"time": np.arange(n) / fs})
    rec.to_netcdf(path, engine="h5netcdf")


def test_new_contents_of_a_fit_to_record_recompute_its_tasks(tmp_path, count):
    """The same path, other contents: the fitted tensor, hence every period of the tasks fitting it, changes."""
    for name, seed in (("a.nc", 1), ("b.nc", 2)):
        sonic_record(tmp_path / name, seed)
    spec = write_campaign(tmp_path, '[[sweep]]\n"turbulence.fit_to" = ["a.nc", "b.nc"]\n"lidar.span" = [10.0, 20.0]',
                          extra='periods = ["P"]', turbulence='fit_to = "a.nc"')
    out = tmp_path / "out"
    run(spec, out)
    assert sorted(count) == [(10.0, 0), (20.0, 0)]
    first = task_results(out)
    count.clear()
    run(spec, out)
    assert count == []
    sonic_record(tmp_path / "b.nc", 3)  # b.nc rewritten in place
    run(spec, out)
    assert count == [(20.0, 0)]  # the task fitting b.nc, and only it
    again = task_results(out)
    same(again[10.0], first[10.0])
    fit = [json.loads(r.attrs["turbulence_fit"]) for r in (first[20.0], again[20.0])]
    assert fit[0]["path"] == fit[1]["path"] and again[20.0].attrs["alpha_eps"] != first[20.0].attrs["alpha_eps"]


CONE = """
name = "cone"
kind = "conical"
seed = 2
duration = 10.0
[scan]
heights = [20.0, 30.0]
scan_revs = [1]
[lidar]
tier = "los"
[turbulence]
source = "fixed"
alpha_eps = 0.05
length_scale = 15.0
gamma = 3.9
[[period]]
name = "a"
mean_speed = 8.0
[[period]]
name = "b"
mean_speed = 9.0
seed = 5
"""


def test_a_conical_campaign_seeds_every_unit_apart_and_runs(tmp_path):
    (tmp_path / "cone.toml").write_text(CONE)
    spec = loads_campaign('name = "cc"\nseed = 3\nbase = "cone.toml"\nreplicas = 2\n', base_dir=str(tmp_path))
    tasks = expand(spec)
    seeds = [t.scene.unit_seed(i) for t in tasks for i in range(len(t.scene.unit_names()))]
    assert len(seeds) == 8 and len(set(seeds)) == 8  # replicas x periods x heights (the base's own seed cleared)
    one = loads_campaign('name = "cc"\nseed = 3\nbase = "cone.toml"\nperiods = ["a"]\n[set]\n"scan.heights" = [20.0]\n',
                         base_dir=str(tmp_path))
    s = run(one, tmp_path / "out")
    assert s["done"] == 1 and not s["failed"]
    ds = task_results(tmp_path / "out")[None]
    assert list(ds.period.values) == ["a_z20"] and "std_ratio" in ds
