"""The fields every lidar shares, declared once.

:class:`LidarFields` holds them with their defaults, in the order of a
scene's ``[lidar]`` table: the signal chain's (its settings,
:class:`cwlidar_sim.signal.chain.ChainSettings`, which takes its defaults
from here), the probe volume's and a cloud layer's.  The sensors
(:class:`cwlidar_sim.sensors.LidarBase`, which documents and validates every
field) and the scenes' ``[lidar]`` tables
(:class:`cwlidar_sim.campaign.scenes.lidar_spec.LidarSpecBase`) derive from it, so a
field is added, renamed or given another default in one place.  A sensor or
a scene kind may still give a field its own default by declaring it again
(the scanning lidars' span and speckle, the scenes' ``cell_length`` that
defaults to the field's spacing); those are listed in their docstrings.

This module imports nothing but :mod:`dataclasses`: the scene parser reads it
without loading a numerical library.
"""

from __future__ import annotations

import dataclasses

__all__ = ["LidarFields", "LIDAR_KEYS"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class LidarFields:
    """Every lidar's shared fields and their defaults (module notes; documented by :class:`cwlidar_sim.sensors.LidarBase`)."""

    tier: str = "spectral"
    cnr_db: float = -10.0
    cnr_variation_db: float = 0.0
    cnr_time_scale: float = 600.0
    weighting: str = "exact"
    span: float = 20.0
    cell_length: float = 0.5
    cell_growth: float = 0.0
    tail: str = "mean_wind"
    transverse_speed: float | None = None
    speckle: str = "continuum"
    subcell_spread: float | None = None
    exact_background: bool = False
    background_pause: bool = False
    line_broadening: float = 0.0
    cloud_base: float | None = None
    cloud_strength: float = 0.0
    cloud_depth: float = 30.0
    cloud_speed: float | None = None
    cloud_direction_deg: float = 0.0


#: The shared fields' names, in order (a scene's ``[lidar]`` keys that are sensor fields).
LIDAR_KEYS = tuple(f.name for f in dataclasses.fields(LidarFields))
