"""Hostile records: a scene's ``fit_to`` record and the twin's records, read by one reader.

Each case runs the CLI (or the public API) in a child process under the
harness's memory cap and ends in a named one-line error before compute, a
warning with a flag in the results, or the right answer.
"""

import json
import os

import numpy as np
import pytest
import xarray as xr
from conftest import FIT_TO_SCENE, assert_one_line_error, run_cli, run_python

U, FS, N = 8.0, 10.0, 2**13

SCENE = FIT_TO_SCENE

TWIN = """
name = "tw"
duration = 60.0
[turbulence]
alpha_eps = 0.06
length_scale = 18.0
gamma = 3.9
condition_on = [{{ path = "{path}", kind = "sonic", noise_std = 0.05, rotation = "none" }}]
[lidar]
preset = "prototype"
tier = "los"
instrument = {{ focus = 67.5 }}
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


@pytest.fixture(scope="module")
def line():
    """A line of the tensor (alpha_eps 0.063, L 18.8 m, Gamma 3.2) sampled as a 10 Hz sonic at U = 8 m/s."""
    from cwlidar_sim.turbulence import MannParameters, generate_line

    ln = generate_line(MannParameters(0.063, 18.8, 3.2), N, U / FS, 5, dtype=np.float64)
    return {c: ln[c].values[::-1] + (U if c == "u" else 0.0) for c in "uvw"}


def write_nc(path, vals, scale=1.0, units="m s-1"):
    t = np.arange(len(vals["u"])) / FS
    ds = xr.Dataset({c: ("time", vals[c] * scale, {"units": units}) for c in "uvw"},
                    coords={"time": ("time", t, {"units": "s"})})
    ds.to_netcdf(path, engine="h5netcdf")
    return path


def write_csv(path, vals, t=None, encoding="utf-8", bom=False):
    t = np.arange(len(vals["u"])) / FS if t is None else t
    with open(path, "w", encoding=encoding) as f:
        f.write(("\ufeff" if bom else "") + "time,u,v,w\n")
        for row in zip(t, vals["u"], vals["v"], vals["w"]):
            f.write(",".join(repr(float(x)) for x in row) + "\n")
    return path


def scene(tmp_path, record, mean_speed=U):
    p = tmp_path / "s.toml"
    p.write_text(SCENE.format(path=record, U=mean_speed))
    return p


def run_fit_to(tmp_path, record, mean_speed=U, timeout=120):
    return run_cli(["run", scene(tmp_path, record, mean_speed), "--out", tmp_path / "o", "--no-progress"],
                   cwd=tmp_path, timeout=timeout)


FIT = """
import json, warnings
from cwlidar_sim.campaign import load_scene
from cwlidar_sim.campaign.periods.staring_field import scene_params
out = {}
for name in %r:
    p, info = scene_params(load_scene(name))
    out[name] = [p.alpha_eps, p.length_scale, p.gamma, info]
