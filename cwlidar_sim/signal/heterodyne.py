"""Tier 3 (`signal`): the real heterodyne signal at the sampling rate, block FFTs, averaged periodograms.

The signal model, the CNR definition and the spectrum convention are those of
:mod:`cwlidar_sim.signal.spectral` (module notes): one complex-Gaussian
speckle amplitude per range cell with ``E|a_s|^2 = 2 CNR w_s``, AR(1)
decorrelation with time ``tau_c``, Doppler phase ``2 pi f_s' n / f_s`` from the
cell's radial speed, the real part (homodyne), plus unit-variance white
Gaussian shot noise.  Samples are cut into blocks of N, windowed, transformed
by FFTW (``cwlidar_sim._fft.RowsRFFT``) and ``|X_k|^2 / sum w_n^2`` is
averaged over the M blocks of each estimate.  This tier is the reference for
tier 2.

Implementation notes
--------------------
* The amplitude of a cell is held constant over sub-steps of ``L`` samples,
  ``L`` the largest divisor of N with ``L / f_s <= tau_c / 32`` (``L = N``, one
  value per block, whenever ``tau_c >= 32 T_b``, e.g. 0.33 ms for the
  prototype); it follows the AR(1) recursion from step to step with
  coefficient ``exp(-L / (f_s tau_c))``.  Tier 2's line shape assumes a
  per-sample AR(1); the two differ by O(L / (f_s tau_c)) in the broadening of
  the line, i.e. not at all in the frozen-speckle regime of real lidars.
* Fused and cache-resident: a task is a run of ``_task_blocks`` blocks of
  one estimate (64 for N = 512).  A thread synthesises them straight into its
  own FFT input buffer, transforms them with a plan bound to that buffer and
  sums ``|X_k|^2`` in float64; an estimate's partial sums are added in task
  order.  Tasks are handed out one at a time to the package's threads
  (``processing._run_tasks`` on ``_fft.run_dynamic``), so a core taken by another process slows the
  run down to the cores left instead of stalling it.
* Samples (``_kernels.synth_blocks_kernel``): per block, the shot noise from
  the block's counter-based stream (splitmix64 words, inverse-CDF table
  normals, ``_kernels.block_normals_tab2``: tier 2's table in the centre,
  second-level tables in the tails beyond |z| = 2.66 instead of Acklam's
  formula); the tones as sums over cells of
  ``c_s cos(theta_s n) - d_s sin(theta_s n)``, ``c_s + i d_s = a_s exp(i
  phi_s)`` the cell's amplitude times its phasor at the block's start, from
  per-estimate tables of ``cos/sin(theta_s n)``, n < N, and of the blocks'
  phasors (``_tone_tables``, each entry a product of two or three factors
  from cos/sin of their own angles,
  so no error grows along a block or an estimate).  The tones are summed in
  float32, four cells per pass over the block (a loop that vectorises eight
  samples wide), and added to the float64 noise before the single rounding
  of each sample to float32: their rounding (6e-8 of the tones' amplitude)
  is that of the float32 samples and FFT themselves.  Amplitudes: one AR(1)
  stream per cell (a task per cell).
* The result does not depend on the number of threads, on the chunking or
  on the scheduling: every block and every partial sum depends on its own
  indices only.
* Random streams: the speckle amplitudes are those of the earlier versions;
  the shot noise is drawn by the table method since the fused path replaced
  Marsaglia's polar method (same seed, different noise samples; same law).
* The speed of a cell is held constant over an estimate (the Doppler phase
  is continuous across estimates).
* The noise above shot noise (RIN, the 0 Hz reflection: real AR(1)
  processes of variance ``var_c`` and coefficient ``rho_c``,
  :func:`cwlidar_sim.signal.noise.noise_correlation`) is not drawn from
  normals of its own: shot noise plus the components is a stationary
  Gaussian process of spectrum ``1 + sum_c var_c (1 - rho_c^2) / |1 - rho_c
  e^{-i w}|^2``, which is exactly that of ``y = a0 z + sum_c u_c``,
  ``u_c[n] = rho_c u_c[n-1] + b_c z[n]``, driven by the shot-noise normals
  ``z`` themselves (:func:`noise_filter`: the innovations form of the
  process, from the steady-state Kalman filter).  The filter runs inside
  the fused synthesis (``_kernels.colour_noise_block``, a blocked scan),
  its state carried from block to block through an estimate and drawn from
  its stationary law at the estimate's first block, so that each estimate
  is an exact stationary sample, as before.  The law of every sample is that
  of independent shot noise, RIN and reflection; the draws are not those of
  the separate AR(1) streams of earlier versions (same seed, other
  samples; tests/signal/test_noise_colour.py checks the spectrum and the
  estimates statistically).  Because the state runs through an estimate,
  the tasks of one estimate synthesise in order (``_InOrder``; their
  FFTs and sums still overlap), which does not change any bit.
* Continuum cells (``speed_spread > 0``: the sub-cell spread of
  docs/signal_chain.md) and the noise above shot noise are one Gaussian
  process given the speeds; it is synthesised per estimate from its
  spectrum (``_Continuum``: the DFT of its correlation on a circular
  length ``P >= M N + t_max``, random phases, one inverse FFT of length P)
  and its real part is added to the samples before the window.  Its cost
  does not grow with the number of cells; its randomness is a third stream
  of the seed, drawn only when needed (runs without it keep their earlier
  bits).
"""

