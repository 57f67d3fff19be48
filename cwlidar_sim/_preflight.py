"""Checks made before a long computation, so that it cannot fail at the end for a reason known at the start.

Each raises :class:`PreflightError` (a ValueError: the CLI prints it as one
line and exits with status 2) naming the cause and the fix.
"""

from __future__ import annotations

import os
import shutil
import tempfile

__all__ = ["PreflightError", "ResultsWriteError", "check_engine", "check_writable", "check_disk", "check_scheduler",
           "preflight", "DISK_MARGIN"]

#: Safety factor on an estimated output size (partial files, the assembled file, temporaries).
DISK_MARGIN = 2.5


class PreflightError(ValueError):
    """A run cannot write its results; raised before anything is computed (message: cause and fix)."""


class ResultsWriteError(OSError):
    """Writing a finished result failed (e.g. a full disk); what was written before is kept."""


def check_engine() -> None:
    """Raise :class:`PreflightError` unless the NetCDF engine (h5netcdf with its h5py backend) imports."""
    for module in ("h5netcdf", "h5py"):
        try:
            __import__(module)
        except ImportError as e:
            raise PreflightError(
                f"cannot write NetCDF results: {module} does not import ({e}); "
                f"fix: pip install 'h5netcdf>=1.3' 'h5py>=3.15' (or reinstall cwlidar_sim)") from None


def check_writable(folder) -> None:
    """Create ``folder`` if needed and raise :class:`PreflightError` unless a file can be written in it."""
    folder = os.fspath(folder)
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".write-check-"):
            pass
    except OSError as e:
        raise PreflightError(f"cannot write to output folder {folder!r}: {e.strerror or e}; "
                             f"fix: choose another --out or make it writable") from None


def check_disk(folder, need_bytes: float) -> None:
    """Raise :class:`PreflightError` unless ``folder``'s disk has ``need_bytes`` free."""
    free = shutil.disk_usage(os.fspath(folder)).free
    if free < need_bytes:
        raise PreflightError(f"not enough disk space in {os.fspath(folder)!r}: the run needs about "
                             f"{need_bytes / 1e6:.0f} MB, {free / 1e6:.0f} MB free; "
                             f"fix: free space or choose another --out")


def check_scheduler(address: str, timeout: float = 3.0) -> None:
    """Raise :class:`PreflightError` unless a TCP connection to a Dask scheduler ``address`` opens.

    ``tcp://``, ``tls://``, ``ws://``, ``wss://`` (and bare ``host:port``)
    addresses are probed, for at most ``timeout`` seconds; ``ucx://`` is left
    to Dask; an ``inproc://`` address must be one of this very process (an
    in-process cluster; from the command line there is none); any other
    protocol is refused by name.  Whether the scheduler has workers is
    ``cwlidar_sim._dask.connect_scheduler``'s question.
    """
    import socket
    from urllib.parse import urlsplit

    if not isinstance(address, str) or not address:
        raise PreflightError(f"dask scheduler address must be a non-empty string like tcp://host:8786, "
                             f"got {address!r}")
    text = address if "://" in address else f"tcp://{address}"
    parts = urlsplit(text)
    if parts.scheme == "inproc":
        # inproc://HOST/PID/N exists only inside process PID (a LocalCluster(processes=False) of this process)
        fields = parts.path.strip("/").split("/")
        pid = fields[0] if len(fields) == 2 and fields[1].isdigit() else None
        if pid is None or not pid.isdigit():
            raise PreflightError(f"dask scheduler address {address!r} is not an in-process address of this process "
                                 f"(inproc://host/pid/n); an inproc:// scheduler exists only inside the Python "
                                 f"process that created it; fix: use its tcp://host:port address")
        if int(pid) != os.getpid():
            raise PreflightError(f"dask scheduler address {address!r} is an in-process scheduler of another process "
                                 f"(pid {pid}); fix: use its tcp://host:port address")
        return
    if parts.scheme == "ucx":
        return
    if parts.scheme not in ("tcp", "tls", "ws", "wss"):
        raise PreflightError(f"dask scheduler address {address!r} has the protocol {parts.scheme!r}; allowed: "
                             f"tcp, tls, ws, wss, ucx, inproc (e.g. tcp://host:8786)")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if not host or port is None:
        raise PreflightError(f"dask scheduler address {address!r} needs a host and a port, like tcp://host:8786")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as e:
        reason = "timed out" if isinstance(e, TimeoutError) else (e.strerror or str(e))
        raise PreflightError(f"dask scheduler {address} is unreachable ({reason}); "
                             f"fix: start it (dask scheduler) or run without Dask") from None


def preflight(out_dir, need_bytes: float = 0.0, *, scheduler=None, engine: bool = True) -> None:
    """Every check before a run: folder writable, engine importable, disk space, scheduler reachable.

    Parameters
    ----------
    out_dir : str or path or None
        Output folder (created); None: nothing is written, only ``scheduler`` is checked.
    need_bytes : float
        Estimated size of what the run writes [bytes] (a scene kind's ``estimate_bytes``, :class:`cwlidar_sim.campaign.registry.SceneKind`).
    scheduler : str, optional
        Dask scheduler address.
    engine : bool
        Whether NetCDF will be written (check that h5netcdf and h5py import).

    Raises
    ------
    PreflightError
        With the cause and the fix in one line.
    """
    if out_dir is not None:
        check_writable(out_dir)
        if engine:
            check_engine()
        check_disk(out_dir, DISK_MARGIN * float(need_bytes))
    if scheduler is not None:
        check_scheduler(scheduler)


