"""A results folder: one run at a time, one scene (or campaign), safe file names, no orphaned temporaries.

Rules (the store's, see :mod:`cwlidar_sim.campaign.execution.store`):

* **One run at a time.**  A run holds an exclusive ``fcntl.flock`` on
  ``DIR/.cwlidar-sim.lock`` (the holder's pid written in it) from before its
  first period to its last file; a second run into the same folder is refused
  at once with a one-line error naming that pid.  The lock is reentrant within
  one process (the CLI holds it across the run and its figures).
* **One owner.**  ``DIR/cwlidar-run.json`` (the manifest, written atomically)
  names the folder's owner -- a scene (its name, kind and results digest,
  :func:`cwlidar_sim.campaign.execution.store.scene_digest`) or a campaign -- and the files
  its run wrote (results, figures).  A run of *another* scene or campaign (another
  name or kind) is refused before anything is computed unless ``overwrite``,
  which removes every file of the old run (its period files, figures, task files
  and manifest) before computing; the old results file is only removed once the
  new one is written, so it survives a run that fails.  The *same* scene with
  changed settings is not refused: its periods whose identity changed are
  computed again, the others reused, and the files of the old run that the new
  one no longer uses (period files of removed periods, the figures) are removed.
* **No orphans.**  Temporary files (``.tmp-*``) that a killed run left are
  removed at the next run's start, under the lock (so never a live run's).
* **Safe names.**  Scene and period names become file names: they are checked
  before anything is computed (no path separator, NUL, control character or
  ``..``, not starting with '.', and every file name derived from them at most
  :data:`NAME_MAX` bytes).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import glob
import json
import os
import shutil
import unicodedata

from ..._preflight import PreflightError, check_writable

__all__ = ["CAMPAIGN", "NAME_MAX", "LOCK_NAME", "MANIFEST_NAME", "check_file_names", "locked", "clean_temporaries",
           "read_manifest", "write_manifest", "claim", "settle", "finish", "record_figures",
           "record_files", "CAMPAIGN_FILES", "SIDE_SUFFIX_MAX"]

#: Longest file name (bytes) of common file systems (ext4, xfs, btrfs, APFS).
NAME_MAX = 255
LOCK_NAME = ".cwlidar-sim.lock"
MANIFEST_NAME = "cwlidar-run.json"
#: Files and folders of a campaign's run (:mod:`cwlidar_sim.campaign.execution.batch`), removed by ``overwrite``.
#: The owner kind of a campaign's folder (a scene's folder is owned by its scene kind).
CAMPAIGN = "campaign"
CAMPAIGN_FILES = ("tasks", "index.json", "campaign.json", "summary.json", "campaign.nc", "figures")

_held: dict = {}  # real path of a locked folder -> [open lock file, depth] (this process)


def _check_name(field: str, name: str) -> None:
    """``name`` can be part of a file name: no separator, NUL, control character, '..', leading '.'."""
    bad = [c for c in name if c in "/\\" or unicodedata.category(c).startswith("C")]
    if bad or ".." in name or name.startswith(".") or not name.strip():
        why = (f"it holds {bad[0]!r}" if bad else "it holds '..'" if ".." in name
               else "it starts with '.'" if name.startswith(".") else "it is blank")
        raise ValueError(f"{field} {name!r} cannot name a file: {why}; allowed: letters, digits and "
                         f"punctuation other than '/' and '\\', not starting with '.', without '..'")


def _check_length(field: str, name: str, file_name: str) -> None:
    n = len(os.fsencode(file_name))
    if n > NAME_MAX:
        raise ValueError(f"{field} {name[:40]!r}... is too long: the file name derived from it is {n} bytes, "
                         f"over the file system's limit of {NAME_MAX}; fix: shorten it")


#: The longest suffix of a file a run writes beside ``<name>.nc`` (the tidy table's ``.stats.parquet``; a kind's
#: side files, such as the nacelle's ``.preview.csv``, are no longer).
SIDE_SUFFIX_MAX = ".stats.parquet"


def check_file_names(scene) -> None:
    """Raise ValueError unless every file name the scene's run derives from its names is safe.

    Checked: the scene's name (``<name>.nc``, ``<name>.periods``, the files beside the
    results, up to ``<name>`` + :data:`SIDE_SUFFIX_MAX`), each
    period's name and each unit's file ``<index>_<unit>.nc``.  Called before
    anything is computed or written.
    """
    _check_name("scene name", scene.name)
    _check_length("scene name", scene.name, f"{scene.name}{SIDE_SUFFIX_MAX}")
    for i, unit in enumerate(scene.unit_names()):  # each holds its period's name
        _check_name("period name", unit)
        _check_length("period name", unit, f"{i:03d}_{unit}.nc")


def _holder(path) -> str:
    try:
        with open(path, encoding="utf-8") as fh:
            pid = fh.read().strip()
    except OSError:
        pid = ""
    return f"pid {pid}" if pid.isdigit() else "a process whose pid is not yet written"


@contextlib.contextmanager
def locked(folder):
    """Hold the folder's lock (created with the folder); a second holder gets :class:`PreflightError`.

    Reentrant within one process: a nested ``locked`` of the same folder
    passes through.  The lock is released when the outermost one exits, or
    by the system when the process dies (``kill -9`` included).
    """
    folder = os.fspath(folder)
    check_writable(folder)
    key = os.path.realpath(folder)
    if key in _held:
        _held[key][1] += 1
        try:
            yield
        finally:
            _held[key][1] -= 1
        return
    path = os.path.join(folder, LOCK_NAME)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as e:
        os.close(fd)
        if e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            raise PreflightError(f"results folder {folder!r} is in use by another run ({_holder(path)}); "
                                 f"fix: wait for it to finish, or choose another --out") from None
        raise PreflightError(f"cannot lock results folder {folder!r}: {e.strerror or e}") from None
    try:
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        _held[key] = [fd, 1]
        yield
    finally:
        _held.pop(key, None)
        os.close(fd)  # releases the flock


def clean_temporaries(folder, log=None) -> list:
    """Remove the temporary files a killed run left in ``folder`` (call under its lock); return them."""
    folder = os.fspath(folder)
    found = []
    for sub in ("", "*.periods", "tasks", os.path.join("tasks", "*", "*.periods")):
        for pattern in (".tmp-*", ".write-check-*", "*.json.tmp-*", ".*.tmp", ".*.tmp.*"):  # the last two: _atomic's
            found.extend(glob.glob(os.path.join(folder, sub, pattern)))
    for path in sorted(found):
        try:
            os.unlink(path)
        except OSError:
            continue
        if log is not None:
            log(f"removed {path}, a temporary file of an interrupted run")
    return found


def read_manifest(folder) -> dict | None:
    """The folder's manifest, or None when there is none (an unreadable one counts as none)."""
    try:
        with open(os.path.join(os.fspath(folder), MANIFEST_NAME), encoding="utf-8") as fh:
            m = json.load(fh)
    except (OSError, ValueError):
        return None
    return m if isinstance(m, dict) else None