from __future__ import annotations

import contextlib
import functools
import math
import queue
import threading

import numpy as np

from .._validation import check_int
from ._tasks import _rng, _run_tasks
from .noise import _noise_components, _noise_lag_count, noise_correlation, window_samples
from .spectral import _as_2d, _weights, cnr_linear

__all__ = ["simulate_signal_spectra", "synthesize_samples", "substep_length", "noise_filter"]


def substep_length(n_fft: int, sample_rate: float, correlation_time: float) -> int:
    """Samples per speckle sub-step: the largest divisor L of N with L / f_s <= tau_c / 32."""
    if math.isinf(correlation_time):
        return n_fft
    for L in range(n_fft, 0, -1):
        if n_fft % L == 0 and L / sample_rate <= correlation_time / 32.0:
            return L
    return 1


def noise_filter(instrument):
    """Coefficients that colour unit white noise into shot noise plus RIN plus reflection (exact law).

    With ``rho_c = exp(-2 pi f_c / f_s)`` and ``var_c = P0_c (1 - rho_c) /
    (1 + rho_c)`` for each component of
    :func:`cwlidar_sim.signal.noise.noise_correlation` (corners that give the
    same ``rho`` are one component), the process ``y = a0 z + sum_c u_c``,
    ``u_c[n] = rho_c u_c[n-1] + b_c z[n]``, ``z`` unit white noise, has the
    correlation ``delta(tau) + sum_c var_c rho_c^|tau|`` of independent shot
    noise and components.  ``(a0, b)`` are the innovations form of that
    process: ``b = k sqrt(S)``, ``a0 = (1 - sum k) sqrt(S)``, with ``k = P 1
    / S`` and ``S = 1 + 1' P 1`` from the steady-state Kalman filter of the
    components observed in shot noise (``P`` the solution of the discrete
    Riccati equation), polished by Newton's method on the correlation
    equations ``a0 (a0 + sum_c b_c) = 1``, ``b_i (a0 + sum_j b_j / (1 - rho_i
    rho_j)) = var_i`` to a relative residual below 1e-12.

    Parameters
    ----------
    instrument : Instrument

    Returns
    -------
    cf_8 : ndarray, shape (8,)
        ``(a0, b_1, b_2, rho_1, rho_2, L00, L10, L11)`` [-]: a single
        component has ``b_2 = rho_2 = 0``; ``L`` is the Cholesky factor of the
        states' stationary covariance ``b_i b_j / (1 - rho_i rho_j)``.
        Empty (shape (0,)) without RIN and reflection.
    """
    comps = tuple(_noise_components(instrument))
    if not comps:
        return np.zeros(0)
    return _filter_coefficients(comps, float(instrument.sample_rate)).copy()


