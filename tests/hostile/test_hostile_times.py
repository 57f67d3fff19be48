"""Hostile inputs of the twin's clock and the platform series: time units, holes, epochs, fractions of a second.

Every case runs the CLI in a child process (conftest) and ends in a named one-line error before compute, or
the right answer checked against physics (the record and the twin's own sonic on one clock).
"""

from decimal import Decimal

import numpy as np
import pytest
from conftest import assert_one_line_error, run_cli

TWIN_SCENE = """
name = "tw"
duration = 60.0
[turbulence]
alpha_eps = 0.06
length_scale = 18.0
gamma = 3.9
condition_on = [{ path = "m.csv", kind = "sonic", noise_std = 0.05, rotation = "none" }]
[lidar]
preset = "prototype"
tier = "los"
instrument = { focus = 67.5 }
[field]
kind = "line"
dx = 0.25
[analysis]
segment_duration = 60.0
fit = false
estimator_theory_lines = 0
[[period]]
name = "A"
mean_speed = 8.0
"""

NACELLE_SCENE = """
name = "nac_small"
kind = "nacelle"
seed = 3
duration = 60.0
[scan]
half_angle_deg = 15.0
focus_distances = [40.0, 80.0]
rotor_radius = 20.0
spacing = 8.0
segment_duration = 15.0
k_min = 0.04
k_max = 0.3
n_k = 5
theory_beams = 4
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[[period]]
name = "p0"
mean_speed = 10.0
[platform]
csv = "motion.csv"
"""


def _smooth(n, seed=3):
    rng = np.random.default_rng(seed)
    x = np.convolve(rng.normal(0, 1, n + 63), np.ones(64) / 8.0, mode="valid")
    return 8.0 + 0.6 * (x - x.mean()) / x.std(), 0.2 * rng.normal(size=n), 0.1 * rng.normal(size=n)


def _mast(path, cells, header="time"):
    u, v, w = _smooth(len(cells))
    with open(path, "w") as f:
        f.write(f"{header},u,v,w\n")
        for c, a, b, d in zip(cells, u, v, w):
            f.write(f"{c},{a},{b},{d}\n")


def _exact(start, fs, n):
    return [str(Decimal(start) + Decimal(i) / Decimal(int(fs))) for i in range(n)]


def _twin(tmp_path, cells, header="time"):
    _mast(tmp_path / "m.csv", cells, header)
    (tmp_path / "tw.toml").write_text(TWIN_SCENE)
    return run_cli(["twin", "tw.toml", "--twins", "1", "--out", "o", "--no-progress"], cwd=tmp_path)


def _lag(tmp_path):
    """Lag [tenths] of the cross-correlation peak of record_10hz against the twin's own sonic_10hz."""
    import glob

    import xarray as xr

    (f,) = glob.glob(str(tmp_path / "o" / "*.nc"))
    with xr.open_dataset(f, engine="h5netcdf") as ds:
        rec = np.asarray(ds["record_10hz"].values, float)
        son = np.asarray(ds["sonic_10hz"].values[0], float)
        attrs = dict(ds.attrs)
    a, b = rec - rec.mean(), son - son.mean()
    lags = np.arange(-10, 11)
    return int(lags[np.argmax([np.dot(np.roll(a, lag), b) for lag in lags])]), attrs


# ---------------------------------------------------------------------------
# records of the twin
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("fs, start", [(32.0, "0.525"), (20.0, "1700000000.525"), (32.0, "-300.0333")])
def test_records_off_a_tenth_on_unix_or_negative_clocks_line_up(tmp_path, corpus, fs, start):
    """A record starting 0.525 s past a second sat 5 tenths early in record_10hz (T2 0.17x at 0.28 rad/m); a
    20 Hz Unix-time record was refused as 20.0000191 Hz: now both line up with the twin's sonic at lag 0."""
    child = _twin(tmp_path, _exact(start, fs, int(60 * fs)))
    assert child.rc == 0, child.stderr[-3000:]
    lag, attrs = _lag(tmp_path)
    assert lag == 0
    assert Decimal(attrs["time_origin"]) + Decimal(str(attrs["record_delay"])) == Decimal(start)
    corpus.record("right", child)


