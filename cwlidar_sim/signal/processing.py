"""Processing shared by tiers 2 and 3: background, threshold, Doppler estimators, quality flags.

Spectrum convention
-------------------
An averaged spectrum ``S[e, k]`` holds, for estimate ``e`` and one-sided bin
``k = 0 .. N/2`` (frequency ``k f_s / N``), the mean over M blocks of the block
periodogram ``|X_k|^2 / sum_n w_n^2`` (``X`` the DFT of the windowed block,
``w`` the window).  White noise of variance sigma^2 then has expected level
sigma^2 in *every* bin (bins are not doubled: the sum over k = 0..N-1 of the
two-sided periodogram is N times the mean power).  The package measures power
in units of the shot-noise variance, so the noise floor is 1.

Steps, for every estimate
-------------------------
1. Normalise by the background (noise-floor) spectrum ``B``:
   ``y_k = S_k / B_k - 1`` (0 on average where there is no signal, with
   standard deviation ``sigma_y = sqrt(1/M + 1/M_bg)``).
2. Threshold (:func:`threshold_levels`): a level ``t``, then A2012's
   "raise by x %" in one of two readings (of the raw level ``B (1 + t)``
   or of the excess ``t``).
3. Keep the bins outside the low-frequency blind zone and below the Nyquist
   bin (``first_bin <= k < N/2``) whose ``y`` exceeds ``t``; the thresholded
   spectrum is ``p_k = y_k - t`` there and 0 elsewhere (subtracting ``t``
   keeps ``p`` continuous as a bin crosses the threshold).
4. Estimate a Doppler bin with an estimator of :data:`ESTIMATORS`; convert to
   Hz (``x f_s / N``) and m/s (``lambda/2`` per Hz).  Homodyne detection
   loses the sign: estimates are >= 0.
5. Flags (:class:`Flag`); failed estimates are NaN and flagged, and counted
   in :attr:`DopplerEstimates.availability`.

What availability counts
------------------------
One definition everywhere (:func:`usable_mask`, :func:`usable_fraction`): the
``availability`` of :class:`DopplerEstimates`, of the signal chain's records
and of every campaign's results is the fraction of *usable* estimates, finite
and carrying none of :data:`UNUSABLE_FLAGS`:

* :data:`FAIL_FLAGS` (NO_SIGNAL, FIT_FAILED, PAUSED, BLOCKED): no estimate,
  the value is NaN;
* :data:`SUSPECT_FLAGS` (NEAR_ZERO, NEAR_NYQUIST): the value is finite but
  made by the instrument's limits, not by the wind: within the edge guard of
  the blind zone the line is cut by it and mixed with the relative-intensity
  noise and the homodyne mirror (at 0.3 m/s the prototype's median reports
  about 0.56 m/s, every estimate flagged NEAR_ZERO), within the guard of
  Nyquist it may be aliased.  A user reading "availability" as "usable" must
  not count it, and a campaign's averaged series (the staring 10 Hz blocks, a
  nacelle lidar's revolution means) leave it out as they leave out a NaN;
  the 50 Hz record keeps the value with its flag.

SECOND_PEAK is informational and counted: the estimate is that of the
thresholded spectrum as the instrument forms it (with a cloud, its centroid
or median *is* what the instrument reports, bias included: that bias is what
a cloud study measures), and turbulence alone splits a broad line into two
groups at times; the flag tells, ``flag_count`` counts it.  The fraction of
finite estimates, flagged or not, is :attr:`DopplerEstimates.valid_fraction`.
"""

from __future__ import annotations

import dataclasses
import enum
import math

import numpy as np

from .._repr import summary_repr
from .._validation import check_choice, check_int
from ._tasks import _ROWS_PER_TASK, _rng, _run_tasks  # noqa: F401  (_rng: used by sensors)
from .noise import noise_floor
from .spectral import line_shape_table

__all__ = [
    "Flag",
    "ESTIMATORS",
    "FAIL_FLAGS",
    "SUSPECT_FLAGS",
    "UNUSABLE_FLAGS",
    "usable_mask",
    "usable_fraction",
    "usable_speeds",
    "DopplerEstimates",
    "threshold_levels",
    "raised_level",
    "background_gain",
    "noise_floor",
    "background_spectrum",
    "estimate",
    "estimate_variants",
    "check_estimator",
]