@functools.lru_cache(maxsize=32)
def _filter_coefficients(comps, fs):
    from scipy.linalg import solve_discrete_are

    merged = {}
    for p0, fc in comps:
        r = math.exp(-2.0 * math.pi * fc / fs)
        merged[r] = merged.get(r, 0.0) + p0 * (1.0 - r) / (1.0 + r)
    rho = np.array(sorted(merged, reverse=True))
    var = np.array([merged[r] for r in rho])
    c = rho.size
    kmat = 1.0 / (1.0 - np.outer(rho, rho))
    one = np.ones((c, 1))
    p = solve_discrete_are(np.diag(rho), one, np.diag(var * (1.0 - rho) * (1.0 + rho)), np.ones((1, 1)))
    s = 1.0 + float((one.T @ p @ one)[0, 0])
    k = (p @ one)[:, 0] / s
    x = np.concatenate([[(1.0 - k.sum()) * math.sqrt(s)], k * math.sqrt(s)])

    def residual(x):
        a0, b = x[0], x[1:]
        g = a0 + kmat @ b
        return np.concatenate([[a0 * (a0 + b.sum()) - 1.0], b * g - var]), g

    for _ in range(4):
        f, g = residual(x)
        a0, b = x[0], x[1:]
        jac = np.zeros((c + 1, c + 1))
        jac[0, 0] = 2.0 * a0 + b.sum()
        jac[0, 1:] = a0
        jac[1:, 0] = b
        jac[1:, 1:] = np.diag(g) + b[:, None] * kmat
        x = x - np.linalg.solve(jac, f)
    f, _ = residual(x)
    if not (np.all(np.isfinite(x)) and np.max(np.abs(f)) <= 1e-12 * (1.0 + var.sum())):
        raise ValueError(f"rin_*/reflection_* = {comps!r} at sample_rate={fs!r}: the noise filter did not converge "
                         f"(residual {np.max(np.abs(f))!r}); allowed: levels and corners whose processes differ")
    a0, b = float(x[0]), np.concatenate([x[1:], np.zeros(2 - c)])
    r2 = np.concatenate([rho, np.zeros(2 - c)])
    cov = np.outer(b, b) / (1.0 - np.outer(r2, r2))
    l00 = math.sqrt(cov[0, 0])
    l10 = cov[1, 0] / l00 if l00 > 0.0 else 0.0
    l11 = math.sqrt(max(0.0, cov[1, 1] - l10 * l10))
    out = np.array([a0, b[0], b[1], r2[0], r2[1], l00, l10, l11])
    out.setflags(write=False)
    return out


def _filter_powers(cf_8, n_fft):
    """``pw[c, k] = rho_c^(k + 1)``, k < N, by repeated multiplication (the powers colour_noise_block uses)."""
    pw = np.empty((2, n_fft))
    for c in range(2):
        pw[c] = np.cumprod(np.full(n_fft, cf_8[3 + c]))
    return pw


class _InOrder:
    """Lets task (e, r) synthesise only after task (e, r - 1) has: the coloured noise's state runs through an estimate.

    Tasks are numbered r-major (all estimates' first tasks, then their
    second ones, ...), so a task waits only for one numbered before it,
    which a running thread already holds: no deadlock, and a single thread
    runs them in order without waiting.  A task that fails wakes the waiting
    ones, which then fail too.
    """

    def __init__(self, n_estimates, ordered):
        self.ordered = ordered
        self.next_r = [0] * n_estimates
        self.cond = threading.Condition()
        self.failed = False

    @contextlib.contextmanager
    def turn(self, e, r):
        if not self.ordered:
            yield
            return
        with self.cond:
            self.cond.wait_for(lambda: self.failed or self.next_r[e] == r)
            if self.failed:
                raise RuntimeError("an earlier task of the same estimate failed")
        try:
            yield
        except BaseException:
            with self.cond:
                self.failed = True
                self.cond.notify_all()
            raise
        with self.cond:
            self.next_r[e] = r + 1
            self.cond.notify_all()


