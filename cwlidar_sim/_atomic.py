"""Atomic file writes: the file at a path is the old one or the whole new one, never a torn one.

Every writer of the package (turbulence boxes, results, reports, JSON,
figures, scene files) writes through :func:`atomic_path` (or
:func:`atomic_paths` for files that belong together, :func:`atomic_open`,
:func:`write_netcdf_atomic` built on them):

1. a temporary file is created in the target's own folder with
   :func:`tempfile.mkstemp` (an unpredictable name, created with ``O_EXCL``,
   so a symlink planted at a guessable name is never followed);
2. the caller writes it completely;
3. it is flushed to disk (``fsync``), given the permissions a new file gets
   under the process umask, and renamed over the target with
   :func:`os.replace` (atomic on POSIX within one file system); the folder is
   then synced so that the rename itself survives a crash;
4. on any failure (an exception, a full disk, Ctrl-C, a SIGTERM turned into
   an exception by the CLI) the temporary file is removed and the old file at
   the target is left exactly as it was.

A kill -9 between the steps leaves at most a stray ``.NAME.*.tmp`` file
beside the target, never a partial file at the target itself.

:func:`check_output_file` is the matching check made before a long
computation: the target must be a regular file or not exist yet (not a
directory, ``/dev/null``, a FIFO), in an existing folder.
"""

from __future__ import annotations

import contextlib
import errno as _errno
import io
import os
import sys
import stat
import tempfile

from ._preflight import PreflightError, ResultsWriteError

__all__ = ["atomic_path", "atomic_paths", "atomic_open", "write_netcdf_atomic", "check_output_file", "temp_name_pattern"]


