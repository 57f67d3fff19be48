"""Running scenes and campaigns: the runner, sweeps, Dask batches, the store, results folders and files.

:mod:`~cwlidar_sim.campaign.execution.runner` runs a scene of any kind through the registry;
:mod:`~cwlidar_sim.campaign.execution.store` keeps each finished unit and the results file;
:mod:`~cwlidar_sim.campaign.execution.folder` the rules of a results folder (one run at a time);
:mod:`~cwlidar_sim.campaign.execution.results_file` checks results files before opening them;
:mod:`~cwlidar_sim.campaign.execution.sweep` expands a campaign file into tasks and
:mod:`~cwlidar_sim.campaign.execution.batch` runs them on a Dask cluster;
:mod:`~cwlidar_sim.campaign.execution.reproduce` the bundled scenes and their quick mode.
"""

__all__: list = []
