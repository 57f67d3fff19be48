"""The one child-process timing protocol every benchmark here shares.

A *measurement* runs in a fresh interpreter, so that no JIT state, FFTW
plan, allocator arena or memory high-water mark carries over from the driver
or from another measurement::

    driver                                   child (same script, ``--child JSON``)
    ------                                   -------------------------------------
    spawn(__file__, task)  ----------->      child_main(handlers)
                                               handler(task): import, warm up, time
    result dict  <---- one tagged JSON line    print(RESULT_TAG + json.dumps(result))

Rules (all benchmarks):

1. **Fresh interpreter per measurement** (:func:`spawn`, :func:`spawn_rounds`).
   The child is started from a neutral folder when ``pythonpath`` is given,
   so that ``--pythonpath DIR`` decides which ``cwlidar_sim`` is imported.
2. **Warm-up first.**  A child imports, runs a small version of the same
   work (numba's on-disk cache load, lazy imports, pools and FFTW planning
   excluded), then times (:func:`timed`, :func:`time_repeats`).
3. **Minimum over children.**  Other jobs on a shared machine only ever
   add time, so the headline is the minimum over all runs of all children;
   the median is given beside it (:func:`summarize`), with the CPU time per
   wall second (about the thread count when the cores are ours) and the
   1-minute load averages before and after.
4. **Peak memory is VmHWM** (:func:`vmhwm`), the child's own high-water
   resident set.  ``getrusage(...).ru_maxrss`` is not used: Linux carries the
   parent's high-water mark across fork + exec, so a child of a large driver
   reports at least the driver's peak.  It is recorded (:func:`ru_maxrss`)
   for information only.  The baseline is the RSS after the warm-up
   (:func:`vmrss`).
5. **JSON on stdout**: one line prefixed with :data:`RESULT_TAG`, whatever
   else the child prints; the driver prints its own report as JSON too.

Benchmarks are run by hand (``python benchmarks/run_all.py``); they are never
part of the tests.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import threading
import time

RESULT_TAG = "@@BENCH_RESULT@@"

#: The checkout holding this benchmarks/ folder.  ``python benchmarks/x.py`` puts only
#: benchmarks/ on sys.path, so an installed cwlidar_sim (e.g. an editable install of
#: another checkout) would be imported; the checkout goes right after PYTHONPATH's
#: entries instead, so that ``--pythonpath DIR`` still wins.  The place is found by
#: looking the entries up in sys.path (a script that inserted its own folder in front,
#: as every benchmark does, shifts them: counting them placed the checkout in front of
#: ``--pythonpath DIR``, and the "before" of a before/after comparison ran this checkout).
REPO_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _place_repo_root():
    if REPO_ROOT in sys.path:
        return
    entries = {os.path.abspath(p) for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p}
    after = [i for i, p in enumerate(sys.path) if p and os.path.abspath(p) in entries]
    sys.path.insert(max(after) + 1 if after else min(1, len(sys.path)), REPO_ROOT)


_place_repo_root()

__all__ = ["RESULT_TAG", "vmhwm", "vmrss", "ru_maxrss", "TreeRssSampler", "timed", "time_repeats",
           "child_main", "spawn", "spawn_rounds", "summarize", "machine", "versions", "log"]


def _status_field(name):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(name + ":"):
                return int(line.split()[1]) * 1024
    raise RuntimeError(f"{name} not found in /proc/self/status")


def vmhwm() -> int:
    """Peak resident set of this process so far [bytes] (VmHWM; see rule 4)."""
    return _status_field("VmHWM")


def vmrss() -> int:
    """Current resident set of this process [bytes] (VmRSS)."""
    return _status_field("VmRSS")


def ru_maxrss() -> int:
    """``getrusage(RUSAGE_SELF).ru_maxrss`` [bytes]; inherits the parent's peak (information only)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


