"""Scene files, parsed: one frozen, validated dataclass per table, unknown keys refused by name.

Parsing only: this sub-package imports nothing of the campaign layer but the
registry (:mod:`cwlidar_sim.campaign.registry`) and the shared words
(``campaign._labels``).  :mod:`~cwlidar_sim.campaign.scenes.spec` is the machinery every
kind shares (TOML interchange, key checks, ``RESULTS_VERSION``);
:mod:`~cwlidar_sim.campaign.scenes.lidar_spec` and
:mod:`~cwlidar_sim.campaign.scenes.turbulence_spec` the ``[lidar]`` and
``[turbulence]`` tables of every kind; :mod:`~cwlidar_sim.campaign.scenes.staring`,
:mod:`~cwlidar_sim.campaign.scenes.conical` and :mod:`~cwlidar_sim.campaign.scenes.nacelle`
the three built-in kinds' scenes.  How a scene is run is in
:mod:`cwlidar_sim.campaign.periods`.
"""

__all__: list = []
