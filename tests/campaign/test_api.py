"""The high-level API's scene handling: open by name or file, change dotted keys, keep periods, refuse by name.

(Running and reading back: tests/test_quickstart.py.)
"""

import subprocess
import sys

import pytest

import cwlidar_sim as cw
from cwlidar_sim.campaign import bundled_scene
from cwlidar_sim.campaign.execution.reproduce import bundled_text


def test_import_stays_light_and_the_api_is_there():
    code = ("import sys, cwlidar_sim as cw; names = sorted(cw.__all__); "
            "print(sorted(m for m in ('numpy', 'numba', 'xarray', 'cwlidar_sim.campaign') if m in sys.modules), names)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[] ['__version__', 'open_results', 'open_scene', 'run']"
    assert {"open_scene", "run", "open_results"} <= set(dir(cw))
    with pytest.raises(AttributeError, match="no attribute 'opn_scene'"):
        getattr(cw, "opn_scene")


@pytest.mark.parametrize("name, key, value, get", [
    ("a2012", "lidar.instrument.focus", 80.0, lambda s: s.lidar.instrument["focus"]),
    ("cs", "lidar.cnr_db", -15.0, lambda s: s.lidar.cnr_db),
    ("nacelle", "period.0.mean_speed", 9.5, lambda s: s.periods[0].mean_speed),
])
def test_with_values_changes_one_dotted_key_of_every_scene_kind(name, key, value, get):
    scene = cw.open_scene(name)
    assert scene == bundled_scene(name)
    new = scene.with_values({key: value})
    assert type(new) is type(scene) and get(new) == value and get(scene) != value
    assert new.with_values({key: get(scene)}) == scene  # nothing else moved


def test_with_values_refuses_by_key_and_value():
    scene = cw.open_scene("a2012")
    with pytest.raises(ValueError, match=r"lidar\.tier='fast' is not allowed"):
        scene.with_values({"lidar.tier": "fast"})
    with pytest.raises(ValueError, match=r"did you mean 'focus'"):
        scene.with_values({"lidar.instrument.focuss": 80.0})
    with pytest.raises(ValueError, match="duration=-1.0 is out of range"):
        scene.with_values({"duration": -1.0})
    with pytest.raises(ValueError, match="is a value, not a table"):
        scene.with_values({"lidar.cnr_db.x": 1.0})
    with pytest.raises(TypeError, match="dict of dotted scene keys"):
        scene.with_values([("duration", 600.0)])


def test_open_scene_by_file_periods_and_quick(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(bundled_text("a2012"), encoding="utf-8")
    assert cw.open_scene(path) == bundled_scene("a2012").replace(base_dir=str(tmp_path))
    assert cw.open_scene("a2012", quick=True) == bundled_scene("a2012", quick=True)
    kept = cw.open_scene("a2012", periods=["D", "B"])
    assert [p.name for p in kept.periods] == ["B", "D"]  # the scene's order
    with pytest.raises(ValueError, match=r"\['X'\] are not periods of scene 'a2012'; allowed: \['A', 'B', 'C', 'D'\]"):
        cw.open_scene("a2012", periods=["X"])
    with pytest.raises(TypeError, match="a list of period names"):
        cw.open_scene("a2012", periods="C")
    with pytest.raises(ValueError, match="quick=True applies to the bundled scenes"):
        cw.open_scene(path, quick=True)
    with pytest.raises(ValueError, match="no bundled scene of that name; bundled: a2012, cs, nacelle"):
        cw.open_scene("a2013")


def test_open_results_of_a_folder_without_finished_results(tmp_path):
    with pytest.raises(ValueError, match="holds no finished results"):
        cw.open_results(tmp_path)
    with pytest.raises(ValueError, match="is empty"):
        (tmp_path / "x.nc").write_bytes(b"")
        cw.open_results(tmp_path / "x.nc")
