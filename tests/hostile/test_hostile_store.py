"""Hostile cases of the results store: names that escape --out, folders of another scene, concurrent runs, kill -9.

Each case drives ``python -m cwlidar_sim run`` in a child process on a tiny
scene (three 40-s periods) and ends in a named one-line error before compute,
a warning with the period recomputed, or the right answer.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from conftest import assert_one_line_error, run_cli

TINY = """
name = "{name}"
seed = {seed}
duration = 40.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
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
name = "{q}"
mean_speed = 7.0
[[period]]
name = "R"
mean_speed = 6.0
"""

#: Attributes that describe a run, not its results.
RUN_ATTRS = ("wall_time", "timing", "periods_reused")


def write_scene(path, name="tiny", seed=1, q="Q"):
    path.write_text(TINY.format(name=name, seed=seed, q=q), encoding="utf-8")
    return path


def files_under(root):
    return sorted(str(p.relative_to(root)) for p in Path(root).rglob("*"))


def read(path):
    from cwlidar_sim.campaign import read_results

    return read_results(path)


def same_results(a, b):
    xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())
    strip = lambda d: {k: v for k, v in d.attrs.items() if k not in RUN_ATTRS}  # noqa: E731
    assert json.dumps(strip(a), sort_keys=True, default=str) == json.dumps(strip(b), sort_keys=True, default=str)


@pytest.mark.parametrize("bad", ["../../../../../victim/escaped", "/tmp/victim_abs", "a\\\\b", "a\\u0000b",
                                 "x" * 252])
def test_a_period_name_that_would_escape_or_overflow_is_refused(tmp_path, corpus, bad):
    deep = tmp_path / "a" / "b" / "c"
    deep.mkdir(parents=True)
    scene = write_scene(tmp_path / "s.toml", q=bad)
    before = files_under(tmp_path)
    child = run_cli(["run", str(scene), "--out", str(deep / "out"), "--no-progress"], cwd=tmp_path)
    assert_one_line_error(child, "period name")
    assert files_under(tmp_path) == before  # nothing written, inside --out or outside it
    assert not os.path.exists("/tmp/victim_abs.nc")
    corpus.record("error", child)


def test_a_scene_name_over_the_file_name_limit_is_refused(tmp_path, corpus):
    scene = write_scene(tmp_path / "s.toml", name="n" * 242)  # its longest file, <name>.stats.parquet, 256 bytes
    child = run_cli(["run", str(scene), "--out", str(tmp_path / "out"), "--no-progress"], cwd=tmp_path)
    assert_one_line_error(child, "scene name", "256 bytes", "255")
    assert not (tmp_path / "out").exists()
    corpus.record("error", child)


def test_another_scene_into_a_results_folder_is_refused_then_overwritten(tmp_path, corpus):
    out = tmp_path / "out"
    first = run_cli(["run", str(write_scene(tmp_path / "a.toml", name="a2012")), "--out", str(out), "--no-progress"])
    assert first.rc == 0, first.stderr[-2000:]
    old = read(out / "a2012.nc")
    other = write_scene(tmp_path / "b.toml", name="mine", seed=2)
    child = run_cli(["run", str(other), "--out", str(out), "--no-progress"])
    assert_one_line_error(child, "'a2012'", "'mine'", "--overwrite")
    same_results(read(out / "a2012.nc"), old)  # untouched
    corpus.record("error", child)
    again = run_cli(["run", str(other), "--out", str(out), "--no-progress", "--overwrite"])
    assert again.rc == 0, again.stderr[-2000:]
    assert sorted(os.listdir(out)) == [".cwlidar-sim.lock", "cwlidar-run.json", "mine.nc", "mine.periods",
                                    "mine.stats.csv"]
    assert json.loads((out / "cwlidar-run.json").read_text())["name"] == "mine"
    corpus.record("right", again)


def test_a_bit_flipped_period_file_is_recomputed_with_a_warning(tmp_path, corpus):
    out = tmp_path / "out"
    scene = write_scene(tmp_path / "s.toml")
    assert run_cli(["run", str(scene), "--out", str(out), "--no-progress"]).rc == 0
    whole = read(out / "tiny.nc")
    p = out / "tiny.periods" / "001_Q.nc"
    data = bytearray(p.read_bytes())
    data[100] ^= 0x04  # the superblock's end: the file no longer opens (a flip in its numbers: test_folder.py)
    p.write_bytes(bytes(data))
    child = run_cli(["run", str(scene), "--out", str(out), "--no-progress"])
    assert child.rc == 0, child.stderr[-2000:]
    assert "001_Q.nc is damaged and is computed again" in child.stderr
    assert json.loads(child.stdout)["periods_reused"] == ["P", "R"]
    same_results(read(out / "tiny.nc"), whole)
    corpus.record("warned", child)


def _cli(args, **kw):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[2]) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.Popen([sys.executable, "-m", "cwlidar_sim", *map(str, args)], env=env, text=True, **kw)


def test_concurrent_runs_into_one_folder_never_mix(tmp_path, corpus):
    """Seeds 7 and 8 of one scene name into one folder: while the first is mid-run, the second is refused.

    The first run is stopped (SIGSTOP) right after its first period is written,
    as a slow run would be, so the two overlap whatever the machine's load.
    """
    out = tmp_path / "out"
    first = _cli(["run", write_scene(tmp_path / "s7.toml", seed=7), "--out", out, "--no-progress"],
                 stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        err = []
        while not any("written to" in ln for ln in err):
            line = first.stderr.readline()
            assert line, "".join(err)[-2000:]
            err.append(line)
        os.kill(first.pid, signal.SIGSTOP)
        second = run_cli(["run", write_scene(tmp_path / "s8.toml", seed=8), "--out", out, "--no-progress"])
        assert_one_line_error(second, f"in use by another run (pid {first.pid})")
        corpus.record("error", second)
    finally:
        os.kill(first.pid, signal.SIGCONT)
    _, rest = first.communicate(timeout=300)
    assert first.returncode == 0, rest[-2000:]
    ds = read(out / "tiny.nc")
    assert json.loads(ds.attrs["scene"])["seed"] == 7
    ref = run_cli(["run", tmp_path / "s7.toml", "--out", tmp_path / "ref", "--no-progress"])
    assert ref.rc == 0
    same_results(ds, read(tmp_path / "ref" / "tiny.nc"))  # the whole file is the first run's, nothing of seed 8


def test_kill_9_at_random_points_then_resume_gives_the_uninterrupted_bits(tmp_path, corpus):
    rng = np.random.default_rng(20261203)
    scene = write_scene(tmp_path / "s.toml")
    ref = _cli(["run", scene, "--out", tmp_path / "ref", "--no-progress"], stdout=subprocess.DEVNULL,
               stderr=subprocess.DEVNULL)
    assert ref.wait(timeout=300) == 0
    out = tmp_path / "out"
    killed = 0
    for _ in range(8):  # until three kills landed mid-run (a run that finished first starts the folder afresh)
        if killed == 3:
            break
        wait_lines, delay = int(rng.integers(0, 3)), float(rng.uniform(0.0, 0.5))
        proc = _cli(["run", scene, "--out", out, "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        seen = 0
        while seen < wait_lines:  # after the n-th period written (0: before the first), then a random delay
            line = proc.stderr.readline()
            if not line:
                break
            seen += "written to" in line
        time.sleep(delay)
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
            killed += 1
        elif killed < 3:
            shutil.rmtree(out)
        proc.wait(timeout=300)
        proc.stderr.close()
    final = run_cli(["run", scene, "--out", out, "--no-progress"])
    assert final.rc == 0, final.stderr[-2000:]
    assert killed >= 2
    same_results(read(out / "tiny.nc"), read(tmp_path / "ref" / "tiny.nc"))
    assert not [f for f in files_under(out) if ".tmp-" in f or ".tmp." in f or f.endswith(".tmp")]  # orphans cleaned
    corpus.record("right", final)
