"""Virtual campaigns: scenes in TOML, the runner, results in NetCDF, figures.

See :mod:`cwlidar_sim.campaign.scene` for the scene file,
:mod:`cwlidar_sim.campaign.runner` for what a run computes and
:mod:`cwlidar_sim.campaign.figures` for the figures.
"""

from .reproduce import bundled_scene
from .runner import choose_field, plan_field, run_scene
from .scene import Scene, load_scene, loads_scene
from .store import PreflightError, ResultsWriteError, read_results, write_results

__all__ = ["Scene", "load_scene", "loads_scene", "run_scene", "read_results", "choose_field", "plan_field",
           "bundled_scene", "PreflightError", "ResultsWriteError", "write_results"]
