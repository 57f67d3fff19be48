"""Words the results and figures share: sign conventions, wind-direction conventions, durations.

Line-of-sight sign
------------------
The package's line-of-sight speed is ``n . (U + u, v, w)`` with ``n`` the
beam's unit vector pointing *away* from the lidar: positive away from the
lidar (:mod:`cwlidar_sim.beam`, :mod:`cwlidar_sim.sensors`,
:mod:`cwlidar_sim.signal`, ``cwlidar-sim doppler --speed``).  A homodyne cw
lidar measures its magnitude only.  A staring campaign's results
(:mod:`cwlidar_sim.campaign.periods.staring`, the virtual twin) report the speed
*toward* the lidar, ``-n . (U + u, v, w)``, positive for a lidar looking into
the wind, so that the lidar's magnitude, its ideal and the sonic compare with
no sign flip; each such variable says so in its ``sign_convention``
attribute (:data:`TOWARD_LIDAR`, :data:`HOMODYNE`).

Wind direction
--------------
A conical scene's lidar frame is east-north-up: x (the scan's azimuth 0) is
east, y (azimuth 90 deg) is north, z up; its azimuths run counter-clockwise
seen from above.  ``wind_direction_deg`` and the results' ``*_direction`` are
the direction the wind blows *toward*, counter-clockwise from x; the
meteorological direction (where the wind comes *from*, clockwise from north)
is ``(270 - toward) mod 360`` (:func:`wind_from_toward`, its own inverse).
"""

from __future__ import annotations

import json

import numpy as np

#: ``sign_convention`` of a series of the speed toward the lidar.
TOWARD_LIDAR = ("positive toward the lidar: -n . (U + u, v, w), n the beam's unit vector pointing away from the "
                "lidar (the package's line-of-sight speed n . u is positive away); a lidar looking into the wind "
                "reads +U cos(misalignment)")
#: ``sign_convention`` of a homodyne lidar's speed estimates.
HOMODYNE = ("the magnitude |n . (U + u, v, w)| a homodyne lidar measures, >= 0, no sign: for a lidar looking into "
            "the wind, the speed toward the lidar")
#: ``wind_direction_convention`` of a conical scene's results.
WIND_DIRECTION_CONVENTION = (
    "lidar frame east-north-up: x (scan azimuth 0) east, y (azimuth 90 deg) north, z up. *_direction (and the "
    "scene's wind_direction_deg): where the wind blows toward, degrees counter-clockwise from x, in [-180, 180); "
    "*_wind_from (and the scene's wind_from_deg): meteorological, where the wind comes from, degrees clockwise "
    "from north, in [0, 360); from = (270 - toward) mod 360")


def wind_from_toward(degrees):
    """The meteorological direction of a direction toward, or back: ``(270 - degrees) mod 360`` [deg].

    Toward: counter-clockwise from the lidar frame's x (east); from:
    clockwise from its y (north).  A float for a float, an array for an array.
    """
    out = np.mod(270.0 - np.asarray(degrees, dtype=np.float64), 360.0)
    return float(out) if out.ndim == 0 else out


def duration_phrase(seconds: float) -> str:
    """'10-min' for 600 s (A2012's and CS's records), else the seconds, e.g. '120-s'."""
    seconds = float(seconds)
    return "10-min" if seconds == 600.0 else f"{seconds:g}-s"


def _scene(ds) -> dict:
    try:
        return json.loads(ds.attrs.get("scene", "{}"))
    except (TypeError, ValueError):
        return {}


def period_durations(ds) -> list:
    """The scene's period lengths [s] (each ``[[period]]``'s own, else the scene's ``duration``)."""
    d = _scene(ds)
    default = d.get("duration")
    out = [p.get("duration", default) for p in d.get("period", [])]
    return [float(x) for x in out if x is not None]


def periods_phrase(ds) -> str:
    """'10-min', '120-s', ... when every period of the results lasts the same; 'period' otherwise."""
    durations = set(period_durations(ds))
    return duration_phrase(durations.pop()) if len(durations) == 1 else "period"


def segment_phrase(ds) -> str:
    """'10-min segments', '300-s segments': a staring scene's ``analysis.segment_duration``."""
    seg = _scene(ds).get("analysis", {}).get("segment_duration")
    return "segments" if seg is None else f"{duration_phrase(seg)} segments"


#: The CF conventions the results files follow (global ``Conventions``): CF-1.10 (2022) is the newest version whose
#: standard-name table (v79+) holds every name used here and that xarray's time encoding writes without caveat.
CF_CONVENTIONS = "CF-1.10"
#: CF ``standard_name`` (and ``cell_methods`` where the value is a period's statistic) of results variables, by
#: name; added where a variable lacks one, never changing its values, units or other attributes.  Only quantities
#: that are what the CF name says: the conical scene's directions *toward* (counter-clockwise from east) have no
#: CF name, their meteorological copies ``*_wind_from_unit`` are ``wind_from_direction``; a staring scene's
#: speeds along the beam (toward the lidar, or the homodyne magnitude) are not CF's
#: ``radial_velocity_of_scatterers_away_from_instrument``; the sonic's (u, v, w) are in the mean wind's frame,
#: not east-north-up, so they are not ``eastward_wind`` / ``northward_wind``.
CF_STANDARD_NAMES = {
    "height": ("height", None),
    "unit_height": ("height", None),
    "in_situ_height_unit": ("height", None),
    "mean_speed": ("wind_speed", "time: mean"),
    "mean_speed_unit": ("wind_speed", "time: mean"),
    "cup_mean_unit": ("wind_speed", "time: mean"),
    "cup_std_unit": ("wind_speed", "time: standard_deviation"),
    "sonic_std_unit": ("wind_speed", "time: standard_deviation"),
    "lidar_mean_unit": ("wind_speed", "time: mean"),
    "lidar_std_unit": ("wind_speed", "time: standard_deviation"),
    "lidar_wind_from_unit": ("wind_from_direction", "time: mean"),
    "sonic_wind_from_unit": ("wind_from_direction", "time: mean"),
    "preview_rews": ("wind_speed", None),
    "preview_estimate": ("wind_speed", None),
}
#: The instant a results file's ``time`` coordinate counts from, when its scene names ``start_time``.
CF_TIME_UNITS = "seconds since 1970-01-01 00:00:00"
