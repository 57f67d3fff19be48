"""Hostile outputs: targets that cannot take a file, a full disk, SIGTERM and kill -9 during a write.

Every writer replaces its file atomically (cwlidar_sim._atomic): the file at
the target is the old one or the whole new one, never a torn one.
"""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import assert_one_line_error, run_cli, run_python

ROOT = Path(__file__).resolve().parents[2]
SMALL = ["--alpha-eps", "1", "--length-scale", "33.6", "--gamma", "3.9", "--shape", "64", "8", "8",
         "--spacing", "2", "2", "2"]


def box_args(out, seed=1, *extra):
    return ["box", *SMALL, "--seed", str(seed), "--out", str(out), *extra]


def _temps(folder):
    return sorted(p.name for p in Path(folder).iterdir() if ".tmp" in p.name)


def test_box_out_dev_null_is_refused_before_compute(tmp_path, corpus):
    # was: the box computed, then h5netcdf failed on /dev/null and the process segfaulted (exit 139)
    child = run_cli(box_args("/dev/null"), cwd=tmp_path)
    assert_one_line_error(child, "--out", "/dev/null", "device")
    corpus.record("error", child)


def test_box_out_directory_is_refused_before_compute(tmp_path, corpus):
    (tmp_path / "d").mkdir()
    child = run_cli(box_args(tmp_path / "d"), cwd=tmp_path)
    assert_one_line_error(child, "--out", "directory")
    assert "finished results are kept" not in child.last_line  # refused up front, not a failed write
    corpus.record("error", child)


def test_box_out_fifo_is_refused_without_blocking(tmp_path, corpus):
    os.mkfifo(tmp_path / "pipe.nc")
    child = run_cli(box_args(tmp_path / "pipe.nc"), cwd=tmp_path, timeout=60)
    assert_one_line_error(child, "pipe.nc", "FIFO")
    corpus.record("error", child)


def test_hawc2_component_that_is_a_directory_is_refused(tmp_path, corpus):
    (tmp_path / "t_v.bin").mkdir()
    child = run_cli(box_args(tmp_path / "t", 1, "--format", "hawc2"), cwd=tmp_path)
    assert_one_line_error(child, "component v", "t_v.bin", "directory")
    assert not (tmp_path / "t_u.bin").exists()
    corpus.record("error", child)


def test_scenes_write_into_a_missing_folder_is_refused(tmp_path, corpus):
    target = tmp_path / "nonexist" / "dir" / "z.toml"
    child = run_cli(["scenes", "--write", "a2012", str(target)], cwd=tmp_path)
    assert_one_line_error(child, str(tmp_path / "nonexist" / "dir"), "does not exist")
    assert not (tmp_path / "nonexist").exists()  # was: created silently
    corpus.record("error", child)


def test_twin_out_that_is_a_file_is_refused_before_the_records_are_read(tmp_path, corpus):
    scene = ROOT / "cwlidar_sim" / "campaign" / "data" / "examples" / "twin" / "twin.toml"
    (tmp_path / "afile").write_text("x", encoding="utf-8")
    child = run_cli(["twin", str(scene), "--out", "afile", "--twins", "2"], cwd=tmp_path)
    assert_one_line_error(child, "afile", "--out")
    corpus.record("error", child)


def test_report_into_a_figure_folder_that_is_a_file_is_refused_before_reading(tmp_path, corpus):
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "x.nc").write_bytes(b"not read: the folder check comes first")
    (tmp_path / "figs").write_text("a file", encoding="utf-8")
    child = run_cli(["report", "res", "--out", "figs"], cwd=tmp_path)
    assert_one_line_error(child, "figs", "output folder")
    corpus.record("error", child)


_FULL_DISK = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG instead of killing
resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY))
from cwlidar_sim.cli import main
sys.exit(main({argv!r}))
"""


def test_box_write_on_a_full_disk_keeps_the_old_file_and_resumes(tmp_path, corpus):
    """Acceptance (issue 34): an injected ENOSPC-like failure (RLIMIT_FSIZE -> EFBIG) mid-write."""
    target = tmp_path / "box.nc"
    assert run_cli(box_args(target, 2), cwd=tmp_path).rc == 0  # the good old file (and a warm numba cache)
    old = target.read_bytes()
    child = run_python(_FULL_DISK.format(limit=len(old) // 3, argv=box_args(target, 1)), cwd=tmp_path)
    assert "Traceback" not in child.stderr, child.stderr[-3000:]
    assert child.rc == 1, (child.rc, child.stderr[-2000:])  # cli.main's documented status of a failed write
    assert "box.nc" in child.last_line and "File too large" in child.last_line, child.last_line
    assert "unchanged" in child.last_line and "resume" not in child.last_line  # a box has nothing to resume
    assert target.read_bytes() == old
    assert _temps(tmp_path) == []
    # the same command without the limit writes the file a fresh run writes, bit for bit
    assert run_cli(box_args(target, 1), cwd=tmp_path).rc == 0
    (tmp_path / "fresh").mkdir()
    assert run_cli(box_args(tmp_path / "fresh" / "box.nc", 1), cwd=tmp_path).rc == 0
    assert target.read_bytes() == (tmp_path / "fresh" / "box.nc").read_bytes() != old
    corpus.record("error", child)


def test_hawc2_write_on_a_full_disk_keeps_the_old_triplet(tmp_path, corpus):
    base = tmp_path / "turb"
    assert run_cli(box_args(base, 2, "--format", "hawc2"), cwd=tmp_path).rc == 0
    names = [tmp_path / f"turb_{c}.bin" for c in "uvw"]
    old = [p.read_bytes() for p in names]
    child = run_python(_FULL_DISK.format(limit=len(old[0]) // 2, argv=box_args(base, 1, "--format", "hawc2")),
                       cwd=tmp_path)
    assert "Traceback" not in child.stderr and child.rc == 1, (child.rc, child.stderr[-2000:])
    assert "turb_u.bin" in child.last_line and "File too large" in child.last_line, child.last_line
    assert [p.read_bytes() for p in names] == old
    assert _temps(tmp_path) == []
    corpus.record("error", child)


def _wait_for_sigterm_handler(pid, timeout=60.0):
    """Wait until process ``pid`` catches SIGTERM (bit 15 of SigCgt in /proc/PID/status)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        status = Path(f"/proc/{pid}/status").read_text()
        caught = int(next(ln.split()[1] for ln in status.splitlines() if ln.startswith("SigCgt:")), 16)
        if caught >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.005)
    raise AssertionError("the CLI never installed its SIGTERM handler")


