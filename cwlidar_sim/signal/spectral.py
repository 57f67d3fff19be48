"""Tier 2 (`spectral`): the expected Doppler spectrum of each estimate and its speckle statistics.

Signal model (shared with tier 3, :mod:`cwlidar_sim.signal.heterodyne`)
-----------------------------------------------------------------------
The detector signal sampled at ``f_s`` is real (homodyne detection):

``x[n] = sum_s Re(a_s[n] exp(i 2 pi f_s' n / f_s)) + sigma xi[n]``

with one term per range cell ``s`` at Doppler frequency ``f_s' = 2 v_s / lambda``,
``a_s`` a circular complex-Gaussian speckle amplitude with
``E|a_s|^2 = 2 CNR w_s`` (``w_s`` the beam weight of the cell, summing to 1)
that decorrelates as an AR(1) process with correlation time ``tau_c``
(``E[a(n) a*(n+d)] / E|a|^2 = rho^|d|``, ``rho = exp(-1 / (f_s tau_c))``),
and white Gaussian shot noise ``xi`` (unit variance, ``sigma = 1``).

**CNR** (carrier-to-noise ratio) is the total signal power over the noise
power in the detection bandwidth (0 .. f_s/2, the Nyquist band), both
measured on the real detector signal: ``CNR = E[sum_s Re(.)^2] / sigma^2 =
sum_s w_s E|a_s|^2 / 2``.  In decibels, ``10 log10(CNR)``.

Line shape (derived)
--------------------
For a block of N samples tapered by a window ``w_n`` the DFT at bin ``k`` of a
unit-power complex tone at ``x`` bins, with the AR(1) amplitude, has

``E|X_k|^2 / sum_n w_n^2 = G(k - x)``,
``G(u) = sum_{d=-(N-1)}^{N-1} R_w(d) rho^|d| exp(i 2 pi u d / N) / R_w(0)``,

with ``R_w(d) = sum_n w_n w_{n+d}`` the window's autocorrelation.  For the
rectangular window and ``rho = 1`` (speckle frozen over a block)
``R_w(d) = N - |d|`` and ``G`` is the Fejer kernel
``G(u) = sin^2(pi u) / (N sin^2(pi u / N))`` (the periodic sinc^2), with
``G(0) = N`` and ``sum_k G(k - x) = N`` for any x.  ``G`` is tabulated on
``[0, N/2]`` by one FFT (:func:`line_shape_table`).

The real part splits a tone into ``+f`` and ``-f`` halves of power 1/4 each
of ``E|a|^2``, so a cell adds ``(CNR w_s / 2) [G(k - x_s) + G(k + x_s)]`` to
the expected spectrum of bin k (the second term is the homodyne mirror: the
spectrum sits at ``|f|`` and the sign of ``v`` is lost).  Speeds beyond
Nyquist alias naturally through the periodicity of G.  A single-speed target
at a bin centre thus has a per-bin signal-to-noise ratio of ``CNR N / 2``
(CNR + 24.1 dB for N = 512).

Speckle of an M-block average (derived)
---------------------------------------
With speckle frozen over a block, the signal power of a bin in block ``b`` is
``|a_b|^2`` times a fixed line shape, and blocks ``j`` apart have intensity
correlation ``|E[a_b a*_{b+j}]|^2 / E|a|^4 = r^j``, ``r = exp(-2 T_b / tau_c)``
(``T_b = N / f_s``).  The mean of M blocks then has relative variance
``(1 + c) / M`` with ``c = 2 sum_{j=1}^{M-1} (1 - j/M) r^j``, i.e. that of
Gamma(M_eff, 1/M_eff) with

``M_eff = M / (1 + c)``,  ``c = 2 [r / (1 - r) - r (1 - r^M) / (M (1 - r)^2)]``

(:func:`speckle_looks`): ``M_eff = M`` when ``tau_c << T_b`` and
``M_eff -> 1`` when ``tau_c >> M T_b``; in between
``M_eff ~ M T_b / tau_c`` (the number of correlation times in the estimate).
The correlation time is the transit time of aerosols across the beam waist,
``tau_c = w0 / v_perp``, ``w0 = lambda r / (pi a0)`` (1.66 mm at 67.5 m: 1.7 ms
at 1 m/s, so the prototype's 1953 blocks of 10.24 us give M_eff = 12).  The
real transit correlation of a Gaussian beam is Gaussian in time with the
same 1/e time; the exponential (Markov) form is used in both tiers.

Continuum speckle (derived; docs/signal_chain.md)
-------------------------------------------------
Cells are continua of scatterers whose speeds spread about the cell's by
the sub-cell spread sigma_v (the field's unresolved scales,
:func:`cwlidar_sim.turbulence.subcell_variance`): a cell's amplitude then has
correlation ``g(tau) = exp(-2 pi^2 sigma_f^2 tau^2) exp(-|tau| / tau_c)``,
``sigma_f = 2 sigma_v / lambda`` (:func:`line_correlation`), and given the
speeds the signal is a Gaussian process.  :func:`continuum_moments` gives
every bin's exact mean and variance from the block-to-block correlations
``c_k(j)`` of its DFT; the scatterers inside a bin dephase within
``1 / (2 pi sigma_f)``, about a tenth of a block, so a turbulent volume's
bins have nearly M looks and the result converges as the beam is cut
finer.  :func:`sample_moments` draws them.  The point-cell models below
('coherent', 'independent') remain for a single speed (exact there) and for
comparison.

The draw (:func:`sample_spectra`): per estimate a signal gain
``G_sig ~ Gamma(M_eff, 1/M_eff)`` (numpy), common to all bins ('coherent':
exact for one speed, where every bin of a block scales with the same
``|a_b|^2``) or one per bin ('independent': the per-bin factor of the classic
model); then, given the signal power, the average of M blocks of a bin with
noise is ``(noise / 2M)`` times a noncentral chi-square with 2M degrees of
freedom (M at 0 Hz and Nyquist) and noncentrality ``2 M signal / noise``,
drawn with Patnaik's approximation and the Wilson-Hilferty cube of a
counter-based normal.  Every bin's mean and variance,
``(sig + noise)`` and ``(sig^2 (1 + c) + noise^2 + 2 sig noise) / M``, equal
those of the M-block average of tier 3.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .._validation import check_choice, check_int, check_real
from ._gridded import GRID_HALF_WIDTH, gridded_lag_tasks  # noqa: F401  (GRID_HALF_WIDTH: part of the notes)
from ._tasks import _ROWS_PER_TASK, _rng, _run_tasks
from .noise import (  # noqa: F401  (re-exported: part of tier 2's public names)
    _G_CUT,
    _fold_noise,
    _noise_components,
    _noise_lag_count,
    _window_lags,
    lag_coefficients,
    noise_correlation,
    noise_floor,
    window_samples,
)

__all__ = [
    "continuum_moments",
    "sample_moments",
    "continuum_lags",
    "line_correlation",
    "noise_correlation",
    "spread_frequency",
    "window_samples",
    "line_shape_table",
    "line_shape",
    "fejer",
    "speckle_looks",
    "cnr_linear",
    "expected_spectrum",
    "sample_spectra",
]

#: Nodes of the tabulated line shape per bin.
OVERSAMPLE = 256


@functools.lru_cache(maxsize=32)
def _table(n_fft: int, window: str, rho: float, oversample: int):
    from .._fft import rfft_rows

    w = window_samples(n_fft, window)
    # R_w(d) for d = 0..N-1 by direct sums (N^2 / 2 products, once per call)
    r = np.array([np.dot(w[: n_fft - d], w[d:]) for d in range(n_fft)])
    d = np.arange(n_fft)
    c = r / r[0] * (rho**d if rho < 1.0 else 1.0)
    m = n_fft * oversample
    seq = np.zeros(m)
    seq[:n_fft] = c
    seq[m - n_fft + 1:] = c[1:][::-1]
    g = rfft_rows(seq[None, :])[0].real.copy()
    g.setflags(write=False)
    return g


def line_shape_table(n_fft: int, window: str = "rect", correlation_time: float = math.inf,
                     sample_rate: float = 50e6, oversample: int = OVERSAMPLE):
    """Tabulated line shape ``G(u)`` on ``u = j / oversample`` bins, ``0 <= u <= N/2``.

    Parameters
    ----------
    n_fft : int
        Block length N.
    window : {'rect', 'hann'}
    correlation_time : float
        Speckle correlation time tau_c [s]; inf for amplitudes frozen over a block.
    sample_rate : float
        f_s [Hz] (only used with a finite ``correlation_time``).
    oversample : int
        Table nodes per bin.

    Returns
    -------
    (table, oversample)
        ``table[j] = G(j / oversample)`` [-], see the module notes (``G(0) = N`` for
        rect and frozen speckle).
    """
    n_fft = check_int("n_fft", n_fft, lo=2, hi=65536)
    check_choice("window", window, ("rect", "hann"))
    oversample = check_int("oversample", oversample, lo=1, hi=4096)
    tau = check_real("correlation_time", correlation_time, lo=0.0, lo_open=True) if math.isfinite(
        correlation_time) else math.inf
    rho = 1.0 if math.isinf(tau) else math.exp(-1.0 / (check_real("sample_rate", sample_rate, lo=0.0, lo_open=True)
                                                        * tau))
    return _table(n_fft, window, float(rho), oversample), oversample


def line_shape(u, n_fft: int, window: str = "rect", correlation_time: float = math.inf, sample_rate: float = 50e6):
    """Line shape ``G(u)`` at offsets ``u`` [bins] (linear interpolation in the table)."""
    table, over = line_shape_table(n_fft, window, correlation_time, sample_rate)
    u = np.abs(np.mod(np.asarray(u, dtype=np.float64) + 0.5 * n_fft, n_fft) - 0.5 * n_fft)
    return np.interp(u * over, np.arange(table.size), table)


def fejer(u, n_fft: int):
    """Fejer kernel ``sin^2(pi u) / (N sin^2(pi u / N))`` (value N at integer multiples of N)."""
    u = np.asarray(u, dtype=np.float64)
    s = np.sin(np.pi * u / n_fft)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.sin(np.pi * u) ** 2 / (n_fft * s * s)
    return np.where(np.abs(s) < 1e-12, float(n_fft), out)


def speckle_looks(m_blocks: int, block_duration: float, correlation_time: float) -> float:
    """Effective number of independent blocks M_eff of an M-block average (see the module notes).

    Parameters
    ----------
    m_blocks : int
        Blocks averaged, M; >= 1.
    block_duration : float
        T_b = N / f_s [s]; > 0.
    correlation_time : float
        Speckle amplitude correlation time tau_c [s]; > 0 or inf.

    Returns
    -------
    float
        ``M / (1 + c)``, in [1, M].
    """
    m = check_int("m_blocks", m_blocks, lo=1)
    tb = check_real("block_duration", block_duration, lo=0.0, lo_open=True)
    if math.isinf(correlation_time) and correlation_time > 0:
        return 1.0
    tau = check_real("correlation_time", correlation_time, lo=0.0, lo_open=True)
    r = math.exp(-2.0 * tb / tau)
    if r == 0.0 or m == 1:
        return float(m)
    one_r = -math.expm1(-2.0 * tb / tau)
    c = 2.0 * (r / one_r - r * (-math.expm1(m * math.log(r))) / (m * one_r * one_r))
    return m / (1.0 + c)


def cnr_linear(cnr_db: float) -> float:
    """CNR in linear units from decibels (``10**(dB/10)``); dB in [-200, 200]."""
    return 10.0 ** (check_real("cnr_db", cnr_db, lo=-200.0, hi=200.0) / 10.0)


def expected_spectrum(instrument, vlos_es, weight_s, cnr_db: float, *, correlation_time: float = math.inf):
    """Expected averaged spectrum of each estimate: signal and noise parts.

    Parameters
    ----------
    instrument : Instrument
    vlos_es : array_like, shape (n_estimates, n_cells) or (n_cells,)
        Radial speed of each range cell during each estimate [m/s] (signed;
        held constant over the estimate).
    weight_s : array_like, shape (n_cells,)
        Beam weight of each cell [-]; >= 0, summing to 1 (the signal power
        is ``CNR * sum(weight_s)``).
    cnr_db : float
        Carrier-to-noise ratio [dB], defined in the module notes.
    correlation_time : float
        Speckle correlation time tau_c [s] (inf: frozen).

    Returns
    -------
    signal_ef : ndarray, shape (n_estimates, N/2 + 1)
        Expected signal part of the averaged periodogram [units of the noise floor].
    noise_f : ndarray, shape (N/2 + 1,)
        Expected noise floor (shot noise 1 plus RIN) [-].
    """
    from . import _kernels as K
    from .._config import apply_numba_threads

    v = _as_2d("vlos_es", vlos_es)
    w = _weights(weight_s, v.shape[1])
    cnr = cnr_linear(cnr_db)
    table, over = line_shape_table(instrument.n_fft, instrument.window, correlation_time, instrument.sample_rate)
    x = v / (instrument.speed_per_hz * instrument.bin_width)
    amp = np.broadcast_to(0.5 * cnr * w, v.shape).astype(np.float64)
    out = np.empty((v.shape[0], instrument.n_bins))
    apply_numba_threads()
    K.expected_signal_kernel(np.ascontiguousarray(x), np.ascontiguousarray(amp), table, over, instrument.n_fft, out)
    return out, noise_floor(instrument)


def sample_spectra(signal_ef, noise_f, m_blocks: int, m_eff: float, seed, *, n_estimates=None,
                   speckle: str = "coherent"):
    """Draw averaged spectra (tier 2): expected spectrum times the speckle and noise statistics.

    Parameters
    ----------
    signal_ef : array_like, shape (n_estimates, N/2 + 1) or (N/2 + 1,)
        Expected signal spectrum (from :func:`expected_spectrum`); one row is
        broadcast to ``n_estimates``.
    noise_f : array_like, shape (N/2 + 1,)
        Expected noise floor; > 0.
    m_blocks : int
        Blocks averaged, M.
    m_eff : float
        Effective independent looks of the signal, in [1, M] (:func:`speckle_looks`).
    seed : int or numpy.random.Generator
    n_estimates : int, optional
        Needed when ``signal_ef`` has one row.
    speckle : {'coherent', 'independent'}
        Signal gain common to all bins of an estimate, or one per bin.

    Returns
    -------
    ndarray, shape (n_estimates, N/2 + 1)
        Averaged periodograms (module convention of
        :mod:`cwlidar_sim.signal.processing`).
    """
    sig = np.asarray(signal_ef, dtype=np.float64)
    if sig.ndim == 1:
        sig = sig[None, :]
    if sig.ndim != 2:
        raise ValueError(f"signal_ef must be 1-D or 2-D, got shape {np.shape(signal_ef)}")
    if not np.all(np.isfinite(sig)) or np.any(sig < 0):
        raise ValueError("signal_ef must be finite and >= 0")
    nf = sig.shape[1]
    noise = np.asarray(noise_f, dtype=np.float64)
    if noise.shape != (nf,) or not np.all(np.isfinite(noise)) or np.any(noise <= 0):
        raise ValueError(f"noise_f must have shape ({nf},) with finite values > 0")
    m = check_int("m_blocks", m_blocks, lo=1)
    m_eff = check_real("m_eff", m_eff, lo=1.0, hi=float(m) * (1 + 1e-12))
    check_choice("speckle", speckle, ("coherent", "independent"))
    if n_estimates is None:
        ne = sig.shape[0]
    else:
        ne = check_int("n_estimates", n_estimates, lo=1)
        if sig.shape[0] not in (1, ne):
            raise ValueError(f"signal_ef has {sig.shape[0]} rows; allowed: 1 or n_estimates={ne}")
    key, gain = _speckle_draws(_rng(seed), ne, nf, m_eff, speckle)
    out = np.empty((ne, nf))
    _draw_rows(sig, noise, m, gain, key, 0, out)
    return out


def _speckle_draws(rng, ne, nf, m_eff, speckle):
    """Stream key of the per-bin normals and the signal gains, in the order sample_spectra draws them."""
    key = int(rng.integers(0, 2**63, dtype=np.int64))
    gshape = (ne, 1) if speckle == "coherent" else (ne, nf)
    return key, rng.gamma(m_eff, 1.0 / m_eff, size=gshape)


def _draw_rows(sig, noise, m, gain_eg, key, e0, out):
    """Rows e0 .. e0 + len(out) - 1 of a sample_spectra draw (gain_eg holds those rows only)."""
    from . import _kernels as K

    sig = np.ascontiguousarray(sig)
    gain_eg = np.ascontiguousarray(gain_eg)
    key = np.uint64(key)
    ne = out.shape[0]

    def run(t):
        K.spectral_sample_rows(sig, noise, gain_eg, float(m), key, e0, t * _ROWS_PER_TASK,
                               min(ne, (t + 1) * _ROWS_PER_TASK), out)

    _run_tasks(-(-ne // _ROWS_PER_TASK), run)


def _as_2d(name, a):
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] < 1:
        raise ValueError(f"{name} must have shape (n_estimates, n_cells) or (n_cells,), got {np.shape(a)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr


def _weights(weight_s, ns):
    w = np.asarray(weight_s, dtype=np.float64)
    if w.shape != (ns,):
        raise ValueError(f"weight_s must have shape ({ns},) to match the cells of vlos_es, got {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weight_s must be finite and >= 0")
    if not 0.0 < w.sum() <= 1.0 + 1e-9:
        raise ValueError(f"weight_s must sum to a value in (0, 1], got {w.sum()!r}")
    return w


# ---------------------------------------------------------------------------
# continuum speckle: sub-cell speed spread and per-bin looks (derived)
# ---------------------------------------------------------------------------
#: Largest block lag J kept by the continuum speckle model (lags beyond are
#: below :data:`_G_CUT` of the line's correlation, or the model is refused).
CONTINUUM_MAX_LAG = 16


def spread_frequency(instrument, speed_spread: float) -> float:
    """Doppler frequency spread ``sigma_f = 2 sigma_v / lambda`` [Hz] of a speed spread sigma_v [m/s]."""
    return check_real("speed_spread", speed_spread, lo=0.0, hi=100.0) / instrument.speed_per_hz


def line_correlation(instrument, speed_spread: float, correlation_time: float, n_lags: int) -> np.ndarray:
    """Correlation ``g(tau)`` of one cell's speckle amplitude at lags tau = 0 .. n_lags - 1 samples.

    ``g(tau) = exp(-2 pi^2 sigma_f^2 (tau / f_s)^2) exp(-|tau| / (f_s tau_c))``:
    the Gaussian factor is the sub-cell spread of speeds (a Gaussian
    distribution of Doppler shifts of standard deviation
    ``sigma_f = 2 sigma_v / lambda`` among the cell's scatterers), the
    exponential the transit of the scatterers across the waist.  Values
    below 1e-12 are set to 0.
    """
    fs = instrument.sample_rate
    sf = spread_frequency(instrument, speed_spread)
    t = np.arange(check_int("n_lags", n_lags, lo=1)) / fs
    lg = -2.0 * (math.pi * sf * t) ** 2
    if math.isfinite(correlation_time):
        lg = lg - t / correlation_time
    g = np.exp(lg)
    g[g < _G_CUT] = 0.0
    return g


def continuum_lags(instrument, speed_spread: float, correlation_time: float = math.inf):
    """Lags the continuum model needs: ``(t_max, J)``, the line's correlation is < 1e-12 from t_max on.

    ``J = ceil(t_max / N)`` block lags (the instrument's noise processes,
    :func:`noise_correlation`, have their own).  Raises ValueError when ``J`` would
    exceed ``CONTINUUM_MAX_LAG`` (a spread too narrow: use the
    'coherent' or 'independent' model).
    """
    fs = instrument.sample_rate
    sf = spread_frequency(instrument, speed_spread)
    cut = math.log(1.0 / _G_CUT)
    tmax = math.inf
    if sf > 0.0:
        tmax = fs * math.sqrt(cut / 2.0) / (math.pi * sf)
    if math.isfinite(correlation_time):
        tmax = min(tmax, fs * correlation_time * cut)
    n = instrument.n_fft
    if math.isinf(tmax) or tmax > CONTINUUM_MAX_LAG * n:
        raise ValueError(
            f"speed_spread={speed_spread!r} m/s with correlation_time={correlation_time!r} s keeps the speckle "
            f"correlated over more than {CONTINUUM_MAX_LAG} blocks; allowed: speed_spread >= "
            f"{fs * math.sqrt(cut / 2.0) / (math.pi * CONTINUUM_MAX_LAG * n) * instrument.speed_per_hz:.3g} m/s "
            "(or use speckle 'coherent' / 'independent')")
    t_max = max(1, int(math.ceil(tmax)))
    return t_max, int(math.ceil(t_max / n))


def _signal_lag_rows(instrument, vlos_es, amp_s, a_d, method: str = "gridded"):
    """Folded lag sequences of the exact expected signal spectrum (:func:`cwlidar_sim.signal.exact.signal_rows`).

    ``out[e, 0] = a_0 C(0)``, ``out[e, d] = a_d C(d) + a_{N-d} C(N-d)`` with ``C(d) = 2 sum_s amp_s
    cos(2 pi x_s d / N)``, ``x_s`` the cells' speeds in bins: the real DFT of a row is ``S_k =
    sum_{|d|<N} a_|d| C(d) exp(-i 2 pi k d / N)``.  'exact' gives the bits of
    ``_kernels.lag_sequence_kernel`` (the same recurrence, sums and fold); 'gridded'
    the cosine sums of :func:`continuum_moments`'s gridded method (within ~1e-13 of ``C(0)``).

    Parameters
    ----------
    instrument : Instrument
    vlos_es : ndarray, shape (n_estimates, n_cells)
        Cell speeds [m/s].
    amp_s : ndarray, shape (n_cells,)
        ``CNR w_s / 2`` [-].
    a_d : ndarray, shape (N,)
        Lag coefficients (:func:`lag_coefficients`).
    method : {'exact', 'gridded'}

    Returns
    -------
    ndarray, shape (n_estimates, N)
    """
    from . import _kernels as K

    check_choice("method", method, ("exact", "gridded"))
    n = instrument.n_fft
    x = np.ascontiguousarray(np.asarray(vlos_es, dtype=np.float64) / instrument.bin_speed)
    amp = np.ascontiguousarray(amp_s, dtype=np.float64)
    a_d = np.ascontiguousarray(a_d, dtype=np.float64)
    ne = x.shape[0]
    lags = np.empty((ne, 1, n))
    ones = np.ones(2 * n)
    if method == "exact":
        def fold(t):
            K.continuum_lag_rows(x, amp, ones, a_d, n, n, t * _ROWS_PER_TASK, min(ne, (t + 1) * _ROWS_PER_TASK),
                                 np.empty(2 * n), lags)

        _run_tasks(-(-ne // _ROWS_PER_TASK), fold)
    else:
        def keep(lo, hi, lags_rjn):
            lags[lo:hi] = lags_rjn

        gridded_lag_tasks(x, amp, ones, a_d, n, n, 1, keep, transform=False)
    return lags.reshape(ne, n)


def continuum_moments(instrument, vlos_es, weight_s, cnr_db: float, speed_spread: float, *,
                      correlation_time: float = math.inf, cnr_gain_e=None, method: str = "gridded"):
    """Mean and variance of every bin of every estimate's M-block average, and the signal's looks (tier 2).

    Model (the cells of :mod:`cwlidar_sim.signal.spectral`, each a continuum
    of scatterers): the complex signal of cell s has correlation
    ``E|a_s|^2 exp(i theta_s tau) g(tau)`` (:func:`line_correlation`), so
    given the cell speeds the detector signal is a Gaussian process.  The
    DFT of block b at bin k then has block-lag correlation

    ``c_k(j) = sum_{|d|<N} (R_w(d) / R_w(0)) g(jN + d) C(jN + d) exp(-i 2 pi k d / N)``,
    ``C(tau) = sum_s CNR w_s cos(theta_s tau)``

    (j = 0 gives the expected spectrum ``S_k``; the homodyne mirror is in
    the cosine), and the average of M blocks of signal plus noise ``n_k``
    (shot noise, RIN and reflection: :func:`noise_correlation`) has mean
    ``S_k + n_k`` and variance

    ``[(S_k + n_k)^2 + 2 sum_{j>=1} (1 - j/M) |c_k(j) + c^noise_k(j)|^2] / M``

    (twice that at 0 Hz and Nyquist).  The looks of the signal,
    ``M_k = M S_k^2 / (S_k^2 + 2 sum_j (1 - j/M) |c_k(j)|^2)``, are set by how
    fast the bin decorrelates: the scatterers inside a bin's window have
    Doppler shifts spread over the sub-cell distribution and over the cells
    that fall in the bin, and dephase within about ``1 / (2 pi sigma_f)``
    (1.3 us for 0.11 m/s), a fraction of a 10 us block; the transit across
    the waist (ms) hardly matters then.  Because a cell is a continuum, the
    result converges as the beam is cut finer (the sub-cell spread shrinks
    as the cells resolve more of the field).

    Parameters
    ----------
    instrument : Instrument
    vlos_es : array_like, shape (n_estimates, n_cells) or (n_cells,)
        Cell speeds [m/s] (signed).
    weight_s : array_like, shape (n_cells,)
        Beam weights [-].
    cnr_db : float
        Wideband CNR [dB].
    speed_spread : float
        Sub-cell speed standard deviation sigma_v [m/s]; see :func:`continuum_lags`
        for the smallest allowed.
    correlation_time : float
        Transit correlation time tau_c [s] (inf: none).
    cnr_gain_e : array_like, shape (n_estimates,), optional
        Per-estimate factor on the signal power (aerosol load varying over
        a record); > 0.
    method : {'gridded', 'exact'}
        How the cells' cosine sums ``C(tau)`` are computed: 'gridded' (the
        default), the cells spread on a grid of ``M >= 4 t_max`` angles by a
        Gaussian of ``GRID_HALF_WIDTH`` points, one real FFT of length M
        and the Gaussian divided out (type-1 non-uniform FFT, Greengard &
        Lee 2004), ``O(cells + M log M)``; 'exact', the Chebyshev recurrence
        per cell, ``O(cells x t_max)`` per estimate (the reference the tests
        hold 'gridded' to). ``C`` agrees within about 1e-13 of ``C(0)`` (the
        exact method's own rounding is about 3e-14), so the moments agree to
        rounding but not bit for bit; 'gridded' is 1.3-2.5x faster from 4 to
        360 cells (benchmarks/bench_subbin.py).

    Returns
    -------
    mean_ef, var_ef, looks_ef : ndarray, shape (n_estimates, N/2 + 1)
        Mean [-] and variance [-] of each averaged periodogram bin, and the
        signal's effective number of independent blocks [-] (M where there
        is no signal).
    """
    from . import _kernels as K

    v = _as_2d("vlos_es", vlos_es)
    w = _weights(weight_s, v.shape[1])
    cnr = cnr_linear(cnr_db)
    check_choice("method", method, ("exact", "gridded"))
    t_max, n_j, g, r_d = _continuum_setup(instrument, speed_spread, correlation_time)
    n = instrument.n_fft
    x = np.ascontiguousarray(v / instrument.bin_speed)
    amp = np.ascontiguousarray(0.5 * cnr * w)
    ne = x.shape[0]
    nt = -(-ne // _ROWS_PER_TASK)

    def fold(t):
        K.continuum_lag_rows(x, amp, g, r_d, n, min(t_max, (n_j + 1) * n), t * _ROWS_PER_TASK,
                             min(ne, (t + 1) * _ROWS_PER_TASK), np.empty((n_j + 2) * n), lags)

    if method == "exact":
        lags = np.empty((ne, n_j + 1, n))
        _run_tasks(nt, fold)
        return _lag_moments(instrument, lags, cnr_gain_e)
    # gridded: every stage of a task of estimates in the worker's cache (signal._gridded)
    gain = _check_gain(cnr_gain_e, ne)
    fn, tail, noise, mb, mean, var, looks = _moment_setup(instrument, ne, n_j + 1)

    def moments(lo, hi, f_rjk):
        if gain is not None:
            f_rjk *= gain[lo:hi, None, None]
        K.continuum_moment_rows(f_rjk, fn, tail, noise, mb, 0, hi - lo, mean[lo:hi], var[lo:hi], looks[lo:hi])

    gridded_lag_tasks(x, amp, g, r_d, n, min(t_max, (n_j + 1) * n), n_j + 1, moments)
    return mean, var, looks


def _continuum_setup(instrument, speed_spread, correlation_time):
    """``(t_max, J, g, r_d)`` of continuum_moments: lags, the line's correlation (0 from t_max on), window lags."""
    t_max, n_j = continuum_lags(instrument, speed_spread, correlation_time)
    n = instrument.n_fft
    g = line_correlation(instrument, speed_spread, correlation_time, (n_j + 2) * n)
    g[t_max:] = 0.0
    return t_max, n_j, g, _window_lags(instrument)