def write_manifest(folder, manifest: dict) -> None:
    """Write the manifest atomically (temporary file, fsync, rename)."""
    path = os.path.join(os.fspath(folder), MANIFEST_NAME)
    tmp = os.path.join(os.fspath(folder), f".tmp-{MANIFEST_NAME}")
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(manifest, fh, indent=1)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _is_results_file(path) -> bool:
    """Whether ``path`` is a scene results file of this package (its root attributes hold ``scene``)."""
    try:
        import h5py

        with h5py.File(path, "r") as f:
            return "scene" in f.attrs
    except Exception:  # not HDF5, unreadable: not ours
        return False


def _legacy_owner(folder, name: str, kind: str) -> list:
    """Files of another run in a folder without a manifest (written before manifests existed)."""
    found = []
    if kind != CAMPAIGN and os.path.isfile(os.path.join(folder, "campaign.json")):
        found += [f for f in CAMPAIGN_FILES if os.path.exists(os.path.join(folder, f))]
    for d in glob.glob(os.path.join(folder, "*.periods")):
        if os.path.basename(d) != f"{name}.periods" or kind == CAMPAIGN:
            found.append(os.path.basename(d))
    for f in glob.glob(os.path.join(folder, "*.nc")):
        base = os.path.basename(f)
        if base != f"{name}.nc" and base != "campaign.nc" and _is_results_file(f):
            found.append(base)
    return sorted(set(found))


def _plain(rel) -> bool:
    """Whether a manifest's entry is a plain file name in the folder (a damaged or crafted one may not be)."""
    return isinstance(rel, str) and rel not in ("", ".", "..") and os.path.basename(rel) == rel and "\\" not in rel


def _remove(folder, rel, log) -> None:
    if not _plain(rel):
        return
    path = os.path.join(folder, rel)
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path)
    elif os.path.lexists(path):
        os.unlink(path)
    else:
        return
    if log is not None:
        log(f"removed {path} (--overwrite: a file of the old run)")


def _owner(name, kind) -> str:
    """How a message names a folder's owner: ``campaign 'x'`` or ``staring scene 'y'``."""
    return f"{CAMPAIGN if kind == CAMPAIGN else f'{kind} scene'} {name!r}"


