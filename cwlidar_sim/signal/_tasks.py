"""Threads and seeds of the signal chain: the task runner every row kernel uses."""

from __future__ import annotations

import numpy as np

from .._validation import check_seed


def _rng(seed):
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(check_seed("seed", seed))


# ---------------------------------------------------------------------------
# threads of the signal chain
# ---------------------------------------------------------------------------
#: Rows (estimates) per task of the row-wise kernels: about 0.1-0.5 ms of work.
_ROWS_PER_TASK = 256

def _run_tasks(n_tasks, fn):
    """Call ``fn(t)`` for t = 0 .. n_tasks - 1 on the signal chain's threads.

    ``fn`` must depend on ``t`` only and call ``nogil`` kernels.  Tasks are
    handed out one at a time (dynamic scheduling), so a thread that another
    process keeps off its core for a while only takes fewer tasks; with the
    cores to ourselves this matches numba's static prange, and under load it
    degrades to the throughput of the cores actually available, where a
    static split waits for the slowest thread (and OpenMP threads spin).
    Results never depend on which thread ran a task, hence on the thread
    count.  Called from one of these threads, it runs the tasks inline.
    """
    from .._fft import run_dynamic

    run_dynamic(range(n_tasks), lambda _w, t: fn(t))
