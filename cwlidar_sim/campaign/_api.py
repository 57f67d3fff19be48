"""The high-level API, re-exported at the top of the package: open a scene, change it, run it, read results.

``cwlidar_sim.open_scene``, ``cwlidar_sim.run`` and ``cwlidar_sim.open_results``
are these functions; a scene's dotted keys change with its own
:meth:`~cwlidar_sim.campaign.scenes.spec.SceneSpec.with_values`.  Each is a thin
front to the campaign layer: the scene loader and the bundled scenes
(:mod:`cwlidar_sim.campaign.scenes.staring`, :mod:`cwlidar_sim.campaign.execution.reproduce`), the
runner and its results-folder rules (:func:`cwlidar_sim.campaign.run_scene`,
:mod:`cwlidar_sim.campaign.execution.folder`) and the checked reader of results files
(:mod:`cwlidar_sim.campaign.execution.results_file`), so a scene run here and by
``cwlidar-sim run`` gives the same files and the same bits.
"""

from __future__ import annotations

import os

from .._bundled import bundled_or_path
from .._dask import DEFAULT_WORKER_TIMEOUT
from .._validation import check_bool
from .execution import folder, results_file
from .execution.reproduce import BUNDLED, bundled_scene
from .execution.runner import run_scene
from .scenes.load import load_scene
from .scenes.spec import SceneSpec, select_periods

__all__ = ["open_scene", "run", "open_results"]


def open_scene(scene, *, periods=None, quick: bool = False):
    """A scene, from a bundled name or a scene file (TOML), validated.

    Parameters
    ----------
    scene : str or path
        A bundled scene's name (``"a2012"``, ``"cs"``, ``"nacelle"``; ``cwlidar-sim
        scenes`` lists them) or the path of a scene file.  A file of that name
        in the working folder is taken before a bundled scene.
    periods : list of str, optional
        Keep only these periods (by name, in the scene's order).  The periods
        kept are numbered afresh: one without its own ``seed`` draws another
        turbulence realisation than in the whole scene.
    quick : bool
        A bundled scene's quick mode (``cwlidar-sim reproduce --quick``: shorter
        periods or fewer units, same physics, see
        :mod:`cwlidar_sim.campaign.execution.reproduce`); a scene file has none.

    Returns
    -------
    Scene, ConicalScene or NacelleScene
        By the file's ``kind``.  Change it with ``scene.with_values({...})``
        (dotted keys), run it with :func:`cwlidar_sim.run`.

    Raises
    ------
    ValueError
        Neither a file nor a bundled name (the bundled names are listed), a
        scene file's mistake (named by key), an unknown period, or ``quick``
        for a scene file.
    """
    if isinstance(scene, SceneSpec):
        raise TypeError("scene is already a scene; open_scene takes a bundled name or a scene file's path")
    quick = check_bool("quick", quick)
    name = os.fspath(scene)
    path = bundled_or_path(name, "scene")
    if path != name and name in BUNDLED:
        out = bundled_scene(name, quick=quick)
    elif quick:
        raise ValueError(f"quick=True applies to the bundled scenes {sorted(BUNDLED)}, not to the scene file "
                         f"{path!r}; shorten a file's scene with scene.with_values({{'duration': ...}})")
    else:
        out = load_scene(path)
    return out if periods is None else select_periods(out, periods)


def run(scene, out=None, *, overwrite: bool = False, progress: bool = True, client=None, log=None,
        worker_timeout: float = DEFAULT_WORKER_TIMEOUT):
    """Run a scene and return its results; with ``out``, keep them in that folder.

    The same run as ``cwlidar-sim run SCENE --out OUT`` (without figures):
    every unit (period) is computed here, one after the other, or on a Dask
    cluster, and with ``out`` written as it finishes, so an interrupted run
    resumes where it stopped and a second call with the same scene reads
    the results back instead of computing them.

    Parameters
    ----------
    scene : Scene, ConicalScene, NacelleScene or str
        A scene (:func:`open_scene`), or a bundled name or scene file opened
        by :func:`open_scene`.
    out : str or path, optional
        Results folder: ``<scene name>.nc`` and the per-period files
        ``<scene name>.periods/`` (created).  The folder's rules (one run at a
        time, one scene per folder unless ``overwrite``, see
        :mod:`cwlidar_sim.campaign.execution.folder`) apply.  None: nothing is written.
    overwrite : bool
        ``out`` holds another scene's results: remove them and run (default:
        refuse before computing).
    progress : bool
        A progress bar over the periods.
    client : dask.distributed.Client, optional
        Run the periods on this cluster (a trusted one: see the README's Dask
        section); same bits as a run here.
    log : callable, optional
        Receives one line per decision (field kind and why, files written).
    worker_timeout : float
        With ``client``: the longest the cluster may have no worker [s].

    Returns
    -------
    xarray.Dataset
        The results on dimension ``period`` (a staring scene's transfer
        functions on ``k``: ``transfer_ratio`` (A2012's method 1),
        ``transfer_cross`` (method 2), ``transfer_theory`` (exp(-2 k zR)); the
        variables' ``long_name`` and ``units`` say what each is).

    Raises
    ------
    PreflightError
        Before anything is computed: ``out`` cannot take the results, another
        run holds it, or it holds another scene's results (no ``overwrite``).
    """
    if not isinstance(scene, SceneSpec):
        scene = open_scene(scene)
    return run_scene(scene, out, client=client, progress=check_bool("progress", progress), log=log,
                     overwrite=check_bool("overwrite", overwrite), worker_timeout=worker_timeout)


def open_results(path):
    """A run's results, loaded into memory after every check, from its folder or its file.

    Parameters
    ----------
    path : str or path
        A results folder written by :func:`run` or ``cwlidar-sim run --out``
        (its results file is the one its manifest names), or a results file
        (``<scene name>.nc``).

    Returns
    -------
    xarray.Dataset

    Raises
    ------
    ValueError
        One line naming the path: a folder without finished results, or a
        file that is not a cwlidar_sim results file (empty, truncated,
        another program's: :func:`cwlidar_sim.campaign.execution.results_file.open_results`).
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        manifest = folder.read_manifest(path) or {}
        name = manifest.get("results")
        if not isinstance(name, str) or not name or os.sep in name:
            raise ValueError(f"results folder {path!r} holds no finished results (its run has not ended, or it "
                             f"is not a results folder: no '{folder.MANIFEST_NAME}' naming a results file)")
        path = os.path.join(path, name)
    return results_file.open_results(path)
