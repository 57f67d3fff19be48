"""Reading results files that may not be ours: checked before they are opened, refused in one line.

``report``, ``probe-length`` and ``campaign-report`` read files a user names,
which may be anything: a zero-byte file left by an interrupted copy, a
directory or a FIFO named ``x.nc`` (opening a FIFO blocks forever), a
truncated file, an HDF5 file of another program, or a campaign's merged
``campaign.nc``.  :func:`open_results` checks, in this order and before any
data is loaded, that the path is a regular file, that it is not empty, that
it starts with the HDF5 signature, that the NetCDF library can open it, that
it carries the attributes every cwlidar_sim results file has (``scene``,
``sensor``, the ``period`` dimension), and that its data fit in memory; each
failure is a ValueError naming the file and what is wrong with it.
"""

from __future__ import annotations

import json
import os
import re

from ..._validation import available_memory
from ..registry import kind_names
from ..scenes.spec import RESULTS_VERSION, open_regular_file
from .store import ENGINE

__all__ = ["HDF5_SIGNATURE", "check_results_file", "results_problem", "open_results", "lacking"]

#: The first 8 bytes of an HDF5 (hence NetCDF-4) file's superblock.
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Fraction of the memory available now that a results file's data may take when loaded.
MEMORY_FRACTION = 0.8

#: What a library may raise on a damaged or foreign HDF5 file (h5py, h5netcdf, xarray's decoding).
_DECODE_ERRORS = (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError, RuntimeError,
                  NotImplementedError)


def check_results_file(path, what: str = "results file") -> None:
    """Raise ValueError unless ``path`` is a non-empty regular file starting with the HDF5 signature.

    Nothing but the first bytes is read; a FIFO, socket or device is refused
    without blocking (:func:`cwlidar_sim.campaign.scenes.spec.open_regular_file`).
    The signature may sit at byte 0 or after a user block (512, 1024, 2048, ...
    bytes), as the HDF5 format allows.
    """
    path = os.fspath(path)
    with open_regular_file(path, what) as fh:
        size = os.fstat(fh.fileno()).st_size
        if size == 0:
            raise ValueError(f"{what} {path!r} is empty (0 bytes): not a cwlidar_sim results file "
                             f"(an interrupted copy? run the command that wrote it again)")
        offset = 0
        while offset + len(HDF5_SIGNATURE) <= size:
            fh.seek(offset)
            if fh.read(len(HDF5_SIGNATURE)) == HDF5_SIGNATURE:
                return
            offset = 512 if offset == 0 else 2 * offset
    raise ValueError(f"{what} {path!r} is not a NetCDF-4/HDF5 file (no HDF5 signature): not a cwlidar_sim "
                     f"results file")


def results_problem(ds) -> str | None:
    """What makes an opened Dataset not a cwlidar_sim results file, or None if it looks like one."""
    if "scene" not in ds.attrs:
        if "sweep_dims" in ds.attrs:
            return "no 'scene' attribute (it is a campaign's merged file: read it with xarray, or run campaign-report)"
        return "no 'scene' attribute"
    try:
        scene = json.loads(ds.attrs["scene"])
    except (TypeError, ValueError):
        return "its 'scene' attribute is not JSON"
    if not isinstance(scene, dict):
        return "its 'scene' attribute is not a table"
    sensor = ds.attrs.get("sensor")
    if sensor not in kind_names():
        return f"its 'sensor' attribute is {sensor!r}, not one of {list(kind_names())}"
    if "period" not in ds.dims:
        return "no 'period' dimension"
    return None


def _available_memory() -> float:
    # the package's one memory check (psutil, capped by a cgroup's limit); unknown: no refusal
    avail = available_memory()
    return float("inf") if avail is None else float(avail)


def open_results(path, *, sensor=None, what: str = "results file"):
    """A cwlidar_sim results file, loaded into memory, after every check (see the module docstring).

    Parameters
    ----------
    path : str or path
        The file.
    sensor : str or tuple of str, optional
        The scene kinds the caller can use (:func:`cwlidar_sim.campaign.registry.kind_names`);
        another is refused by name.
    what : str
        How the file is named in an error.

    Returns
    -------
    xarray.Dataset

    Raises
    ------
    ValueError
        One line naming the file and what is wrong: not a regular file, empty,
        not HDF5, damaged or truncated, not a cwlidar_sim results file (the
        missing attribute or dimension), another sensor's, or larger than the
        memory available.
    """
    import xarray as xr

    path = os.fspath(path)
    check_results_file(path, what)
    try:
        # phony_dims: what h5netcdf does anyway for a foreign file's unnamed dimensions, said so (no warning)
        ds = xr.open_dataset(path, engine=ENGINE, phony_dims="access")
    except _DECODE_ERRORS as e:
        raise ValueError(f"cannot read {what} {path!r} (damaged or truncated?): "
                         f"{' '.join(str(e).split())[:300]}") from None
    with ds:
        problem = results_problem(ds)
        if problem is not None:
            raise ValueError(f"{what} {path!r} is not a cwlidar_sim results file: {problem}")
        if sensor is not None:
            allowed = (sensor,) if isinstance(sensor, str) else tuple(sensor)
            if ds.attrs["sensor"] not in allowed:
                raise ValueError(f"{what} {path!r} holds a {ds.attrs['sensor']} scene's results; this needs "
                                 f"{' or '.join(allowed)} results")
        need = float(sum(v.nbytes for v in ds.variables.values()))
        avail = _available_memory()
        if need > MEMORY_FRACTION * avail:
            raise ValueError(f"{what} {path!r} holds {need / 1e9:.2f} GB of data, more than "
                             f"{MEMORY_FRACTION:.0%} of the {avail / 1e9:.2f} GB of memory available; refused")
        try:
            return ds.load()
        except _DECODE_ERRORS as e:
            raise ValueError(f"cannot read {what} {path!r} (damaged or truncated?): "
                             f"{' '.join(str(e).split())[:300]}") from None


def lacking(path, ds, error, need: str) -> ValueError:
    """The one-line error for a results file that lacks a variable or attribute ``need`` reads.

    ``error`` is the KeyError or AttributeError raised by the reading code
    (the figures, the probe-length fit); the message names the file, what is
    missing, and the file's results version against this one's (an older
    file may lack what is read now).
    """
    named = re.search(r"attribute '([^']+)'", str(error))  # xarray: "'Dataset' object has no attribute 'x'"
    missing = error.args[0] if isinstance(error, KeyError) and error.args else named.group(1) if named else str(error)
    version = ds.attrs.get("results_version", "unknown")
    return ValueError(f"results file {os.fspath(path)!r} lacks {missing!r}, which {need} read (its results_version "
                      f"is {version}, this version writes {RESULTS_VERSION}); fix: run its scene again")
