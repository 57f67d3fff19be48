"""Doppler signal chain of a cw coherent lidar: one chain that every sensor feeds, in three tiers.

``chain``
    :func:`run_chain`, the one entry point: a sensor's line-of-sight speeds
    of every estimate's looks and cells (plus a cloud) in, speeds, flags,
    processing variants and diagnostics out, through any tier, with every
    instrument effect (speckle models, noise, background, CNR variation,
    clouds, thresholds, estimators).

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
``exact``
    Tier 2's expected spectrum by the exact lag sum.
``noise``
    The noise floor: shot noise, relative-intensity noise, the 0 Hz reflection.
``doppler``
    Uniform-target runs through the chain (the ``doppler`` CLI command).

The ideal tier 1 (``los``, the weighted line-of-sight average of A2012 Eq. 2)
lives in :mod:`cwlidar_sim.beam`.  Importing this package does not import
numba; kernels compile on first use.
"""

from .chain import (
    CNR_DB_RANGE,
    SIGNAL_MAX_ESTIMATES,
    SPECKLE_MODELS,
    TIERS,
    VARIANT_KEYS,
    ChainRecord,
    ChainSettings,
    FocusGroup,
    homodyne_flags,
    run_chain,
)
from .doppler import simulate_uniform, uniform_report
from .exact import expected_spectrum_exact
from .noise import noise_correlation, noise_floor
from .heterodyne import simulate_signal_spectra, synthesize_samples
from .instrument import CS_SERIES, PRESETS, PROTOTYPE_2003, Instrument, preset
from .processing import (
    ESTIMATORS,
    FAIL_FLAGS,
    DopplerEstimates,
    Flag,
    background_spectrum,
    estimate,
    estimate_variants,
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
    "ESTIMATORS", "Flag", "FAIL_FLAGS", "DopplerEstimates", "estimate", "estimate_variants", "background_spectrum", "noise_floor",
    "threshold_levels",
    "TIERS", "simulate_uniform", "uniform_report",
    "run_chain", "ChainSettings", "FocusGroup", "ChainRecord", "homodyne_flags", "SPECKLE_MODELS", "VARIANT_KEYS",
    "SIGNAL_MAX_ESTIMATES", "CNR_DB_RANGE", "expected_spectrum_exact", "noise_correlation",
]
