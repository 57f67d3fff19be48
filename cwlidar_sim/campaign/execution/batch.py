"""Run a campaign's tasks on a Dask cluster, keep each as it finishes, resume, merge.

Layout of a campaign folder ``DIR``:

* ``campaign.json``: the campaign file's content and its tasks (id, values,
  replica, seed);
* ``index.json``: per task, ``done`` or ``failed`` (with the error), its wall
  time and its ``key`` (:func:`cwlidar_sim.campaign.execution.store.scene_digest`: the
  task's scene, its tensor -- given or fitted to a record --, the package and
  results versions); rewritten atomically after every task;
* ``tasks/<task_id>/<scene>.periods/``: the units (periods, or conical
  period x height) of a task in progress, each written as soon as it
  finishes, exactly as ``run`` keeps them (:class:`cwlidar_sim.campaign.execution.store.PeriodStore`);
  removed once the task's file is written;
* ``tasks/<task_id>.nc``: each finished task's results (a scene results file,
  as :func:`cwlidar_sim.campaign.run_scene` writes);
* ``campaign.nc`` and ``figures/``: written by :func:`merge_campaign`;
* ``cwlidar-run.json`` and ``.cwlidar-sim.lock``: the folder's owner (this
  campaign: a scene's or another campaign's folder is refused unless
  ``overwrite``) and the lock a run holds (:mod:`cwlidar_sim.campaign.execution.folder`).

Every unit of every task is its own Dask task, and the driver writes every
file, so workers need no shared file system.  Re-running the same command
skips the tasks whose result is on disk with the same key, reuses the stored
units of an interrupted task whose units' keys still match
(:func:`cwlidar_sim.campaign.execution.store.scene_key`), retries the failed ones and
computes the rest: nothing stale is reused (a changed ``[set]`` value, sweep
value, campaign seed, tensor or ``fit_to`` record changes the keys of what it
affects), nothing finished is computed twice.  A unit that raises fails its
task, which is recorded, and the campaign goes on.  A task whose memory
estimate (:func:`cwlidar_sim.campaign.execution.sweep.estimate_task`) exceeds a
worker's memory is refused before it starts.

Threads: each worker runs one task at a time with ``threads`` numba/FFTW
threads, and ``workers x threads`` never exceeds the cores (results are
bit-identical for any split, so this only changes speed).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import time

from ... import _config
from ..._atomic import atomic_open, atomic_path
from ..._dask import DEFAULT_WORKER_TIMEOUT, check_worker_timeout, completed, connect_scheduler
from ..._preflight import preflight
from . import folder, runner
from ..registry import kind_of
from .results_file import open_results
from ..scenes.spec import open_regular_file
from .store import write_results
from .sweep import CampaignSpec, _expand_values, estimate_task, expand

__all__ = ["run_campaign", "merge_campaign", "plan_cluster", "dry_run", "CampaignIndex"]


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _total_memory() -> float:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8e9


def plan_cluster(n_tasks: int, task_memory: float, workers=None, *, cores=None, memory=None) -> dict:
    """Workers x threads for a local cluster: every core busy, none oversubscribed, memory respected.

    Parameters
    ----------
    n_tasks : int
        Tasks to run (more workers than tasks would idle).
    task_memory : float
        Largest task's memory estimate [bytes].
    workers : int, optional
        Requested workers; default ``min(cores, n_tasks)`` capped by memory.
    cores, memory : optional
        The machine's cores and memory [bytes] (default: this machine's).

    Returns
    -------
    dict
        ``workers``, ``threads`` (per worker), ``memory_limit`` (per worker
        [bytes]) and ``why``.
    """
    cores = cores or _cores()
    memory = memory or _total_memory()
    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= 4 * cores:
            raise ValueError(f"--workers {workers!r} is out of range; allowed: 1..{4 * cores} ({cores} cores)")
        w, why = workers, f"{workers} workers as asked"
    else:
        by_mem = max(1, int(0.8 * memory // max(task_memory, 1.0)))
        w = max(1, min(cores, max(n_tasks, 1), by_mem))
        why = (f"min({cores} cores, {n_tasks} tasks, {by_mem} tasks of "
               f"{task_memory / 1e9:.2f} GB in 80 % of {memory / 1e9:.1f} GB)")
    return {"workers": w, "threads": max(1, cores // w), "memory_limit": 0.8 * memory / w, "why": why}


def dry_run(spec: CampaignSpec) -> list[dict]:
    """One row per task: id, label, estimated seconds (one worker's share of cores) and memory."""
    rows = []
    for t in expand(spec):
        est = estimate_task(t.scene)
        rows.append({"task_id": t.task_id, "label": t.label(), "values": t.values, "replica": t.replica,
                     "seed": t.seed, "periods": len(t.scene.unit_names()), "sim_hours": t.scene.simulated_hours(),
                     "est_seconds": round(est["seconds"], 1), "est_memory_gb": round(est["memory_bytes"] / 1e9, 3)})
    return rows


def _write_json(path, obj) -> None:
    """Write JSON atomically (key order kept: a sweep table's first key names its dimension)."""
    with atomic_open(path, "w") as fh:  # an unpredictable temporary name, never followed through a symlink
        json.dump(obj, fh, indent=1, default=str)


class CampaignIndex:
    """``DIR/index.json``: the state of every task, rewritten atomically on each change."""

    def __init__(self, out_dir):
        self.path = os.path.join(os.fspath(out_dir), "index.json")
        self.entries = {}
        if os.path.isfile(self.path):
            try:
                with open(self.path, encoding="utf-8") as fh:
                    entries = json.load(fh).get("tasks", {})
            except (OSError, ValueError, AttributeError):  # unreadable or not an index: every task is redone
                entries = {}
            # an entry that is not a table (a foreign or damaged index) counts as not done
            if isinstance(entries, dict):
                self.entries = {k: v for k, v in entries.items() if isinstance(v, dict)}

    def record(self, task, status, key=None, **info) -> None:
        """Record ``task`` as ``status`` ('done' or 'failed'); ``key``: the identity of its results."""
        self.entries[task.task_id] = {"status": status, "values": task.values, "replica": task.replica,
                                      "seed": task.seed, "key": key, **info}
        _write_json(self.path, {"tasks": self.entries})

    def is_done(self, task, key, result_path) -> bool:
        """Whether ``task`` is done with results of identity ``key`` whose file exists."""
        e = self.entries.get(task.task_id)
        return (e is not None and e.get("status") == "done" and key is not None and e.get("key") == key
                and os.path.isfile(result_path))


def _run_unit(scene, index, params, threads):
    """Worker side: unit ``index`` of a task's scene, in memory (the driver writes it)."""
    _config.set_num_threads(int(threads))
    return kind_of(scene).run_unit(scene, index, params)


def run_campaign(spec: CampaignSpec, out_dir, *, workers=None, scheduler=None, client=None, local=False,
                 memory_limit=None, progress=True, log=None, on_task=None, on_unit=None, overwrite=False,
                 worker_timeout: float = DEFAULT_WORKER_TIMEOUT) -> dict:
    """Run (or resume) every task of a campaign.

    Parameters
    ----------
    spec : CampaignSpec
    out_dir : str or path
        Campaign folder (created).
    workers : int, optional
        Workers of the local Dask cluster (default: :func:`plan_cluster`).
    scheduler : str, optional
        Address of an existing Dask scheduler to send the tasks to instead;
        only one you trust (its workers run what they are sent, results come
        back by pickle: see the README's Dask section).
    client : dask.distributed.Client, optional
        An existing client (takes precedence over ``scheduler``).
    local : bool
        Run the tasks here, one after the other, without Dask.
    memory_limit : float, optional
        Memory per worker [bytes] (default: the cluster's, or 80 % of the
        machine's share); tasks estimated above it are refused.
    progress : bool
        Progress bar: tasks done / total, throughput, ETA.
    log : callable, optional
        Receives one line per event.
    on_task : callable, optional
        Called as ``on_task(task, status)`` after each task is recorded (a
        hook; an exception it raises stops the campaign, what is recorded stays).
    on_unit : callable, optional
        Called as ``on_unit(task, index)`` after each unit of a task is
        computed and stored (a hook, like ``on_task``; the stored units stay).
    overwrite : bool
        When ``out_dir`` holds a scene's or another campaign's results: remove
        them and run (default: refuse before anything is computed); for the same
        campaign: remove its tasks and compute them all again.  The folder is
        locked for the whole run (a second run into it is refused, naming the
        first one's pid) and temporaries a killed run left are removed at the
        start (:mod:`cwlidar_sim.campaign.execution.folder`).
    worker_timeout : float
        With a scheduler: the longest wait for its first worker before
        anything is computed (then a PreflightError), and the longest the
        cluster may have no worker while units are pending (then
        :class:`~cwlidar_sim._dask.WorkersLostError`; what finished is kept) [s].

    Returns
    -------
    dict
        Summary: tasks, done, reused, failed (id, label, error), wall time,
        simulated hours and throughput; ``units_reused`` counts the stored
        units of interrupted tasks that were not computed again.
    """
    if not isinstance(spec, CampaignSpec):
        raise TypeError(f"spec must be a CampaignSpec, got {type(spec).__name__}")
    say = log or (lambda s: None)
    worker_timeout = check_worker_timeout(worker_timeout)
    t0 = time.perf_counter()
    tasks = expand(spec)
    out_dir = os.fspath(out_dir)
    for t in tasks:  # every file name a task derives, before anything is computed or written
        folder.check_file_names(t.scene)
    preflight(out_dir, sum(kind_of(t.scene).estimate_bytes(t.scene) for t in tasks),
              scheduler=scheduler if client is None else None)
    if scheduler is not None and client is None and not local:
        # before any task is prepared or written: the scheduler answers and has a worker (a probe, closed;
        # the run connects again below only if something is left to compute)
        connect_scheduler(scheduler, worker_timeout=worker_timeout).close()
    with folder.locked(out_dir):
        folder.clean_temporaries(out_dir, say)
        manifest = folder.claim(out_dir, spec.name, folder.CAMPAIGN, overwrite=overwrite, log=say)
        summary = _run_campaign(spec, out_dir, tasks, t0, say, workers=workers, scheduler=scheduler, client=client,
                                local=local, memory_limit=memory_limit, progress=progress, on_task=on_task,
                                on_unit=on_unit, worker_timeout=worker_timeout)
        folder.finish(out_dir, manifest, "index.json", log=say)  # an overwritten scene's results file goes now
        return summary


def _run_campaign(spec, out_dir, tasks, t0, say, *, workers, scheduler, client, local, memory_limit, progress,
                  on_task, on_unit, worker_timeout) -> dict:
    """:func:`run_campaign` once its folder is locked and claimed."""
    task_dir = os.path.join(out_dir, "tasks")
    os.makedirs(task_dir, exist_ok=True)
    _write_json(os.path.join(out_dir, "campaign.json"),
                {"campaign": spec.as_dict(), "tasks": [{"task_id": t.task_id, "values": t.values,
                                                        "replica": t.replica, "seed": t.seed} for t in tasks]})
    index = CampaignIndex(out_dir)
    path = {t.task_id: os.path.join(task_dir, f"{t.task_id}.nc") for t in tasks}
    units_dir = {t.task_id: os.path.join(task_dir, t.task_id) for t in tasks}
    failed, finished, reused = [], [], []

    def record(task, status, key=None, **info):
        index.record(task, status, key=key, **info)
        if status == "failed":
            failed.append({"task_id": task.task_id, "label": task.label(), "error": info.get("error", "")})

    # every task's scene resolved, its tensor fitted where asked, its stored units loaded: its key is known
    runs, todo = {}, []
    for t in tasks:
        try:
            runs[t.task_id] = runner.prepare_scene(t.scene, units_dir[t.task_id], check=False)
        except Exception as e:  # a task's own failure (e.g. an unreadable fit_to record) is recorded
            record(t, "failed", error=f"{type(e).__name__}: {e}")
            say(f"task {t.task_id} ({t.label()}) failed: {type(e).__name__}: {e}")
            if on_task is not None:
                on_task(t, "failed")
            continue
        if index.is_done(t, runs[t.task_id].key(), path[t.task_id]):
            reused.append(t)
        else:
            todo.append(t)
    if reused:
        say(f"{len(reused)} of {len(tasks)} tasks already done in {task_dir}; reused")
    units_reused = sum(len(runs[t.task_id].done) for t in todo)
    if units_reused:
        say(f"{units_reused} finished unit(s) of interrupted tasks reused from {task_dir}")
    est = {t.task_id: estimate_task(t.scene) for t in todo}

    cluster = plan = None
    own_client = False
    n_units = sum(len(runs[t.task_id].todo) for t in todo)
    if n_units and not local and client is None:
        from dask.distributed import Client, LocalCluster

        if scheduler is not None:
            client = connect_scheduler(scheduler, worker_timeout=worker_timeout)  # waits for a worker
        else:
            plan = plan_cluster(n_units, max(e["memory_bytes"] for e in est.values()), workers)
            say(f"local Dask cluster: {plan['workers']} workers x {plan['threads']} threads ({plan['why']})")
            cluster = LocalCluster(n_workers=plan["workers"], threads_per_worker=1, processes=True,
                                   memory_limit=memory_limit or plan["memory_limit"], dashboard_address=None)
            client = Client(cluster)
        own_client = True
    if client is not None and n_units:
        info = client.scheduler_info().get("workers", {})
        limits = [w.get("memory_limit") or math.inf for w in info.values()] or [math.inf]
        limit = memory_limit or min(limits)
        # a local cluster's workers share this machine's cores; a remote worker may run several tasks at once
        threads = plan["threads"] if cluster is not None else 1
    else:
        limit = memory_limit or 0.8 * _total_memory()
        threads = _cores()
    runnable = []
    for t in todo:
        need = est[t.task_id]["memory_bytes"]
        if need > limit:
            record(t, "failed", error=f"refused before starting: estimated {need / 1e9:.2f} GB, "
                                      f"a worker has {limit / 1e9:.2f} GB")
            say(f"task {t.task_id} ({t.label()}): refused, needs {need / 1e9:.2f} GB > {limit / 1e9:.2f} GB")
            if on_task is not None:
                on_task(t, "failed")
        else:
            runnable.append(t)

    sim_hours = 0.0
    bar = None
    if progress and runnable:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(tasks), initial=len(tasks) - len(runnable), desc=spec.name, unit="task")
    pending = {t.task_id: set(runs[t.task_id].todo) for t in runnable}
    gone = set()  # tasks finished or failed

    def report(task, error=None):
        elapsed = time.perf_counter() - t0
        rate = sim_hours / (elapsed / 3600.0) if elapsed > 0 else 0.0
        if bar is not None:
            bar.set_postfix_str(f"{rate:.1f} sim-h/wall-h, {len(failed)} failed", refresh=False)
            bar.update(1)
        else:
            n_done = len(finished) + len(failed) + len(reused)
            left = len(tasks) - n_done
            eta = elapsed / max(1, len(finished) + len(failed)) * left
            say(f"[{n_done}/{len(tasks)}] {task.task_id} {'done' if error is None else 'failed'}; "
                f"{rate:.1f} sim-h/wall-h; ETA {eta:.0f} s")
        if on_task is not None:
            on_task(task, "done" if error is None else "failed")

    def task_failed(task, error):
        gone.add(task.task_id)
        record(task, "failed", error=f"{type(error).__name__}: {error}")
        say(f"task {task.task_id} ({task.label()}) failed: {type(error).__name__}: {error}")
        report(task, error)

    def task_done(task, started):
        nonlocal sim_hours
        gone.add(task.task_id)
        run = runs[task.task_id]
        ds = run.assemble(started)
        write_results(ds, path[task.task_id])
        runner.write_side_files(ds, run.scene, path[task.task_id][:-3])  # tasks/<id>.stats.csv beside it
        hours = task.scene.simulated_hours()
        sim_hours += hours
        finished.append(task)
        record(task, "done", key=run.key(), wall_s=round(time.perf_counter() - started, 3), sim_hours=hours,
               result=os.path.relpath(path[task.task_id], out_dir))
        shutil.rmtree(units_dir[task.task_id], ignore_errors=True)  # the task's file holds every unit now
        report(task)

    def unit_done(task, i, ds, started):
        runs[task.task_id].finish(i, ds)  # stored at once, even for a task that failed meanwhile
        if on_unit is not None:
            on_unit(task, i)
        pending[task.task_id].discard(i)
        if not pending[task.task_id] and task.task_id not in gone:
            task_done(task, started)

    try:
        for t in runnable:  # interrupted after its last unit: only the assembly is left
            if not pending[t.task_id]:
                task_done(t, time.perf_counter())
        if client is not None and n_units:
            futures = {}
            for t in runnable:
                run = runs[t.task_id]
                for i in run.todo:
                    futures[client.submit(_run_unit, run.scene, i, run.params, threads, pure=False,
                                          key=f"unit-{t.task_id}-{i}")] = (t, i)
            started = time.perf_counter()
            try:
                # as dask's as_completed, but stops when the cluster has had no worker for worker_timeout s
                for fut in completed(client, futures, worker_timeout=worker_timeout, address=scheduler):
                    t, i = futures[fut]
                    try:
                        ds = fut.result()
                    except Exception as e:  # a unit's own failure fails its task; the campaign goes on
                        if t.task_id not in gone:
                            task_failed(t, e)
                        continue
                    unit_done(t, i, ds, started)
            finally:
                for fut in futures:
                    fut.cancel()
        else:
            for t in runnable:
                run, started = runs[t.task_id], time.perf_counter()
                for i in run.todo:
                    try:
                        ds = _run_unit(run.scene, i, run.params, threads)
                    except Exception as e:  # a unit's own failure fails its task; the campaign goes on
                        task_failed(t, e)
                        break
                    unit_done(t, i, ds, started)
    finally:
        if bar is not None:
            bar.close()
        if own_client:
            client.close()
        if cluster is not None:
            cluster.close()
    wall = time.perf_counter() - t0
    summary = {"campaign": spec.name, "out": out_dir, "tasks": len(tasks), "done": len(finished) + len(reused),
               "computed": len(finished), "reused": len(reused), "units_reused": units_reused, "failed": failed,
               "wall_s": round(wall, 2), "sim_hours_computed": round(sim_hours, 3),
               "throughput_sim_h_per_wall_h": round(sim_hours / (wall / 3600.0), 1) if wall > 0 else None}
    _write_json(os.path.join(out_dir, "summary.json"), summary)
    return summary


