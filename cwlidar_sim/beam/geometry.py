"""One description of a conical scan, for the sensors that scan and the theories of their estimates.

A conically scanning lidar points its beam at the fixed angle ``a``
(``half_angle_deg``) from the cone's axis and sweeps it round the axis at a
constant rate, one revolution per ``revolution_time`` [s], starting at the
azimuth ``azimuth0_deg`` at ``t = 0``: the azimuth at time ``t`` is
``azimuth0 + 360 t / revolution_time`` [deg].  With the axis ``e_a`` and
two lateral unit vectors ``e_1``, ``e_2`` (the azimuth counted from ``e_1``
toward ``e_2``), the beam direction at azimuth ``theta`` is

    n(theta) = cos a e_a + sin a (cos theta e_1 + sin theta e_2),

and a focus at distance r along the beam lies ``r cos a`` along the axis
(the measurement height, the preview distance) on a circle of radius
``r sin a``.  Two axes are in use (``axis``), in the field's frame (x along
the mean wind, y lateral, z up):

``'up'``
    A ground-based wind profiler (the ZephIR of CS,
    :class:`cwlidar_sim.sensors.ConicalLidar`): ``e_a = +z``, azimuth from
    ``e_1 = +x`` toward ``e_2 = +y``, ``n = (sin a cos theta, sin a sin
    theta, cos a)``; the focus for a measurement height z is ``z / cos a``.
``'upwind'``
    A forward-looking nacelle lidar (:class:`cwlidar_sim.sensors.NacelleLidar`,
    :func:`cwlidar_sim.analysis.rews_theory.circular_scan`) in its nacelle
    frame: ``e_a = -x``, azimuth from ``e_1 = +y`` toward ``e_2 = +z``,
    ``n = (-cos a, sin a cos theta, sin a sin theta)``.

A ``revolution_time`` of 0 is a multi-beam lidar sampling all its beams at
once (the theories' limit).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_real

__all__ = ["ConicalScanGeometry", "SCAN_AXES"]

#: Cone axes (module notes): name -> (axial component index, its sign, index of e_1, index of e_2).
SCAN_AXES = {"up": (2, 1.0, 0, 1), "upwind": (0, -1.0, 1, 2)}


@dataclasses.dataclass(frozen=True)
class ConicalScanGeometry:
    """A beam sweeping a cone round its axis at a constant rate (module notes).

    Parameters
    ----------
    half_angle_deg : float
        Angle a between the beam and the cone's axis [deg]; in [0, 90).
    axis : {'up', 'upwind'}
        The cone's axis and azimuth convention (module notes).
    revolution_time : float
        Time of one revolution [s]; >= 0 (0: all azimuths at once).
    azimuth0_deg : float
        Azimuth at t = 0 [deg], finite.
    """

    half_angle_deg: float = 30.0
    axis: str = "up"
    revolution_time: float = 1.0
    azimuth0_deg: float = 0.0

    def __post_init__(self):
        put = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        put("half_angle_deg", check_real("half_angle_deg", self.half_angle_deg, lo=0.0, hi=90.0, hi_open=True))
        check_choice("axis", self.axis, tuple(SCAN_AXES))
        put("revolution_time", check_real("revolution_time", self.revolution_time, lo=0.0))
        put("azimuth0_deg", check_real("azimuth0_deg", self.azimuth0_deg))

    @property
    def half_angle(self) -> float:
        """The half angle a [rad]."""
        return math.radians(self.half_angle_deg)

    def direction_rad(self, azimuth_rad) -> np.ndarray:
        """Unit beam directions at azimuths [rad], shape (..., 3) [-]."""
        az = np.asarray(azimuth_rad, dtype=np.float64)
        a = self.half_angle
        s, c = math.sin(a), math.cos(a)
        i_a, sign, i_1, i_2 = SCAN_AXES[self.axis]
        comp = [None, None, None]
        comp[i_a] = np.full(az.shape, sign * c)
        comp[i_1] = s * np.cos(az)
        comp[i_2] = s * np.sin(az)
        return np.stack(comp, axis=-1)

    def direction(self, azimuth_deg) -> np.ndarray:
        """Unit beam directions at azimuths [deg], shape (..., 3) [-]."""
        return self.direction_rad(np.radians(np.asarray(azimuth_deg, dtype=np.float64)))

    def azimuth_at(self, time):
        """Azimuth at time ``t`` [s], ``azimuth0 + 360 t / revolution_time`` [deg] (unwrapped)."""
        if self.revolution_time == 0.0:
            raise ValueError("azimuth_at needs revolution_time > 0 (0 samples all azimuths at once)")
        return self.azimuth0_deg + 360.0 * time / self.revolution_time

    def axial_distance(self, focus: float) -> float:
        """Distance of a focus along the axis, ``r cos a`` [m] (height, preview distance)."""
        return float(focus) * math.cos(self.half_angle)

    def focus_at(self, axial_distance: float) -> float:
        """Focus distance for a distance along the axis, ``z / cos a`` [m]."""
        return float(axial_distance) / math.cos(self.half_angle)

    def circle_diameter(self, axial_distance: float) -> float:
        """Diameter of the scanned circle at a distance along the axis, ``2 z tan a`` [m]."""
        return 2.0 * float(axial_distance) * math.tan(self.half_angle)

    def spot_speed(self, focus: float) -> float:
        """Speed of the focal spot along its circle, ``2 pi r sin a / revolution_time`` [m/s]."""
        return 2.0 * math.pi * float(focus) * math.sin(self.half_angle) / self.revolution_time
