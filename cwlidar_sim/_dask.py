"""A Dask scheduler that is there and has workers: connected with bounded waits, watched while it computes.

Dask itself waits forever: a client of a scheduler without workers, or whose
last worker died, keeps its tasks pending with no error.  Here
:func:`connect_scheduler` (before anything is computed) waits at most
``worker_timeout`` seconds for a first worker, and :func:`completed` (during
the run) stops with :class:`WorkersLostError` once the scheduler has had no
worker, or has not answered, for ``worker_timeout`` seconds.  What finished
before is kept by the callers, so the same command resumes.

Security: a Dask scheduler runs whatever its clients send, and results come
back by pickle, which runs code when read.  Connect only to schedulers (and
their workers) that you and only you control; see the README's Dask section.
"""

from __future__ import annotations

import math
import time

from ._preflight import PreflightError, check_scheduler

__all__ = ["DEFAULT_WORKER_TIMEOUT", "WorkersLostError", "check_worker_timeout", "connect_scheduler", "completed"]

#: Seconds to wait for a first worker before a run, and the longest a run waits without any worker [s].
DEFAULT_WORKER_TIMEOUT = 60.0
#: How often a waiting run asks the scheduler for its workers [s].
POLL_S = 1.0


class WorkersLostError(TimeoutError):
    """The scheduler has had no worker (or has not answered) for longer than the timeout; finished units are kept."""


def check_worker_timeout(value) -> float:
    """``worker_timeout`` [s] as a float in (0, 86400]; else a ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not 0 < value <= 86400:
        raise ValueError(f"worker_timeout (--worker-timeout) {value!r} s is out of range; allowed: "
                         f"0 < seconds <= 86400 (how long to wait for a Dask worker)")
    return float(value)


def connect_scheduler(address: str, *, worker_timeout: float = DEFAULT_WORKER_TIMEOUT, connect_timeout: float = 10.0):
    """A ``dask.distributed.Client`` of ``address`` with at least one worker, or a one-line PreflightError.

    Parameters
    ----------
    address : str
        Scheduler address (``tcp://host:8786``; see :func:`~cwlidar_sim._preflight.check_scheduler`).
    worker_timeout : float
        Longest wait for a first worker [s].
    connect_timeout : float
        Longest wait for the scheduler to answer [s].

    Raises
    ------
    PreflightError
        The address is malformed, the scheduler is unreachable or does not
        answer as one, or no worker arrived in ``worker_timeout`` seconds;
        the message names the address.
    """
    from dask.distributed import Client

    worker_timeout = check_worker_timeout(worker_timeout)
    check_scheduler(address)
    try:
        client = Client(address, timeout=connect_timeout)
    except (OSError, ValueError) as e:  # TimeoutError is an OSError; a malformed address is a ValueError
        raise PreflightError(f"dask scheduler {address} did not answer as a scheduler ({e}); "
                             f"fix: check the address or run without Dask") from None
    try:
        client.wait_for_workers(1, timeout=worker_timeout)
    except (OSError, ValueError) as e:  # distributed's WorkerStartTimeoutError is a TimeoutError
        client.close()
        raise PreflightError(f"dask scheduler {address} has no worker: none arrived in {worker_timeout:g} s "
                             f"({e}); fix: start one (dask worker {address}), wait longer (--worker-timeout) "
                             f"or run without Dask") from None
    return client


def _n_workers(client) -> int:
    """Workers the scheduler has now (asked, not cached); 0 when it does not answer."""
    try:
        return len(client.nthreads())
    except (OSError, ValueError, RuntimeError):  # scheduler gone: CommClosedError is an OSError
        return 0


def _where(client, address) -> str:
    return address or getattr(client.scheduler, "address", None) or "(unknown address)"


def _reason(future) -> str:
    """Why a cancelled future was cancelled, in one line (distributed says it in the exception)."""
    try:
        future.result(timeout=1)
    except Exception as e:  # FutureCancelledError names the reason, e.g. scheduler-connection-lost
        return " ".join(str(e).split())[:300]
    return "cancelled"


def completed(client, futures, *, worker_timeout: float = DEFAULT_WORKER_TIMEOUT, address=None, poll: float = POLL_S):
    """Yield ``futures`` as they finish (with a result or an error), like ``dask.distributed.as_completed``.

    Unlike it, raise :class:`WorkersLostError` once the scheduler has had no
    worker, or has not answered, for ``worker_timeout`` seconds while
    futures are pending (Dask would wait forever), and as soon as a future
    comes back cancelled (the client lost its scheduler; the caller only
    cancels after the loop), instead of handing it on to raise a traceback.

    Parameters
    ----------
    client : dask.distributed.Client
    futures : iterable of Future
    worker_timeout : float
        Longest time without any worker [s].
    address : str, optional
        The scheduler's address, for the message (default: the client's).
    poll : float
        Seconds between two questions to the scheduler while nothing finishes.
    """
    from dask.distributed import as_completed

    worker_timeout = check_worker_timeout(worker_timeout)
    # as_completed's own queue, filled by callbacks: each completion costs O(1) however many are pending
    ac = as_completed(futures)
    alone_since = None
    last_asked = time.monotonic()
    while not ac.is_empty():
        if ac.has_ready():
            for f in ac.next_batch(block=False):
                if f.status == "cancelled":  # not by us (we cancel only after the loop): the scheduler is gone
                    raise WorkersLostError(f"dask scheduler {_where(client, address)} lost task {f.key} "
                                           f"({_reason(f)}); stopped with {ac.count()} more pending")
                yield f
            alone_since = None
            continue
        time.sleep(min(0.05, poll))  # a blocking next() could not be interrupted when the workers are gone
        now = time.monotonic()
        if now - last_asked < poll:
            continue
        last_asked = now
        if _n_workers(client):
            alone_since = None
        elif alone_since is None:
            alone_since = now
        elif now - alone_since > worker_timeout:
            raise WorkersLostError(f"dask scheduler {_where(client, address)} has had no worker for "
                                   f"{worker_timeout:g} s "
                                   f"with {ac.count()} task(s) pending; stopped (--worker-timeout)")
