"""Run a scene: dispatch its units by scene kind, keep every finished unit, assemble the results.

The runner is sensor-agnostic: it asks the scene's kind
(:func:`cwlidar_sim.campaign.registry.kind_of`) for everything -- its unit
task (``run_unit``: one period of a staring or a nacelle scene, one
(period, height) or one cycling period of a conical scene, one unit of a
plugin kind), which turns one unit into an xarray.Dataset on ``period``, its
automatic settings (``resolve``), its shared tensor (``scene_params``), its
size estimate and its finishing step (``summarise``).  The runner
resolves the scene's automatic settings, checks before computing that the
results can be written (:func:`cwlidar_sim.campaign.execution.store.preflight`), reuses
the units an earlier run finished, runs the others here or on a Dask cluster,
writes each as it finishes (:class:`~cwlidar_sim.campaign.execution.store.PeriodStore`)
and assembles the scene's file from the unit files.  :func:`prepare_scene` and
:class:`SceneRun` are those steps one by one, for drivers that schedule the
units themselves (the campaign's :mod:`cwlidar_sim.campaign.execution.batch`).

Each unit is independent and seeded from the scene (see
:meth:`~cwlidar_sim.campaign.Scene.unit_seed`), so a scene gives the same bits whether its units
run one after the other here, on the workers of a Dask cluster, or across an
interrupted run and its resumption.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time

from ..._dask import DEFAULT_WORKER_TIMEOUT, check_worker_timeout, completed
from . import folder
from ..registry import kind_of, side_files_of
from ..scenes.spec import SceneSpec
from ..scenes.start_time import start_datetime
from .cf import annotate
from .store import PeriodStore, combine_periods, preflight, scene_digest, write_results
from .tidy import write_statistics

__all__ = ["run_scene", "SceneRun", "prepare_scene", "write_side_files"]


@dataclasses.dataclass
class SceneRun:
    """A scene ready to compute (:func:`prepare_scene`): what is reused, what is left, where it goes.

    Attributes
    ----------
    scene : scene of a registered kind
        The scene with its automatic settings resolved.
    params : MannParameters or None
        The tensor shared by the units (a staring scene's, given or fitted); None where each unit has its own.
    fit_info : dict or None
        The fit's summary for ``turbulence.fit_to``.
    auto_why : dict
        Each automatic setting's choice and why.
    store : PeriodStore or None
        The unit files (None: nothing is written).
    names : list of str
        The units' names.
    done : dict
        Unit index -> its Dataset (reused, or finished by this run).
    reused : list of str
        Names of the units taken from disk.
    task, finalise : callable
        The scene kind's unit task (``run_unit``) and finishing step (``summarise``).
    """

    scene: object
    params: object
    fit_info: dict | None
    auto_why: dict
    store: PeriodStore | None
    names: list
    done: dict
    reused: list
    task: object
    finalise: object

    @property
    def todo(self) -> list:
        """Indices of the units still to compute, in run order."""
        return [i for i in range(len(self.names)) if i not in self.done]

    def key(self) -> str:
        """Identity of the whole scene's results (:func:`cwlidar_sim.campaign.execution.store.scene_digest`)."""
        return scene_digest(self.scene, self.params)

    def finish(self, index: int, ds, log=None):
        """Keep unit ``index``'s Dataset: written to the store (and read back) first, if there is one."""
        if self.store is not None:
            ds = self.store.save(index, ds)
            if log is not None:
                log(f"period {self.names[index]}: written to {self.store.path(index)}")
        self.done[index] = ds
        return ds

    def assemble(self, t0: float):
        """The scene's results from every unit (all must be done), with the run's and CF's attributes.

        CF attributes and, when the scene names ``start_time``, the absolute ``time`` axis:
        :func:`cwlidar_sim.campaign.execution.cf.annotate`.
        """
        ds = annotate(self.finalise(combine_periods([self.done[i] for i in range(len(self.names))])),
                      start_datetime(self.scene))
        ds.attrs["wall_time"] = float(time.perf_counter() - t0)
        ds.attrs["periods_reused"] = json.dumps(self.reused)
        ds.attrs["auto_choice"] = json.dumps(self.auto_why)
        if self.fit_info is not None:
            ds.attrs["turbulence_fit"] = json.dumps(self.fit_info)
        return ds


def prepare_scene(scene, out_dir=None, *, log=None, check: bool = True) -> SceneRun:
    """Resolve a scene's automatic settings and tensor, check the output, load the finished units.

    Parameters
    ----------
    scene : scene of a registered kind
    out_dir : str or path, optional
        Folder of the unit files ``<scene.name>.periods/`` (None: none).
    log : callable, optional
        Receives one line per decision.
    check : bool
        Run :func:`~cwlidar_sim.campaign.execution.store.preflight` on ``out_dir``
        (a caller that checked the whole output already passes False).
    """
    say = log or (lambda s: None)
    kind = kind_of(scene)
    start_datetime(scene)  # a scene built in code: its start_time checked before anything is computed
    scene, auto_why = kind.resolve(scene)  # e.g. a staring "auto" tier: the cheapest sufficient setting
    for key, why in auto_why.items():
        say(f"{key} = {why}")
    if check:
        preflight(out_dir, kind.estimate_bytes(scene))
    params, fit_info = kind.scene_params(scene, say)
    names = scene.unit_names()
    st = PeriodStore(out_dir, scene, params) if out_dir is not None else None
    done = {}
    if st is not None:
        for i, name in enumerate(names):
            ds = st.load(i)
            if ds is not None:
                done[i] = ds
                say(f"period {name}: reused {st.path(i)}")
    return SceneRun(scene=scene, params=params, fit_info=fit_info, auto_why=auto_why, store=st, names=names,
                    done=done, reused=[names[i] for i in sorted(done)], task=kind.run_unit,
                    finalise=kind.summarise)


def run_scene(scene: SceneSpec, out_dir=None, *, client=None, progress: bool = True, log=None, on_period=None,
              overwrite: bool = False, worker_timeout: float = DEFAULT_WORKER_TIMEOUT):
    """Run every period of a scene, keep each as it finishes, and assemble the results.

    Parameters
    ----------
    scene : scene of a registered kind
        A staring or a nacelle scene (its units are its periods), a conical
        one (its units are period x height, :mod:`cwlidar_sim.campaign.periods.conical`),
        or a plugin kind's (:mod:`cwlidar_sim.campaign.registry`).
    out_dir : str or path, optional
        Folder for ``<scene.name>.nc`` and the per-period files
        ``<scene.name>.periods/*.nc`` (created); None: write nothing.  Periods
        already stored there for the same scene are reused, not computed.
    client : dask.distributed.Client, optional
        Run the periods on this cluster (one task per period); default: here,
        one after the other.  The results are identical bit for bit.  Use
        only a cluster you trust: its workers run what they are sent, and
        results come back by pickle (see the README's Dask section).
    progress : bool
        Show a progress bar (tqdm) over the periods.
    log : callable, optional
        Receives one line per decision (field kind and why, periods reused,
        files written).
    on_period : callable, optional
        Called as ``on_period(index, dataset)`` after each period is computed
        and stored (a progress hook; an exception it raises stops the run, the
        stored periods stay).
    overwrite : bool
        When ``out_dir`` holds another scene's (or a campaign's) results: remove
        them and run (default: refuse, :class:`PreflightError`); for the same
        scene: compute every period afresh.  See :mod:`cwlidar_sim.campaign.execution.folder`.
    worker_timeout : float
        With ``client``: the longest the cluster may have no worker while
        periods are pending [s]; then :class:`~cwlidar_sim._dask.WorkersLostError`
        (the finished periods stay, a rerun resumes).

    Returns
    -------
    xarray.Dataset
        The periods joined along ``period`` (:func:`~cwlidar_sim.campaign.execution.store.combine_periods`);
        ``attrs["periods_reused"]`` lists the periods taken from disk.

    Raises
    ------
    PreflightError
        Before anything is computed, when the results could not be written, when
        another run holds ``out_dir`` (its lock), or when ``out_dir`` holds another
        scene's results and not ``overwrite``.
    ValueError
        Before anything is computed, when a scene or period name cannot name a file.
    ResultsWriteError
        When writing a finished period fails (the periods written before stay).
    WorkersLostError
        When the cluster has had no worker for ``worker_timeout`` seconds.
    """
    say = log or (lambda s: None)
    worker_timeout = check_worker_timeout(worker_timeout)
    if out_dir is None:
        return _run_scene(scene, None, client, progress, say, on_period, None, worker_timeout)
    folder.check_file_names(scene)
    preflight(out_dir)  # writable, engine: before the folder is locked and claimed (the disk: once resolved)
    with folder.locked(out_dir):
        folder.clean_temporaries(out_dir, say)
        manifest = folder.claim(out_dir, scene.name, scene.kind, overwrite=overwrite, log=say)
        return _run_scene(scene, out_dir, client, progress, say, on_period, manifest, worker_timeout)


def _run_scene(scene, out_dir, client, progress, say, on_period, manifest, worker_timeout):
    """:func:`run_scene` once the folder is locked and claimed (``manifest``; None: nothing written)."""
    t0 = time.perf_counter()
    run = prepare_scene(scene, out_dir, log=say)
    if run.store is not None:
        folder.settle(out_dir, manifest, run.key(), run.store.folder,
                      [os.path.basename(run.store.path(i)) for i in range(len(run.names))], log=say)
    scene, names, todo = run.scene, run.names, run.todo

    def finish(i, ds):
        ds = run.finish(i, ds, say)
        if on_period is not None:
            on_period(i, ds)

    if client is not None and todo:
        futures = {client.submit(run.task, scene, i, run.params, pure=False): i for i in todo}
        try:
            # as dask's as_completed, but stops when the cluster has had no worker for worker_timeout s
            for fut in completed(client, futures, worker_timeout=worker_timeout):
                finish(futures[fut], fut.result())
        finally:
            for fut in futures:
                fut.cancel()
    elif todo:
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(names), initial=len(run.done), desc=scene.name, unit="period")
        try:
            for i in todo:
                status = (lambda s, b=bar: b.set_postfix_str(s, refresh=True)) if bar is not None else None
                finish(i, run.task(scene, i, run.params, status=status))
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    ds = run.assemble(t0)
    if run.store is not None:
        path = os.path.join(os.fspath(out_dir), f"{scene.name}.nc")
        write_results(ds, path)
        folder.finish(out_dir, manifest, os.path.basename(path), log=say)
        say(f"results written to {path}")
        side = write_side_files(ds, scene, path[:-3])
        folder.record_files(out_dir, side)  # the manifest's files of this run: an overwrite removes them
        for p in side:
            say(f"written {p}")
    return ds


def write_side_files(ds, scene, stem) -> list:
    """Beside the results file ``<stem>.nc``: the tidy statistics table and the scene kind's own files; their paths.

    :func:`cwlidar_sim.campaign.execution.tidy.write_statistics` (``<stem>.stats.csv``, ``.parquet``)
    and :meth:`~cwlidar_sim.campaign.registry.SceneKind.side_files` (a nacelle scene's preview signal),
    each written atomically.
    """
    kind = kind_of(scene)
    return write_statistics(ds, kind, stem) + side_files_of(kind, ds, stem)
