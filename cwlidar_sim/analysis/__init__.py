"""Analysis stage: measured spectra, transfer functions, theory and tensor fits (A2012 sections V-VI).

``spectra``
    Segment-averaged one-sided periodograms (:func:`segment_spectra`),
    log-binning (:func:`log_bins`, :func:`bin_average`), the measured
    transfer functions of A2012's methods 1 and 2 with their sampling
    uncertainty (:func:`transfer_functions`) and log-binned component
    spectra (:func:`component_spectra`).
``theory``
    exp(-2 |k| zR) (A2012 Eq. 9) and the misaligned-beam spectra of A2012
    Eqs. 12-14 from the Mann tensor (:func:`misaligned_spectra`).
``vad``
    The conical scan's rectified-cosine fit (:func:`fit_rectified_cosine`,
    :func:`fit_record`), CS's turbulence parameter and radial variances,
    the sonic-equivalent radial variance, period statistics with CS's
    65 % selection.
``cs_model``
    CS's filter model (Kaimal or Mann spectra, probe and scan filters):
    :func:`cs_model.std_ratio`, :func:`cs_model.radial_variance_ratio`.
``estimator_theory``
    Each Doppler estimator's expected method-2 transfer function for the
    aligned beam from a seeded ensemble of cheap line fields
    (:func:`estimator_transfer`) and its effective probe length
    (:func:`fit_zr_eff`); the probe length from measured method-2 values
    (:func:`fit_probe_length`; on a results file:
    :func:`cwlidar_sim.campaign.fit_probe_length_results`).
``fitting``
    Least-squares fit of the Mann tensor parameters to measured one-point
    spectra (:func:`fit_mann`).

Every spectrum returned here, measured or theoretical, is *one-sided* in k1
(``sigma^2 = integral of F dk1 over 0..inf``; the package's convention), so a
measured spectrum and its theory compare without any factor.

Importing this package does not import numba or scipy; they load on first use.
"""

from .estimator_theory import (
    EstimatorTransfer,
    ProbeLengthError,
    ProbeLengthFit,
    estimator_transfer,
    fit_probe_length,
    fit_zr_eff,
)
from .fitting import MannFit, fit_mann
from .spectra import (
    SegmentSpectra,
    TransferEstimate,
    bin_average,
    component_spectra,
    log_bins,
    segment_spectra,
    transfer_functions,
)
from . import cs_model
from .theory import misaligned_spectra, transfer_aligned
from .vad import VadFit, VadFlag, fit_record, fit_rectified_cosine, period_statistics, sonic_radial_variance

__all__ = [
    "log_bins",
    "bin_average",
    "SegmentSpectra",
    "segment_spectra",
    "TransferEstimate",
    "transfer_functions",
    "component_spectra",
    "transfer_aligned",
    "misaligned_spectra",
    "EstimatorTransfer",
    "estimator_transfer",
    "fit_zr_eff",
    "ProbeLengthFit",
    "ProbeLengthError",
    "fit_probe_length",
    "MannFit",
    "fit_mann",
    "VadFit", "VadFlag", "fit_rectified_cosine", "fit_record", "period_statistics", "sonic_radial_variance",
    "cs_model",
]
