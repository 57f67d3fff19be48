"""The package's one route to FFTW (through pyfftw).

Every transform in cwlidar_sim goes through this module, so that alignment,
planning flags and threading are decided once.

Reproducibility
---------------
Results must be bit-for-bit identical whatever the number of threads.  FFTW's
own multi-threaded planner may pick a different decomposition (and so a
different rounding) for a different thread count, and ``FFTW_MEASURE`` picks
plans by timing, which differs from run to run.  This module therefore

* plans with ``FFTW_ESTIMATE`` only (a deterministic cost model);
* splits every multi-dimensional transform into passes of batched 1-D
  transforms, cuts each pass into chunks whose size depends only on the array
  shape, and plans each chunk single-threaded.  Worker threads pick up
  whole chunks, so every 1-D transform is computed by the same plan whatever
  the thread count.

Plans
-----
``FFTW_ESTIMATE`` plans cost microseconds; a plan is built once per chunk
shape and worker for each call, and FFTW's in-process wisdom makes repeats
cheaper still.  Plans are not kept between calls on purpose: a pyfftw plan
holds a reference to the arrays it was built on, and keeping it would keep a
whole turbulence box alive after the caller dropped it.

Conventions
-----------
Inverse transforms are *unnormalised* synthesis sums,
``x[n] = sum_k X[k] exp(+2j pi k n / N)``; forward transforms are
``X[k] = sum_n x[n] exp(-2j pi k n / N)`` (numpy's conventions without the
``1/N``).
"""

from __future__ import annotations

import numpy as np
import pyfftw

from ._config import get_num_threads, get_pool, in_pool_thread, run_static as _run_chunks

#: Target number of complex elements in one chunk of a batched pass.
_CHUNK_ELEMENTS = 1 << 17
_FLAGS = ("FFTW_ESTIMATE", "FFTW_UNALIGNED", "FFTW_DESTROY_INPUT")

_COMPLEX_OF = {np.dtype(np.float32): np.dtype(np.complex64), np.dtype(np.float64): np.dtype(np.complex128)}


def complex_dtype(real_dtype) -> np.dtype:
    """Complex dtype matching a real floating dtype (float32 or float64)."""
    dt = np.dtype(real_dtype)
    if dt not in _COMPLEX_OF:
        raise TypeError(f"dtype must be float32 or float64, got {dt}")
    return _COMPLEX_OF[dt]


def empty_halfspectrum(shape, real_dtype=np.float32):
    """Allocate a half-spectrum buffer for an in-place inverse real FFT.

    Parameters
    ----------
    shape : tuple of int
        Shape of the real field to be synthesised, e.g. ``(nx, ny, nz)``.
    real_dtype : dtype
        float32 or float64.

    Returns
    -------
    spec : ndarray, complex
        Uninitialised array of shape ``shape[:-1] + (shape[-1] // 2 + 1,)`` whose
        memory is exactly the padded real array, so :func:`irfftn_inplace`
        needs no second buffer.
    """
    cdt = complex_dtype(real_dtype)
    nh = shape[-1] // 2 + 1
    spec = pyfftw.empty_aligned(tuple(shape[:-1]) + (nh,), dtype=cdt)
    return spec


