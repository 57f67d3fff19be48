"""Virtual sensors: sonic and cup anemometers, staring and conically scanning cw lidars in a turbulence field.

``sonic``
    :class:`Sonic` and :func:`sample_sonic` (three components of the total
    wind at a point, Taylor advection), A2012's 32 Hz -> 10 Hz resampling
    (:func:`resample_a2012`, Eqs. 5-7, with its time stamps) and the lidar's
    50 Hz -> 10 Hz :func:`block_average`.
``base``
    :class:`LidarBase`, the fields every lidar shares (instrument, signal
    chain, probe volume and tail rule, cloud layer), and :class:`BeamSampler`,
    which samples a field along a lidar's looks for the one signal chain
    (:mod:`cwlidar_sim.signal.chain`).  A lidar sensor is geometry only.
``protocol``
    :class:`Sensor`, the protocol by which a lidar states its record's foci
    (:class:`Focus`: instrument, cells, looks, a sampling callback) and what
    it adds after the chain; :func:`measure`, the one orchestration of every
    lidar (checks, seeding, sub-cell spread, the chain); :class:`LidarRecord`,
    the one record type.
``lidar``
    :class:`StaringLidar` and :func:`measure_staring`: a fixed beam, one look
    per estimate.  The ``measure_*`` functions are the public API's thin
    wrappers of :func:`measure`, each with its sensor's way of saying when.
``conical``
    :class:`ConicalLidar` and :func:`measure_conical`: the conically scanning
    ZephIR of CS (sweep within each 20 ms dwell as looks, the spot's speed
    for the speckle, dwell or height cycle as focus groups).
``nacelle``
    :class:`NacelleLidar` and :func:`measure_nacelle`: a forward-looking
    nacelle lidar for turbine control (circular scan or fixed beams, focus
    distances in turn, yaw misalignment, platform motion and its correction,
    blade blockage).
``cup``
    :class:`Cup`: horizontal speed through a first-order response (distance constant).

A lidar states the region a box must hold (``box_region``); the box itself is
:func:`cwlidar_sim.turbulence.cover.cover_box`'s.  A whole period (field,
sensors and their analysis) is the campaign layer's:
:mod:`cwlidar_sim.campaign.periods.staring` and :mod:`cwlidar_sim.campaign.periods.conical_simulation`.

Importing this package does not import numba; kernels compile on first use.
"""

from .base import BeamSampler, LidarBase, instrument_from_spec
from .protocol import Focus, LidarRecord, RecordPlan, Sensor, measure
from .lidar import StaringLidar, measure_staring
from .conical import ConicalLidar, measure_conical
from .nacelle import NacelleLidar, measure_nacelle
from .platform import PlatformMotion
from .cup import Cup, cup_response, cup_transfer, sample_cup
from .sonic import (
    A2012_OUTPUTS,
    A2012_PARTITION,
    Sonic,
    block_average,
    nearest_node,
    project,
    resample_a2012,
    resample_a2012_times,
    sample_sonic,
)

__all__ = [
    "Sonic", "sample_sonic", "nearest_node", "project", "resample_a2012", "resample_a2012_times", "block_average",
    "A2012_PARTITION", "A2012_OUTPUTS",
    "LidarBase", "BeamSampler",
    "Sensor", "measure", "Focus", "RecordPlan", "LidarRecord",
    "StaringLidar", "measure_staring", "instrument_from_spec",
    "ConicalLidar", "measure_conical",
    "NacelleLidar", "PlatformMotion", "measure_nacelle",
    "Cup", "sample_cup", "cup_response", "cup_transfer",
]
