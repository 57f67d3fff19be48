"""Numba options and thread settings, kept in one place.

Every ``@njit`` kernel in the package is decorated with one of the option
dictionaries below so that caching, error model and fast-math choices are
made once.  ``fastmath`` stays off: results must be bit-for-bit identical
whatever the number of threads, and reassociation would let the compiler
change summation order between serial and parallel builds.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

#: Options for serial kernels.
NJIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy")
#: Options for kernels that use ``numba.prange``.  Each parallel iteration
#: writes its own outputs and no kernel reduces across iterations, so the
#: result does not depend on the thread count.
NJIT_PARALLEL = dict(NJIT, parallel=True)

_lock = threading.Lock()
_num_threads: int | None = None


def default_num_threads() -> int:
    """Number of worker threads used when the caller does not set one."""
    env = os.environ.get("CWLIDAR_SIM_NUM_THREADS")
    if env:
        try:
            n = int(env)
        except ValueError:
            raise ValueError(
                f"CWLIDAR_SIM_NUM_THREADS={env!r} is not an integer; allowed: 1..{os.cpu_count()}"
            ) from None
        if n < 1:
            raise ValueError(f"CWLIDAR_SIM_NUM_THREADS={n} must be >= 1")
        return n
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def get_num_threads() -> int:
    """Thread count used by the FFT module and the parallel numba kernels."""
    global _num_threads
    with _lock:
        if _num_threads is None:
            _num_threads = default_num_threads()
        return _num_threads


def set_num_threads(n: int) -> None:
    """Set the thread count for FFTs and numba kernels.

    Results are bit-for-bit identical for any thread count; this only changes
    speed.

    Parameters
    ----------
    n : int
        Number of threads, >= 1.
    """
    global _num_threads
    if isinstance(n, bool) or not isinstance(n, int):
        raise TypeError(f"num_threads must be an int, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"num_threads={n} is out of range; allowed: >= 1")
    with _lock:
        _num_threads = n


def apply_numba_threads() -> int:
    """Make numba use the configured thread count; returns it.

    Imported lazily so that importing the package (and the CLI) does not
    import numba.
    """
    import numba

    n = min(get_num_threads(), numba.config.NUMBA_NUM_THREADS)
    numba.set_num_threads(n)
    return n


# ---------------------------------------------------------------------------
# Long-lived worker threads, shared by every parallel pass of the package
# ---------------------------------------------------------------------------
_pool_lock = threading.Lock()
_pool = None
_pool_size = 0
_in_pool = threading.local()


def _mark_pool_thread():
    _in_pool.flag = True


def _forget_pool():
    # a forked child inherits the executor but not its threads
    global _pool, _pool_lock, _pool_size
    _pool, _pool_size = None, 0
    _pool_lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def in_pool_thread() -> bool:
    """True when called from one of the package's worker threads (nested parallel passes run inline)."""
    return getattr(_in_pool, "flag", False)


def get_pool(n: int):
    """The package's pool of ``n`` worker threads, made once and kept (a new count makes a new pool).

    Starting a thread costs about 0.6 ms on the 2-core VMs this runs on, and
    a campaign period makes thousands of parallel passes (row FFTs, box
    slabs, fits); idle threads cost nothing.
    """
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size != n:
            old = _pool
            _pool = ThreadPoolExecutor(n, thread_name_prefix="cwlidar_sim", initializer=_mark_pool_thread)
            _pool_size = n
            if old is not None:
                old.shutdown(wait=False)
        return _pool


def run_static(tasks, worker_fn) -> None:
    """Run ``worker_fn(w, task)`` for every task on the configured threads.

    Worker ``w`` takes tasks ``w, w + T, w + 2T, ...``.  Callers make every
    task's result independent of the worker that runs it (tasks are cut by
    data index, and each carries its own random stream), so the outcome is
    the same for any thread count.  ``worker_fn`` should release the GIL
    (numba ``nogil`` kernels, FFTW, numpy's random generators do).  The
    threads are the package's long-lived pool (:func:`get_pool`); called from
    one of them, the tasks run inline.
    """
    tasks = list(tasks)
    n = get_num_threads()
    nthreads = min(n, len(tasks))
    if nthreads <= 1 or in_pool_thread():
        for t in tasks:
            worker_fn(0, t)
        return

    def run(w):
        for t in tasks[w::nthreads]:
            worker_fn(w, t)

    pool = get_pool(n)
    for f in [pool.submit(run, w) for w in range(nthreads)]:
        f.result()
