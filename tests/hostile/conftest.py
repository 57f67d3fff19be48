"""The hostile-input corpus: every case runs in a child process under a memory limit.

Each case ends in one of three outcomes, and says which through the ``corpus``
fixture:

``error``
    a named one-line error, exit status 2, no traceback, before compute;
``warned``
    the right answer with a warning and a flag in the results;
``right``
    the right answer (the input was odd but meaningful).

The child runs with its address space capped at :data:`MEM_LIMIT_BYTES`, so a
case that allocates without bound fails as a MemoryError traceback instead of
passing; its peak resident memory is measured (``wait4``) and the worst case
is printed with the counts per outcome at the end of the session (and written
as JSON to ``$CWLIDAR_HOSTILE_REPORT`` when that is set).
"""

from __future__ import annotations

import dataclasses
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

#: Address-space cap of every corpus child [bytes]: a normal quick run stays well under it
#: (about 0.3-1.5 GB resident, 3-4 GB mapped by numba/LLVM and the thread pools), a 24 GB
#: allocation cannot.
MEM_LIMIT_BYTES = 8 * 2**30

OUTCOMES = ("error", "warned", "right")

#: A one-period staring scene fitted to a record (``{path}``, mean speed ``{U}``): the records cases' scene.
FIT_TO_SCENE = """
name = "h"
seed = 3
duration = 60.0
[turbulence]
fit_to = "{path}"
[lidar]
tier = "los"
[analysis]
segment_duration = 30.0
fit = false
[[period]]
name = "a"
mean_speed = {U}
"""
_CASES: list[dict] = []


@dataclasses.dataclass
class Child:
    """What a corpus child did: exit status, its output, its peak resident memory [MB]."""

    rc: int
    stdout: str
    stderr: str
    peak_mb: float

    @property
    def last_line(self) -> str:
        lines = [ln for ln in self.stderr.splitlines() if ln.strip()]
        return lines[-1] if lines else ""


def _limit():  # runs in the child before exec
    resource.setrlimit(resource.RLIMIT_AS, (MEM_LIMIT_BYTES, MEM_LIMIT_BYTES))


def _spawn(argv, *, cwd=None, env=None, timeout=300.0, stdin_text=None) -> Child:
    full_env = dict(os.environ)
    # the package under test, whatever checkout the suite runs from
    root = str(Path(__file__).resolve().parents[2])
    full_env["PYTHONPATH"] = root + os.pathsep + full_env.get("PYTHONPATH", "")
    full_env.setdefault("OMP_NUM_THREADS", "1")
    if env:
        full_env.update(env)
    # a session of its own: on a time-out the whole group goes (the wrapper and the CLI it runs, which
    # holds the pipes; killing the wrapper alone would leave communicate() waiting on them)
    proc = subprocess.Popen(argv, cwd=cwd, env=full_env, preexec_fn=_limit, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(stdin_text, timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        raise AssertionError(f"{argv[2:]} hung for more than {timeout} s\n{err[-2000:]}") from None
    return Child(proc.returncode, out, err, float("nan"))


def _run_measured(argv, *, cwd=None, env=None, timeout=300.0, stdin_text=None) -> Child:
    """Run ``argv`` under the memory cap through a tiny wrapper that reports the child's own peak RSS."""
    wrapper = (
        "import os, resource, subprocess, sys, json\n"
        f"lim = {MEM_LIMIT_BYTES}\n"
        "def f(): resource.setrlimit(resource.RLIMIT_AS, (lim, lim))\n"
        "p = subprocess.Popen(sys.argv[1:], preexec_fn=f)\n"
        "_, status, ru = os.wait4(p.pid, 0)\n"
        "sys.stderr.write('\\n@@peak_kb=%d\\n' % ru.ru_maxrss)\n"
        "rc = os.waitstatus_to_exitcode(status)\n"
        "sys.exit(rc if rc >= 0 else 128 - rc)  # killed by signal N: 128 + N, as a shell says\n"
    )
    child = _spawn([sys.executable, "-c", wrapper, *argv], cwd=cwd, env=env, timeout=timeout,
                   stdin_text=stdin_text)
    peak = float("nan")
    kept = []
    for ln in child.stderr.splitlines():
        if ln.startswith("@@peak_kb="):
            peak = int(ln.split("=", 1)[1]) / 1024
        else:
            kept.append(ln)
    child.stderr = "\n".join(kept)
    child.peak_mb = peak
    return child


def run_cli(args, *, cwd=None, env=None, timeout=300.0, stdin_text=None) -> Child:
    """Run ``python -m cwlidar_sim ARGS`` under the memory cap; return a :class:`Child`."""
    return _run_measured([sys.executable, "-m", "cwlidar_sim", *map(str, args)], cwd=cwd, env=env,
                         timeout=timeout, stdin_text=stdin_text)


def run_python(code: str, *, cwd=None, env=None, timeout=300.0) -> Child:
    """Run a Python snippet (the public API) under the memory cap; return a :class:`Child`."""
    return _run_measured([sys.executable, "-c", code], cwd=cwd, env=env, timeout=timeout)


def assert_one_line_error(child: Child, *fragments: str) -> None:
    """Exit status 2, no traceback, and the last line of stderr names every fragment (case-insensitive)."""
    assert "Traceback" not in child.stderr, child.stderr[-3000:]
    assert child.rc == 2, (child.rc, child.stderr[-3000:])
    line = child.last_line.lower()
    for frag in fragments:
        assert frag.lower() in line, (frag, child.last_line)


class Corpus:
    """Records each case's outcome and peak memory for the session summary."""

    def __init__(self, nodeid):
        self.nodeid = nodeid

    def record(self, outcome: str, child: Child | None = None, *, peak_mb: float | None = None):
        if outcome not in OUTCOMES:
            raise ValueError(f"outcome must be one of {OUTCOMES}, got {outcome!r}")
        peak = child.peak_mb if child is not None else peak_mb
        _CASES.append({"case": self.nodeid, "outcome": outcome,
                       "peak_mb": None if peak is None or peak != peak else round(float(peak), 1)})


@pytest.fixture
def corpus(request):
    """The recorder of this case's outcome (see the module docstring)."""
    return Corpus(request.node.nodeid)


def pytest_terminal_summary(terminalreporter):
    if not _CASES:
        return
    counts = {o: sum(c["outcome"] == o for c in _CASES) for o in OUTCOMES}
    peaks = [c for c in _CASES if c["peak_mb"] is not None]
    worst = max(peaks, key=lambda c: c["peak_mb"]) if peaks else None
    terminalreporter.write_sep("-", "hostile-input corpus")
    terminalreporter.write_line(f"{len(_CASES)} cases: " + ", ".join(f"{n} {o}" for o, n in counts.items())
                                + (f"; worst peak {worst['peak_mb']:.0f} MB ({worst['case']})" if worst else "")
                                + f"; memory cap {MEM_LIMIT_BYTES / 2**30:.0f} GiB")
    path = os.environ.get("CWLIDAR_HOSTILE_REPORT")
    if path:
        with open(path, "w", encoding="utf-8") as fh:
            json.dump({"counts": counts, "worst": worst, "cases": _CASES}, fh, indent=1)