class TreeRssSampler:
    """Samples the summed RSS of this process and its descendants (for code that forks a pool).

    Use as a context manager; ``peak`` [bytes] and ``saw_children`` afterwards.
    """

    def __init__(self, period=0.02):
        self.period = period
        self.peak = 0
        self.saw_children = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    @staticmethod
    def _rss_of(pid):
        try:
            with open(f"/proc/{pid}/statm") as f:
                return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
        except OSError:
            return 0

    @staticmethod
    def _children(pid):
        out = []
        try:
            for tid in os.listdir(f"/proc/{pid}/task"):
                try:
                    with open(f"/proc/{pid}/task/{tid}/children") as f:
                        out.extend(int(c) for c in f.read().split())
                except OSError:
                    pass
        except OSError:
            pass
        return out

    def _run(self):
        me = os.getpid()
        while not self._stop.is_set():
            total, stack = 0, [me]
            while stack:
                pid = stack.pop()
                total += self._rss_of(pid)
                ch = self._children(pid)
                if ch and pid == me:
                    self.saw_children = True
                stack.extend(ch)
            self.peak = max(self.peak, total)
            self._stop.wait(self.period)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def timed(fn):
    """``(wall_s, cpu_s, result)`` of one call ``fn()`` (process CPU time, all threads)."""
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - w, time.process_time() - c, out


def time_repeats(fn, repeats, warmup=None):
    """Run ``warmup()`` (default ``fn``) once, then time ``fn`` ``repeats`` times.

    Returns a dict: ``runs`` (list of [wall_s, cpu_s]), ``baseline_bytes``
    (RSS after the warm-up), ``peak_bytes`` (VmHWM after the runs) and the
    1-minute load averages before and after.
    """
    (warmup or fn)()
    out = {"baseline_bytes": vmrss(), "load_before": os.getloadavg()[0]}
    runs = []
    for _ in range(repeats):
        w, c, _r = timed(fn)
        runs.append([w, c])
    out.update(runs=runs, peak_bytes=vmhwm(), load_after=os.getloadavg()[0])
    return out


def child_main(handlers, task_json):
    """Child side: run ``handlers[task['kind']](task)`` and print its dict as the tagged JSON line.

    ``peak_bytes`` (VmHWM) and ``ru_maxrss_bytes`` are added unless the
    handler set them.  Leaves with ``os._exit(0)`` (a peer's process pool is
    not waited for).
    """
    task = json.loads(task_json)
    res = handlers[task.get("kind", "default")](task)
    res.setdefault("peak_bytes", vmhwm())
    res.setdefault("ru_maxrss_bytes", ru_maxrss())
    sys.stdout.write("\n" + RESULT_TAG + json.dumps(res, default=float) + "\n")
    sys.stdout.flush()
    os._exit(0)


def spawn(script, task, *, timeout=1800, pythonpath=None, args=()):
    """Run ``python script --child JSON`` in a fresh interpreter; its result dict, or ``{'error': ...}``.

    ``child_wall_s`` (start-up included) is added.  With ``pythonpath`` the
    child runs from the script's folder with DIR first on ``PYTHONPATH``.
    """
    env = dict(os.environ)
    cwd = None
    if pythonpath:
        env["PYTHONPATH"] = os.path.abspath(pythonpath) + os.pathsep + env.get("PYTHONPATH", "")
        cwd = os.path.dirname(os.path.abspath(script))
    cmd = [sys.executable, os.path.abspath(script), *args, "--child", json.dumps(task)]
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=cwd)
    except subprocess.TimeoutExpired:
        return {"error": f"timeout after {timeout} s"}
    wall = time.perf_counter() - t0
    for line in reversed(p.stdout.splitlines()):
        if line.startswith(RESULT_TAG):
            r = json.loads(line[len(RESULT_TAG):])
            r["child_wall_s"] = wall
            return r
    return {"error": f"child failed (rc={p.returncode}): {p.stderr[-3000:]}"}


def spawn_rounds(script, tasks, rounds, *, on_result=None, **kw):
    """Each of ``tasks`` (name -> task) once per round, round after round; name -> list of results.

    Running in rounds lets a change of machine load reach every task alike.
    """
    out = {name: [] for name in tasks}
    for rnd in range(rounds):
        for name, task in tasks.items():
            r = spawn(script, task, **kw)
            out[name].append(r)
            if on_result is not None:
                on_result(name, rnd, r)
    return out


