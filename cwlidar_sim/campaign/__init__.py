"""Virtual campaigns: scenes in TOML, the runner, results in NetCDF, figures.

Modules, bottom to top (each imports only those above it in this list, and
the stages below the campaign layer):

``spec``, ``registry``
    Scene-spec machinery shared by every scene kind (TOML interchange, key
    checks, ``RESULTS_VERSION``); the registry of scene kinds and the
    :class:`~cwlidar_sim.campaign.registry.SceneKind` protocol, through which
    everything that depends on a scene's kind finds it (built-in kinds and
    those of the entry-point group ``cwlidar_sim.scene_kinds``, loaded by name).
``turbulence_spec``
    The ``[turbulence]`` table of every scene kind.
``conical_scene``, ``nacelle_scene``, ``scene``
    The scene files: conical (:class:`ConicalScene`), nacelle
    (:class:`NacelleScene`) and staring (:class:`Scene`); :func:`load_scene`
    reads any registered kind by ``kind``.
``planning``, ``auto``, ``folder``, ``store``, ``results_file``
    A staring period's field and tensor; the automatic fidelity choice;
    a results folder's lock, owner (manifest, ``overwrite``), orphaned
    temporaries and safe names; results on disk (checks, per-unit files,
    resume); results files a user names, checked before they are read
    (``report``, ``probe-length``, ``campaign-report``).
``staring``, ``conical_period``, ``conical``, ``nacelle``
    One unit of work of each scene kind: a staring period, a conical period
    (field, lidar, cup, sonic, VAD fits, CS's model) and the conical scene's
    units and summary, a nacelle period (REWS, preview, coherence, theory).
``runner``
    :func:`run_scene`: runs a scene's units through its kind, keeps every finished unit.
``reproduce``, ``sweep``, ``batch``, ``figures``, ``figures_cs``, ``figures_nacelle``, ``twin``
    The bundled reproductions, campaign files and their Dask runs, figures, the virtual twin.
``kinds``
    The built-in scene kinds (staring, conical, nacelle) as registry objects.
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