#: Largest campaign.json read [bytes]: a million tasks take about 200 MB.
_MAX_META_BYTES = 256 << 20
#: Names merge_campaign gives coordinates of its own along ``task``; a sweep dimension may not take them.
_MERGE_NAMES = ("task", "replica", "task_seed")


def _dim_names(sweep, taken=()):
    """Dimension name of each sweep group: its first key's last part; ``sweep_<part>`` if a results file uses that.

    The whole key (dots as underscores) when two groups' last parts are the
    same; ``sweep_<part>`` when the last part names a dimension of the task
    files or a coordinate of the merge itself (``taken``): a sweep over
    ``lidar.instrument.estimator`` is ``sweep_estimator`` beside the
    per-estimator theory's own ``estimator`` dimension.  A data variable of
    that name (``mean_speed``, the period's nominal speed) becomes the sweep
    coordinate, as it always did.
    """
    taken = set(taken) | set(_MERGE_NAMES)
    firsts = [next(iter(g)) for g in sweep]
    short = [k.rsplit(".", 1)[-1] for k in firsts]
    names = [s if short.count(s) == 1 else k.replace(".", "_") for s, k in zip(short, firsts)]
    return [f"sweep_{n}" if n in taken else n for n in names]


def _read_campaign_meta(out_dir) -> dict:
    """``campaign.json`` of a campaign folder, its shape checked: a ValueError names the file and the fault."""
    path = os.path.join(out_dir, "campaign.json")
    if not os.path.lexists(path):
        raise ValueError(f"{out_dir!r} is not a campaign folder (no campaign.json); run 'cwlidar-sim campaign' first")
    with open_regular_file(path, "campaign file") as fh:  # a FIFO named campaign.json is refused, not waited on
        size = os.fstat(fh.fileno()).st_size
        if size > _MAX_META_BYTES:
            raise ValueError(f"campaign file {path!r} is {size} bytes, more than {_MAX_META_BYTES}; not one of ours")
        try:
            meta = json.loads(fh.read().decode("utf-8"))
        except (OSError, ValueError) as e:  # UnicodeDecodeError is a ValueError
            raise ValueError(f"{path!r} is not a cwlidar_sim campaign file ({e})") from None
    tasks = meta.get("tasks") if isinstance(meta, dict) else None
    if not isinstance(meta, dict) or not isinstance(meta.get("campaign"), dict) or not isinstance(tasks, list):
        raise ValueError(f"{path!r} is not a cwlidar_sim campaign file: it needs a 'campaign' table and a "
                         f"'tasks' list")
    sweep = meta["campaign"].get("sweep", [])
    if not isinstance(sweep, list) or not all(isinstance(g, dict) and g for g in sweep):
        raise ValueError(f"{path!r}: 'campaign.sweep' must be a list of non-empty tables")
    for i, t in enumerate(tasks):
        ok = (isinstance(t, dict) and isinstance(t.get("task_id"), str)
              and re.fullmatch(r"[A-Za-z0-9_-]{1,64}", t["task_id"]) is not None
              and isinstance(t.get("values"), dict) and all(k in t["values"] for g in sweep for k in g)
              and "replica" in t and "seed" in t)
        if not ok:
            raise ValueError(f"{path!r}: tasks[{i}] is not a task of this campaign (it needs a task_id of "
                             f"letters and digits, the values of every sweep key, replica and seed)")
    return meta


