"""Doppler signal chain of a cw coherent lidar, in two stochastic tiers that must agree.

``instrument``
    :class:`Instrument` presets (:data:`PROTOTYPE_2003` of A2012,
    :data:`CS_SERIES` of CS), bin/speed/Nyquist conversions.
``spectral`` (tier 2)
    Expected Doppler spectrum of each estimate (line shape, homodyne folding,
    shot noise, RIN) and its speckle statistics; fast.
``heterodyne`` (tier 3)
    The real signal at the sampling rate, block FFTs, averaged periodograms;
    the reference for tier 2.
``processing``
    Background, thresholds, the estimator registry, quality flags.
``doppler``
    Uniform-target runs through any tier (the ``doppler`` CLI command).

The ideal tier 1 (``los``, the weighted line-of-sight average of A2012 Eq. 2)
lives in :mod:`cwlidar_sim.beam`.  Importing this package does not import
numba; kernels compile on first use.
"""

from .doppler import TIERS, simulate_uniform, uniform_report
from .heterodyne import simulate_signal_spectra, synthesize_samples
from .instrument import CS_SERIES, PRESETS, PROTOTYPE_2003, Instrument, preset
from .processing import (
    ESTIMATORS,
    FAIL_FLAGS,
    DopplerEstimates,
    Flag,
    background_spectrum,
    estimate,
    noise_floor,
    threshold_levels,
)
from .spectral import (
    cnr_linear,
    expected_spectrum,
    fejer,
    line_shape,
    line_shape_table,
    sample_spectra,
    speckle_looks,
    window_samples,
)

__all__ = [
    "Instrument", "PROTOTYPE_2003", "CS_SERIES", "PRESETS", "preset",
    "expected_spectrum", "sample_spectra", "speckle_looks", "line_shape", "line_shape_table", "fejer",
    "window_samples", "cnr_linear",
    "simulate_signal_spectra", "synthesize_samples",
    "ESTIMATORS", "Flag", "FAIL_FLAGS", "DopplerEstimates", "estimate", "background_spectrum", "noise_floor",
    "threshold_levels",
    "TIERS", "simulate_uniform", "uniform_report",
]