def summarize(runs, sim_s=None):
    """Minimum and median of ``runs`` ([wall_s, cpu_s] pairs, all children together).

    With ``sim_s`` (simulated seconds per run) also the real-time factors.
    """
    walls = [r[0] for r in runs]
    cpus = [r[1] for r in runs]
    best = min(walls)
    out = {"wall_s_min": best, "wall_s_median": statistics.median(walls), "n_runs": len(walls),
           "cpu_per_wall": statistics.median([c / w for c, w in zip(cpus, walls)])}
    if sim_s is not None:
        out.update(realtime_factor=sim_s / best, realtime_factor_median=sim_s / statistics.median(walls),
                   realtime_factor_per_cpu_s=sim_s / min(cpus))
    return out


def versions():
    """Versions of Python and the packages that matter for the timings (None when absent)."""
    from importlib.metadata import PackageNotFoundError, version

    v = {"python": platform.python_version()}
    for mod in ("numpy", "scipy", "numba", "pyfftw", "cwlidar_sim", "mannrs", "hipersim", "dask"):
        try:
            v[mod] = version(mod)
        except PackageNotFoundError:
            v[mod] = None
    return v


def machine():
    """Host, cores, memory, load and date of this run."""
    return {"date": datetime.datetime.now().isoformat(timespec="seconds"), "host": platform.node(),
            "cpu": platform.processor() or platform.machine(), "cpu_count": os.cpu_count(),
            "mem_total_bytes": os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"),
            "loadavg_1min": os.getloadavg()[0], "versions": versions()}


def log(msg):
    print(msg, flush=True)


