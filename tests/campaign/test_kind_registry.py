"""The registry of scene kinds: the protocol checked at registration, entry-point discovery, the example
``mast`` kind (examples/mast_kind, outside the package) end to end, every built-in kind through the same path."""

import json
import pathlib
import sys

import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene, registry, run_scene
from cwlidar_sim.campaign.execution.reproduce import BUNDLED, bundled_scene
from cwlidar_sim.cli import main

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "mast_kind"

MAST = """
name = "m"
kind = "mast"
seed = 5
duration = 60.0
[mast]
heights = [10.0, 30.0]
spacing = 4.0
[turbulence]
alpha_eps = 0.08
length_scale = 15.0
gamma = 3.2
[[period]]
name = "low"
mean_speed = 6.0
[[period]]
name = "high"
mean_speed = 11.0
"""


@pytest.fixture
def mast():
    """The mast kind installed as a distribution would be: its package and a dist-info with the entry point on
    sys.path (importlib.metadata reads ``*.dist-info/entry_points.txt`` there); removed afterwards."""
    import tempfile

    with tempfile.TemporaryDirectory() as site:
        info = pathlib.Path(site) / "mast_kind-0.1.0.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: mast-kind\nVersion: 0.1.0\n")
        (info / "entry_points.txt").write_text("[cwlidar_sim.scene_kinds]\nmast = mast_kind:KIND\n")
        sys.path[:0] = [str(EXAMPLE), site]
        registry.refresh()
        try:
            yield registry.get_kind("mast")
        finally:
            sys.path.remove(str(EXAMPLE))
            sys.path.remove(site)
            for name in [m for m in sys.modules if m == "mast_kind" or m.startswith("mast_kind.")]:
                del sys.modules[name]
            registry.refresh()


def test_every_builtin_kind_is_found_and_checked_through_the_registry():
    assert registry.kind_names()[:3] == ("staring", "conical", "nacelle")
    for name in ("staring", "conical", "nacelle"):
        kind = registry.get_kind(name)
        assert registry.check_kind(kind, name) is kind and isinstance(kind, registry.SceneKind)
        assert kind.scene_class.kind == name
    kinds = {bundled: registry.kind_of(bundled_scene(bundled)).name for bundled in BUNDLED}
    assert kinds == {"a2012": "staring", "cs": "conical", "nacelle": "nacelle", "spinner": "spinner",
                     "windscanner": "windscanner"}
    # the twin: staring and conical take one, the nacelle refuses
    assert [registry.get_kind(n).twin is not None for n in ("staring", "conical", "nacelle")] == [True, True, False]


def test_quick_rules_are_the_kinds():
    a, c, n = (bundled_scene(name, quick=True) for name in ("a2012", "cs", "nacelle"))
    assert {a.period_duration(p) for p in a.periods} == {1200.0}
    assert len(c.periods) == 2 and c.scan.periods_per_height == ()
    assert {n.period_duration(p) for p in n.periods} == {300.0}


def test_a_kind_missing_members_is_refused_naming_them():
    class Half(registry.KindBase):
        name = "half"
        scene_class = type(bundled_scene("a2012"))

        def run_unit(self, scene, index, params=None, *, status=None):
            return None

    with pytest.raises(TypeError, match=r"scene kind .* lacks estimate_bytes, estimate_unit, summary"):
        registry.register(Half())
    assert "half" not in registry.kind_names()

    class NoScene:
        name = "noscene"
    with pytest.raises(TypeError, match=r"lacks scene_class, resolve, scene_params, run_unit"):
        registry.register(NoScene())

    class WrongName(Half):
        name = "other"
        estimate_bytes = estimate_unit = summary = run_unit = Half.run_unit
    with pytest.raises(TypeError, match=r"scene class Scene has kind = 'staring', not 'other'"):
        registry.register(WrongName())


def test_unknown_kind_names_the_closest_and_every_registered_one():
    text = bundled_scene("nacelle").as_dict()
    text["kind"] = "nacell"
    from cwlidar_sim.campaign.scenes.load import scene_from_dict

    with pytest.raises(ValueError, match=r"^kind = 'nacell' is not a scene kind \(did you mean 'nacelle' for "
                                         r"'nacell'\?\); allowed: \['staring', 'conical', 'nacelle'[,\]]"):
        scene_from_dict(text)


