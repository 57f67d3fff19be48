"""SIGTERM as an exception, so that a terminated command cleans up like an interrupted one.

A batch system, ``timeout`` or ``kill`` ends a process with SIGTERM, whose
default action stops it on the spot: no ``finally`` runs, temporary files
stay, and nothing is said.  Inside :func:`sigterm_raises` a SIGTERM raises
:class:`Terminated` in the main thread instead, so every ``finally`` and
context manager on the way up runs (the atomic writers of
:mod:`cwlidar_sim._atomic` remove their temporary files, leaving the old
file in place) and the CLI prints one line and exits with
:data:`EXIT_SIGTERM`.
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["Terminated", "EXIT_SIGTERM", "RESUMABLE", "sigterm_raises", "terminated_message"]

#: Exit status after SIGTERM, the one a shell reports for a process killed by it (128 + 15).
EXIT_SIGTERM = 143
#: CLI commands that keep what they finished and resume it when run again.
RESUMABLE = ("run", "reproduce", "campaign", "twin")


class Terminated(BaseException):
    """SIGTERM was received.

    A BaseException, as KeyboardInterrupt is: no ``except Exception`` on the
    way up swallows it.
    """


def _raise_terminated(signum, frame):
    # a second SIGTERM during the clean-up ends the process the default way
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    raise Terminated()


@contextlib.contextmanager
def sigterm_raises():
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread; the old handler is restored after.

    Outside the main thread (where Python cannot install a handler) the block runs unchanged.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def terminated_message(command: str, out=None) -> str:
    """The CLI's one line after SIGTERM: what is kept and how to go on."""
    if command in RESUMABLE and out:
        what = "tasks" if command == "campaign" else "periods"
        return (f"cwlidar-sim {command}: interrupted by SIGTERM; finished {what} are kept in {out}; "
                f"run the same command again to resume")
    return (f"cwlidar-sim {command}: interrupted by SIGTERM; nothing half-written was left "
            f"(a file that was being replaced is unchanged)")