print(json.dumps(out))
"""


# ---------------------------------------------------------------------------
# units
# ---------------------------------------------------------------------------
def test_fit_to_in_other_speed_units_fits_the_same_tensor(tmp_path, corpus, line):
    """cm s-1, km h-1 and knots are converted: the fit is that of the m s-1 record (was alpha_eps 27.8, L 2045 m)."""
    names = []
    for i, (units, scale) in enumerate((("m s-1", 1.0), ("cm s-1", 100.0), ("km h-1", 3.6),
                                        ("knots", 3600.0 / 1852.0))):
        write_nc(tmp_path / f"r{i}.nc", line, scale, units)
        (tmp_path / f"s{i}.toml").write_text(SCENE.format(path=f"r{i}.nc", U=U))
        names.append(f"s{i}.toml")
    child = run_python(FIT % (names,), cwd=tmp_path, timeout=120)
    assert child.rc == 0, child.stderr[-3000:]
    fits = json.loads(child.stdout.strip().splitlines()[-1])
    ref = fits["s0.toml"]
    assert abs(ref[0] - 0.063) < 0.02 and abs(ref[1] - 18.8) < 5 and ref[3]["quality"] == "ok", ref
    for name in names[1:]:
        np.testing.assert_allclose(fits[name][:3], ref[:3], rtol=1e-9)
        assert fits[name][3]["mean_speed"] == pytest.approx(U, rel=0.02)
    assert [fits[n][3]["units"]["u"] for n in names] == ["m s-1", "cm s-1", "km h-1", "knots"]
    corpus.record("right", child)


def test_fit_to_with_nonsense_units_is_refused_by_name(tmp_path, corpus, line):
    write_nc(tmp_path / "r.nc", line, 1.0, "furlongs per fortnight")
    child = run_fit_to(tmp_path, "r.nc")
    assert_one_line_error(child, "fit_to", "furlongs per fortnight", "do not parse as a speed")
    corpus.record("error", child)


def test_fit_to_with_speeds_a_thousand_times_too_large_is_refused(tmp_path, corpus, line):
    """U = 8029 m/s in 'm s-1' is not wind (was: fitted L = 5000, Gamma = 8 on the bounds, no warning)."""
    write_nc(tmp_path / "r.nc", line, 1000.0)
    child = run_fit_to(tmp_path, "r.nc")
    assert_one_line_error(child, "fit_to", "exceed 100 m/s", "units")
    corpus.record("error", child)


def test_fit_to_mean_conflicting_with_the_scene_is_refused_naming_both(tmp_path, corpus, line):
    write_nc(tmp_path / "r.nc", line)
    child = run_fit_to(tmp_path, "r.nc", mean_speed=12.0)
    assert_one_line_error(child, "fit_to", "mean speed 8", "mean_speed = 12 m/s", "30 %")
    corpus.record("error", child)


def test_fit_to_white_noise_is_warned_about_and_flagged_in_the_results(tmp_path, corpus):
    """A white-noise record fits L and Gamma on their bounds: a warning, and quality 'suspect' in the results."""
    rng = np.random.default_rng(1)
    write_nc(tmp_path / "r.nc", {c: rng.normal(size=N) * 0.8 + (U if c == "u" else 0.0) for c in "uvw"})
    child = run_fit_to(tmp_path, "r.nc")
    assert child.rc == 0, child.stderr[-3000:]
    assert "UserWarning" in child.stderr and "is suspect" in child.stderr and "lower bound" in child.stderr
    with xr.open_dataset(tmp_path / "o" / "h.nc") as ds:
        fit = json.loads(ds.attrs["turbulence_fit"])
    assert fit["quality"] == "suspect"
    assert fit["at_bound"] == ["length_scale=0.5 (lower bound)", "gamma=0 (lower bound)"], fit
    corpus.record("warned", child)


# ---------------------------------------------------------------------------
# sizes, before allocation
# ---------------------------------------------------------------------------
def test_a_csv_row_1e8_s_later_is_refused_before_the_grid_is_allocated(tmp_path, corpus, line):
    """Was: 23.8 GiB allocated before the gap check.  Through the twin's CLI (the same reader)."""
    t = np.arange(N) / FS
    t[-1] = 1e8
    write_csv(tmp_path / "m.csv", line, t)
    (tmp_path / "tw.toml").write_text(TWIN.format(path="m.csv"))
    child = run_cli(["twin", "tw.toml", "--twins", "1", "--out", "o", "--no-progress"], cwd=tmp_path, timeout=120)
    assert_one_line_error(child, "m.csv", "gap of 9.99992e+07 s", "longer than max_gap")
    assert child.peak_mb < 1500, child.peak_mb
    corpus.record("error", child)


def test_a_small_netcdf_declaring_2e9_samples_is_refused_before_reading(tmp_path, corpus):
    import h5netcdf

    with h5netcdf.File(tmp_path / "r.nc", "w") as f:
        f.dimensions = {"time": 2_000_000_000}
        for c in ("time", "u", "v", "w"):
            f.create_variable(c, ("time",), float, chunks=(2**16,))
    assert os.path.getsize(tmp_path / "r.nc") < 100_000
    child = run_fit_to(tmp_path, "r.nc")
    assert_one_line_error(child, "r.nc", "declares 2000000000 samples", "33554432")
    assert child.peak_mb < 1500, child.peak_mb
    corpus.record("error", child)


