"""The SpinnerLidar and the WindScanner as the other kinds run (issue 31): reproduce, resume, Dask, campaigns.

Each kind at a small size (the spinner: 6-s periods of three rosettes, a coarse box, tier 1; the
WindScanner: one 30-s period of three 10-s segments): an interrupted run resumes from its kept periods
to the bits of a whole run, a run on an in-process Dask cluster gives the same bits, a campaign sweeps
one of the kind's own scene fields (stopped after its first unit and resumed, merged, its sweep
figures drawn), and ``cwlidar-sim reproduce NAME --quick`` runs the bundled scene with its figures.
"""

from __future__ import annotations

import json
import os

import distributed
import pytest
import xarray as xr

from cwlidar_sim.campaign import loads_scene, read_results, registry, run_scene
from cwlidar_sim.campaign.execution import batch
from cwlidar_sim.campaign.execution.reproduce import bundled_text
from cwlidar_sim.campaign.execution.sweep import expand, loads_campaign
from cwlidar_sim.cli import main
from kind_scenes import WINDSCANNER

WINDSCANNER_TWO_PERIODS = WINDSCANNER + """[[period]]
name = "b"
mean_speed = 11.0
"""


def spinner_text():
    """The bundled spinner scene made small: 6-s periods (3 rosettes), an 8-m box, tier 1."""
    text = bundled_text("spinner")
    for old, new in (("duration = 600.0", "duration = 6.0"), ('tier = "spectral"', 'tier = "los"'),
                     ("spacing = 4.0", "spacing = 8.0")):
        assert old in text
        text = text.replace(old, new)
    return text


TEXTS = {"spinner": spinner_text, "windscanner": lambda: WINDSCANNER_TWO_PERIODS}
#: (a scene field of the kind's own to sweep, its two values, a product that must change with it)
SWEEPS = {"spinner": ("scan.focus_distance", [60.0, 100.0], "preview_time"),
          "windscanner": ("scanner.unit_height", [2.0, 11.0], "wind_std")}
KINDS = sorted(TEXTS)


def same(a, b):
    xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """Each kind's small scene run whole, here: (scene, results)."""
    out = {}
    for kind in KINDS:
        scene = loads_scene(TEXTS[kind]())
        out[kind] = scene, run_scene(scene, tmp_path_factory.mktemp(kind) / "whole", progress=False)
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_an_interrupted_run_resumes_to_the_bits_of_a_whole_run(kind, whole, tmp_path):
    scene, ref = whole[kind]
    assert len(scene.periods) >= 2 and ref.attrs["sensor"] == kind

    class Stop(Exception):
        pass

    def stop(index, ds):
        raise Stop

    out = tmp_path / "run"
    with pytest.raises(Stop):
        run_scene(scene, out, progress=False, on_period=stop)  # interrupted after the first period
    kept = sorted(os.listdir(out / f"{scene.name}.periods"))
    assert [k[:4] for k in kept] == ["000_"] and not (out / f"{scene.name}.nc").exists()
    ds = run_scene(scene, out, progress=False)
    assert json.loads(ds.attrs["periods_reused"]) == [scene.periods[0].name]
    same(ds, ref)
    same(read_results(out / f"{scene.name}.nc"), ref)


@pytest.mark.parametrize("kind", KINDS)
def test_a_run_on_dask_gives_the_bits_of_a_local_run(kind, whole, tmp_path):
    scene, ref = whole[kind]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        ds = run_scene(scene, tmp_path / "dask", client=client, progress=False)
    assert json.loads(ds.attrs["periods_reused"]) == []
    same(ds, ref)


@pytest.mark.parametrize("kind", KINDS)
def test_a_campaign_over_the_kinds_own_field_resumes_merges_and_draws(kind, tmp_path):
    key, values, product = SWEEPS[kind]
    (tmp_path / "base.toml").write_text(TEXTS[kind]())
    first = {"spinner": "aligned", "windscanner": "a"}[kind]
    spec = loads_campaign(f'name = "c"\nseed = 5\nbase = "base.toml"\nperiods = ["{first}"]\n'
                          f'[[sweep]]\n"{key}" = {json.dumps(values)}\n', base_dir=str(tmp_path))
    tasks = expand(spec)
    assert [registry.kind_of(t.scene).name for t in tasks] == [kind, kind]
    out = tmp_path / "out"

    class Stop(Exception):
        pass

    def stop(task, index):
        raise Stop

    with pytest.raises(Stop):
        batch.run_campaign(spec, out, local=True, progress=False, on_unit=stop)  # stopped after one unit
    s = batch.run_campaign(spec, out, local=True, progress=False)
    assert s["units_reused"] == 1 and s["computed"] == 2 and not s["failed"]
    merged = batch.merge_campaign(out)
    dim = key.rsplit(".", 1)[1]
    assert json.loads(merged.attrs["sweep_dims"]) == [dim] and merged.sizes[dim] == 2
    # each task is its own scene's run: the swept field changes the kind's product, as a lone run says
    for i, v in enumerate(values):
        alone = run_scene(tasks[i].scene, progress=False)
        got = merged.isel({dim: i}).sel(replica=0)
        xr.testing.assert_identical(got[product].drop_vars([c for c in got[product].coords if c != "period"]),
                                    alone[product].drop_vars([c for c in alone[product].coords if c != "period"]))
    assert float(merged[product].isel({dim: 0}).max()) != float(merged[product].isel({dim: 1}).max())
    figs = batch.sweep_figures(merged, tmp_path / "figures")
    assert figs and all(os.path.isfile(f) for f in figs)


@pytest.mark.parametrize("kind", KINDS)
def test_reproduce_runs_the_bundled_scene_quick_with_its_figures(kind, tmp_path, capsys, monkeypatch):
    """``reproduce NAME --quick``: the bundled scene through its kind's quick rule, figures written.

    The quick rule is made smaller still here (the small scene's sizes on the bundled geometry).
    """
    k = registry.get_kind(kind)
    seen = []
    small = loads_scene(TEXTS[kind]())

    def quick(scene):
        seen.append(scene.name)
        return small.replace(name=scene.name)

    monkeypatch.setattr(k, "quick", quick)
    out = tmp_path / "r"
    assert main(["reproduce", kind, "--quick", "--out", str(out), "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert seen == [kind] and summary["results"] == os.path.join(str(out), f"{kind}.nc")
    assert summary["figures"] and all(os.path.isfile(f) for f in summary["figures"])
    assert read_results(out / f"{kind}.nc").attrs["sensor"] == kind
