"""The corpus harness itself: the memory cap bites, the peak is measured, errors are judged."""

import signal
import sys
import time

from conftest import MEM_LIMIT_BYTES, assert_one_line_error, run_cli, run_python


def test_the_memory_cap_stops_an_unbounded_allocation():
    child = run_python(f"import numpy as np; np.ones({MEM_LIMIT_BYTES // 8 + 2**27}); print('allocated')")
    assert child.rc != 0 and "allocated" not in child.stdout
    assert "MemoryError" in child.stderr or "Unable to allocate" in child.stderr, child.stderr[-2000:]


def test_peak_memory_is_measured():
    small = run_python("print(1)")
    big = run_python("import numpy as np; a = np.ones(2**27); a += 1; print(a[0])")  # 1 GiB touched
    assert big.stdout.strip() == "2.0"
    assert small.peak_mb < 200 and 1000 < big.peak_mb < 1400, (small.peak_mb, big.peak_mb)


def test_a_named_one_line_error_is_recognised(tmp_path):
    tmp = tmp_path
    child = run_cli(["box", "--alpha-eps", "1", "--length-scale", "-20", "--gamma", "3",
                     "--shape", "16", "4", "4", "--spacing", "1", "1", "1", "--seed", "1", "--out", "x.nc"], cwd=tmp)
    assert_one_line_error(child, "length")


def test_a_hanging_case_fails_and_leaves_no_process(tmp_path):
    """A case that hangs is killed with its whole process group after the time-out (the harness itself
    must never hang on the pipes of a grandchild): the call ends, and the grandchild is gone."""
    import pytest

    from conftest import _run_measured

    pid_file = tmp_path / "pid"
    code = f"import os, time; open({str(pid_file)!r}, 'w').write(str(os.getpid())); time.sleep(600)"
    def ring(signum, frame):  # a watchdog: with the grandchild left holding the pipes, the harness would hang
        raise RuntimeError("the harness is still waiting on a killed case's pipes")

    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(60)
    try:
        with pytest.raises(AssertionError, match="hung"):
            _run_measured([sys.executable, "-c", code], timeout=3)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    pid = int(pid_file.read_text())

    def state():  # gone, or a zombie awaiting its reaper (this container's init may reap late)
        try:
            with open(f"/proc/{pid}/stat") as fh:
                return fh.read().rsplit(")", 1)[1].split()[0]
        except FileNotFoundError:
            return "gone"

    for _ in range(200):  # SIGKILL is delivered asynchronously: let the kernel finish it
        if state() in ("gone", "Z"):
            break
        time.sleep(0.05)
    assert state() in ("gone", "Z"), state()