def test_the_runner_asks_the_registry(tmp_path):
    """A kind registered in place of the staring one is the one that runs: nothing dispatches around it."""
    real = registry.get_kind("staring")
    calls = []

    class Counting(type(real)):
        def run_unit(self, scene, index, params=None, *, status=None):
            calls.append(index)
            return super().run_unit(scene, index, params, status=status)

    scene = bundled_scene("a2012").with_values({"duration": 600.0, "lidar.tier": "los", "analysis.fit": False,
                                                "analysis.estimator_theory_lines": 0})
    scene = scene.replace(periods=scene.periods[:1])
    registry.register(Counting(), replace=True)
    try:
        ds = run_scene(scene, progress=False)
    finally:
        registry.unregister("staring")
    assert calls == [0] and ds.attrs["sensor"] == "staring"
    assert registry.get_kind("staring") is real


def test_entry_point_discovery(mast):
    import mast_kind

    assert mast is mast_kind.KIND and "mast" in registry.kind_names()
    scene = loads_scene(MAST)
    assert type(scene) is mast_kind.MastScene and registry.kind_of(scene) is mast
    assert scene.with_values({"mast.spacing": 3.0}).mast.spacing == 3.0
    with pytest.raises(ValueError, match=r"unknown key\(s\) in mast: \['height'\] \(did you mean 'heights'"):
        loads_scene(MAST.replace("heights =", "height ="))


def test_without_the_entry_point_the_mast_is_unknown():
    with pytest.raises(ValueError, match=r"kind = 'mast' is not a scene kind"):
        loads_scene(MAST)


def test_the_mast_kind_end_to_end(mast, tmp_path, capsys):
    """run (figures), resume, report, campaign sweeps (here and on Dask, the same bits), campaign-report, twin."""
    import distributed

    from cwlidar_sim.campaign import read_results
    from cwlidar_sim.campaign.execution.batch import merge_campaign, run_campaign
    from cwlidar_sim.campaign.execution.sweep import loads_campaign
    from cwlidar_sim.campaign.twin.run import run_twin

    path = tmp_path / "m.toml"
    path.write_text(MAST)
    out = tmp_path / "run"
    assert main(["run", str(path), "--out", str(out), "--figures", "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary["cup_sonic_std_ratio"]) == {"low", "high"} and summary["periods_reused"] == []
    assert (out / "std_profile.png").is_file()
    ds = read_results(out / "m.nc")
    assert ds.attrs["sensor"] == "mast" and ds.cup_std.dims == ("period", "height")
    # the cup's first-order response filters the speed: its std below the sonic's, more so at the lower speed
    ratio = ds.cup_sonic_std_ratio.values
    assert np.all((ratio > 0.6) & (ratio < 1.0)) and np.all(ratio[0] < ratio[1])
    # resume: every period reused, the same bits
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert again["periods_reused"] == ["low", "high"]
    assert read_results(out / "m.nc").cup_std.equals(ds.cup_std)
    assert main(["report", str(out), "--out", str(tmp_path / "fig")]) == 0
    assert json.loads(capsys.readouterr().out)["figures"] == [str(tmp_path / "fig" / "std_profile.png")]

    camp = loads_campaign(f'name = "c"\nbase = "{path}"\nseed = 2\n[[sweep]]\n"mast.spacing" = [3.0, 4.0]\n')
    here = run_campaign(camp, tmp_path / "here", local=True, progress=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        there = run_campaign(camp, tmp_path / "dask", client=client, progress=False)
    assert here["computed"] == there["computed"] == 2 and not here["failed"] and not there["failed"]
    a, b = merge_campaign(tmp_path / "here"), merge_campaign(tmp_path / "dask")
    assert set(a.cup_std.dims) == {"spacing", "replica", "period", "height"} and a.cup_std.equals(b.cup_std)
    assert run_campaign(camp, tmp_path / "here", local=True, progress=False)["reused"] == 2
    assert main(["campaign-report", str(tmp_path / "here")]) == 0
    capsys.readouterr()

    with pytest.raises(ValueError, match=r"^a mast scene has no virtual twin \(kinds with one: staring, conical\)"):
        run_twin(loads_scene(MAST), tmp_path / "twin")
    assert mast.quick(loads_scene(MAST)).duration == 120.0
