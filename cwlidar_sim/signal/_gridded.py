"""Continuum speckle, gridded: the cells' cosine sums by Gaussian gridding, a cache-sized task at a time.

What is computed
----------------
Tier 2's continuum moments (:func:`cwlidar_sim.signal.spectral.continuum_moments`)
and the exact expected signal rows (:func:`cwlidar_sim.signal.exact.signal_rows`)
both need, per estimate, the cells' cosine sums ``C(t) = 2 sum_s amp_s cos(2 pi
x_s t / N)`` for ``t < t_used`` lags, folded into block lags and transformed.
The sums come from a type-1 non-uniform FFT (Greengard & Lee 2004): each
cell's amplitude is spread on a periodic grid of ``M >= 4 t_used`` angles by
a Gaussian of :data:`GRID_HALF_WIDTH` points each side
(``_kernels.gaussian_deposit_rows``), the grid is transformed once, and the
Gaussian's transform is divided out (``deconv``).  The result agrees with the
per-cell recurrence (method 'exact') within about 1e-13 of ``C(0)``
(``tests/signal/test_gridded.py``).

Why tasks
---------
An estimate's grid is 8 M bytes (16 kB for A2012's M = 2048), its lags and
their transform a few kB more.  Done a stage at a time over thousands of
estimates, every stage streams its arrays through main memory.  Here a task
of :data:`ROWS` estimates runs every stage (deposit, FFT, fold, FFT of the
block lags, and the caller's finish) on buffers of its own worker that stay
in the core's cache, and the FFTs are single-threaded plans made once per
worker (:class:`cwlidar_sim._fft.RowsRFFT`).  A task always transforms
:data:`ROWS` rows, so every estimate's numbers come from the same plans
whichever task, chunk or thread computes it.
"""

from __future__ import annotations

import functools
import math
import threading

import numpy as np

from ._tasks import _run_tasks

__all__ = ["GRID_HALF_WIDTH", "ROWS", "gridding", "gridded_lag_tasks"]

#: Half-width (grid points) of the Gaussian of the gridded cosine sums: error ~1e-13 of C(0)
#: with a grid of twice the needed lags (benchmarks/bench_subbin.py measures it).
GRID_HALF_WIDTH = 14
#: Estimates per task: the A2012 grid (M = 2048) and its transform of 16 rows take 0.8 MB.
ROWS = 16

_local = threading.local()


def grid_length(t_used: int) -> int:
    """The grid length M for ``t < t_used`` lags: at least ``4 t_used``, a power of two when that costs
    at most 25 % more points than the smallest 5-smooth length (FFTW is fastest there: 2048 points take
    0.66 of the time of 1944)."""
    from scipy.fft import next_fast_len

    need = 4 * t_used
    smooth = int(next_fast_len(need, real=True))
    pow2 = 1 << (need - 1).bit_length()
    return pow2 if pow2 <= 1.25 * smooth else smooth


@functools.lru_cache(maxsize=16)
def gridding(t_used: int):
    """Grid length M, Gaussian width tau_g, weights e_j and the deconvolution for t < t_used lags (read-only)."""
    k = 2 * t_used
    m = grid_length(t_used)
    r = m / k
    w = GRID_HALF_WIDTH
    tau = math.pi * w / (k * k * r * (r - 0.5))
    h = 2.0 * math.pi / m
    e_j = np.exp(-((np.arange(-w, w + 1) * h) ** 2) / (4.0 * tau))
    deconv = math.sqrt(math.pi / tau) * np.exp(np.arange(t_used) ** 2 * tau) / m
    e_j.flags.writeable = False
    deconv.flags.writeable = False
    return m, tau, e_j, deconv


def fold_factors(g_t, r_d, n_fft, nj):
    """``(a_jn, b_jn)`` of ``_kernels.gridded_lag_rows``: the window's lag weights ``r_d`` and the line's
    correlation ``g_t`` multiplied out, ``a[j, m] = r_m g(jN + m)``, ``b[j, m] = r_{N-m} g(jN + m - N)``
    (``b[0, m] = r_{N-m} g(N - m)``, the mirror of lag -m; ``b[j, 0] = 0``)."""
    n = n_fft
    a = np.zeros((nj, n))
    b = np.zeros((nj, n))
    for j in range(nj):
        a[j] = r_d[:n] * g_t[j * n:(j + 1) * n]
        if j == 0:
            b[0, 1:] = r_d[n - np.arange(1, n)] * g_t[n - np.arange(1, n)]
        else:
            b[j, 1:] = r_d[n - np.arange(1, n)] * g_t[j * n + np.arange(1, n) - n]
    return a, b


class _Buffers:
    """One worker's grid, lags and their transforms (plans bound to them)."""

    def __init__(self, m: int, nj1: int, n: int):
        from .._fft import RowsRFFT

        self.grid = RowsRFFT(ROWS, m, np.float64)
        self.lags = RowsRFFT(ROWS * nj1, n, np.float64)
        self.c_t = np.empty(nj1 * n)


def _buffers(m, nj1, n):
    book = getattr(_local, "book", None)
    if book is None:
        book = _local.book = {}
    key = (m, nj1, n)
    buf = book.get(key)
    if buf is None:
        buf = book[key] = _Buffers(m, nj1, n)
    return buf


def gridded_lag_tasks(x, amp, g, r_d, n, t_used, nj1, finish, *, transform=True):
    """Run every estimate through deposit, FFT, fold and the FFT of its block lags, in tasks; hand each task on.

    Parameters
    ----------
    x : ndarray, shape (n_e, n_c)
        Cell speeds in bins [-] (any real; reduced mod N).
    amp : ndarray, shape (n_c,)
        Cell amplitudes ``CNR w_s / 2`` [-].
    g : ndarray, shape (>= (nj1 + 1) N,)
        The line's correlation at lags 0, 1, ... [-] (0 from ``t_used`` on).
    r_d : ndarray, shape (N,)
        The window's lag weights [-].
    n : int
        Block length N [samples].
    t_used : int
        Lags with a non-zero cosine sum.
    nj1 : int
        Block lags j = 0 .. nj1 - 1 to fold.
    finish : callable
        ``finish(lo, hi, f_rjk)`` with ``f_rjk`` the real DFTs of the folded
        lag sequences of estimates ``lo .. hi - 1`` (shape ``(hi - lo, nj1,
        N/2 + 1)``, the worker's buffer: use it before returning).
    transform : bool
        False: hand on the folded lag sequences themselves (shape ``(hi - lo,
        nj1, N)``).
    """
    from . import _kernels as K

    m, tau, e_j, deconv = gridding(t_used)
    a_jn, b_jn = fold_factors(g, r_d, n, nj1)
    ne = x.shape[0]

    def task(t):
        lo = t * ROWS
        hi = min(ne, lo + ROWS)
        r = hi - lo
        buf = _buffers(m, nj1, n)
        grid = buf.grid.x
        K.gaussian_deposit_rows(x, amp, n, tau, e_j, lo, hi, grid)
        if r < ROWS:
            grid[r:] = 0.0
        f = buf.grid.execute()
        lags = buf.lags.x.reshape(ROWS, nj1, n)
        K.gridded_lag_rows(f, deconv, a_jn, b_jn, 0, r, buf.c_t, lags)
        if not transform:
            finish(lo, hi, lags[:r])
            return
        if r < ROWS:
            lags[r:] = 0.0
        f_rjk = buf.lags.execute().reshape(ROWS, nj1, n // 2 + 1)
        finish(lo, hi, f_rjk[:r])

    _run_tasks(-(-ne // ROWS), task)