class _Continuum:
    """Gaussian-process part of a run synthesised from its spectrum, one estimate at a time.

    The continuum signal (cells with a sub-cell speed spread) and the noise
    above shot noise (RIN, reflection) form, given the cell speeds, a
    stationary Gaussian process of known correlation: that of
    :func:`_kernels.continuum_correlation_fill`.  An estimate's M N samples
    are the first M N of a circular process of length ``P >= M N + T``
    (``T`` the lags beyond which the correlation is < 1e-12, so the
    wrap-around leaves the samples' joint law exact to that level), drawn
    as the inverse FFT of ``sqrt(S_m / 2P) (z0 + i z1)``, ``S_m`` the DFT of
    the correlation; its real part is added to the samples.
    """

    def __init__(self, instrument, v_es, w_s, cnr, spread, tau, key):
        from scipy.fft import next_fast_len

        from .spectral import continuum_lags, line_correlation

        self.inst = instrument
        self.key = key
        t = max(int(math.ceil(_noise_lag_count(instrument))) + 1, continuum_lags(instrument, spread, tau)[0])
        self.t_max = t
        self.g = line_correlation(instrument, spread, tau, t)
        self.rn = noise_correlation(instrument, t)
        self.x_es = np.ascontiguousarray(v_es / instrument.bin_speed)
        self.amp2_s = np.ascontiguousarray(2.0 * cnr * w_s)
        self.n_samples = instrument.blocks_per_estimate * instrument.n_fft
        self.P = int(next_fast_len(self.n_samples + t))

    def fill(self, w, e, out_t):
        """The real samples of estimate e into ``out_t`` (``w`` a :class:`_Scratch`)."""
        from . import _kernels as K

        line = w.line(self.P)
        K.continuum_correlation_fill(self.x_es[e], self.amp2_s, self.g, self.rn, self.inst.n_fft, self.t_max, line.x)
        line.forward()
        K.continuum_shape_noise(np.uint64(self.key), e, line.x, w.cwords, w.ctails, w.ctmp)
        line.backward()
        K.real_part_into(line.x, self.n_samples, out_t)