def _umask() -> int:
    """The process umask, read without changing it where Linux allows.

    ``os.umask`` can only be read by setting it: another thread creating a
    file in between would get umask 0, so ``/proc/self/status`` is read first.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def temp_name_pattern(path) -> tuple[str, str]:
    """``(prefix, suffix)`` of the temporary files :func:`atomic_path` makes for ``path``.

    The suffix keeps the target's extension (``.tmp.png``), so a writer that
    picks its format from the name (matplotlib's ``savefig``) picks the same.
    """
    name = os.path.basename(os.fspath(path))
    suffix = f".tmp{os.path.splitext(name)[1]}"
    # the temporary's name fits NAME_MAX whenever the target's does: '.' + name + '.' + 8 random + suffix
    room = 255 - 10 - len(suffix.encode())
    stem = name.encode()[:room].decode("utf-8", "ignore")
    return f".{stem}.", suffix


def check_output_file(path, *, label: str = "output file", create_folder: bool = False) -> str:
    """Refuse an output path that cannot receive a file, before anything is computed.

    Parameters
    ----------
    path : str or os.PathLike
        The file to be written.
    label : str
        What the file is, for the message (e.g. ``"--out"``).
    create_folder : bool
        Create a missing parent folder (default False: a missing folder is an error naming it).

    Returns
    -------
    str
        ``path`` as a string.

    Raises
    ------
    PreflightError
        ``path`` exists and is not a regular file (a directory, a device such as
        ``/dev/null``, a FIFO, a socket), or its folder is missing or not a folder.
    """
    path = os.fspath(path)
    if not isinstance(path, str) or not path or os.path.basename(path) in ("", ".", ".."):
        raise PreflightError(f"{label} {path!r} names no file; fix: give a file path such as out/box.nc")
    try:
        st = os.stat(path)  # follows a symlink: what matters is what the name would replace
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise PreflightError(f"{label} {path!r} cannot be examined: {e.strerror or e}") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        kind = ("a directory" if stat.S_ISDIR(st.st_mode) else "a FIFO" if stat.S_ISFIFO(st.st_mode)
                else "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else "not a regular file")
        raise PreflightError(f"{label} {path!r} is {kind}; allowed: a regular file or a new name in an "
                             f"existing folder (the file is written beside it and renamed into place)")
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        if create_folder and not os.path.exists(folder):
            try:
                os.makedirs(folder, exist_ok=True)
            except OSError as e:
                raise PreflightError(f"cannot create folder {folder!r} for {label} {path!r}: "
                                     f"{e.strerror or e}") from None
        else:
            what = "does not exist" if not os.path.exists(folder) else "is not a folder"
            raise PreflightError(f"folder {folder!r} of {label} {path!r} {what}; fix: create it first "
                                 f"or choose another path")
    return path


def _fsync_path(path, *, directory: bool = False) -> None:
    fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    try:
        os.fsync(fd)
    except OSError as e:
        # some file systems cannot sync a folder (EINVAL); the rename is done all the same
        if not directory or e.errno not in (_errno.EINVAL, _errno.ENOTSUP, _errno.EBADF):
            raise
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path, *, mode: int | None = None):
    """Yield a temporary path beside ``path``; rename it over ``path`` when the block ends normally.

    Parameters
    ----------
    path : str or os.PathLike
        The target file.  Its folder must exist.  An existing regular file is
        replaced only once the new one is complete; a symlink at ``path`` is
        replaced by the file (its target is not written through).
    mode : int, optional
        Permission bits of the new file; default ``0o666`` less the umask,
        what :func:`open` gives a new file.

    Yields
    ------
    str
        A new, empty temporary file's path in the same folder (name
        ``.NAME.XXXXXXXX.tmp.EXT``); write it by name (``to_netcdf``,
        ``savefig``...).

    Raises
    ------
    ResultsWriteError
        An OSError while writing, syncing or renaming (a full disk, a
        quota): it names ``path`` and says the old file is unchanged.
    """
    with atomic_paths([path], mode=mode) as (tmp,):
        yield tmp


@contextlib.contextmanager
def atomic_paths(paths, *, mode: int | None = None):
    """:func:`atomic_path` for files that belong together (a HAWC2 u, v, w triplet).

    Every temporary file is written and synced before the first rename, so a
    failure while writing or syncing any of them (a full disk may surface only
    at ``fsync``) leaves every old file in place.  Only a failing rename
    between the first and the last (same folder, already on disk: not seen in
    practice) could mix old and new files.

    Parameters
    ----------
    paths : sequence of str or os.PathLike
        The target files, renamed in this order.
    mode : int, optional
        Permission bits (see :func:`atomic_path`).

    Yields
    ------
    list of str
        One temporary path per target, in order.
    """
    paths = [os.fspath(p) for p in paths]
    tmps = []
    try:
        for path in paths:
            prefix, suffix = temp_name_pattern(path)
            fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), prefix=prefix, suffix=suffix)
            os.close(fd)
            tmps.append(tmp)
        yield list(tmps)
        perm = (0o666 & ~_umask()) if mode is None else mode  # mkstemp makes 0600
        for tmp in tmps:  # every new file on disk before the first rename
            _fsync_path(tmp)
            os.chmod(tmp, perm)
        for tmp, path in zip(tmps, paths):
            os.replace(tmp, path)
    except BaseException as e:
        for tmp in tmps:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if isinstance(e, OSError) and not isinstance(e, ResultsWriteError):
            names = ", ".join(repr(p) for p in paths)
            raise ResultsWriteError(e.errno, f"cannot write {names}: {e.strerror or e}; "
                                             f"the previous file{'s' if len(paths) > 1 else ''} there "
                                             f"(if any) {'are' if len(paths) > 1 else 'is'} unchanged") from None
        raise
    for folder in dict.fromkeys(os.path.dirname(os.path.abspath(p)) for p in paths):
        _fsync_path(folder, directory=True)  # the renames themselves survive a crash


@contextlib.contextmanager
def atomic_open(path, mode: str = "w", *, encoding: str | None = "utf-8"):
    """Open a temporary file beside ``path`` for writing; it replaces ``path`` when the block ends normally.

    Parameters
    ----------
    path : str or os.PathLike
        The target file (see :func:`atomic_path`).
    mode : {"w", "wb"}
        Text or binary.
    encoding : str, optional
        Text encoding (text mode only; default UTF-8).

    Yields
    ------
    file object
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode={mode!r} is not allowed; allowed: 'w', 'wb'")
    with atomic_path(path) as tmp:
        with open(tmp, mode, encoding=None if "b" in mode else encoding) as fh:
            yield fh


