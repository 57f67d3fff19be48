"""Virtual campaigns: scenes in TOML, the runner, results in NetCDF, figures.

Sub-packages and modules, bottom to top (each imports only its own row and
those above it, and the stages below the campaign layer; the rows are
``SUB_LAYERS`` in tests/test_architecture.py):

``registry``, ``_labels``
    The registry of scene kinds and the
    :class:`~cwlidar_sim.campaign.registry.SceneKind` protocol, through which
    everything that depends on a scene's kind finds it (built-in kinds and
    those of the entry-point group ``cwlidar_sim.scene_kinds``, loaded by name);
    the words results and figures share.
:mod:`~cwlidar_sim.campaign.scenes`
    Scene files, parsed only: the machinery every kind shares (``spec``:
    TOML interchange, key checks, ``RESULTS_VERSION``), the ``[lidar]`` and
    ``[turbulence]`` tables, the staring (:class:`Scene`), conical
    (:class:`ConicalScene`) and nacelle (:class:`NacelleScene`) scenes;
    :func:`load_scene` (``scenes.load``) reads any registered kind by ``kind``.
:mod:`~cwlidar_sim.campaign.periods`, :mod:`~cwlidar_sim.campaign.figures`
    One unit of work of each kind (a staring period with its field planner
    and automatic settings, a conical period and the conical scene's units,
    a nacelle period) and its results; the figures of each kind's results.
:mod:`~cwlidar_sim.campaign.execution`
    :func:`run_scene` (any kind, through the registry), the store (per-unit
    files, resume), results folders and files, campaign files (sweeps) and
    their Dask runs, the bundled reproductions.
:mod:`~cwlidar_sim.campaign.twin`
    The virtual twin.
``kinds``
    The built-in scene kinds (staring, conical, nacelle) as registry objects.
``_api``
    The high-level API re-exported at the top of the package.
"""

from .execution.reproduce import bundled_scene
from .execution.runner import run_scene
from .execution.store import PreflightError, ResultsWriteError, read_results, write_results
from .periods.conical_simulation import simulate_conical_cycle, simulate_conical_period
from .periods.staring import fit_probe_length_results
from .periods.staring_field import choose_field, plan_field
from .scenes.conical import ConicalScene
from .scenes.nacelle import NacelleScene
from .scenes.load import load_scene, loads_scene
from .scenes.staring import Scene

from .._dask import WorkersLostError

__all__ = ["WorkersLostError", "Scene", "ConicalScene", "NacelleScene", "load_scene", "loads_scene", "run_scene", "read_results", "choose_field",
           "plan_field", "bundled_scene", "PreflightError", "ResultsWriteError", "write_results",
           "fit_probe_length_results", "simulate_conical_period", "simulate_conical_cycle"]