def merge_campaign(out_dir, *, keep_series=False, band=(0.02, 0.6)):
    """All finished tasks of a campaign folder as one Dataset with the sweep dimensions as coordinates.

    Dimensions: one per sweep group (named after its first key's last part,
    ``sweep_<part>`` when the task files have a dimension of that name, e.g.
    ``sweep_estimator`` beside the per-estimator theory's ``estimator``; the
    group's other keys are coordinates along it; the names are in
    ``attrs["sweep_dims"]``), ``replica``, and the scene's own
    (``period``, ``k``, ...).  Every task file is checked before it is read
    (:func:`cwlidar_sim.campaign.execution.results_file.open_results`): a damaged or
    foreign one is a ValueError naming it.  Missing (failed) combinations are NaN.  The
    raw time series stay in the task files unless ``keep_series``.

    Added per task and period, for staring scenes: ``t2_log_error`` and
    ``t1_log_error``, the RMS of log10(T / theory) over ``band`` [rad/m]
    (method 2 against the misaligned theory chi^2/F_vs^2, method 1 against
    F_vr/F_vs), a one-number accuracy of each method.
    """
    import numpy as np
    import xarray as xr

    out_dir = os.fspath(out_dir)
    meta = _read_campaign_meta(out_dir)
    index = CampaignIndex(out_dir).entries
    sweep = meta["campaign"].get("sweep", [])
    done = []
    for t in meta["tasks"]:
        e = index.get(t["task_id"])
        if not isinstance(e, dict) or e.get("status") != "done":
            continue
        # the task's own file, whatever index.json says: a path there could point outside the folder
        path = os.path.join(out_dir, "tasks", f"{t['task_id']}.nc")
        try:
            ds = open_results(path, what="task file")
        except ValueError as err:
            raise ValueError(f"{err}; fix: delete it and run 'cwlidar-sim campaign' again to recompute that "
                             f"task") from None
        if not keep_series:  # dropped at once: only one task's series is in memory at a time
            ds = ds.drop_vars([n for n, v in ds.data_vars.items() if any(d.startswith("time_") for d in v.dims)])
            ds = ds.drop_dims([d for d in ds.dims if d.startswith("time_")])
        done.append((t, ds))
    # a sweep dimension named like one of the task files' own (e.g. 'estimator') is renamed 'sweep_<name>'
    dims = _dim_names(sweep, {d for _, ds in done for d in ds.dims})
    parts = []
    for t, ds in done:
        # transfer functions without a theory beside them (a WindScanner's): no log error
        if all(v in ds for v in ("transfer_cross", "transfer_ratio", "transfer_theory_cross", "transfer_theory_ratio")):
            k = ds.k
            inband = (k >= band[0]) & (k <= band[1])
            for m, th in (("t2", "transfer_theory_cross"), ("t1", "transfer_theory_ratio")):
                var = "transfer_cross" if m == "t2" else "transfer_ratio"
                lr = np.log10(ds[var] / ds[th]).where(inband)
                ds[f"{m}_log_error"] = np.sqrt((lr**2).mean("k", skipna=True)).assign_attrs(
                    units="1", long_name=f"RMS log10({var} / {th}) over k in {band[0]}..{band[1]} rad/m")
        ds = ds.expand_dims(task=[t["task_id"]])
        for dim, group in zip(dims, sweep):
            for key in group:
                name = dim if key == next(iter(group)) else key.replace(".", "_")
                ds = ds.assign_coords({name: ("task", [t["values"][key]])})
        ds = ds.assign_coords(replica=("task", [t["replica"]]), task_seed=("task", [t["seed"]]))
        ds.attrs = {k: v for k, v in ds.attrs.items() if k not in ("timing", "wall_time", "periods_reused", "scene")}
        parts.append(ds)
    if not parts:
        raise ValueError(f"no finished task in {out_dir!r}; see index.json")
    for p in parts:
        for name, var in p.variables.items():
            if var.dtype.kind in "US":
                p[name] = var.astype(object)
    merged = xr.concat(parts, dim="task", data_vars="minimal", coords="minimal", compat="override",
                       join="outer", combine_attrs="drop_conflicts")
    if dims:
        merged = merged.set_index(task=dims + ["replica"]).unstack("task")
    else:  # replicas only
        merged = merged.swap_dims(task="replica").drop_vars("task")
    # a zipped partner key is a function of its group's first key: one value along that dimension
    for dim, group in zip(dims, sweep):
        keys = list(group)
        vals = {k: _expand_values(k, v) for k, v in group.items()}
        for key in keys[1:]:
            lookup = dict(zip(vals[keys[0]], vals[key]))
            merged = merged.assign_coords({key.replace(".", "_"): (dim, [lookup[v] for v in merged[dim].values])})
    merged.attrs["campaign"] = json.dumps(meta["campaign"], default=str)
    merged.attrs["sweep_dims"] = json.dumps(dims)
    return merged