class _Synth:
    """State of one tier-3 run: keys, AR(1) carry-over and Doppler phases."""

    def __init__(self, instrument, vlos_es, weight_s, cnr_db, seed, correlation_time, speed_spread=0.0):
        from .._validation import check_real

        tau = float(correlation_time)
        if not (tau > 0):
            raise ValueError(f"correlation_time={correlation_time!r} must be > 0 s (or inf)")
        spread = check_real("speed_spread", speed_spread, lo=0.0, hi=100.0)
        self.inst = instrument
        self.v = _as_2d("vlos_es", vlos_es)
        self.w = _weights(weight_s, self.v.shape[1])
        self.cnr = cnr_linear(cnr_db)
        rng = _rng(seed)
        self.key_noise, self.key_amp = (int(k) for k in rng.integers(0, 2**63, size=2, dtype=np.int64))

        self.cont = None
        self.key_c = 0
        self.cf = np.zeros(0)
        if spread > 0.0 or _noise_components(instrument):
            # the third key: the continuum's random phases, or the coloured noise's stationary starts
            self.key_c = int(rng.integers(0, 2**63, dtype=np.int64))
            if spread > 0.0:
                self.cont = _Continuum(instrument, self.v, self.w, self.cnr, spread, tau, self.key_c)
            else:
                self.cf = noise_filter(instrument)
        self.pw = _filter_powers(self.cf, instrument.n_fft) if self.cf.size else np.zeros((2, 0))
        self.coloured = self.cf.size > 0
        # cells with a sub-cell spread are in the continuum: no tones
        self.v_tones = self.v[:, :0] if spread > 0.0 else self.v
        n, fs = instrument.n_fft, instrument.sample_rate
        self.L = substep_length(n, fs, tau)
        self.n_sub = n // self.L
        self.rho = 1.0 if math.isinf(tau) else math.exp(-self.L / (fs * tau))
        ns = self.v_tones.shape[1]
        self.std_s = np.sqrt(2.0 * self.cnr * self.w[:ns])
        self.last_re = np.zeros(ns)
        self.last_im = np.zeros(ns)
        self.dtheta_es = 2.0 * np.pi * (self.v_tones / instrument.speed_per_hz) / fs
        m = instrument.blocks_per_estimate
        # Doppler phase of each cell at the start of each estimate, continuous across estimates
        adv = np.mod(self.dtheta_es * (n * m), 2.0 * np.pi)
        self.phase_es = np.mod(np.concatenate([np.zeros((1, ns)), np.cumsum(adv, axis=0)[:-1]]), 2.0 * np.pi)
        self.win = window_samples(n, instrument.window)
        self.use_window = instrument.window != "rect"

    def chunk_size(self, chunk_samples):
        """Estimates per chunk: about ``chunk_samples`` samples, or as many speckle amplitudes."""
        m, n = self.inst.blocks_per_estimate, self.inst.n_fft
        return max(1, chunk_samples // (m * max(n, self.n_sub * self.v_tones.shape[1])))

    def chunk(self, e0, e1, run):
        """Inputs of :func:`_kernels.synth_blocks_kernel` for estimates e0..e1-1 (chunks in order only).

        ``run(n_tasks, fn)`` runs ``fn(worker, task)`` on the pool; the
        speckle amplitudes of the cells are independent tasks (each carries
        its cell's AR(1) state over from the previous chunk).
        """
        from . import _kernels as K

        inst = self.inst
        m = inst.blocks_per_estimate
        ne = e1 - e0
        nt = ne * m * self.n_sub
        ns = self.v_tones.shape[1]
        step0 = e0 * m * self.n_sub
        are = np.empty((ns, nt))
        aim = np.empty((ns, nt))
        key = np.uint64(self.key_amp)

        def cell(w, s):
            K.ar1_cell(key, s, step0, self.rho, self.std_s[s], self.last_re[s], self.last_im[s], are[s], aim[s])

        run(ns, cell)
        if nt:
            self.last_re = are[:, -1].copy()
            self.last_im = aim[:, -1].copy()
        tab, ph_re, ph_im = _tone_tables(self.phase_es[e0:e1], self.dtheta_es[e0:e1], inst.n_fft, m, run)
        if self.cont is None:
            extra = np.empty((0, 0))
        else:
            extra = np.empty((ne, self.cont.n_samples))
            run(ne, lambda w, i: self.cont.fill(w, e0 + i, extra[i]))
        return (np.uint64(self.key_noise), e0 * m, m, self.n_sub, are, aim, tab, ph_re, ph_im, 1.0, self.win,
                self.use_window, extra, np.uint64(self.key_c), e0, self.cf, self.pw)


def _tone_tables(phase_es, dtheta_es, n_fft, m_blocks, run=None):
    """Inputs of the tones in :func:`_kernels.synth_blocks_kernel`: per estimate, tables and block phasors.

    ``tab[e, g, k, n]`` (float32) holds ``cos(theta_s n)``, ``sin(theta_s n)``
    of the cells of group g (:data:`_kernels.TONE_CELLS` per group, the last
    one padded with silent cells) and ``ph_*[e, i, s]`` the phasor ``exp(i
    (phase_es[e, s] + theta_s N i))`` of block i (:func:`_kernels.tone_tables_kernel`).
    ``run(n_tasks, fn)`` runs ``fn(worker, e)`` for each estimate (default: in turn).
    """
    from . import _kernels as K

    ne, ns = dtheta_es.shape
    ng = (ns + K.TONE_CELLS - 1) // K.TONE_CELLS
    tab = np.empty((ne, ng, 2 * K.TONE_CELLS, n_fft), dtype=np.float32)
    ph_re = np.empty((ne, m_blocks, K.TONE_CELLS * ng))
    ph_im = np.empty((ne, m_blocks, K.TONE_CELLS * ng))

    def one(w, e):
        K.tone_tables_kernel(np.ascontiguousarray(phase_es[e]), np.ascontiguousarray(dtheta_es[e]), n_fft, tab[e],
                             ph_re[e], ph_im[e])

    if ns:
        if run is None:
            for e in range(ne):
                one(None, e)
        else:
            run(ne, one)
    return tab, ph_re, ph_im


def _task_blocks(n_fft: int) -> int:
    """Blocks per task: a worker's unit of synthesis, FFT and partial power sum.

    Fixed by N alone (about 32k samples, so a task's buffers stay in the
    core's cache), which makes the summation order, and so the result,
    independent of the thread count and of the chunking.
    """
    return max(1, 32768 // n_fft)


class _Scratch:
    """Per-thread scratch of the fused path: FFT buffers and plans, synthesis scratch."""

    def __init__(self, n_fft):
        from .._fft import RowsRFFT

        self.fft = RowsRFFT(_task_blocks(n_fft), n_fft, np.float32)
        self.acc = np.empty(n_fft)
        self.words = np.empty((n_fft + 1) // 2, dtype=np.uint64)
        self.tails = np.empty(n_fft, dtype=np.int64)
        self._line = None
        self.ctmp = np.empty(4096)
        self.cwords = np.empty(2048, dtype=np.uint64)
        self.ctails = np.empty(4096, dtype=np.int64)

    def line(self, p):
        """A :class:`_fft.LineC2C` of length p (made on first use, kept for the run)."""
        if self._line is None or self._line.x.shape[0] != p:
            from .._fft import LineC2C

            self._line = LineC2C(p)
        return self._line


class _Runner:
    """Runs tasks on the signal chain's threads, lending each task a scratch (made as needed, then reused)."""

    def __init__(self, n_fft):
        self.n_fft = n_fft
        self.free = queue.SimpleQueue()

    def run(self, n_tasks, fn):
        """Call ``fn(scratch, t)`` for t < n_tasks (see :func:`processing._run_tasks`)."""

        def one(t):
            try:
                w = self.free.get_nowait()
            except queue.Empty:
                w = _Scratch(self.n_fft)
            try:
                fn(w, t)
            finally:
                self.free.put(w)

        _run_tasks(n_tasks, one)


def synthesize_samples(instrument, vlos_es, weight_s, cnr_db: float, seed, *, correlation_time: float = math.inf,
                       speed_spread: float = 0.0):
    """The real detector signal of every estimate, in blocks (for inspection and tests).

    These are exactly the samples that :func:`simulate_signal_spectra`
    transforms for the same arguments.

    Parameters
    ----------
    instrument : Instrument
    vlos_es : array_like, shape (n_estimates, n_cells) or (n_cells,)
        Radial speed of each range cell in each estimate [m/s].
    weight_s : array_like, shape (n_cells,)
        Beam weights [-], summing to at most 1.
    cnr_db : float
        Carrier-to-noise ratio [dB] (total signal power over noise power in 0..f_s/2).
    seed : int or numpy.random.Generator
    correlation_time : float
        Speckle correlation time [s] (inf: frozen).
    speed_spread : float
        Sub-cell speed spread sigma_v [m/s] (0: point-like cells, each a
        tone with AR(1) speckle); > 0 makes every cell a continuum of
        scatterers (``_Continuum``).

    Returns
    -------
    ndarray, float32, shape (n_estimates * M, N)
        Windowed samples, in units of the shot-noise standard deviation.
    """
    from . import _kernels as K

    st = _Synth(instrument, vlos_es, weight_s, cnr_db, seed, correlation_time, speed_spread)
    m, n = instrument.blocks_per_estimate, instrument.n_fft
    ne = st.v.shape[0]
    out = np.empty((ne * m, n), dtype=np.float32)
    rows = _task_blocks(n)
    n_r = (m + rows - 1) // rows
    pool = _Runner(n)
    args = st.chunk(0, ne, pool.run)
    order = _InOrder(ne, st.coloured)
    state = np.zeros((ne, 2))

    def task(w, t):
        r, e = divmod(t, ne)
        b_lo = e * m + r * rows
        b_hi = min((e + 1) * m, b_lo + rows)
        with order.turn(e, r):
            K.synth_blocks_kernel(*args[:2], b_lo, b_hi, *args[2:], state[e], w.acc, w.words, w.tails,
                                  out[b_lo:b_hi])

    pool.run(ne * n_r, task)
    return out


def simulate_signal_spectra(instrument, vlos_es, weight_s, cnr_db: float, seed, *,
                            correlation_time: float = math.inf, chunk_samples: int = 1 << 22,
                            speed_spread: float = 0.0):
    """Averaged periodogram of each estimate from the synthesised 50 MHz signal (tier 3).

    Parameters
    ----------
    instrument, vlos_es, weight_s, cnr_db, seed, correlation_time, speed_spread
        As in :func:`synthesize_samples`.
    chunk_samples : int
        Bounds memory: estimates are prepared (speckle amplitudes, phases) a
        chunk of about this many samples, or as many amplitudes, at a time
        (whole estimates, at least one); does not change the result.

    Returns
    -------
    ndarray, shape (n_estimates, N/2 + 1)
        ``mean_b |X_k|^2 / sum_n w_n^2`` (units of the noise floor; see
        :mod:`cwlidar_sim.signal.processing`).

    Notes
    -----
    Each estimate's M blocks are cut into tasks of ``_task_blocks``
    blocks; a worker thread synthesises a task's blocks into its FFT
    buffer, transforms them (FFTW, one thread) and sums ``|X_k|^2`` over
    them in float64; the partial sums of an estimate are then added in task
    order.  The bits depend on neither the thread count nor the chunking.
    """
    from . import _kernels as K

    chunk_samples = check_int("chunk_samples", chunk_samples, lo=1)
    st = _Synth(instrument, vlos_es, weight_s, cnr_db, seed, correlation_time, speed_spread)
    m, n = instrument.blocks_per_estimate, instrument.n_fft
    ne = st.v.shape[0]
    nf = instrument.n_bins
    per = st.chunk_size(chunk_samples)
    rows = _task_blocks(n)
    n_r = (m + rows - 1) // rows
    out = np.empty((ne, nf))
    factor = 1.0 / (float(np.sum(st.win**2)) * m)
    pool = _Runner(n)
    for e0 in range(0, ne, per):
        e1 = min(ne, e0 + per)
        args = st.chunk(e0, e1, pool.run)
        partial = np.empty((e1 - e0, n_r, nf))
        order = _InOrder(e1 - e0, st.coloured)
        state = np.zeros((e1 - e0, 2))

        def task(w, t, args=args, partial=partial, order=order, state=state, ne_c=e1 - e0):
            r, e = divmod(t, ne_c)
            b_lo = e * m + r * rows
            b_hi = min((e + 1) * m, b_lo + rows)
            x = w.fft.x[:b_hi - b_lo]
            with order.turn(e, r):
                K.synth_blocks_kernel(*args[:2], b_lo, b_hi, *args[2:], state[e], w.acc, w.words, w.tails, x)
            K.power_sum_kernel(w.fft.execute(b_hi - b_lo), b_hi - b_lo, partial[e, r])

        pool.run((e1 - e0) * n_r, task)
        K.combine_partials_kernel(partial, factor, out[e0:e1])
    return out