def _lag_moments(instrument, lags, cnr_gain_e=None):
    """Mean, variance and looks of continuum_moments from the folded lag sequences ``lags[e, j, :]``."""
    from . import _kernels as K
    from .._fft import rfft_rows

    ne, nj1, n = lags.shape
    nt = -(-ne // _ROWS_PER_TASK)
    c = _check_gain(cnr_gain_e, ne)
    if c is not None:
        lags *= c[:, None, None]
    f = rfft_rows(lags.reshape(ne * nj1, n)).reshape(ne, nj1, n // 2 + 1)
    fn, tail, noise, m, mean, var, looks = _moment_setup(instrument, ne, nj1)

    def mom(t):
        K.continuum_moment_rows(f, fn, tail, noise, m, t * _ROWS_PER_TASK, min(ne, (t + 1) * _ROWS_PER_TASK), mean, var,
                                looks)

    _run_tasks(nt, mom)
    return mean, var, looks


def _moment_setup(instrument, ne, nj1):
    """What the continuum moments of ``ne`` estimates with ``nj1`` block lags need besides the lags: the folded
    noise, its tail beyond those lags, the noise floor, M, and the mean, variance and looks to fill."""
    from . import _kernels as K

    fn = _fold_noise(instrument)
    m = float(instrument.blocks_per_estimate)
    tail = np.empty(instrument.n_bins)
    K.noise_tail(fn, nj1, m, tail)
    mean = np.empty((ne, instrument.n_bins))
    return fn, tail, noise_floor(instrument), m, mean, np.empty_like(mean), np.empty_like(mean)


def _check_gain(cnr_gain_e, ne):
    if cnr_gain_e is None:
        return None
    c = np.asarray(cnr_gain_e, dtype=np.float64)
    if c.shape != (ne,) or not np.all(np.isfinite(c)) or np.any(c <= 0):
        raise ValueError(f"cnr_gain_e must have shape ({ne},) with finite values > 0")
    return c


def sample_moments(mean_ef, var_ef, seed, *, e0: int = 0):
    """Draw averaged spectra with the given per-bin mean and variance (two-moment Gamma, continuum speckle).

    Each bin is independent of the others (the periodogram bins of a
    spectrum smooth on the scale of a bin are nearly uncorrelated for the
    rectangular window) and drawn as the Wilson-Hilferty cube of a
    counter-based normal: exact mean and variance, Gamma skewness.

    Parameters
    ----------
    mean_ef, var_ef : array_like, shape (n_estimates, N/2 + 1)
        From :func:`continuum_moments`; mean > 0, var >= 0.
    seed : int or numpy.random.Generator
        Or a uint64 stream key (from ``_speckle_key``).
    e0 : int
        Global index of the first row (rows use the counter-based streams
        ``e0 ..``, so a record may be drawn in chunks).

    Returns
    -------
    ndarray, shape (n_estimates, N/2 + 1)
    """
    from . import _kernels as K

    mean = np.ascontiguousarray(mean_ef, dtype=np.float64)
    var = np.ascontiguousarray(var_ef, dtype=np.float64)
    if mean.ndim != 2 or var.shape != mean.shape:
        raise ValueError(f"mean_ef and var_ef must be 2-D of one shape, got {mean.shape} and {var.shape}")
    if not (np.all(np.isfinite(mean)) and np.all(mean > 0) and np.all(np.isfinite(var)) and np.all(var >= 0)):
        raise ValueError("mean_ef must be finite and > 0, var_ef finite and >= 0")
    key = np.uint64(seed) if isinstance(seed, np.uint64) else np.uint64(
        int(_rng(seed).integers(0, 2**63, dtype=np.int64)))
    ne = mean.shape[0]
    out = np.empty_like(mean)

    def run(t):
        K.gamma_moment_rows(mean, var, key, int(e0), t * _ROWS_PER_TASK, min(ne, (t + 1) * _ROWS_PER_TASK), out)

    _run_tasks(-(-ne // _ROWS_PER_TASK), run)
    return out