def write_json(path, obj):
    """Write ``obj`` as indented JSON, creating the folder."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        json.dump(obj, f, indent=1, default=float)


def reset_peak() -> bool:
    """Reset this process's VmHWM to its current RSS (``/proc/self/clear_refs`` = 5); False if refused.

    Lets one child report the peak of each of several measurements in turn.
    """
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def stage_seconds(ds, stage) -> float:
    """The sum over periods of one stage's seconds in the results' ``timing`` attribute (per period or flat)."""
    timing = json.loads(ds.attrs["timing"])
    if stage in timing:
        return float(timing[stage])
    return float(sum(v.get(stage, 0.0) for v in timing.values() if isinstance(v, dict)))


def spectral_against_floor(scene, sensor_module, measure_name) -> tuple:
    """Run ``scene`` (results and figures) and its tier-1 floor (tier ``los``, no variants) in this process.

    The lidar stage's CPU seconds (every thread's) are timed around ``sensor_module.<measure_name>``
    (replaced here for the rest of the process); the JIT must be warm.  Returns the wall and CPU
    seconds of both runs and their ratios, the lidar stage's seconds (CPU and from the results'
    ``timing``), the real-time factors (the scene's simulated seconds per wall, CPU and lidar-stage
    second), the periods' own compute ratio, both ``timing`` attributes, the units and the peak
    memory; and the spectral run's results (for a benchmark's own extra numbers): ``(out, ds)``.
    """
    import dataclasses
    import tempfile

    from cwlidar_sim.campaign import run_scene
    from cwlidar_sim.campaign.registry import kind_of

    real, lidar_cpu = getattr(sensor_module, measure_name), []

    def timed_measure(*args, **kw):
        c = time.process_time()
        try:
            return real(*args, **kw)
        finally:
            lidar_cpu.append(time.process_time() - c)

    setattr(sensor_module, measure_name, timed_measure)
    out = {}
    simulated = sum(scene.period_duration(p) for p in scene.periods)
    with tempfile.TemporaryDirectory() as tmp:
        t, c = time.perf_counter(), time.process_time()
        ds = run_scene(scene, tmp, progress=False)
        kind_of(scene).figures(ds, tmp)
        out["wall_s"], out["cpu_s"] = time.perf_counter() - t, time.process_time() - c
    out["lidar_cpu_s"] = sum(lidar_cpu)
    out["realtime_factor_lidar_cpu"] = simulated / out["lidar_cpu_s"]
    floor = scene.replace(lidar=dataclasses.replace(scene.lidar, tier="los", variants=()))
    with tempfile.TemporaryDirectory() as tmp:  # written and drawn as the spectral run is: like for like
        t, c = time.perf_counter(), time.process_time()
        fl = run_scene(floor, tmp, progress=False)
        kind_of(floor).figures(fl, tmp)
        out["floor_s"], out["floor_cpu_s"] = time.perf_counter() - t, time.process_time() - c
    out["cpu_ratio_to_floor"] = out["cpu_s"] / out["floor_cpu_s"]  # steadier than wall time on a loaded machine
    out["floor_lidar_cpu_s"] = sum(lidar_cpu) - out["lidar_cpu_s"]
    out["lidar_cpu_ratio_to_floor"] = out["lidar_cpu_s"] / out["floor_lidar_cpu_s"]  # the chain's own cost
    out["units"] = len(scene.unit_names())
    out["simulated_s"] = simulated
    out["lidar_s"] = stage_seconds(ds, "lidar")
    out["floor_lidar_s"] = stage_seconds(fl, "lidar")
    out["realtime_factor"] = simulated / out["wall_s"]
    out["realtime_factor_cpu"] = simulated / out["cpu_s"]  # per CPU second: what one free core would give
    # the periods' own compute (box, lidar, fits), without writing or figures, against the floor's
    out["compute_ratio_to_floor"] = stage_seconds(ds, "total") / stage_seconds(fl, "total")
    out["realtime_factor_lidar"] = simulated / out["lidar_s"] if out["lidar_s"] > 0 else None
    out["timing"] = json.loads(ds.attrs["timing"])
    out["floor_timing"] = json.loads(fl.attrs["timing"])
    out["peak_bytes"] = vmhwm()
    return out, ds


def scene_benchmark_main(script, child, *, name, targets, what, argv=None, extra=None) -> int:
    """The ``main`` of a benchmark that times one bundled scene against its tier-1 floor in a fresh child.

    ``child(task)`` runs in the child (``task``: ``quick``, ``threads``) and returns at least
    ``wall_s``, ``floor_s``, ``units`` and ``peak_bytes``; ``targets`` maps ``'quick'`` and
    ``'full'`` to the target wall time [s]; ``what`` names the units in the summary line
    ("units", "periods"); ``extra(r)``, if given, prints more of the result.  Writes the result,
    the mode, the target, the ratio to the floor, the load and the machine to ``--json``.
    """
    import argparse

    ap = argparse.ArgumentParser(description=f"Wall time and peak memory of cwlidar-sim reproduce {name}")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--threads", type=int, default=len(os.sched_getaffinity(0)))
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_main({"default": child}, a.child)
    r = spawn(script, {"quick": a.quick, "threads": a.threads})
    if "error" in r:
        print(r["error"], file=sys.stderr)
        return 1
    mode = "quick" if a.quick else "full"
    r.update(mode=mode, target_s=targets[mode], met=r["wall_s"] < targets[mode], ratio_to_floor=r["wall_s"] / r["floor_s"],
             threads=a.threads, load=os.getloadavg(), time=time.strftime("%Y-%m-%dT%H:%M:%S"), machine=machine())
    print(f"reproduce {name}{' --quick' if a.quick else ''}: {r['wall_s']:.1f} s for {r['units']} {what} "
          f"({r['ratio_to_floor']:.2f}x the tier-1 floor of {r['floor_s']:.1f} s), peak {r['peak_bytes'] / 2**30:.2f} GiB; "
          f"target < {targets[mode]:.0f} s: {'met' if r['met'] else 'MISSED'}")
    if extra is not None:
        extra(r)
    if a.json:
        write_json(a.json, r)
    return 0