def test_sigterm_during_a_box_run_exits_143_with_one_line(tmp_path, corpus):
    target = tmp_path / "box.nc"
    target.write_bytes(b"the old file")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "cwlidar_sim", *box_args(target, 1)[:-2], "--out", str(target),
                             "--no-progress"], cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    _wait_for_sigterm_handler(proc.pid)  # cli.main is running (before it, SIGTERM kills the default way)
    time.sleep(0.2)  # inside the imports or the computation
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, (proc.returncode, err[-2000:])
    assert "Traceback" not in err
    last = [ln for ln in err.splitlines() if ln.strip()][-1]
    assert "interrupted by SIGTERM" in last, err[-2000:]
    assert target.read_bytes() == b"the old file"
    assert _temps(tmp_path) == []
    corpus.record("error", peak_mb=None)


def test_sigterm_message_of_a_resumable_command_names_the_folder(tmp_path, corpus):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    code = ("import os, signal, sys\n"
            "import cwlidar_sim.cli as cli\n"
            "def fake(args):\n"
            "    os.kill(os.getpid(), signal.SIGTERM)\n"
            "    raise AssertionError('not interrupted')\n"
            "cli._cmd_twin = fake\n"
            "p = cli.build_parser()\n"
            "sys.exit(cli.main(['twin', 'x.toml', '--out', 'res/tw']))\n")
    # build_parser binds _cmd_twin when called, so the fake is what main runs
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 143, (out.returncode, out.stderr[-2000:])
    assert out.stderr.strip().splitlines()[-1] == ("cwlidar-sim twin: interrupted by SIGTERM; finished periods are "
                                                   "kept in res/tw; run the same command again to resume")
    corpus.record("error", peak_mb=None)


def test_kill_9_at_random_points_of_a_box_write_never_leaves_a_torn_file(tmp_path, corpus):
    """The file at the target is the old box or the whole new one after a kill -9 anywhere."""
    args = ["--alpha-eps", "1", "--length-scale", "33.6", "--gamma", "3.9", "--shape", "256", "32", "32",
            "--spacing", "2", "2", "2", "--no-progress"]
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")

    def start(out, seed):
        return subprocess.Popen([sys.executable, "-m", "cwlidar_sim", "box", *args, "--seed", str(seed), "--out",
                                 str(out)], cwd=tmp_path, env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)

    (tmp_path / "ref").mkdir()
    assert start(tmp_path / "ref" / "s1.nc", 1).wait(120) == 0
    t0 = time.monotonic()
    assert start(tmp_path / "ref" / "s2.nc", 2).wait(120) == 0
    run_s = time.monotonic() - t0  # a whole run, start-up included
    old, new = ((tmp_path / "ref" / f"s{s}.nc").read_bytes() for s in (1, 2))
    target = tmp_path / "box.nc"
    rng = random.Random(34)
    outcomes = []
    for trial in range(6):
        target.write_bytes(old)
        stamp = target.stat().st_mtime_ns
        proc = start(target, 2)
        t0 = time.monotonic()
        if trial % 2 == 0:  # anywhere in the run
            time.sleep(rng.uniform(0.1, 1.2) * run_s)
        else:  # inside the write: once the temporary file appears (or the target changes), after a random delay
            while (proc.poll() is None and not _temps(tmp_path) and target.stat().st_mtime_ns == stamp
                   and time.monotonic() - t0 < 60):
                time.sleep(0.001)
            time.sleep(rng.uniform(0.0, 0.1))
        proc.kill()
        proc.wait(60)
        now = target.read_bytes()
        assert now in (old, new), f"trial {trial}: a torn file of {len(now)} bytes at the target"
        outcomes.append("new" if now == new else "old")
        for name in _temps(tmp_path):  # a kill -9 can leave a stray temporary beside it, never at the target
            (tmp_path / name).unlink()
    print("kill -9 outcomes:", outcomes)
    corpus.record("right", peak_mb=None)