def _chunks(n: int, per_slice: int) -> list[tuple[int, int]]:
    """Split range(n) into chunks whose size depends only on the shape."""
    step = max(1, _CHUNK_ELEMENTS // max(1, per_slice))
    return [(i, min(n, i + step)) for i in range(0, n, step)]


class _PlanBook:
    """Per-call plan store: one pyfftw plan per (worker, kind, shape, strides)."""

    def __init__(self):
        self._plans = {}

    def get(self, worker, key, make):
        k = (worker,) + key
        p = self._plans.get(k)
        if p is None:
            p = make()
            self._plans[k] = p
        return p


def _c2c_pass(spec, axis, book, worker, lo, hi, chunk_axis):
    sl = [slice(None)] * spec.ndim
    sl[chunk_axis] = slice(lo, hi)
    block = spec[tuple(sl)]
    key = ("c2c", axis, block.shape, block.strides, block.dtype.str)
    plan = book.get(
        worker,
        key,
        lambda: pyfftw.FFTW(block, block, axes=(axis,), direction="FFTW_BACKWARD", flags=_FLAGS, threads=1),
    )
    plan.update_arrays(block, block)
    plan.execute()


def _c2r_pass(spec, real, book, worker, lo, hi):
    s_in = spec[lo:hi]
    s_out = real[lo:hi]
    key = ("c2r", s_in.shape, s_in.strides, s_out.strides, s_in.dtype.str)
    axis = spec.ndim - 1
    plan = book.get(
        worker,
        key,
        lambda: pyfftw.FFTW(s_in, s_out, axes=(axis,), direction="FFTW_BACKWARD", flags=_FLAGS, threads=1),
    )
    plan.update_arrays(s_in, s_out)
    plan.execute()


def irfftn_inplace(spec, n_last: int):
    """Unnormalised inverse real N-D FFT, computed in place.

    Parameters
    ----------
    spec : ndarray, complex64 or complex128, C-contiguous
        Half spectrum of shape ``(..., n_last // 2 + 1)`` as returned by
        :func:`empty_halfspectrum`.  Destroyed.  The planes ``k_last = 0`` and
        (for even ``n_last``) ``k_last = n_last / 2`` must already be
        Hermitian; FFTW does not check it.
    n_last : int
        Length of the last axis of the real output.

    Returns
    -------
    real : ndarray, float32 or float64
        View of ``spec``'s memory with shape ``spec.shape[:-1] + (n_last,)``:
        ``real[x] = sum_k spec[k] exp(+2j pi k.x / N)``.  It is not
        C-contiguous (its rows keep FFTW's in-place padding of one or two
        values), which keeps the peak memory at the size of the output.
    """
    if not spec.flags.c_contiguous:
        raise ValueError("spec must be C-contiguous")
    nh = n_last // 2 + 1
    if spec.shape[-1] != nh:
        raise ValueError(f"spec.shape[-1]={spec.shape[-1]} does not match n_last={n_last} (expected {nh})")
    rdt = np.float32 if spec.dtype == np.complex64 else np.float64
    padded = spec.view(rdt)  # shape (..., 2 * nh)
    real = padded[..., :n_last]
    book = _PlanBook()
    nd = spec.ndim
    # c2c passes over all axes but the last, then c2r along the last.
    for axis in range(nd - 1):
        chunk_axis = 1 if axis == 0 else 0
        per_slice = spec.size // spec.shape[chunk_axis]
        tasks = _chunks(spec.shape[chunk_axis], per_slice)
        _run_chunks(tasks, lambda w, t, a=axis, ca=chunk_axis: _c2c_pass(spec, a, book, w, t[0], t[1], ca))
    if nd == 1:
        plan = pyfftw.FFTW(spec, real, axes=(0,), direction="FFTW_BACKWARD", flags=_FLAGS, threads=1)
        plan.execute()
        return real
    per_slice = spec.size // spec.shape[0]
    tasks = _chunks(spec.shape[0], per_slice)
    _run_chunks(tasks, lambda w, t: _c2r_pass(spec, real, book, w, t[0], t[1]))
    return real


def irfft3_floor(shape, real_dtype=np.float32, threads: int | None = None):
    """Return a callable timing floor: FFTW's own threaded inverse real 3-D FFT.

    Used by the benchmarks as the speed floor of box generation.  It is not
    used for generation because FFTW's threaded plans are not guaranteed to
    round identically for different thread counts.

    Parameters
    ----------
    shape : tuple of int
        Real shape ``(nx, ny, nz)``.
    threads : int, optional
        FFTW threads (default: the configured thread count).

    Returns
    -------
    run : callable
        ``run()`` executes one transform on a pre-allocated buffer.
    """
    threads = get_num_threads() if threads is None else threads
    spec = empty_halfspectrum(shape, real_dtype)
    real = spec.view(np.float32 if spec.dtype == np.complex64 else np.float64)[..., : shape[-1]]
    plan = pyfftw.FFTW(spec, real, axes=tuple(range(len(shape))), direction="FFTW_BACKWARD",
                       flags=("FFTW_ESTIMATE", "FFTW_DESTROY_INPUT"), threads=threads)
    return plan.execute


def rfft_rows(x, out=None):
    """Unnormalised forward real FFT along the last axis of a 2-D array.

    Parameters
    ----------
    x : ndarray, float32 or float64, shape (m, n)
        Rows to transform (not modified).
    out : ndarray, complex, shape (m, n // 2 + 1), optional
        Output buffer.

    Returns
    -------
    X : ndarray, complex, shape (m, n // 2 + 1)
        ``X[r, k] = sum_j x[r, j] exp(-2j pi k j / n)``.
    """
    x = np.ascontiguousarray(x)
    if x.ndim != 2:
        raise ValueError(f"x must be 2-D (rows, samples), got shape {x.shape}")
    m, n = x.shape
    cdt = complex_dtype(x.dtype)
    if out is None:
        out = pyfftw.empty_aligned((m, n // 2 + 1), dtype=cdt)
    book = _PlanBook()

    def work(w, t):
        lo, hi = t
        xi, oi = x[lo:hi], out[lo:hi]
        key = ("r2c", xi.shape, xi.strides, oi.strides, xi.dtype.str)
        plan = book.get(w, key, lambda: pyfftw.FFTW(
            xi, oi, axes=(1,), direction="FFTW_FORWARD", flags=("FFTW_ESTIMATE", "FFTW_UNALIGNED"), threads=1))
        plan.update_arrays(xi, oi)
        plan.execute()

    _run_chunks(_chunks(m, n), work)
    return out


class RowsRFFT:
    """A single-threaded batched forward real FFT on buffers of its own, for worker threads.

    A worker synthesises up to ``max_rows`` rows of length ``n`` straight into
    :attr:`x` and transforms the first ``rows`` of them into :attr:`X` with
    :meth:`execute`; the plans are made once (``FFTW_ESTIMATE``, one thread,
    one per distinct ``rows``) and bound to these buffers, so a call costs
    no planning and no copy.  Each worker owns one instance, and a row's
    transform is computed by the same kind of plan whichever worker runs
    it, so results do not depend on the thread count.

    Parameters
    ----------
    max_rows : int
        Rows of the buffers.
    n : int
        Row length (samples).
    real_dtype : dtype
        float32 or float64.

    Attributes
    ----------
    x : ndarray, shape (max_rows, n)
        Input rows; overwritten by :meth:`execute` (``FFTW_DESTROY_INPUT``).
    X : ndarray, complex, shape (max_rows, n // 2 + 1)
        ``X[r, k] = sum_j x[r, j] exp(-2j pi k j / n)`` after :meth:`execute`.
    """

    def __init__(self, max_rows: int, n: int, real_dtype=np.float32):
        self.x = pyfftw.empty_aligned((max_rows, n), dtype=np.dtype(real_dtype))
        self.X = pyfftw.empty_aligned((max_rows, n // 2 + 1), dtype=complex_dtype(real_dtype))
        self._plans = {}

    def execute(self, rows: int | None = None):
        """Transform rows ``0 .. rows - 1`` (all by default); returns the view ``X[:rows]``.

        Releases the GIL while FFTW runs.
        """
        rows = self.x.shape[0] if rows is None else rows
        plan = self._plans.get(rows)
        if plan is None:
            plan = pyfftw.FFTW(self.x[:rows], self.X[:rows], axes=(1,), direction="FFTW_FORWARD",
                               flags=("FFTW_ESTIMATE", "FFTW_DESTROY_INPUT"), threads=1)
            self._plans[rows] = plan
        plan.execute()
        return self.X[:rows]


class LineC2C:
    """A single-threaded in-place 1-D complex128 FFT of length ``n`` on a buffer of its own (worker threads).

    :attr:`x` is transformed in place by :meth:`forward`
    (``X[k] = sum_n x[n] exp(-2j pi k n / n)``) or :meth:`backward` (the
    unnormalised synthesis sum, ``+2j pi``); plans ``FFTW_ESTIMATE``, one
    thread, made once per instance, so results do not depend on the thread
    count.  Releases the GIL while FFTW runs.
    """

    def __init__(self, n: int):
        self.x = pyfftw.empty_aligned(int(n), dtype=np.complex128)
        self._fwd = pyfftw.FFTW(self.x, self.x, direction="FFTW_FORWARD", flags=("FFTW_ESTIMATE",), threads=1)
        self._bwd = pyfftw.FFTW(self.x, self.x, direction="FFTW_BACKWARD", flags=("FFTW_ESTIMATE",), threads=1)

    def forward(self):
        self._fwd.execute()
        return self.x

    def backward(self):
        self._bwd.execute()
        return self.x


# ---------------------------------------------------------------------------
# Dynamic scheduling on the package's long-lived threads (box generator and signal chain).
# ---------------------------------------------------------------------------
import itertools as _itertools  # noqa: E402


def run_dynamic(tasks, worker_fn) -> None:
    """Run ``worker_fn(w, task)`` for every task, each thread taking the next free task.

    For tasks whose result does not depend on the worker that runs them
    (each writes its own part of the output, and any plan or scratch keyed
    by ``w`` computes the same numbers whoever builds it), so the outcome is
    the same for any thread count and any interleaving.  Unlike
    :func:`cwlidar_sim._config.run_static` a thread held up by another
    process does not leave its share of the tasks waiting, and the threads
    (``get_num_threads()`` of them) live on between calls.  Called from one
    of those threads it runs serially.
    """
    tasks = list(tasks)
    n = get_num_threads()
    nthreads = min(n, len(tasks))
    if nthreads <= 1 or in_pool_thread():
        for t in tasks:
            worker_fn(0, t)
        return
    counter = _itertools.count()  # next() on it is atomic under the GIL

    def run(w):
        for i in iter(lambda: next(counter), None):
            if i >= len(tasks):
                return
            worker_fn(w, tasks[i])

    pool = get_pool(n)
    for f in [pool.submit(run, w) for w in range(nthreads)]:
        f.result()


def new_plan_store():
    """A plan store for :func:`irfftn_inplace_shared`, to be dropped after use.

    Plans pin the arrays they were last given, so keep the store only for
    the duration of one group of transforms (e.g. the u, v, w of one box).
    """
    return _PlanBook()


def _c2r2_pass(spec, real, book, worker, lo, hi):
    # 2-D c2r over the last two axes of slabs lo..hi of a 3-D half spectrum.
    s_in = spec[lo:hi]
    s_out = real[lo:hi]
    key = ("c2r2", s_in.shape, s_in.strides, s_out.strides, s_in.dtype.str)
    plan = book.get(
        worker,
        key,
        lambda: pyfftw.FFTW(s_in, s_out, axes=(1, 2), direction="FFTW_BACKWARD", flags=_FLAGS, threads=1),
    )
    plan.update_arrays(s_in, s_out)
    plan.execute()


def irfftn_inplace_shared(spec, n_last: int, plans):
    """:func:`irfftn_inplace` with the plans of a caller-held store, 3-D in two passes.

    Same arguments and result as :func:`irfftn_inplace` (to rounding).  Two
    differences, both for speed:

    * transforms of several arrays of one shape and dtype (the u, v, w of a
      box) plan once instead of once each: building the FFTW_ESTIMATE plans
      costs about a tenth of a 4096 x 32 x 32 transform;
    * a 3-D array is transformed in two passes instead of three: batched
      1-D c2c transforms along axis 0 (chunked along axis 1), then batched
      2-D c2r transforms over axes 1 and 2 of each slab (chunked along
      axis 0; a slab is small enough to stay in cache while both of its
      axes are done).  A quarter faster at 4096 x 32 x 32.

    Chunks depend on the shape only and each is planned single-threaded, so
    the result is bit-for-bit the same for any thread count (but not the
    same bits as :func:`irfftn_inplace`, whose passes differ); threads take
    chunks as they come free (:func:`run_dynamic`).

    Parameters
    ----------
    spec, n_last
        As for :func:`irfftn_inplace`.
    plans
        Store from :func:`new_plan_store`.
    """
    if not spec.flags.c_contiguous:
        raise ValueError("spec must be C-contiguous")
    nh = n_last // 2 + 1
    if spec.shape[-1] != nh:
        raise ValueError(f"spec.shape[-1]={spec.shape[-1]} does not match n_last={n_last} (expected {nh})")
    if spec.ndim != 3:
        return irfftn_inplace(spec, n_last)
    rdt = np.float32 if spec.dtype == np.complex64 else np.float64
    real = spec.view(rdt)[..., :n_last]
    tasks = _chunks(spec.shape[1], spec.size // spec.shape[1])
    run_dynamic(tasks, lambda w, t: _c2c_pass(spec, 0, plans, w, t[0], t[1], 1))
    tasks = _chunks(spec.shape[0], spec.size // spec.shape[0])
    run_dynamic(tasks, lambda w, t: _c2r2_pass(spec, real, plans, w, t[0], t[1]))
    return real


def _r2c2_pass(real, spec, book, worker, lo, hi):
    # 2-D r2c over the last two axes of slabs lo..hi; the input is preserved.
    s_in = real[lo:hi]
    s_out = spec[lo:hi]
    key = ("r2c2", s_in.shape, s_in.strides, s_out.strides, s_in.dtype.str)
    plan = book.get(
        worker,
        key,
        lambda: pyfftw.FFTW(s_in, s_out, axes=(1, 2), direction="FFTW_FORWARD",
                            flags=("FFTW_ESTIMATE", "FFTW_UNALIGNED"), threads=1),
    )
    plan.update_arrays(s_in, s_out)
    plan.execute()


def _c2c_forward_pass(spec, book, worker, lo, hi):
    # 1-D forward c2c along axis 0 of columns lo..hi of axis 1, in place.
    block = spec[:, lo:hi]
    key = ("c2cf", block.shape, block.strides, block.dtype.str)
    plan = book.get(
        worker,
        key,
        lambda: pyfftw.FFTW(block, block, axes=(0,), direction="FFTW_FORWARD", flags=_FLAGS, threads=1),
    )
    plan.update_arrays(block, block)
    plan.execute()


def rfftn3(real, out=None):
    """Unnormalised forward real 3-D FFT, ``X[k] = sum_n x[n] exp(-2j pi k.n / N)``.

    The inverse of :func:`irfftn_inplace_shared` up to the factor ``N1 N2 N3``.
    Two passes, like it: batched 2-D r2c transforms over axes 1 and 2 of slabs
    of axis 0, then batched 1-D c2c transforms along axis 0 (chunked along
    axis 1); chunks depend on the shape only and are planned single-threaded,
    so the result is the same bits for any thread count.

    Parameters
    ----------
    real : ndarray, float32 or float64, shape (N1, N2, N3)
        Field to transform (not modified); views with padded rows (the
        boxes of :func:`cwlidar_sim.turbulence.generate_box`) are fine.
    out : ndarray, complex, shape (N1, N2, N3 // 2 + 1), C-contiguous, optional
        Output buffer (e.g. from :func:`empty_halfspectrum`); allocated if None.

    Returns
    -------
    spec : ndarray, complex64 or complex128
        The half spectrum, ``spec[k1, k2, k3]`` for ``k3 = 0 .. N3 // 2``.
    """
    if real.ndim != 3:
        raise ValueError(f"real must be 3-D, got shape {real.shape}")
    n1, n2, n3 = real.shape
    shape_out = (n1, n2, n3 // 2 + 1)
    if out is None:
        out = pyfftw.empty_aligned(shape_out, dtype=complex_dtype(real.dtype))
    elif out.shape != shape_out or out.dtype != complex_dtype(real.dtype) or not out.flags.c_contiguous:
        raise ValueError(f"out must be a C-contiguous {complex_dtype(real.dtype)} array of shape {shape_out}")
    book = _PlanBook()
    tasks = _chunks(n1, out.size // n1)
    run_dynamic(tasks, lambda w, t: _r2c2_pass(real, out, book, w, t[0], t[1]))
    tasks = _chunks(n2, out.size // n2)
    run_dynamic(tasks, lambda w, t: _c2c_forward_pass(out, book, w, t[0], t[1]))
    return out
