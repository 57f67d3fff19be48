"""Segment-averaged spectra, log-binning and measured spectral transfer functions.

The spectral analysis of A2012 (section V): the series is cut into
consecutive 10-min segments, each segment's mean is removed, the squared
modulus of its (unwindowed) Fourier transform is averaged over the segments
of the hour, the result is averaged in logarithmically spaced bins and
converted to wavenumber with Taylor's hypothesis ``k = 2 pi f / U``.

Conventions
-----------
* Frequency spectra ``S(f)`` are *one-sided* in f [Hz], defined on the
  positive frequencies ``f_j = j / T``, ``j = 1 .. n // 2`` (T the segment
  duration, n its number of samples; f = 0 is excluded), normalised so that
  ``sum_j S(f_j) df`` with ``df = 1 / T`` is the variance of the detrended
  segment (Parseval; the value at the Nyquist frequency of an even n is not
  doubled).  Cross-spectra ``C_xy(f) = E[X(f) Y(f)^*]`` (x first, y
  conjugated) have the same normalisation and ``Re sum_j C_xy df`` is the
  covariance.
* Wavenumber spectra ``F(k)`` are *one-sided* in k [rad/m] with
  ``F(k) = S(f) U / (2 pi)`` at ``k = 2 pi f / U``, so that
  ``integral of F dk = integral of S df``: the convention of the package's
  analytic spectra too (:func:`cwlidar_sim.turbulence.one_point_spectra`,
  :func:`cwlidar_sim.analysis.misaligned_spectra`), which the measured ones
  estimate without any factor.

scipy.signal
------------
Without gaps, :func:`segment_spectra` is ``scipy.signal.welch`` and
``scipy.signal.csd`` (``nperseg = n_per``, ``noverlap = 0``, window
``"boxcar"`` or ``"hann"``, ``detrend = "constant"`` or ``"linear"``,
``scaling = "density"``) to round-off (a relative 1e-14 on a Mann line,
tests/analysis/test_spectra_vs_scipy.py), with f = 0 left out and the
cross-spectrum conjugated (scipy's is ``E[X^* Y]``).  The core is kept, not
replaced by those calls: scipy has no per-segment gap rejection or filling
(here a step before an ordinary Welch average), and the simulation's
results stay bit-identical.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._repr import summary_repr
from .._validation import check_choice, check_int, check_real

__all__ = [
    "log_bins",
    "bin_average",
    "SegmentSpectra",
    "segment_spectra",
    "TransferEstimate",
    "transfer_functions",
    "component_spectra",
]


# --------------------------------------------------------------------------
# binning
# --------------------------------------------------------------------------
def log_bins(lo, hi, per_decade):
    """Geometrically spaced bin edges from ``lo`` to ``hi``.

    Parameters
    ----------
    lo, hi : float
        First and last edge, ``0 < lo < hi`` (any unit, e.g. rad/m or Hz).
    per_decade : int
        Bins per decade, >= 1.  The number of bins is
        ``ceil(per_decade * log10(hi / lo) - 1e-9)`` (at least 1), so that
        both ends are kept exactly and the bins are at most 1/per_decade of
        a decade wide.

    Returns
    -------
    edges : ndarray, shape (n_bins + 1,)
        Strictly increasing edges, ``edges[0] = lo``, ``edges[-1] = hi``.
    """
    lo = check_real("lo", lo, lo=0.0, lo_open=True)
    hi = check_real("hi", hi, lo=lo, lo_open=True)
    per_decade = check_int("per_decade", per_decade, lo=1, hi=10_000)
    n = max(1, int(math.ceil(per_decade * math.log10(hi / lo) - 1e-9)))
    edges = np.geomspace(lo, hi, n + 1)
    edges[0], edges[-1] = lo, hi
    return edges


def _check_edges(name, edges):
    e = np.asarray(edges, dtype=float)
    if e.ndim != 1 or e.size < 2:
        raise ValueError(f"{name} must be a 1-D array of at least 2 edges, got shape {e.shape}")
    if not np.all(np.isfinite(e)):
        raise ValueError(f"{name} contains non-finite values; allowed: finite, strictly increasing")
    if not np.all(np.diff(e) > 0):
        raise ValueError(f"{name}={e!r} is not strictly increasing; allowed: strictly increasing edges")
    return e


def _bin_index(x, edges):
    """Bin of each x (bins [e_i, e_i+1)), -1 where outside every bin."""
    idx = np.searchsorted(edges, x, side="right") - 1
    idx[(idx < 0) | (idx >= edges.size - 1) | ~np.isfinite(x)] = -1
    return idx


def bin_average(x_f, values_f, edges):
    """Mean of the values whose abscissa falls in each bin.

    Parameters
    ----------
    x_f : array_like, shape (n,)
        Abscissae (e.g. frequency [Hz] or wavenumber [rad/m]).
    values_f : array_like, real or complex, shape (..., n)
        Values to average along the last axis (e.g. spectral densities; any
        unit).  NaN values propagate into their bin's mean.
    edges : array_like, shape (n_bins + 1,)
        Strictly increasing bin edges in the unit of ``x_f``; bin i is the
        half-open interval ``[edges[i], edges[i + 1])``.  Abscissae outside
        ``[edges[0], edges[-1])`` are ignored.

    Returns
    -------
    mean_b : ndarray, shape (..., n_bins)
        Arithmetic mean per bin (same kind, real or complex, as the values),
        NaN where a bin holds no abscissa.
    count_b : ndarray of int, shape (n_bins,)
        Number of abscissae in each bin.
    """
    x = np.asarray(x_f, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"x_f must be 1-D, got shape {x.shape}")
    v = np.asarray(values_f)
    if v.dtype.kind not in "fcib" or v.ndim < 1 or v.shape[-1] != x.size:
        raise ValueError(f"values_f must be a real or complex array whose last axis has len(x_f) = {x.size} "
                         f"values, got shape {v.shape} and dtype {v.dtype}")
    e = _check_edges("edges", edges)
    nb = e.size - 1
    idx = _bin_index(x, e)
    keep = idx >= 0
    count = np.bincount(idx[keep], minlength=nb)
    lead = v.shape[:-1]
    vf = v.reshape(-1, x.size)[:, keep]
    ik = idx[keep]
    cplx = np.iscomplexobj(v)
    out = np.empty((vf.shape[0], nb), dtype=complex if cplx else float)
    with np.errstate(invalid="ignore", divide="ignore"):
        for r in range(vf.shape[0]):
            re = np.bincount(ik, weights=vf[r].real.astype(float), minlength=nb)
            if cplx:
                im = np.bincount(ik, weights=vf[r].imag.astype(float), minlength=nb)
                out[r] = (re + 1j * im) / count
            else:
                out[r] = re / count
    out[:, count == 0] = np.nan
    return out.reshape(lead + (nb,)), count


def _centres(edges):
    return np.sqrt(edges[:-1] * edges[1:])


# --------------------------------------------------------------------------
# segment-averaged periodograms
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class SegmentSpectra:
    """Segment-averaged one-sided periodograms of one or two series.

    Attributes
    ----------
    f_f : ndarray
        Frequencies ``j / T``, ``j = 1 .. n_per // 2`` [Hz] (0 excluded).
    psd_xf : ndarray
        One-sided PSD of x [units^2 / Hz]: ``sum(psd_xf) * df`` plus the
        squared removed mean is the mean square of a segment (Parseval).
    psd_yf : ndarray or None
        Same for y (None without y).
    csd_f : ndarray, complex, or None
        One-sided cross-spectrum ``E[X Y^*]`` [units_x units_y / Hz];
        ``Re(sum(csd_f)) * df`` is the covariance of the detrended segments.
    n_segments : int
        Segments averaged (including the gap-filled ones).
    n_rejected : int
        Segments skipped because more than ``max_gap_fraction`` of their
        samples (of x or y) were not finite.
    n_interpolated : int
        Segments used after their gaps were filled by linear interpolation.
    fs : float
        Sampling rate [Hz].
    segment_duration : float
        Duration of a segment, ``n_per / fs`` [s].
    n_per : int
        Samples per segment.
    """

    __repr__ = summary_repr

    f_f: np.ndarray
    psd_xf: np.ndarray
    psd_yf: np.ndarray | None
    csd_f: np.ndarray | None
    n_segments: int
    n_rejected: int
    n_interpolated: int
    fs: float = math.nan
    segment_duration: float = math.nan
    n_per: int = 0

    @property
    def df(self) -> float:
        """Frequency resolution 1 / T [Hz]."""
        return self.fs / self.n_per


def _as_series(name, a):
    x = np.asarray(a)
    if x.dtype.kind not in "fiu" or x.ndim != 1:
        raise ValueError(f"{name} must be a 1-D real array, got shape {x.shape} and dtype {x.dtype}")
    return x.astype(np.float64, copy=True)


def _fill_rows(rows, bad):
    """Linear interpolation over the non-finite samples of each row, in place."""
    j = np.arange(rows.shape[1])
    for r in np.nonzero(bad.any(axis=1))[0]:
        b = bad[r]
        rows[r, b] = np.interp(j[b], j[~b], rows[r, ~b])


def _detrend(rows, how):
    if how == "mean":
        rows -= rows.mean(axis=1, keepdims=True)
    else:  # linear: least-squares line per row
        n = rows.shape[1]
        t = np.arange(n, dtype=float) - 0.5 * (n - 1)
        slope = rows @ t / (t @ t)
        rows -= rows.mean(axis=1, keepdims=True) + slope[:, None] * t[None, :]


def segment_spectra(x_t, y_t=None, *, fs, segment_duration=600.0, detrend="mean", window="none",
                    max_gap_fraction=0.05, prewhiten=False):
    """Segment-averaged one-sided auto- (and cross-) spectra (A2012 section V.A).

    The series is cut into consecutive, non-overlapping segments of
    ``n_per = round(segment_duration * fs)`` samples (a trailing partial
    segment is dropped); each segment is detrended, optionally windowed and
    Fourier transformed (``cwlidar_sim._fft.rfft_rows``), and the
    periodograms are averaged over the segments.

    Parameters
    ----------
    x_t : array_like, shape (n,)
        Series sampled at ``fs`` (any unit, e.g. m/s); NaN marks a gap.
    y_t : array_like, shape (n,), optional
        Second series for the cross-spectrum (same length and rate).
    fs : float
        Sampling rate [Hz], > 0.
    segment_duration : float
        Segment duration [s], > 0; A2012 uses 600 s.  ``segment_duration *
        fs`` is rounded to an integer number of samples (>= 2).
    detrend : {"mean", "linear"}
        Remove each segment's mean or its least-squares line.
    window : {"none", "hann"}
        Taper.  A2012 uses none.  With "hann" the periodogram is divided by
        ``sum(w**2)`` instead of n, which keeps the level of a smooth
        spectrum (Parseval then holds only on average).
    max_gap_fraction : float
        In [0, 1).  A segment with a fraction of non-finite samples (in x or
        y) up to this value is gap-filled by linear interpolation in time
        (constant beyond its first/last finite sample) and counted in
        ``n_interpolated``; above it, the segment is skipped and counted in
        ``n_rejected``.
    prewhiten : bool
        Analyse the first differences ``x[n] - x[n-1]`` (the first sample's
        difference is taken as 0) and divide the spectra by the differencing
        filter's ``|1 - exp(-i 2 pi f / fs)|^2 = 4 sin^2(pi f / fs)``.  For
        red spectra such as turbulence this keeps the leakage of the strong
        low-frequency power out of the high-frequency bins, where a filtered
        series (a lidar) lies orders of magnitude below the unfiltered one.
        Parseval then holds only on average.

    Returns
    -------
    SegmentSpectra
        One-sided spectra on ``f_j = j fs / n_per``, ``j = 1 .. n_per // 2``:
        ``psd = 2 |X_j|^2 / (fs n_per)`` (no factor 2 at the Nyquist bin of
        an even n_per), ``csd = 2 X_j Y_j^* / (fs n_per)``, averaged over the
        usable segments.

    Raises
    ------
    ValueError
        Bad arguments, a series shorter than one segment, or no usable
        segment (every segment has too many gaps).
    """
    fs = check_real("fs", fs, lo=0.0, lo_open=True)
    segment_duration = check_real("segment_duration", segment_duration, lo=0.0, lo_open=True)
    check_choice("detrend", detrend, ("mean", "linear"))
    check_choice("window", window, ("none", "hann"))
    max_gap_fraction = check_real("max_gap_fraction", max_gap_fraction, lo=0.0, hi=1.0, hi_open=True)
    if not isinstance(prewhiten, (bool, np.bool_)):
        raise TypeError(f"prewhiten must be a bool, got {type(prewhiten).__name__}")
    x = _as_series("x_t", x_t)
    y = None
    if y_t is not None:
        y = _as_series("y_t", y_t)
        if y.size != x.size:
            raise ValueError(f"y_t has {y.size} samples but x_t has {x.size}; allowed: equal lengths")
    if prewhiten:
        x = np.diff(x, prepend=x[:1])
        y = None if y is None else np.diff(y, prepend=y[:1])
    n_per = int(round(segment_duration * fs))
    if n_per < 2:
        raise ValueError(f"segment_duration * fs = {segment_duration * fs:g} samples; allowed: >= 2")
    n_seg = x.size // n_per
    if n_seg < 1:
        raise ValueError(f"x_t has {x.size} samples, fewer than one segment of {n_per} samples "
                         f"(segment_duration={segment_duration} s at fs={fs} Hz); allowed: >= {n_per}")
    series = [x] if y is None else [x, y]
    rows = [s[: n_seg * n_per].reshape(n_seg, n_per) for s in series]
    bad = [~np.isfinite(r) for r in rows]
    frac = np.max([b.mean(axis=1) for b in bad], axis=0)
    use = frac <= max_gap_fraction
    n_used = int(use.sum())
    n_rejected = n_seg - n_used
    if n_used == 0:
        raise ValueError(f"no usable segment: all {n_seg} segments of {n_per} samples have more than "
                         f"max_gap_fraction={max_gap_fraction} non-finite samples (worst-kept fraction "
                         f"{frac.min():.3g}); allowed: at least one segment within the limit")
    n_interp = int(np.count_nonzero(use & (frac > 0)))
    rows = [r[use] for r in rows]
    for r, b in zip(rows, bad):
        _fill_rows(r, b[use])
        _detrend(r, detrend)

    from .._fft import rfft_rows

    if window == "hann":
        w = 0.5 - 0.5 * np.cos(2.0 * math.pi * np.arange(n_per) / n_per)
        norm = float(w @ w)
        for r in rows:
            r *= w
    else:
        norm = float(n_per)
    nf = n_per // 2
    spec = [rfft_rows(r)[:, 1 : nf + 1] for r in rows]
    scale = np.full(nf, 2.0 / (fs * norm))
    if n_per % 2 == 0:
        scale[-1] *= 0.5  # the Nyquist bin has no negative-frequency twin
    psd = [scale * np.mean(s.real**2 + s.imag**2, axis=0) for s in spec]
    csd = scale * np.mean(spec[0] * np.conj(spec[1]), axis=0) if y is not None else None
    f = np.arange(1, nf + 1) * (fs / n_per)
    if prewhiten:
        gain = 4.0 * np.sin(math.pi * f / fs) ** 2
        psd = [p / gain for p in psd]
        csd = None if csd is None else csd / gain
    return SegmentSpectra(f_f=f, psd_xf=psd[0], psd_yf=psd[1] if y is not None else None, csd_f=csd,
                          n_segments=n_used, n_rejected=n_rejected, n_interpolated=n_interp, fs=fs,
                          segment_duration=n_per / fs, n_per=n_per)


# --------------------------------------------------------------------------
# measured transfer functions (A2012 methods 1 and 2)
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class TransferEstimate:
    """Log-binned spectra and spectral transfer functions, lidar against sonic.

    All spectra are *one-sided* in wavenumber k1 [rad/m], in
    [(m/s)^2 / (rad/m)] for speeds in m/s.

    Attributes
    ----------
    k_k : ndarray
        Bin centres, geometric mean of the edges [rad/m].
    k_edges : ndarray
        Bin edges [rad/m].
    F_r_k, F_s_k : ndarray
        Lidar and sonic spectra: bin means of ``S(f) U / (2 pi)``.
    chi_k : ndarray, complex
        Cross-spectrum ``E[V_r V_s^*]`` (lidar times conjugated sonic),
        same units and binning.
    transfer_ratio_k : ndarray
        A2012's method 1, ``F_r / F_s`` (Eq. 8): a results file's
        ``transfer_ratio``.
    transfer_cross_k : ndarray
        A2012's method 2, ``Re(chi)^2 / F_s^2`` (Eq. 11): a results file's
        ``transfer_cross``.
    coherence_k : ndarray
        Magnitude-squared coherence ``|chi|^2 / (F_r F_s)`` of the bin means.
    n_k : ndarray of int
        Raw periodogram values averaged into each bin (segments x
        frequencies in the bin); 0 for an empty bin (whose values are NaN).
    transfer_ratio_sigma_k, transfer_cross_sigma_k : ndarray
        Approximate 1-sigma sampling uncertainty of the two (see
        :func:`transfer_functions`).
    n_segments, n_rejected : int
        Segments used and segments skipped for gaps.
    n_interpolated : int
        Segments used after gap filling.
    U : float
        Mean speed used for Taylor's hypothesis [m/s].
    """

    __repr__ = summary_repr

    k_k: np.ndarray
    k_edges: np.ndarray
    F_r_k: np.ndarray
    F_s_k: np.ndarray
    chi_k: np.ndarray
    transfer_ratio_k: np.ndarray
    transfer_cross_k: np.ndarray
    coherence_k: np.ndarray
    n_k: np.ndarray
    transfer_ratio_sigma_k: np.ndarray
    transfer_cross_sigma_k: np.ndarray
    n_segments: int
    n_rejected: int
    n_interpolated: int = 0
    U: float = math.nan


def _wavenumber_setup(U, k_edges):
    U = check_real("U", U, lo=0.0, lo_open=True)
    e = _check_edges("k_edges", k_edges)
    if e[0] <= 0:
        raise ValueError(f"k_edges[0]={e[0]!r} is out of range; allowed: > 0 rad/m")
    return U, e


def transfer_functions(vr_t, vs_t, *, fs, U, k_edges, segment_duration=600.0, max_gap_fraction=0.05,
                       detrend="mean", window="none", prewhiten=False):
    """Spectral transfer function of the lidar against the sonic, A2012 methods 1 and 2.

    The two 1-D series are analysed by :func:`segment_spectra` (mean
    removed, no window), converted to one-sided wavenumber spectra with
    Taylor's hypothesis (``k = 2 pi f / U``, ``F = S U / (2 pi)``) and
    log-smoothed by averaging the raw segment-averaged values ``F_r``,
    ``F_s`` and ``chi`` over the frequencies in each k bin *first*; the
    ratios are formed from the bin means (averaging ratios would bias them).

    Parameters
    ----------
    vr_t : array_like, shape (n,)
        Lidar line-of-sight speed [m/s] at ``fs``; NaN marks a gap.
    vs_t : array_like, shape (n,)
        Sonic speed projected on the beam [m/s], same times.
    fs : float
        Sampling rate [Hz], > 0 (A2012: 10 Hz).
    U : float
        Mean wind speed [m/s], > 0.
    k_edges : array_like
        Strictly increasing, positive bin edges in k [rad/m] (see
        :func:`log_bins`).
    segment_duration : float
        Segment duration [s] (A2012: 600 s).
    max_gap_fraction : float
        See :func:`segment_spectra`.
    detrend, window : str
        See :func:`segment_spectra`.
    prewhiten : bool
        See :func:`segment_spectra`; the filter cancels in T1 and T2 bin by
        bin and only removes leakage.  A2012 removed the mean and used no
        window; a linear trend or a Hann window reduces the leakage of the
        strong low-k power into the high-k bins, where the lidar's spectrum
        is orders of magnitude below the sonic's.

    Returns
    -------
    TransferEstimate

    Notes
    -----
    Uncertainty.  Treat the N = ``n_k`` raw values averaged into a bin as
    independent samples of a circular complex Gaussian pair (X = lidar,
    Y = sonic Fourier coefficients; the frequencies of an unwindowed
    periodogram of a stationary series are nearly uncorrelated, and
    separate segments are independent), with cross-spectral matrix
    ``[[Gr, C], [C^*, Gs]]``.  Isserlis' theorem gives, per raw value,
    ``var|X|^2 = Gr^2``, ``var|Y|^2 = Gs^2``, ``cov(|X|^2, |Y|^2) = |C|^2``,
    ``var Re(X Y^*) = (Gr Gs + Re(C^2)) / 2`` and
    ``cov(Re(X Y^*), |Y|^2) = Re(C) Gs`` (each |X|^2 being chi-square with 2
    degrees of freedom times G/2; Bendat & Piersol, *Random Data*, ch. 9).
    To first order in the fluctuations of the bin means (delta method):

    * ``(sigma_T1 / T1)^2 = (1 + 1 - 2 gamma^2) / N = 2 (1 - gamma^2) / N``
      with ``gamma^2 = |C|^2 / (Gr Gs)`` the coherence;
    * ``(sigma_T2 / T2)^2 = 4 (sigma_c / c)^2`` with ``c = Re(C) / Gs``,
      ``(sigma_c / c)^2 = (Gr Gs - |C|^2) / (2 N Re(C)^2)``, i.e.
      ``sigma_T2 = |Re C| sqrt(2 (Gr Gs - |C|^2) / N) / Gs^2``, which for real
      C is Bendat & Piersol's gain error ``sqrt(1 - gamma^2) / (|gamma|
      sqrt(2 N))`` doubled for the square.

    The measured bin means stand in for G and C.  The approximation needs
    N >> 1 (say N >= 30); for small N the errors are not Gaussian and T2
    carries a positive bias of relative order ``(1 + 1/gamma_re^2) / (2 N)``
    (``gamma_re^2 = Re(C)^2 / (Gr Gs)``, from ``E[Re(C_hat)^2]``).
    """
    U, e = _wavenumber_setup(U, k_edges)
    seg = segment_spectra(vr_t, vs_t, fs=fs, segment_duration=segment_duration, detrend=detrend, window=window,
                          max_gap_fraction=max_gap_fraction, prewhiten=prewhiten)
    to_k = U / (2.0 * math.pi)
    k_f = seg.f_f / to_k
    raw_cf = np.stack([seg.psd_xf * to_k, seg.psd_yf * to_k, seg.csd_f * to_k])
    mean_ck, count_k = bin_average(k_f, raw_cf, e)
    Fr_k, Fs_k, chi_k = mean_ck[0].real, mean_ck[1].real, mean_ck[2]
    n_k = count_k * seg.n_segments
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio_k = Fr_k / Fs_k
        cross_k = chi_k.real**2 / Fs_k**2
        c2_k = np.abs(chi_k) ** 2
        coh_k = c2_k / (Fr_k * Fs_k)
        nn_k = np.where(n_k > 0, n_k, np.nan)
        sig1_k = ratio_k * np.sqrt(2.0 * np.clip(1.0 - coh_k, 0.0, None) / nn_k)
        sig2_k = np.abs(chi_k.real) * np.sqrt(2.0 * np.clip(Fr_k * Fs_k - c2_k, 0.0, None) / nn_k) / Fs_k**2
    return TransferEstimate(k_k=_centres(e), k_edges=e, F_r_k=Fr_k, F_s_k=Fs_k, chi_k=chi_k, transfer_ratio_k=ratio_k,
                            transfer_cross_k=cross_k, coherence_k=coh_k, n_k=n_k, transfer_ratio_sigma_k=sig1_k,
                            transfer_cross_sigma_k=sig2_k,
                            n_segments=seg.n_segments, n_rejected=seg.n_rejected,
                            n_interpolated=seg.n_interpolated, U=U)


def component_spectra(u_t, v_t, w_t, *, fs, U, k_edges, segment_duration=600.0, max_gap_fraction=0.05):
    """Log-binned one-sided wavenumber spectra of the three velocity components.

    Parameters
    ----------
    u_t, v_t, w_t : array_like, shape (n,)
        Longitudinal, lateral and vertical velocity [m/s] at ``fs`` (the
        mean is removed per segment, so u may include U).
    fs : float
        Sampling rate [Hz], > 0.
    U : float
        Mean wind speed for Taylor's hypothesis [m/s], > 0.
    k_edges : array_like
        Positive, strictly increasing bin edges in k1 [rad/m].
    segment_duration : float
        Segment duration [s].
    max_gap_fraction : float
        See :func:`segment_spectra`; a segment is used only if every
        component is within the limit.

    Returns
    -------
    k_k : ndarray
        Bin centres (geometric mean of the edges) [rad/m].
    F11_k, F22_k, F33_k : ndarray
        *One-sided* auto-spectra [m^2 s^-2 / (rad/m)] (in expectation
        :func:`cwlidar_sim.turbulence.one_point_spectra`'s, no factor),
        bin means of the segment-averaged raw values; NaN in empty bins.
    F13_k : ndarray
        Re of the one-sided u-w cross-spectrum, same units (its integral is
        the u-w covariance).
    n_k : ndarray of int
        Raw periodogram values per bin (segments x frequencies).
    """
    U, e = _wavenumber_setup(U, k_edges)
    u = _as_series("u_t", u_t)
    v = _as_series("v_t", v_t)
    w = _as_series("w_t", w_t)
    if not u.size == v.size == w.size:
        raise ValueError(f"u_t, v_t, w_t must have equal lengths, got {u.size}, {v.size}, {w.size}")
    # A segment is kept or dropped for all components together, so that the
    # three spectra describe the same stretch of time.
    bad = ~(np.isfinite(u) & np.isfinite(v) & np.isfinite(w))
    v_masked = np.where(bad, np.nan, v)
    s_uw = segment_spectra(np.where(bad, np.nan, u), np.where(bad, np.nan, w), fs=fs,
                           segment_duration=segment_duration, max_gap_fraction=max_gap_fraction)
    s_v = segment_spectra(v_masked, fs=fs, segment_duration=segment_duration, max_gap_fraction=max_gap_fraction)
    to_k = U / (2.0 * math.pi)
    raw_cf = np.stack([s_uw.psd_xf, s_v.psd_xf, s_uw.psd_yf, s_uw.csd_f.real]) * to_k
    mean_ck, count_k = bin_average(s_uw.f_f / to_k, raw_cf, e)
    return (_centres(e), mean_ck[0], mean_ck[1], mean_ck[2], mean_ck[3], count_k * s_uw.n_segments)
