"""Hostile records after the merge of h-records and h-times: a scene's ``fit_to`` reads its times as the twin does.

``fit_to`` and the twin share one reader (analysis/record_files.py); its time
column is now read as text and parsed exactly (cwlidar_sim._times): a record
on a Unix clock fits exactly as the same record from 0, a column named
``time_ms`` is in ms, and ms without their unit are refused naming it.
"""

import json
from decimal import Decimal

import numpy as np
import pytest
from conftest import FIT_TO_SCENE, assert_one_line_error, run_cli, run_python

U, FS, N = 8.0, 10.0, 2**12

SCENE = FIT_TO_SCENE

FIT = """
import json
from cwlidar_sim.campaign import load_scene
from cwlidar_sim.campaign.periods.staring_field import scene_params
from cwlidar_sim.analysis.records import RecordSpec, read_record
out = {}
for name in %r:
    s = load_scene(name)
    p, info = scene_params(s)
    rec = read_record(RecordSpec(s.resolve(s.turbulence.fit_to), rotation="none", despike_threshold=0.0))
    out[name] = [p.alpha_eps, p.length_scale, p.gamma, info["n_filled"], rec.sample_rate, rec.time0_ns]
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def line():
    """A line of the tensor (alpha_eps 0.063, L 18.8 m, Gamma 3.2) sampled as a 10 Hz sonic at U = 8 m/s."""
    from cwlidar_sim.turbulence import MannParameters, generate_line

    ln = generate_line(MannParameters(0.063, 18.8, 3.2), N, U / FS, 5, dtype=np.float64)
    return {c: ln[c].values[::-1] + (U if c == "u" else 0.0) for c in "uvw"}


def write(path, vals, header, cells):
    with open(path, "w") as f:
        f.write(f"{header},u,v,w\n")
        for c, a, b, d in zip(cells, vals["u"], vals["v"], vals["w"]):
            f.write(f"{c},{float(a)!r},{float(b)!r},{float(d)!r}\n")
    (path.parent / (path.stem + ".toml")).write_text(SCENE.format(path=path.name, U=U))
    return path.stem + ".toml"


def test_fit_to_on_a_unix_clock_or_in_ms_fits_as_from_zero(tmp_path, corpus, line):
    """Float seconds near 1.7e9 s step in 2.4e-7 s: the Unix-clock record was 10.0000095 Hz on h-records' reader."""
    n = len(line["u"])
    unix = [str(Decimal(1_700_000_000) + Decimal(i) / 10) for i in range(n)]
    names = [write(tmp_path / "zero.csv", line, "time", [f"{i / FS:.1f}" for i in range(n)]),
             write(tmp_path / "unix.csv", line, "time", unix),
             write(tmp_path / "ms.csv", line, "time_ms", [str(100 * i) for i in range(n)])]
    child = run_python(FIT % (names,), cwd=tmp_path, timeout=120)
    assert child.rc == 0, child.stderr[-3000:]
    fits = json.loads(child.stdout.strip().splitlines()[-1])
    zero, unix, ms = (fits[k] for k in names)
    assert zero[4] == unix[4] == ms[4] == 10.0
    assert (zero[5], unix[5], ms[5]) == (0, 1_700_000_000 * 10**9, 0)
    assert unix[:4] == zero[:4] and ms[:4] == zero[:4]  # the same fit, bit for bit
    assert abs(zero[0] - 0.063) < 0.03 and zero[3] == 0, zero
    corpus.record("right", child)


def test_fit_to_in_ms_without_its_unit_is_refused_naming_it(tmp_path, corpus, line):
    write(tmp_path / "r.csv", line, "time", [str(100 * i) for i in range(len(line["u"]))])
    child = run_cli(["run", "r.toml", "--out", "o", "--no-progress"], cwd=tmp_path, timeout=120)
    assert_one_line_error(child, "fit_to", "time column 'time'", "read in ms it would be 10 hz", "time_ms")
    # nothing computed was written: at most the folder's lock and owner files (campaign/execution/folder.py)
    left = {p.name for p in (tmp_path / "o").iterdir()} if (tmp_path / "o").exists() else set()
    assert left <= {"cwlidar-run.json", ".cwlidar-sim.lock"}, left
    corpus.record("error", child)
