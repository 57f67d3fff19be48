"""Discoverability from the terminal: the command list, every command's examples, ``python -m
cwlidar_sim``, and ``cwlidar-sim scenes`` (list, show, write without overwriting)."""

import json
import os
import pathlib
import re
import subprocess
import sys
import tomllib

import pytest

from cwlidar_sim import cli

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _env(**extra):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    env.update(extra)
    return env


def _commands():
    sub = next(a for a in cli.build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    return sub.choices


def test_python_m_cwlidar_sim_is_the_cli_and_lists_every_command_on_one_line():
    out = subprocess.run([sys.executable, "-m", "cwlidar_sim", "--help"], capture_output=True, text=True,
                         check=True, cwd=ROOT, env=_env(COLUMNS="80")).stdout
    assert out.startswith("usage: cwlidar-sim ")
    block = out[out.index("  COMMAND\n") + len("  COMMAND\n"):out.index("\noptions:")].strip("\n").split("\n")
    names = list(_commands())
    # one line per command, each holding the command's name and its help, within 80 columns
    assert len(block) == len(names), block
    for line, name in zip(block, names):
        assert re.match(rf"^    {re.escape(name)} +\S", line), line
        assert len(line) <= 80, line
    assert {"box", "doppler", "run", "report", "reproduce", "campaign", "campaign-report", "probe-length",
            "scenes"} <= set(names)


def test_every_command_help_ends_with_an_example():
    for name, parser in _commands().items():
        text = parser.format_help()
        assert "\nexamples:\n" in text, name
        examples = text[text.index("\nexamples:\n"):]
        assert f"cwlidar-sim {name} " in examples or f"cwlidar-sim {name}\n" in examples, (name, examples)


def test_version_flag_prints_the_version(capsys):
    import cwlidar_sim

    with pytest.raises(SystemExit) as e:
        cli.main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"cwlidar-sim {cwlidar_sim.__version__}"


def test_scenes_lists_bundled_scenes_and_examples_with_descriptions(capsys):
    from cwlidar_sim.campaign.execution.reproduce import BUNDLED

    assert cli.main(["scenes", "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert set(BUNDLED) <= set(rows) and "campaign_quick" in rows
    assert {rows[n]["kind"] for n in BUNDLED} == {"scene"} and rows["campaign_quick"]["kind"] == "campaign"
    for r in rows.values():
        d = tomllib.loads(pathlib.Path(r["file"]).read_text(encoding="utf-8"))
        assert r["description"] == d["description"] and r["description"]
    assert cli.main(["scenes"]) == 0
    text = capsys.readouterr().out
    for r in rows.values():
        assert re.search(rf"^{r['name']} +{r['kind']} +{re.escape(r['description'])}$", text, flags=re.M), r["name"]


def test_scenes_listing_stays_cold():
    code = ("import sys; from cwlidar_sim import cli; cli.main(['scenes']); "
            "print(sorted(m for m in ('numba', 'numpy', 'xarray', 'scipy', 'cwlidar_sim.campaign') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=_env())
    assert out.stdout.strip().splitlines()[-1] == "[]"


def test_scenes_write_gives_a_runnable_starting_point_and_never_overwrites(tmp_path, capsys):
    from cwlidar_sim.campaign import bundled_scene, load_scene
    from cwlidar_sim.campaign.execution.reproduce import bundled_text

    path = tmp_path / "sub" / "my_scene.toml"
    # a missing folder is refused with its name, not created silently (it was, before issue 34)
    assert cli.main(["scenes", "--write", "a2012", str(path)]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and str(tmp_path / "sub") in err and "Traceback" not in err
    assert not (tmp_path / "sub").exists()
    (tmp_path / "sub").mkdir()
    assert cli.main(["scenes", "--write", "a2012", str(path)]) == 0
    assert "cwlidar-sim run" in capsys.readouterr().out
    assert path.read_text(encoding="utf-8") == bundled_text("a2012")
    assert load_scene(path) == bundled_scene("a2012")
    # an existing file is kept, byte for byte, unless --force
    path.write_text("# mine\n", encoding="utf-8")
    assert cli.main(["scenes", "--write", "cs", str(path)]) == 2
    err = capsys.readouterr().err
    assert "exists" in err and "--force" in err and "Traceback" not in err
    assert path.read_text(encoding="utf-8") == "# mine\n"
    assert cli.main(["scenes", "--write", "cs", str(path), "--force"]) == 0
    assert path.read_text(encoding="utf-8") == bundled_text("cs")
    assert [p.name for p in path.parent.iterdir()] == ["my_scene.toml"]  # no temporary file left


def test_scenes_write_campaign_example_loads(tmp_path, capsys):
    from cwlidar_sim.campaign.execution.sweep import expand, load_campaign

    path = tmp_path / "sweep.toml"
    assert cli.main(["scenes", "--write", "campaign_quick", str(path)]) == 0
    assert "cwlidar-sim campaign" in capsys.readouterr().out
    assert len(expand(load_campaign(path))) == 4


def test_scenes_unknown_name_and_show(capsys):
    assert cli.main(["scenes", "--show", "nope"]) == 2
    err = capsys.readouterr().err
    assert "'nope'" in err and "a2012" in err and "campaign_quick" in err
    assert cli.main(["scenes", "--show", "cs"]) == 0
    assert 'kind = "conical"' in capsys.readouterr().out


def test_run_and_campaign_take_a_bundled_name(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no file of that name here
    assert cli.main(["campaign", "campaign_quick", "--dry-run", "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["tasks"]) == 4
    # a scene's name is not a campaign (and the other way round): a clear error naming what exists
    assert cli.main(["campaign", "a2012", "--dry-run"]) == 2
    assert "bundled: campaign_quick" in capsys.readouterr().err
    assert cli.main(["run", "nope", "--out", str(tmp_path / "out")]) == 2
    assert "bundled: a2012, cs" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