def test_a_20_gb_sparse_fit_to_file_is_refused_before_it_is_read_or_hashed(tmp_path, corpus):
    p = tmp_path / "r.nc"
    with open(p, "wb") as f:
        f.truncate(20 * 10**9)
    child = run_fit_to(tmp_path, "r.nc", timeout=60)  # a read or hash of 20 GB would not end in time: "hung"
    assert_one_line_error(child, "fit_to", "18.6 GiB", "at most 4 GiB")
    assert child.peak_mb < 1500, child.peak_mb
    corpus.record("error", child)


# ---------------------------------------------------------------------------
# files that are not records
# ---------------------------------------------------------------------------
def test_a_corrupt_fit_to_file_is_one_line(tmp_path, corpus):
    (tmp_path / "r.nc").write_bytes(np.random.default_rng(2).bytes(5000))
    child = run_fit_to(tmp_path, "r.nc")
    assert_one_line_error(child, "fit_to", "r.nc", "neither netcdf-4")
    corpus.record("error", child)


def test_a_truncated_fit_to_netcdf_is_one_line(tmp_path, corpus, line):
    whole = write_nc(tmp_path / "w.nc", line).read_bytes()
    (tmp_path / "r.nc").write_bytes(whole[: len(whole) // 2])
    child = run_fit_to(tmp_path, "r.nc")
    assert_one_line_error(child, "fit_to", "r.nc")
    corpus.record("error", child)


def test_a_csv_field_over_131072_characters_is_one_line_naming_file_and_line(tmp_path, corpus, line):
    p = write_csv(tmp_path / "r.csv", line)
    rows = p.read_text().splitlines()
    rows[5] = "0.4," + "7" * 200_000 + "x,0.0,0.0"
    p.write_text("\n".join(rows) + "\n")
    child = run_fit_to(tmp_path, "r.csv")
    assert_one_line_error(child, "fit_to", "r.csv", "column 'u'", "line 6", "not numeric")
    assert len(child.last_line) < 400, len(child.last_line)
    corpus.record("error", child)


def test_a_symlink_to_another_file_is_not_echoed(tmp_path, corpus):
    """Was: the error quoted the linked file's first line (root:x:0:0:...)."""
    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n")
    for name in ("r.csv", "r.nc"):
        os.symlink(secret, tmp_path / name)
        child = run_fit_to(tmp_path, name)
        assert_one_line_error(child, "fit_to", name)
        assert "root:x" not in child.stderr and "bash" not in child.stderr and "daemon" not in child.stderr
    corpus.record("error", child)


@pytest.mark.parametrize("what", ["fifo", "directory", "empty", "device"])
def test_a_fit_to_path_that_is_not_a_regular_file_is_refused_by_kind(tmp_path, corpus, what):
    p = tmp_path / "r.nc"
    if what == "fifo":
        os.mkfifo(p)  # reading it would block for ever
    elif what == "directory":
        p.mkdir()
    elif what == "empty":
        p.touch()
    else:
        os.symlink("/dev/zero", p)  # reading it would never end
    child = run_fit_to(tmp_path, "r.nc", timeout=60)  # a blocked or endless read fails as "hung"
    assert_one_line_error(child, "fit_to", "r.nc", {"fifo": "a FIFO", "directory": "a directory",
                                                    "empty": "is empty", "device": "a device"}[what])
    corpus.record("error", child)


def test_a_latin1_csv_is_refused_as_not_utf8(tmp_path, corpus, line):
    p = write_csv(tmp_path / "r.csv", line)
    p.write_bytes(p.read_bytes().replace(b"time,u", "tíme,u".encode("latin-1")))
    child = run_fit_to(tmp_path, "r.csv")
    assert_one_line_error(child, "fit_to", "r.csv", "not utf-8")
    corpus.record("error", child)


READ = """
import json
import numpy as np
from cwlidar_sim.analysis.records import RecordSpec, read_record
a = read_record(RecordSpec("plain.csv", rotation="none"))
b = read_record(RecordSpec("{other}", rotation="none"))
print(json.dumps({{"same": all(np.array_equal(a.values[c], b.values[c]) for c in "uvw"),
                  "filled": [a.n_filled, b.n_filled], "fs": [a.sample_rate, b.sample_rate]}}))
"""


def test_a_csv_with_a_byte_order_mark_reads_as_without(tmp_path, corpus, line):
    write_csv(tmp_path / "plain.csv", line)
    write_csv(tmp_path / "bom.csv", line, bom=True)
    child = run_python(READ.format(other="bom.csv"), cwd=tmp_path)
    assert child.rc == 0, child.stderr[-3000:]
    got = json.loads(child.stdout)
    assert got == {"same": True, "filled": [0, 0], "fs": [10.0, 10.0]}, got
    corpus.record("right", child)


def test_nan_and_inf_values_in_a_fit_to_record_are_filled_and_counted(tmp_path, corpus, line):
    vals = {c: v.copy() for c, v in line.items()}
    vals["u"][[100, 2000]] = np.nan
    vals["w"][3000] = np.inf
    vals["v"][4000] = -np.inf
    write_nc(tmp_path / "r.nc", vals)
    (tmp_path / "s.toml").write_text(SCENE.format(path="r.nc", U=U))
    child = run_python(FIT % (["s.toml"],), cwd=tmp_path, timeout=120)
    assert child.rc == 0, child.stderr[-3000:]
    info = json.loads(child.stdout.strip().splitlines()[-1])["s.toml"][3]
    assert info["n_filled"] == 4 and info["quality"] == "ok", info
    corpus.record("right", child)


def test_a_fit_to_record_of_nan_only_is_refused(tmp_path, corpus, line):
    write_nc(tmp_path / "r.nc", {c: np.full(N, np.nan) for c in "uvw"})
    child = run_fit_to(tmp_path, "r.nc")
    assert_one_line_error(child, "fit_to", "gap of 819.2 s", "longer than max_gap")
    corpus.record("error", child)


# ---------------------------------------------------------------------------
# the twin's records (the same reader)
# ---------------------------------------------------------------------------
def test_a_twin_record_with_units_that_do_not_parse_is_refused_by_name(tmp_path, corpus, line):
    write_csv(tmp_path / "m.csv", line)
    (tmp_path / "tw.toml").write_text(TWIN.format(path="m.csv").replace(
        'rotation = "none" }', 'rotation = "none", units = { u = "parsecs", v = "m s-1", w = "m s-1" } }'))
    child = run_cli(["twin", "tw.toml", "--twins", "1", "--out", "o", "--no-progress"], cwd=tmp_path, timeout=120)
    assert_one_line_error(child, "'parsecs'", "do not parse as a speed")
    corpus.record("error", child)


def test_a_twin_record_symlinked_to_another_file_is_not_echoed(tmp_path, corpus):
    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\n")
    os.symlink(secret, tmp_path / "m.csv")
    (tmp_path / "tw.toml").write_text(TWIN.format(path="m.csv"))
    child = run_cli(["twin", "tw.toml", "--twins", "1", "--out", "o", "--no-progress"], cwd=tmp_path, timeout=120)
    assert_one_line_error(child, "m.csv", "not a header of column names")
    assert "root:x" not in child.stderr and "bash" not in child.stderr
    corpus.record("error", child)


def test_a_csv_line_with_more_fields_than_the_header_is_named(tmp_path, corpus, line):
    """Was: the extra fields were dropped silently (a shifted row read as another sample)."""
    p = write_csv(tmp_path / "m.csv", line)
    rows = p.read_text().splitlines()
    rows[40] += ",9.9"
    p.write_text("\n".join(rows) + "\n")
    (tmp_path / "tw.toml").write_text(TWIN.format(path="m.csv"))
    child = run_cli(["twin", "tw.toml", "--twins", "1", "--out", "o", "--no-progress"], cwd=tmp_path, timeout=120)
    assert_one_line_error(child, "m.csv", "line 41 has 5 fields, the header 4")
    corpus.record("error", child)