def sweep_figures(merged, out_dir) -> list[str]:
    """One PNG per accuracy metric and numeric sweep dimension: mean over periods and replicas +- its error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    dims = json.loads(merged.attrs.get("sweep_dims", "[]"))
    metrics = [m for m in ("t2_log_error", "t1_log_error", "std_ratio", "availability") if m in merged]
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for m in metrics:
        for dim in dims:
            other = [d for d in dims if d != dim]
            reduce = [d for d in merged[m].dims if d not in (dim, *other[:1])]
            mean = merged[m].mean(reduce, skipna=True)
            n = merged[m].notnull().sum(reduce)
            err = merged[m].std(reduce, skipna=True) / np.sqrt(n.where(n > 0))
            fig, ax = plt.subplots(figsize=(6, 4))
            x = merged[dim].values
            numeric = np.issubdtype(np.asarray(x).dtype, np.number)
            xs = x if numeric else np.arange(len(x))
            series = [(None, mean, err)] if not other else [
                (f"{other[0]} = {v}", mean.sel({other[0]: v}), err.sel({other[0]: v})) for v in merged[other[0]].values]
            for label, mu, e in series:
                ax.errorbar(xs, mu.values, yerr=e.values, marker="o", capsize=3, label=label)
            if not numeric:
                ax.set_xticks(xs, [str(v) for v in x])
            ax.set_xlabel(dim)
            ax.set_ylabel(merged[m].attrs.get("long_name", m) if len(merged[m].attrs.get("long_name", m)) < 40 else m)
            ax.set_title(f"{m} against {dim} (mean over {', '.join(reduce)} ± s.e.)", fontsize=9)
            if other:
                ax.legend(fontsize=8)
            ax.grid(alpha=0.3)
            p = os.path.join(out_dir, f"sweep_{m}_{dim}.png")
            fig.tight_layout()
            with atomic_path(p) as tmp:  # a figure on disk is whole or absent
                fig.savefig(tmp, dpi=110)
            plt.close(fig)
            paths.append(p)
    return paths
