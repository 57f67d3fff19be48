"""The README as a front door: its numbers are generated from committed results files, its scene runs,
its outputs table names what a run writes, and it names every sensor.

The generated blocks are written by tools/readme_numbers.py; editing a results file (docs/*.json)
without re-running it, or a number by hand, fails here.
"""

import fnmatch
import importlib.util
import json
import os
import re
import shlex
import tomllib

import pytest
import xarray as xr

from cwlidar_sim import cli
from cwlidar_sim.campaign import loads_scene

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SENSORS = ("sonic", "cup", "staring lidar", "conically scanning", "nacelle lidar")


def _tool():
    spec = importlib.util.spec_from_file_location("readme_numbers", os.path.join(ROOT, "tools", "readme_numbers.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _readme():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        return f.read()


def test_generated_blocks_are_the_results_files():
    """Every generated block is what the script makes from docs/*.json today."""
    tool, text = _tool(), _readme()
    made = tool.blocks()
    assert set(made) == {"first-result", "own-scene", "reproductions", "cs-residual"}
    assert tool.render(text, made) == text, "README.md is stale: run python tools/readme_numbers.py"


def test_a_changed_results_file_changes_the_readme(monkeypatch):
    """The blocks follow the files: a CS ratio changed in the JSON shows up in the README's table."""
    tool = _tool()
    cs = json.load(open(tool.CS_JSON, encoding="utf-8"))
    cs["heights"]["40"]["std_ratio_1s"] = 0.5
    real = tool._load
    monkeypatch.setattr(tool, "_load", lambda p: cs if p == tool.CS_JSON else real(p))
    table = tool.blocks()["reproductions"]
    assert "0.500 ± " in table and tool.render(_readme(), tool.blocks()) != _readme()


def test_the_cs_residual_follows_the_attribution_run(monkeypatch):
    """The CS residual's block states the attribution run's steps and how far the theory lies from the
    simulation in standard errors: a larger 3-D drop and a theory moved 3 standard errors off show up."""
    tool = _tool()
    attribution = json.load(open(tool.CS_ATTRIBUTION_JSON, encoding="utf-8"))
    cs = json.load(open(tool.CS_JSON, encoding="utf-8"))
    steps = attribution["heights"]["40"]["steps"]
    steps["uv_3d"]["1"] = steps["period"]["1"] - 0.5
    sim, se = cs["heights"]["40"]["std_ratio_1s"], cs["heights"]["40"]["std_ratio_1s_se"]
    steps["box"]["1"] = sim - 3.0 * se
    real = tool._load
    monkeypatch.setattr(tool, "_load", lambda p: attribution if p == tool.CS_ATTRIBUTION_JSON else real(p))
    block = tool.blocks()["cs-residual"]
    assert "–0.500;" in block and "within 3.0 standard errors" in block
    assert tool.render(_readme(), tool.blocks()) != _readme()


def _prose(text):
    """The README's text less what is allowed to hold numbers without being generated: the generated
    blocks, code (fenced and inline), link targets, the citations, the paper's equation, figure and
    method numbers, and author-year references."""
    text = re.sub(r"<!-- BEGIN generated:([\w-]+) -->.*?<!-- END generated:\1 -->", "", text, flags=re.S)
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    text = re.sub(r"`[^`]*`", "", text)
    text = re.sub(r"\]\([^)]*\)", "]", text)
    text = re.sub(r"^## How to cite\n.*?(?=^## |\Z)", "", text, flags=re.S | re.M)
    text = re.sub(r"\b(Eqs?\.|Figs?\.|method) \d+(–\d+)?", "", text)  # A2012's equations, figures, methods 1 and 2
    text = re.sub(r"\((19|20)\d\d\)", "", text)
    return text.replace("exp(−2 k zR)", "")


def test_every_number_in_the_readme_is_generated():
    """Outside the generated blocks the README states no number that a run could change (the Python
    version it states is pyproject's)."""
    text = _readme()
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        python = tomllib.load(f)["project"]["requires-python"].lstrip(">=")
    assert f"Python ≥ {python}" in text
    prose = _prose(text).replace(f"Python ≥ {python}", "")
    numbers = [(m.group(), prose[max(0, m.start() - 40):m.end() + 20]) for m in re.finditer(r"(?<!\w)\d[\d.,]*", prose)]
    assert numbers == [], numbers


def test_the_readme_names_every_sensor_and_so_does_the_landing_page():
    """The README's opening and the site's landing page (which includes it) name all five sensors."""
    intro = _readme().split("\n## ", 1)[0]
    with open(os.path.join(ROOT, "docs", "index.md"), encoding="utf-8") as f:
        index = f.read()
    assert '"<!-- after: cwlidar_sim -->"' in index and '"<!-- before: Set up and go -->"' in index
    for name in SENSORS:
        assert name in intro, name


def test_the_readme_commands_are_the_ones_ci_runs():
    """.ci/run calls exactly the README's test and docs commands."""
    text = _readme()
    with open(os.path.join(ROOT, ".ci", "run"), encoding="utf-8") as f:
        ci = f.read()
    commands = re.findall(r"^```bash\n(python3 -m venv .*)\n```", text, flags=re.M)
    assert len(commands) == 3, commands
    for cmd in commands[1:]:
        assert cmd in ci.splitlines(), cmd
    assert commands[0].endswith("cwlidar-sim reproduce a2012 --out results")


# ---------------------------------------------------------------------------------------------------
# the scene of "Your own scene", run as the README says, and the outputs table against what it wrote
# ---------------------------------------------------------------------------------------------------
VARIANTS = ('variants = [{ name = "raise10", threshold_raise_percent = 10.0 }, '
            '{ name = "centroid", estimator = "centroid" }], ')


@pytest.fixture(scope="module")
def own_run(tmp_path_factory):
    """The README's scene with two processing variants added to its lidar table (so that every figure of
    the table is written), run by the README's command; returns the results and the files written."""
    scene = _tool().scene_block()
    assert scene.count("lidar = { ") == 1
    tmp = tmp_path_factory.mktemp("own_scene")
    path = tmp / "my_scene.toml"
    path.write_text(scene.replace("lidar = { ", "lidar = { " + VARIANTS), encoding="utf-8")
    (command,) = re.findall(r"^```bash\n(.*)\n```", _tool().section(_readme(), "Your own scene"), flags=re.M)
    argv = shlex.split(command)
    assert argv[0].endswith("cwlidar-sim") and argv[2] == "my_scene.toml" and argv[argv.index("--out") + 1] == "results/mine"
    argv = [str(path) if a == "my_scene.toml" else str(tmp / a) if a == "results/mine" else a for a in argv[1:]]
    assert cli.main(argv + ["--no-progress"]) == 0
    out = tmp / "results" / "mine"
    ds = xr.load_dataset(out / "my_scene.nc", engine="h5netcdf")
    return ds, sorted(os.listdir(out))


def test_the_readme_scene_is_five_lines_and_valid():
    text = _tool().scene_block()
    assert len(text.strip().split("\n")) == 5
    scene = loads_scene(text)
    assert scene.kind == "staring" and scene.name == "my_scene" and len(scene.periods) == 1
    assert "five lines" in _readme()


def _table(title):
    """The first column's backticked names of each table in the README section ``title``."""
    body = _tool().section(_readme(), title)
    rows = [line for line in body.split("\n") if line.startswith("| `")]
    return [re.findall(r"`([^`]+)`", row.split("|")[1]) for row in rows]


def test_the_outputs_table_names_what_a_run_writes(own_run):
    """Every variable and dimension the table names is in the results file, every figure it names is
    written and every figure written is in the table."""
    ds, files = own_run
    assert "my_scene.nc" in files
    names = [n for row in _table("What the outputs mean") for n in row]
    variables = [n for n in names if not n.endswith(".png")]
    figures = {n for n in names if n.endswith(".png")}
    assert len(variables) >= 15 and len(figures) >= 8
    known = set(ds.variables) | set(ds.dims)
    for n in variables:
        if "*" in n:
            assert fnmatch.filter(known, n), n
        else:
            assert n in known, n
    assert figures == {f for f in files if f.endswith(".png")}

