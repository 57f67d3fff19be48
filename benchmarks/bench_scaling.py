"""Campaign throughput on a local Dask cluster: simulated hours per wall hour, 1 and 2 workers.

    python benchmarks/bench_scaling.py [--quick] [--json PATH]

Runs the same campaign (the A2012 scene's period C, ``--tasks`` replicas of
``--duration`` s each, full processing: spectral tier, five variants) three
times into fresh folders:

* 1 worker x 1 thread (the baseline),
* 1 worker x all cores' threads (numba/FFTW threads inside one task),
* N workers x 1 thread (one task per core),

and reports throughput (simulated hours per wall hour, cluster start-up
included), the scaling efficiency against the baseline
(throughput / (workers x baseline)), the scheduler's per-task overhead
(measured with trivial tasks on the same cluster) and the size of one task's
result, from which it extrapolates what a cluster of M machines would give.
Results are bit-identical across the three runs (checked).  Each run and the
overhead measurement is a fresh interpreter under the shared protocol of
``benchmarks/_protocol.py`` (``peak_bytes`` is the driver process's VmHWM; the
workers are processes of their own).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import child_main, machine, write_json  # noqa: E402


def campaign_text(tasks, duration):
    return f"""
name = "scaling"
seed = 1
base = "a2012"
periods = ["C"]
replicas = {tasks}
paired = false
[set]
duration = {duration}
"analysis.segment_duration" = 600.0
"analysis.fit" = false
"""


def run(spec, out, workers, threads):
    import cwlidar_sim.campaign.execution.batch as batch

    real = batch.plan_cluster

    def plan(n, mem, w=None, **kw):
        p = real(n, mem, workers, **kw)
        p["threads"] = threads
        return p

    batch.plan_cluster = plan
    try:
        t = time.perf_counter()
        s = batch.run_campaign(spec, out, workers=workers, progress=False)
        wall = time.perf_counter() - t
    finally:
        batch.plan_cluster = real
    assert not s["failed"], s["failed"]
    return wall, s


def _child_run(task):
    from cwlidar_sim.campaign.execution.sweep import loads_campaign

    spec = loads_campaign(campaign_text(task["tasks"], task["duration"]))
    wall, _ = run(spec, task["out"], task["workers"], task["threads"])
    return {"wall_s": wall}


def _child_overhead(task):
    return {"s_per_task": scheduler_overhead()}


def _spawn(task):
    r = _protocol.spawn(__file__, task)
    if "error" in r:
        raise RuntimeError(r["error"])
    return r


def scheduler_overhead(n=200):
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c, Client(c) as cl:
        cl.gather(cl.map(abs, range(10)))
        t = time.perf_counter()
        cl.gather(cl.map(abs, range(n), pure=False))
        return (time.perf_counter() - t) / n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="4 tasks of 600 s (about 2 minutes)")
    ap.add_argument("--tasks", type=int, default=None)
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        child_main({"run": _child_run, "overhead": _child_overhead}, a.child)
    tasks = a.tasks or 4
    duration = a.duration or (600.0 if a.quick else 1800.0)
    cores = len(os.sched_getaffinity(0))
    from cwlidar_sim.campaign.execution.batch import merge_campaign

    sim_h = tasks * duration / 3600.0
    rows = []
    merged = []
    with tempfile.TemporaryDirectory() as tmp:
        for workers, threads in ((1, 1), (1, cores), (cores, 1)):
            out = os.path.join(tmp, f"w{workers}t{threads}")
            r = _spawn({"kind": "run", "tasks": tasks, "duration": duration, "out": out, "workers": workers,
                        "threads": threads})
            wall = r["wall_s"]
            size = sum(os.path.getsize(os.path.join(out, "tasks", f)) for f in os.listdir(os.path.join(out, "tasks")))
            rows.append({"workers": workers, "threads": threads, "wall_s": round(wall, 2),
                         "sim_h_per_wall_h": round(sim_h / (wall / 3600.0), 1), "result_bytes_per_task": size // tasks,
                         "peak_bytes_driver": r["peak_bytes"]})
            merged.append(merge_campaign(out))
            print(f"{workers} worker(s) x {threads} thread(s): {wall:6.1f} s, "
                  f"{rows[-1]['sim_h_per_wall_h']:7.1f} sim-h/wall-h", flush=True)
    import xarray as xr

    for m in merged[1:]:
        xr.testing.assert_identical(m.drop_attrs(), merged[0].drop_attrs())
    base = rows[0]["sim_h_per_wall_h"]
    for r in rows:
        r["efficiency"] = round(r["sim_h_per_wall_h"] / (r["workers"] * r["threads"] * base), 3)
    overhead = _spawn({"kind": "overhead"})["s_per_task"]
    task_s = rows[0]["wall_s"] / tasks
    out = {"machine": machine(), "cores": cores, "tasks": tasks, "period_s": duration, "runs": rows, "identical_bits": True,
           "scheduler_overhead_s_per_task": round(overhead, 5), "task_seconds_1core": round(task_s, 2),
           "note": (f"a task of {duration:.0f} s simulated takes {task_s:.1f} s on one core and returns "
                    f"{rows[0]['result_bytes_per_task'] / 1e6:.1f} MB; the scheduler costs {overhead * 1e3:.1f} ms "
                    f"per task, so M machines of C cores keep near-linear scaling (efficiency of the "
                    f"{cores}-worker run here) while M*C*{overhead:.4f} s << {task_s:.1f} s, i.e. up to about "
                    f"{int(task_s / max(overhead, 1e-6) / 10)} workers at 10 % overhead, and while the driver can "
                    f"write M*C*{rows[0]['result_bytes_per_task'] / 1e6:.1f} MB per {task_s:.0f} s")}
    print(json.dumps(out, indent=2))
    if a.json:
        write_json(a.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