class _SinkFile(io.FileIO):
    """A file whose first failed write is kept for later, not reported to HDF5.

    HDF5 does not survive a failed write: its error surfaces in object
    deallocations ("Exception ignored in ObjectID.__dealloc__"), the close
    fails half-way and the process segfaults at exit (status 139).  Given this
    file, HDF5 sees every write succeed; the first OSError (ENOSPC, EFBIG,
    EDQUOT) is kept in :attr:`error`, later writes are dropped, and the caller
    raises :attr:`error` once HDF5 has closed cleanly (and throws the
    temporary file away).  An exception raised in :meth:`write` by a signal
    handler (SIGTERM, Ctrl-C) is kept and re-raised the same way.
    """

    error: BaseException | None = None

    def write(self, b):
        view = memoryview(b).cast("B")
        if self.error is None:
            try:
                done = 0
                while done < len(view):  # a raw write may be short (at a file size limit)
                    done += super().write(view[done:])
            except BaseException as e:  # also a SIGTERM/Ctrl-C arriving here: HDF5 must not see it
                self.error = e
        return len(view)

    def truncate(self, size=None):
        if self.error is None:
            try:
                return super().truncate(size)
            except OSError as e:
                self.error = e
        return self.tell() if size is None else size


@contextlib.contextmanager
def _local_scheduler():
    """Dask's synchronous scheduler for the block, if dask is imported: xarray hands its writes to the
    distributed scheduler whenever a client exists, and an open file cannot travel to a worker."""
    if "dask" not in sys.modules:
        yield
        return
    import dask

    with dask.config.set(scheduler="synchronous"):
        yield


def write_netcdf_atomic(ds, path, *, encoding=None, format: str = "NETCDF4") -> None:
    """Write an xarray Dataset to NetCDF-4 (h5netcdf) atomically; a failed write never reaches HDF5.

    Parameters
    ----------
    ds : xarray.Dataset
    path : str or os.PathLike
        Target file (see :func:`atomic_path`).
    encoding : dict, optional
        Per-variable encoding, as for ``Dataset.to_netcdf``.
    format : str
        ``"NETCDF4"`` (default) or ``"NETCDF4_CLASSIC"``.

    Raises
    ------
    ResultsWriteError
        The write failed (full disk, quota, file size limit); the temporary
        file is removed and the old file at ``path`` is unchanged.

    Notes
    -----
    Why not ``ds.to_netcdf(path)``: when a write fails inside HDF5 (a full
    disk), xarray's close raises half-way, the h5netcdf ``File`` stays marked
    open, and its ``__del__`` closes it again later (at the latest at
    interpreter exit) on an HDF5 file that is half gone: a segmentation fault
    (exit 139) after the error message.  Here HDF5 writes through a
    :class:`_SinkFile` (h5py's file-object driver), so a failed write never
    reaches HDF5: it closes cleanly and the kept error is raised after.
    The Dataset stored is the one ``to_netcdf(path)`` stores (this is
    ``to_netcdf`` on a file object; it reads back identical), but the file's
    internal layout differs (the file-object driver lays the blocks out
    otherwise; a 64 x 8 x 8 box: 61594 bytes instead of 63030).
    """
    path = os.fspath(path)
    # dask-backed variables are computed here, in this process: with a distributed client about (a
    # campaign's worker), to_netcdf would otherwise ship its writes, and the open file, to the cluster
    ds = ds.load() if any(getattr(v, "chunks", None) for v in ds.variables.values()) else ds
    with atomic_path(path) as tmp:
        with _SinkFile(tmp, "w+b") as sink, _local_scheduler():
            try:
                # xarray validates names and attributes, encodes, writes (dask too) and closes its
                # h5netcdf File; HDF5 never sees a failed write, so the close cannot fail half-way
                ds.to_netcdf(sink, engine="h5netcdf", format=format, encoding=encoding or {})
            except BaseException as e:
                if sink.error is not None:  # the write failure (or signal) behind what HDF5 made of it
                    raise sink.error from None
                if isinstance(e, RuntimeError):  # HDF5's own failures surface as RuntimeError
                    raise OSError(_errno.EIO, f"{e}") from None
                raise
            if sink.error is not None:
                raise sink.error