class Flag(enum.IntFlag):
    """Quality flags of an estimate (a bit field, stored as uint8)."""

    #: No bin above the threshold: the estimate is NaN.
    NO_SIGNAL = 1
    #: Estimate within ``edge_guard_speed`` of Nyquist, or the strongest thresholded bin is
    #: the last one scanned: possibly aliased.
    NEAR_NYQUIST = 2
    #: Estimate within ``edge_guard_speed`` of the blind zone, or the strongest thresholded bin
    #: is the first one scanned (a line inside the blind zone seen by its tail): homodyne
    #: ambiguity, RIN.
    NEAR_ZERO = 4
    #: A separate group of thresholded bins carries at least ``second_peak_fraction``
    #: of the main group's power: cloud return or second peak suspected.
    SECOND_PEAK = 8
    #: The estimator could not produce a value: the estimate is NaN.
    FIT_FAILED = 16
    #: The instrument was measuring its background (10 min every 3 h in
    #: A2012): no estimate; set by the campaign runner, the estimate is NaN.
    PAUSED = 32
    #: The beam was blocked (a turbine blade passing through it) for too much of the
    #: dwell: no estimate; set by the nacelle lidar, the estimate is NaN.
    BLOCKED = 64


#: Flags that make an estimate NaN.
FAIL_FLAGS = Flag.NO_SIGNAL | Flag.FIT_FAILED | Flag.PAUSED | Flag.BLOCKED

#: Flags of finite estimates biased by the instrument's limits: not counted as available.
SUSPECT_FLAGS = Flag.NEAR_ZERO | Flag.NEAR_NYQUIST

#: Flags that make an estimate unusable (module notes): not available, never averaged.
UNUSABLE_FLAGS = FAIL_FLAGS | SUSPECT_FLAGS


def usable_mask(speed_e, flags_e) -> np.ndarray:
    """Which estimates are usable: finite and carrying none of :data:`UNUSABLE_FLAGS` (module notes).

    Parameters
    ----------
    speed_e : array_like of float
        Estimates [m/s] (any speed or velocity; NaN where failed).
    flags_e : array_like of int, same shape
        Their :class:`Flag` bit fields.

    Returns
    -------
    ndarray of bool, same shape
    """
    speed = np.asarray(speed_e, dtype=np.float64)
    flags = np.asarray(flags_e)
    if speed.shape != flags.shape:
        raise ValueError(f"speed_e and flags_e must have one shape, got {speed.shape} and {flags.shape}")
    return np.isfinite(speed) & ((flags.astype(np.int64) & int(UNUSABLE_FLAGS)) == 0)


def usable_fraction(speed_e, flags_e) -> float:
    """The availability [-]: fraction of usable estimates (:func:`usable_mask`); NaN when there are none."""
    ok = usable_mask(speed_e, flags_e)
    return float(np.mean(ok)) if ok.size else float("nan")


def usable_speeds(speed_e, flags_e) -> np.ndarray:
    """A float64 copy of ``speed_e`` with every unusable estimate NaN (what an averaged series may use)."""
    out = np.array(speed_e, dtype=np.float64)
    out[~usable_mask(out, flags_e)] = np.nan
    return out

#: Registry of Doppler estimators: name -> (kernel id, description).  All act
#: on the thresholded, noise-normalised spectrum (see the module notes).
ESTIMATORS = {
    "median": (0, "frequency below which half the thresholded power lies, each bin's power spread evenly "
                  "over its width (A2012's prototype)"),
    "centroid": (1, "power-weighted mean frequency of the thresholded spectrum (CS's series instrument)"),
    "peak": (2, "highest thresholded bin, refined with the window's own line shape from the ratio of the "
                "larger neighbour to the peak (exact for a single tone)"),
    "peak_parabolic": (3, "highest bin refined by a parabola through it and its neighbours "
                          "(biased toward bin centres for the narrow rect line, up to ~0.25 bin)"),
    "peak_gaussian": (4, "highest bin refined by a parabola through the logarithms (Gaussian line)"),
    "ml": (5, "maximum (Whittle/Gamma) likelihood of a single line of the instrument's shape plus its "
              "homodyne mirror over the background, position and amplitude fitted within +/-8 bins of the peak"),
}

_THR_IDS = {"sigma": 0, "snr": 1, "peak_fraction": 2}
_WIN_IDS = {"rect": 0, "hann": 1}
_ML_HALF_WIDTH = 8


def check_estimator(name: str) -> int:
    """Kernel id of a registered estimator; unknown names are rejected with the allowed list."""
    check_choice("estimator", name, tuple(ESTIMATORS))
    return ESTIMATORS[name][0]


