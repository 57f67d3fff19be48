"""Beam stage: probe volume of a focused cw lidar and line-of-sight sampling of a wind field.

``optics``
    :class:`BeamOptics`, the Rayleigh length (A2012 Eq. 1), the exact and
    Lorentzian weightings along the beam (Eqs. 3, 4), their transfer functions
    (Eq. 9) and finite range-cell discretisations with the truncated tail
    weight reported.
``sampling``
    Beam geometry (staring, conical scan) and sampling of box, plane or line
    fields along the beam under Taylor's frozen turbulence, point by point
    (:func:`sample_los`) or weighted over the probe volume (:func:`los_average`,
    A2012 Eq. 2).

Importing this package does not import numba; kernels compile on first use.
"""

from .optics import (
    TELESCOPE_RADIUS,
    WAVELENGTH,
    BeamOptics,
    RangeCells,
    cdf_exact,
    cdf_lorentzian,
    fourier_exact,
    rayleigh_length,
    transfer_exact,
    transfer_lorentzian,
    truncated_fraction_lorentzian,
    weight_exact,
    weight_lorentzian,
    weight_truncated,
)
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
    "direction_from_angles",
    "staring_direction",
    "ConicalScan",
    "conical_scan",
    "sample_los",
    "LosAverage",
    "los_average",
]
