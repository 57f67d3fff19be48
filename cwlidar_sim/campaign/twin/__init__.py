"""The virtual twin: what a lidar would have measured in periods whose records were measured.

:mod:`~cwlidar_sim.campaign.twin.run` cuts the records into periods, runs the staring twin and
drives every twin (:func:`~cwlidar_sim.campaign.twin.run.run_twin`);
:mod:`~cwlidar_sim.campaign.twin.conical` is the conical scene's twin;
:mod:`~cwlidar_sim.campaign.twin.example` the bundled example and its closed loop.
"""

__all__: list = []