@dataclasses.dataclass(frozen=True)
class DopplerEstimates:
    """Speed estimates of a run, with their flags.

    Attributes
    ----------
    speed_e : ndarray, float64
        Estimated radial speed |v| [m/s] (homodyne: >= 0); NaN where failed.
    frequency_e : ndarray, float64
        Estimated Doppler frequency [Hz]; NaN where failed.
    flags_e : ndarray, uint8
        :class:`Flag` bit field of each estimate.
    estimator : str
        Name of the estimator used.
    """

    __repr__ = summary_repr

    speed_e: np.ndarray
    frequency_e: np.ndarray
    flags_e: np.ndarray
    estimator: str

    @property
    def n(self) -> int:
        """Number of estimates."""
        return int(self.speed_e.size)

    @property
    def availability(self) -> float:
        """Fraction of usable estimates [-]: :func:`usable_fraction` (module notes)."""
        return usable_fraction(self.speed_e, self.flags_e)

    @property
    def valid_fraction(self) -> float:
        """Fraction of finite estimates [-], suspect ones included."""
        return float(np.mean(np.isfinite(self.speed_e))) if self.n else float("nan")

    def flag_counts(self) -> dict:
        """Number of estimates carrying each flag, by flag name."""
        return {f.name: int(np.count_nonzero(self.flags_e & f.value)) for f in Flag}

    def summary(self) -> dict:
        """Mean and standard deviation of the valid speeds [m/s], availability and flag counts."""
        ok = self.speed_e[np.isfinite(self.speed_e)]
        return {
            "n": self.n,
            "n_valid": int(ok.size),
            "n_usable": int(round(self.availability * self.n)) if self.n else 0,
            "availability": self.availability,
            "valid_fraction": self.valid_fraction,
            "mean": float(ok.mean()) if ok.size else None,
            "std": float(ok.std(ddof=1)) if ok.size > 1 else None,
            "flags": self.flag_counts(),
        }


def background_spectrum(instrument, seed=None, *, n_blocks=None) -> np.ndarray:
    """Background (noise-floor) spectrum measured from signal-free blocks [-].

    Parameters
    ----------
    instrument : Instrument
    seed : int or numpy.random.Generator or None
        Randomness of the measurement; None returns the expected floor
        (an infinitely long measurement).
    n_blocks : int, optional
        Signal-free blocks averaged M_bg; default ``instrument.background_blocks``.

    Returns
    -------
    ndarray, shape (N/2 + 1,)
        ``noise_floor * Gamma(k M_bg / 2, 2 / (k M_bg))`` per bin, k = 2 real
        degrees of freedom per block (k = 1 at 0 Hz and Nyquist, whose DFT
        values are real).  For a rectangular window this is the exact law of
        the averaged periodogram of white Gaussian noise; a Hann window
        correlates neighbouring bins, which this draw ignores.
    """
    floor = noise_floor(instrument)
    if seed is None:
        return floor
    m = instrument.background_blocks if n_blocks is None else check_int("n_blocks", n_blocks, lo=1, hi=10**15)
    rng = _rng(seed)
    dof = np.full(floor.shape, 2.0)
    dof[0] = dof[-1] = 1.0
    shape = 0.5 * dof * m
    return floor * rng.gamma(shape, 1.0 / shape)


