"""TOML files are checked before they are parsed: a regular file, not too large, UTF-8, not nested too deeply."""

import os
import signal

import pytest

from cwlidar_sim.campaign import load_scene, loads_scene
from cwlidar_sim.campaign.scenes.spec import MAX_TOML_BYTES, MAX_TOML_DEPTH, parse_toml, toml_depth
from cwlidar_sim.campaign.execution.sweep import load_campaign, loads_campaign


@pytest.fixture
def alarm():
    """Fail (instead of hanging the suite) if the code under test blocks for 10 s."""
    def ring(signum, frame):
        raise AssertionError("blocked for 10 s")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(10)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def test_depth_counts_tables_and_arrays():
    assert toml_depth(1) == 0
    assert toml_depth({}) == 1
    assert toml_depth({"a": [1, {"b": [[2]]}]}) == 5
    assert toml_depth([{"a": 1}, [[[]]]]) == 4


def test_nesting_up_to_the_limit_is_read():
    n = MAX_TOML_DEPTH - 1  # the document's table is the first level
    d = parse_toml("a = " + "[" * n + "1" + "]" * n, "scene")
    assert toml_depth(d) == MAX_TOML_DEPTH


@pytest.mark.parametrize("text, depth", [
    ("a = " + "[" * MAX_TOML_DEPTH + "]" * MAX_TOML_DEPTH, MAX_TOML_DEPTH + 1),
    (".".join(["a"] * 40) + " = 1", 40),  # dotted keys: no recursion in the parser, deep all the same
])
def test_nesting_beyond_the_limit_is_refused_with_the_depth(text, depth):
    with pytest.raises(ValueError, match=f"nested deeper than {MAX_TOML_DEPTH} levels \\({depth} levels"):
        parse_toml(text, "scene")


def test_nesting_that_overflows_the_parser_is_one_line(tmp_path):
    deep = "a = " + "[" * 5000 + "]" * 5000  # tomllib itself raises RecursionError here
    with pytest.raises(ValueError, match=f"scene: TOML nested deeper than {MAX_TOML_DEPTH} levels"):
        loads_scene(deep)
    (tmp_path / "c.toml").write_text("x = " + "{a = " * 3000 + "1" + "}" * 3000)
    with pytest.raises(ValueError, match="campaign: TOML nested deeper"):
        load_campaign(tmp_path / "c.toml")


def test_an_oversized_file_is_refused_before_it_is_read(tmp_path):
    f = tmp_path / "big.toml"
    f.write_bytes(b"#" * (MAX_TOML_BYTES + 1))
    with pytest.raises(ValueError, match=f"big.toml' is {MAX_TOML_BYTES + 1} bytes, more than the {MAX_TOML_BYTES}"):
        load_scene(f)
    with pytest.raises(ValueError, match="more than"):
        loads_campaign("#" * (MAX_TOML_BYTES + 1))


def test_a_fifo_is_refused_without_blocking(tmp_path, alarm):
    f = tmp_path / "scene.toml"
    os.mkfifo(f)
    with pytest.raises(ValueError, match="is a FIFO \\(named pipe\\), not a regular file"):
        load_scene(f)


def test_a_directory_and_a_missing_file_are_named(tmp_path):
    (tmp_path / "d.toml").mkdir()
    with pytest.raises(ValueError, match="d.toml' is a directory"):
        load_scene(tmp_path / "d.toml")
    with pytest.raises(ValueError, match="cannot read campaign file .*nothere.toml': No such file"):
        load_campaign(tmp_path / "nothere.toml")


def test_a_file_that_is_not_utf8_is_named(tmp_path):
    f = tmp_path / "latin1.toml"
    f.write_bytes('name = "Ås"\n'.encode("latin-1"))
    with pytest.raises(ValueError, match="latin1.toml' is not UTF-8 text \\(byte 8"):
        load_scene(f)