def claim(folder, name: str, kind: str, *, overwrite: bool = False, log=None) -> dict:
    """Take ``folder`` for the run of ``name`` (a scene of ``kind``, or kind 'campaign'); call under the lock.

    Refuses (:class:`PreflightError`, before anything is computed) when the
    folder holds another owner's run, unless ``overwrite``: then every file of
    the old run is removed (its results file only later, see
    ``manifest['remove_after']``).  ``overwrite`` of the same owner starts it
    afresh (nothing reused).

    Returns
    -------
    dict
        The new manifest (written): ``name``, ``kind``, the old run's
        ``digest`` and ``figures`` when it is the same owner, and
        ``remove_after``: old results files to remove once the new results are written.
    """
    folder = os.fspath(folder)
    old = read_manifest(folder)
    me, campaign = _owner(name, kind), kind == CAMPAIGN
    remove_after = []
    if old is not None:
        same = old.get("name") == name and old.get("kind") == kind
        theirs = _owner(old.get("name"), old.get("kind"))
        files = (list(CAMPAIGN_FILES) if old.get("kind") == CAMPAIGN
                 else [f"{old.get('name')}.periods", *old.get("figures", [])])
        side = [f for f in old.get("files", []) if _plain(f)]  # beside its results: removed with them
        remove_after = [f for f in old.get("remove_after", []) if f != f"{name}.nc"]
        results = old.get("results")
    else:
        files = _legacy_owner(folder, name, kind)
        same = not files
        theirs = f"another run ({', '.join(files[:3])}{', ...' if len(files) > 3 else ''})"
        results, side = None, []
    if old is not None and not same and not any(
            os.path.exists(os.path.join(folder, f)) for f in [*files, *([results] if results else [])]):
        # the old owner left nothing on disk (its run failed before its first unit): nothing to protect
        old, same, files, remove_after, results, side = None, True, [], [], None, []
    if not same and not overwrite:
        raise PreflightError(f"results folder {folder!r} holds the results of {theirs}, not of the {me}; "
                             f"fix: choose another --out (e.g. {os.path.join(folder, name)}), or pass --overwrite "
                             f"to remove the old results")
    new = {"name": name, "kind": kind, "digest": old.get("digest") if old and same else None,
           "figures": list(old.get("figures", [])) if old and same else [], "results": results if same else None,
           "files": side if same else []}
    if overwrite:
        if old is not None and old.get("results") and old.get("kind") != CAMPAIGN:
            files.append(old["results"])
        if not campaign:  # the same scene's periods too: overwrite computes afresh
            files.append(f"{name}.periods")
        remove_after += side
        for rel in dict.fromkeys(files):
            if rel.endswith(".nc") and rel != "campaign.nc":
                remove_after.append(rel)  # the old results survive until the new ones are written
            else:
                _remove(folder, rel, log)
        new.update(digest=None, figures=[], results=None, files=[])
    new["remove_after"] = sorted({f for f in remove_after if f != (None if campaign else f"{name}.nc")})
    write_manifest(folder, new)
    return new


def finish(folder, manifest: dict, results: str, log=None) -> None:
    """After the new results file ``results`` is written: remove the old run's results, record the new."""
    for rel in filter(_plain, manifest.get("remove_after", [])):
        path = os.path.join(os.fspath(folder), rel)
        if os.path.isfile(path):
            os.unlink(path)
            if log is not None:
                log(f"removed {path}, the results of the run this one overwrote")
    manifest.update(results=results, remove_after=[])
    write_manifest(folder, manifest)


def settle(folder, manifest: dict, digest: str, periods_dir, keep, log=None) -> None:
    """Before computing, the same scene's run: remove what the old run wrote that this one no longer uses.

    ``keep``: the file names of this run's periods in ``periods_dir``; any
    other ``*.nc`` there (a removed or renamed period) is stale.  When the
    scene's ``digest`` changed since the old run, its figures are stale too.
    """
    folder = os.fspath(folder)
    stale = []
    if os.path.isdir(periods_dir):
        stale = [os.path.join(periods_dir, f) for f in sorted(os.listdir(periods_dir))
                 if f.endswith(".nc") and f not in set(keep)]
    old = manifest.get("digest")
    if old is not None and old != digest:
        if log is not None:
            log(f"the scene {manifest['name']!r} changed since its results in {folder!r} were written: "
                f"the periods it affects are computed again, the others reused; the old figures are removed")
        stale += [os.path.join(folder, f) for f in manifest.get("figures", []) if _plain(f)]
        manifest["figures"] = []
    for path in stale:
        if os.path.isfile(path):
            os.unlink(path)
            if log is not None:
                log(f"removed {path}, which the changed scene no longer uses")
    manifest["digest"] = digest
    write_manifest(folder, manifest)


def record_figures(folder, paths) -> None:
    """Add figure files (written into ``folder`` for its owner) to the manifest, so a later change removes them."""
    folder = os.fspath(folder)
    m = read_manifest(folder)
    if m is None:
        return
    rel = [os.path.relpath(os.path.abspath(p), os.path.abspath(folder)) for p in paths]
    m["figures"] = sorted(set(m.get("figures", [])) | {r for r in rel if not r.startswith("..")})
    write_manifest(folder, m)


def record_files(folder, paths) -> None:
    """Record the files a run wrote beside its results (the tidy table, a kind's side files) in the manifest.

    An overwrite by another owner removes them once its own results are written, as it does the old results.
    """
    folder = os.fspath(folder)
    m = read_manifest(folder)
    if m is None:
        return
    rel = [os.path.relpath(os.path.abspath(p), os.path.abspath(folder)) for p in paths]
    m["files"] = sorted(set(m.get("files", [])) | {r for r in rel if not r.startswith("..")})
    write_manifest(folder, m)