def background_gain(instrument, time_e) -> np.ndarray:
    """Receiver gain at each estimate relative to the gain of the last background calibration [-].

    ``g(t) = 1 + mismatch + drift * tau / (T_cal - D_cal)``,
    ``tau = (t - D_cal) mod T_cal`` the time since the last calibration ended
    (calibrations occupy ``[k T_cal, k T_cal + D_cal)``: A2012's 10 min every
    3 h with the defaults).  The measured spectra are ``g`` times the true
    ones while the background ``B`` is the calibration's, so in a signal-free
    bin ``y = g S/B - 1 = (g - 1) + g eps`` (``eps`` the noise, standard
    deviation sigma_y): a threshold ``t`` on ``y`` acts on the noise as the
    level ``(1 + t) / g - 1``, i.e. at ``((1 + t)/g - 1) / sigma_y`` standard
    deviations instead of ``t / sigma_y``.  A gain that has grown (g > 1:
    the background now underestimated) lets noise bins through and pulls the
    median toward the middle of the band; one that has dropped (g < 1)
    raises the threshold on the signal.

    Parameters
    ----------
    instrument : Instrument
    time_e : array_like
        Estimate times on the calibration clock [s].

    Returns
    -------
    ndarray, float64, like ``time_e``
    """
    t = np.asarray(time_e, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise ValueError("time_e must be finite")
    T, D = instrument.background_interval, instrument.background_duration
    tau = np.mod(t - D, T)
    return 1.0 + instrument.background_mismatch + instrument.background_drift * tau / (T - D)


def threshold_levels(instrument, *, n_background=None) -> dict:
    """The threshold rule of an instrument in words and numbers.

    Every kind sets a level ``t`` on ``y = S/B - 1``, the spectrum's excess
    over the background in units of the background: 'sigma'
    ``t = value * sigma_y``, 'snr' ``t = value``, 'peak_fraction'
    ``t = value * max(y)`` (computed per spectrum, once the peak passes the
    detection test ``max(y) > peak_detection_sigma * sigma_y``: without it a
    noise-only spectrum always yields its highest bin).  A2012's raise of the
    threshold "by x % of its original value" is then applied to that level
    in one of two readings (``threshold_raise_reading``), the same for every
    kind:

    'level' (default)
        the threshold *as a level of the raw spectrum*, ``B (1 + t)``, is
        raised by x %: ``t -> (1 + x/100)(1 + t) - 1 = t + (x/100)(1 + t)``.
        The raise is mostly the floor's: 5 % lifts a 4 sigma_y threshold of
        the prototype (t = 0.091) to 0.145.
    'excess'
        the threshold's height above the removed background is raised by
        x %: ``t -> (1 + x/100) t`` (5 % lifts t = 0.091 to 0.095); for
        'peak_fraction' this is the fraction raised by x %.

    The paper removes the background before thresholding, which favours
    'excess'; 'level' is the earlier reading of this package, kept as the
    default so that results do not change.  Both are
    ``t -> raise_factor t + raise_offset``.

    Returns
    -------
    dict
        ``sigma_y``: standard deviation of ``y`` in a signal-free bin,
        ``sqrt(1/M + 1/M_bg)`` (M blocks per estimate, M_bg background
        blocks); ``t``: the level before the raise (for 'peak_fraction', the
        factor of ``max(y)``); ``detect``: the detection level of 'peak_fraction'
        in units of ``sigma_y`` (0 for the other kinds); ``raise_factor`` ``1 + x/100`` and
        ``raise_offset`` (``x/100`` for 'level', 0 for 'excess'); ``reading``.
    """
    m_bg = instrument.background_blocks if n_background is None else n_background
    sigma_y = math.sqrt(1.0 / instrument.blocks_per_estimate + 1.0 / m_bg)
    kind = instrument.threshold_kind
    if kind == "sigma":
        t = instrument.threshold_value * sigma_y
    else:
        t = instrument.threshold_value
    x = instrument.threshold_raise_percent / 100.0
    reading = instrument.threshold_raise_reading
    return {"kind": kind, "sigma_y": sigma_y, "t": t, "raise_factor": 1.0 + x,
            "raise_offset": x if reading == "level" else 0.0, "reading": reading,
            "detect": instrument.peak_detection_sigma if kind == "peak_fraction" else 0.0}


def raised_level(t: float, instrument) -> float:
    """The level ``t`` after the instrument's raise (:func:`threshold_levels`)."""
    thr = threshold_levels(instrument)
    return thr["raise_factor"] * t + thr["raise_offset"]


def estimate(spectra_ef, instrument, background_f=None, *, estimator=None, n_background=None,
             line_table=None) -> DopplerEstimates:
    """Doppler speed of every averaged spectrum.

    Parameters
    ----------
    spectra_ef : array_like, shape (n_estimates, N/2 + 1)
        Averaged periodograms (see the module notes for the convention).
    instrument : Instrument
        Supplies the threshold rule, blind zone, guards, window and the
        default estimator.
    background_f : array_like, shape (N/2 + 1,), optional
        Background spectrum; default :func:`noise_floor` (exactly known floor).
    estimator : str, optional
        Overrides ``instrument.estimator``; one of :data:`ESTIMATORS`.
    n_background : int, optional
        Blocks behind ``background_f`` for ``sigma_y`` (default
        ``instrument.background_blocks``).
    line_table : tuple, optional
        ``(table, oversample)`` from :func:`cwlidar_sim.signal.spectral.line_shape_table`,
        used by 'ml'; default: the instrument's line for constant speckle.

    Returns
    -------
    DopplerEstimates
    """
    return estimate_variants(spectra_ef, [instrument], background_f, estimators=[estimator],
                             n_background=n_background, line_table=line_table)[0]


def estimate_variants(spectra_ef, instruments, background_f=None, *, estimators=None, n_background=None,
                      line_table=None) -> list:
    """:func:`estimate` for several processings of the same spectra, which are read once.

    Parameters
    ----------
    spectra_ef, background_f, n_background, line_table
        As :func:`estimate` (``line_table`` and the window and resolution
        taken from ``instruments[0]``).
    instruments : sequence of Instrument
        One per processing variant (thresholds, estimators, guards may
        differ); their resolution (``n_fft``, window, bins) must agree.
    estimators : sequence of (str or None), optional
        Estimator overrides, one per instrument.

    Returns
    -------
    list of DopplerEstimates
        One per instrument, each equal (bit for bit) to :func:`estimate`
        with that instrument.
    """
    from . import _kernels as K

    instruments = list(instruments)
    if not instruments:
        raise ValueError("instruments must hold at least one Instrument")
    first = instruments[0]
    estimators = [None] * len(instruments) if estimators is None else list(estimators)
    if len(estimators) != len(instruments):
        raise ValueError(f"estimators has {len(estimators)} entries for {len(instruments)} instruments")
    for i, inst in enumerate(instruments[1:], 1):
        if (inst.n_fft, inst.window, inst.n_bins) != (first.n_fft, first.window, first.n_bins):
            raise ValueError(f"instruments[{i}] has n_fft/window {inst.n_fft}/{inst.window!r}, "
                             f"instruments[0] {first.n_fft}/{first.window!r}; allowed: equal")
    names = [inst.estimator if e is None else e for inst, e in zip(instruments, estimators)]
    est_id = np.array([check_estimator(n) for n in names], dtype=np.int64)
    spec = np.ascontiguousarray(spectra_ef, dtype=np.float64)
    nf = first.n_bins
    if spec.ndim == 1:
        spec = spec[None, :]
    if spec.ndim != 2 or spec.shape[1] != nf:
        raise ValueError(f"spectra_ef must have shape (n_estimates, {nf}), got {np.shape(spectra_ef)}")
    ne = spec.shape[0]
    n_tasks = -(-ne // _ROWS_PER_TASK)
    ok = np.ones(n_tasks, dtype=bool)

    def check(t):
        ok[t] = K.valid_spectra_rows(spec, t * _ROWS_PER_TASK, min(ne, (t + 1) * _ROWS_PER_TASK))

    _run_tasks(n_tasks, check)
    if not ok.all():
        raise ValueError("spectra_ef must be finite and >= 0")
    bg = noise_floor(first) if background_f is None else np.asarray(background_f, dtype=np.float64)
    if bg.shape != (nf,):
        raise ValueError(f"background_f must have shape ({nf},), got {bg.shape}")
    if not np.all(np.isfinite(bg)) or np.any(bg <= 0):
        raise ValueError("background_f must be finite and > 0 in every bin")
    if line_table is None:
        line_table = line_shape_table(first.n_fft, first.window)
    table, over = line_table
    thr = [threshold_levels(inst, n_background=n_background) for inst in instruments]
    v_args = (
        np.array([inst.first_bin for inst in instruments], dtype=np.int64),
        np.full(len(instruments), nf - 1, dtype=np.int64),
        np.array([_THR_IDS[inst.threshold_kind] for inst in instruments], dtype=np.int64),
        np.array([float(inst.threshold_value) for inst in instruments]),
        np.array([t["raise_factor"] for t in thr], dtype=np.float64),
        np.array([t["raise_offset"] for t in thr], dtype=np.float64),
        np.array([t["sigma_y"] for t in thr], dtype=np.float64),
        np.array([t["detect"] for t in thr], dtype=np.float64),
        est_id,
        _WIN_IDS[first.window],
        np.array([inst.second_peak_fraction for inst in instruments], dtype=np.float64),
        np.array([inst.edge_guard_speed / inst.bin_speed for inst in instruments], dtype=np.float64),
        table, over, first.n_fft, _ML_HALF_WIDTH,
    )
    x = np.empty((len(instruments), ne))
    flags = np.empty((len(instruments), ne), dtype=np.uint8)
    inv_bg = 1.0 / bg

    def run(t):
        K.process_rows_variants(spec, inv_bg, *v_args, t * _ROWS_PER_TASK, min(ne, (t + 1) * _ROWS_PER_TASK), x,
                                flags)

    _run_tasks(n_tasks, run)
    out = []
    for v, (inst, name) in enumerate(zip(instruments, names)):
        freq = x[v] * inst.bin_width
        out.append(DopplerEstimates(speed_e=freq * inst.speed_per_hz, frequency_e=freq, flags_e=flags[v],
                                    estimator=name))
    return out