@pytest.mark.parametrize("case, fragments", [
    ("unsorted", ("time", "not strictly increasing", "sample 101", "goes back")),
    ("duplicated", ("time", "not strictly increasing", "sample 101", "repeats")),
    ("nan", ("time", "missing at sample 100")),
    ("ms", ("time column 'time'", "(0.032 hz)", "read in ms it would be 32 hz")),
    ("hours", ("time", "read in h it would be 32 hz")),
    ("jitter", ("time", "sample 100", "steps off the regular 32 hz grid")),
])
def test_bad_record_times_are_refused_in_one_line(tmp_path, corpus, case, fragments):
    n = 1920
    cells = _exact("0.015625", 32.0, n)
    if case == "unsorted":
        cells[100], cells[101] = cells[101], cells[100]
    elif case == "duplicated":
        cells[101] = cells[100]
    elif case == "nan":
        cells[100] = "nan"
    elif case == "ms":
        cells = [str(Decimal(c) * 1000) for c in cells]  # 31.25 ms steps, no unit in the header
    elif case == "hours":
        cells = [str(Decimal(c) / 3600) for c in cells]
    elif case == "jitter":
        cells[100] = str(Decimal(cells[100]) + Decimal("0.01"))  # a third of a step off
    child = _twin(tmp_path, cells)
    assert_one_line_error(child, "m.csv", *fragments)
    assert not (tmp_path / "o").exists() or not list((tmp_path / "o").iterdir())
    corpus.record("error", child)


def test_record_time_in_ms_named_by_its_header_is_right(tmp_path, corpus):
    cells = [str(Decimal(c) * 1000) for c in _exact("0.525", 32.0, 1920)]  # first sample 0.525 s, in ms
    child = _twin(tmp_path, cells, header="time_ms")
    assert child.rc == 0, child.stderr[-3000:]
    lag, attrs = _lag(tmp_path)
    assert lag == 0 and attrs["time_origin"] == "0.509375000"
    corpus.record("right", child)


# ---------------------------------------------------------------------------
# the platform series
# ---------------------------------------------------------------------------
def _write_nacelle(tmp_path, header, cells, heave=None):
    heave = np.zeros(len(cells)) if heave is None else heave
    with open(tmp_path / "motion.csv", "w") as f:
        f.write(f"{header},heave\n")
        for c, h in zip(cells, heave):
            f.write(f"{c},{h}\n")
    (tmp_path / "nac.toml").write_text(NACELLE_SCENE)


def _nacelle(tmp_path, header, cells, heave=None):
    _write_nacelle(tmp_path, header, cells, heave)
    return run_cli(["run", "nac.toml", "--out", "o"], cwd=tmp_path)


@pytest.mark.parametrize("case, fragments", [
    ("ms", ("platform.csv", "time", "100 s (0.01 hz)", "read in ms it would be 10 hz")),
    ("hole", ("platform.csv", "time", "hole of 100 s", "t = 20.000000000 to 120.000000000 s", "max_gap = 1 s")),
    ("duplicated", ("platform.csv", "time", "sample 51", "repeats")),
    ("unsorted", ("platform.csv", "time", "sample 51", "goes back")),
    ("nan", ("platform.csv", "time", "missing at sample 50")),
    ("hours", ("platform.csv", "time", "read in h it would be 10 hz")),
])
def test_bad_platform_times_are_refused_in_one_line(tmp_path, corpus, case, fragments):
    t = [Decimal(i) / 10 for i in range(650)]  # 10 Hz over 0-64.9 s
    if case == "ms":
        t = [x * 1000 for x in t]
    elif case == "hole":
        # nothing between 20 s and 120 s: main interpolated across it, exit 0
        t = [x if x <= 20 else x + Decimal("99.9") for x in t]
    elif case == "duplicated":
        t[51] = t[50]
    elif case == "unsorted":
        t[50], t[51] = t[51], t[50]
    elif case == "hours":
        t = [x / 3600 for x in t]
    cells = [str(x) for x in t]
    if case == "nan":
        cells[50] = "nan"
    child = _nacelle(tmp_path, "time", cells)
    assert_one_line_error(child, *fragments)
    corpus.record("error", child)


def test_platform_time_in_ms_named_by_its_header_is_right(tmp_path, corpus):
    """The motion the nacelle lidar is given from a time_ms column is the series in s (read as the run reads it)."""
    import json

    from conftest import run_python

    t = np.arange(-10, 650) / 10.0
    heave = 0.5 * np.sin(2 * np.pi * t / 7.0)
    _write_nacelle(tmp_path, "time_ms", [str(Decimal(i) * 100) for i in range(-10, 650)], heave)
    code = ("import json; from cwlidar_sim.campaign import load_scene;"
            f"s = load_scene({str(tmp_path / 'nac.toml')!r}); m = s.sensor(s.periods[0]).motion;"
            "print(json.dumps([m.time.tolist(), m.heave.tolist()]))")
    child = run_python(code)
    assert child.rc == 0, child.stderr[-2000:]
    mt, mh = json.loads(child.stdout)
    np.testing.assert_allclose(mt, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mh, heave, rtol=1e-12)
    corpus.record("right", child)
