"""One unit of work per scene kind: a period's field, sensors and analysis, and the kind's results.

:mod:`~cwlidar_sim.campaign.periods.staring` (A2012's staring lidar against a sonic; its field
planned by :mod:`~cwlidar_sim.campaign.periods.staring_field`, its ``"auto"`` settings chosen by
:mod:`~cwlidar_sim.campaign.periods.staring_auto`),
:mod:`~cwlidar_sim.campaign.periods.conical` (CS's conically scanning lidar: units of work and
results; one period's simulation in :mod:`~cwlidar_sim.campaign.periods.conical_simulation`) and
:mod:`~cwlidar_sim.campaign.periods.nacelle` (a nacelle lidar's preview of the rotor-effective wind
speed).  Imports the scenes (:mod:`cwlidar_sim.campaign.scenes`) and the stages below the campaign
layer; nothing of the runner, the figures or the twin.
"""

__all__: list = []
