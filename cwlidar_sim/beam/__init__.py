"""Beam stage: probe volume of a focused cw lidar and line-of-sight sampling of a wind field.

``optics``
    :class:`BeamOptics`, the Rayleigh length (A2012 Eq. 1), the exact and
    Lorentzian weightings along the beam (Eqs. 3, 4), their transfer functions
    (Eq. 9) and finite range-cell discretisations with the truncated tail
    weight reported.
``probe``
    :class:`ProbeVolume`: a :class:`Weighting` bound to the optics, and the
    registry :data:`WEIGHTINGS` of weightings (exact, Lorentzian, truncated
    aperture, point; a new one is one class and :func:`register_weighting`).
``cells``
    Range cells of the probe volume, their weights and the tail rule.
``aperture``
    The weighting of a beam clipped by the telescope's aperture.
``geometry``
    :class:`ConicalScanGeometry`: one description of a conical scan (half
    angle, axis, azimuths, revolution) for the sensors and the theories.
``sampling``
    Beam geometry (staring, conical scan) and sampling of box, plane or line
    fields along the beam under Taylor's frozen turbulence, point by point
    (:func:`sample_los`) or weighted over the probe volume (:func:`los_average`,
    A2012 Eq. 2).

Importing this package does not import numba; kernels compile on first use.
"""

from .cells import RangeCells, weight_truncated
from .geometry import ConicalScanGeometry
from .optics import (
    TELESCOPE_RADIUS,
    WAVELENGTH,
    BeamOptics,
    cdf_exact,
    cdf_lorentzian,
    fourier_exact,
    rayleigh_length,
    transfer_exact,
    transfer_lorentzian,
    truncated_fraction_lorentzian,
    weight_exact,
    weight_lorentzian,
)
from .probe import WEIGHTINGS, ProbeVolume, Weighting, get_weighting, register_weighting
from .sampling import (
    ConicalScan,
    LosAverage,
    conical_scan,
    direction_from_angles,
    los_average,
    sample_los,
    staring_direction,
)

__all__ = [
    "WAVELENGTH",
    "TELESCOPE_RADIUS",
    "BeamOptics",
    "RangeCells",
    "rayleigh_length",
    "weight_exact",
    "weight_lorentzian",
    "cdf_exact",
    "cdf_lorentzian",
    "truncated_fraction_lorentzian",
    "transfer_lorentzian",
    "fourier_exact",
    "transfer_exact",
    "weight_truncated",
    "Weighting",
    "ProbeVolume",
    "WEIGHTINGS",
    "register_weighting",
    "get_weighting",
    "ConicalScanGeometry",
    "direction_from_angles",
    "staring_direction",
    "ConicalScan",
    "conical_scan",
    "sample_los",
    "LosAverage",
    "los_average",
]
