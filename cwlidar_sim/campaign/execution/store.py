"""Results on disk: checks before a run, one file per finished period, resuming, the scene's file.

A run writes each period's results as soon as the period finishes, to
``DIR/<scene>.periods/<index>_<period>.nc`` (a complete one-period results
file), atomically: a temporary file in the same folder, then a rename, so a
file that exists is whole.  The scene's file ``DIR/<scene>.nc`` is then
assembled from the period files alone, whether they were computed by this
run or by an earlier one that was interrupted: a resumed run gives the same
bits as an uninterrupted one.

A stored period is reused only when its ``scene_key`` (a hash of the scene,
the turbulence parameters, the period's index, the package version and the
results version) matches; anything else about the scene changed, and the
period is computed again.  A period file that cannot be read (truncated,
bit-flipped) is computed again too, with a warning naming it.  Writing and
reading back a period checks its key; :func:`combine_periods` refuses periods
whose scene attributes differ (never a file mixed from two runs).

The folder itself (:mod:`cwlidar_sim.campaign.execution.folder`): one run at a time
(a lock naming its holder's pid), one scene per folder (a manifest: another
scene's results are refused unless ``overwrite``, which removes every file of
the old run; the same scene with changed settings recomputes exactly the
periods it affects and removes the files it no longer uses), orphaned
temporary files removed at the next start, scene and period names checked
before compute.

Before the first period starts, :func:`preflight` checks what would make the
end of a long run fail: the folder is writable, the NetCDF engine imports,
the disk holds the estimated size, and a Dask scheduler answers.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings

from ..._version import __version__
from ..._atomic import write_netcdf_atomic
from ..._preflight import PreflightError, ResultsWriteError, check_scheduler, preflight
from ..scenes.spec import RESULTS_VERSION

__all__ = ["PreflightError", "ResultsWriteError", "preflight", "check_scheduler", "scene_key", "scene_digest",
           "PeriodStore", "combine_periods", "write_results", "read_results"]

#: The one NetCDF engine the package writes and reads with.
ENGINE = "h5netcdf"


def scene_key(scene, params, index: int) -> str:
    """Identity of period ``index`` of ``scene`` with turbulence ``params`` (hex digest)."""
    tensor = None if params is None else [params.alpha_eps, params.length_scale, params.gamma]
    blob = json.dumps({"scene": scene.as_dict(), "params": tensor,
                       "index": int(index), "version": __version__, "results_version": RESULTS_VERSION},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def scene_digest(scene, params) -> str:
    """Identity of a whole scene's results: a digest of every unit's :func:`scene_key` (hex).

    It changes with anything a unit's key holds: the scene (its seed and
    every setting), the turbulence parameters (given, or fitted to a record:
    a record whose contents changed behind the same path gives other
    parameters), the package and the results version.
    """
    keys = [scene_key(scene, params, i) for i in range(len(scene.unit_names()))]
    return hashlib.sha256(json.dumps(keys).encode()).hexdigest()[:32]


def _for_netcdf(ds):
    """A copy with object (string) arrays as fixed str, which NetCDF stores as strings."""
    ds = ds.copy()
    for name, var in ds.variables.items():
        if var.dtype == object:
            ds[name] = var.astype(str)
    return ds


def write_results(ds, path) -> None:
    """Write a results Dataset to NetCDF (h5netcdf) atomically; object arrays are stored as strings.

    Through ``cwlidar_sim._atomic.write_netcdf_atomic``: a temporary file beside ``path``, fsync,
    rename; a full disk is a :class:`ResultsWriteError` and leaves the old file.
    """
    write_netcdf_atomic(_for_netcdf(ds), path)


def read_results(path):
    """Read a results file written by :func:`cwlidar_sim.campaign.run_scene` (loaded into memory)."""
    import xarray as xr

    try:
        with xr.open_dataset(path, engine=ENGINE) as ds:
            return ds.load()
    except (OSError, ValueError, KeyError, RuntimeError) as e:  # h5py's errors for a damaged file
        raise ValueError(f"cannot read results file {os.fspath(path)!r}: {e}") from None


def _hash_values(h, a) -> None:
    """Feed an array's values to ``h`` in a canonical form (see :func:`content_digest`)."""
    import numpy as np

    a = np.asarray(a)
    h.update(f"{a.shape}|{a.dtype.kind}|".encode())
    if a.dtype.kind in "OUS":
        h.update("\x1f".join(map(str, a.ravel())).encode("utf-8", "surrogatepass"))
    elif a.dtype.kind in "fc":
        h.update(np.ascontiguousarray(a, dtype=np.complex128 if a.dtype.kind == "c" else np.float64).tobytes())
    elif a.dtype.kind in "Mm":
        h.update(np.ascontiguousarray(a.view(np.int64)).tobytes())
    else:
        h.update(np.ascontiguousarray(a, dtype=np.int64).tobytes())


def content_digest(ds) -> str:
    """SHA-256 (hex) of a Dataset's contents: its variables (names, dimensions, values) and attributes.

    HDF5 keeps no checksum of the data, so a bit flipped in a stored
    period's numbers (or in an attribute's text) reads back without an
    error; the digest, stored with the period (``content_sha256``, left out
    of what it hashes) and checked when the period is reused, turns that
    silent change into a recomputation.  Values are hashed in a canonical
    form (floats as float64, integers as int64, strings as UTF-8 text), so
    the digest of a Dataset equals that of the file written from it and read
    back.
    """
    h = hashlib.sha256()
    for name in sorted(map(str, ds.variables)):
        var = ds.variables[name]
        h.update(f"v|{name}|{var.dims}|".encode())
        _hash_values(h, var.values)
    for key in sorted(k for k in map(str, ds.attrs) if k != "content_sha256"):
        h.update(f"a|{key}|".encode())
        _hash_values(h, ds.attrs[key])
    return h.hexdigest()


class PeriodStore:
    """The per-period files of one scene in ``DIR/<scene>.periods/``.

    Parameters
    ----------
    out_dir : str or path
        The run's output folder.
    scene : Scene
    params : MannParameters or None
        Turbulence of the scene's fields (part of each period's identity;
        None where the scene itself fixes it per unit).
    """

    def __init__(self, out_dir, scene, params):
        self.folder = os.path.join(os.fspath(out_dir), f"{scene.name}.periods")
        self.scene = scene
        self.names = scene.unit_names()
        self.keys = [scene_key(scene, params, i) for i in range(len(self.names))]

    def path(self, index: int) -> str:
        """File of period ``index``."""
        return os.path.join(self.folder, f"{index:03d}_{self.names[index]}.nc")

    def load(self, index: int):
        """The stored Dataset of period ``index`` if it is whole and of this scene, else None.

        A file that cannot be read (truncated, damaged) gives None and a
        warning naming it: the period is computed again and the file replaced.
        """
        p = self.path(index)
        if not os.path.isfile(p):
            return None
        try:
            ds = read_results(p)
        except ValueError as e:
            warnings.warn(f"period file {p} is damaged and is computed again ({e})", RuntimeWarning, stacklevel=2)
            return None
        if ds.attrs.get("scene_key") != self.keys[index]:
            return None
        if ds.attrs.get("content_sha256") != content_digest(ds):
            warnings.warn(f"period file {p} is damaged (its numbers do not match the digest stored with them) "
                          f"and is computed again", RuntimeWarning, stacklevel=2)
            return None
        return ds

    def save(self, index: int, ds):
        """Write period ``index`` atomically and return it as read back (the bits the scene's file gets).

        Raises
        ------
        ResultsWriteError
            When the file read back is not this period of this scene (another
            process wrote it meanwhile): never combined into the results.
        """
        os.makedirs(self.folder, exist_ok=True)
        ds = ds.assign_attrs(scene_key=self.keys[index])
        ds = ds.assign_attrs(content_sha256=content_digest(_for_netcdf(ds)))
        p = self.path(index)
        write_results(ds, p)
        back = read_results(p)
        if back.attrs.get("scene_key") != self.keys[index]:
            raise ResultsWriteError(f"period file {p!r} was replaced by another run while this one wrote it "
                                    f"(scene key {back.attrs.get('scene_key')!r}, expected {self.keys[index]!r})")
        if content_digest(back) != ds.attrs["content_sha256"]:
            raise ResultsWriteError(f"period file {p!r} does not read back as written (its digest differs)")
        return back


#: Attributes that belong to one period; :func:`combine_periods` gathers them into JSON maps.
PERIOD_ATTRS = ("period_index", "scene_key", "field_reason", "timing", "unit_name", "content_sha256")


def _check_same_scene(datasets, attrs) -> None:
    """Raise ValueError unless every period carries the first one's scene attributes."""
    for d in datasets[1:]:
        for k in sorted(set(attrs) | (set(d.attrs) - set(PERIOD_ATTRS))):
            a, b = attrs.get(k), d.attrs.get(k)
            if json.dumps(a, sort_keys=True, default=str) != json.dumps(b, sort_keys=True, default=str):
                raise ValueError(f"periods {datasets[0].period.values[0]!r} and {d.period.values[0]!r} come from "
                                 f"different runs: their attribute {k!r} differs ({str(a)[:60]!r} against "
                                 f"{str(b)[:60]!r}); refusing to combine them")


def _check_same_variables(datasets) -> None:
    """Refuse periods whose variables differ: an outer join would fill the missing ones with NaN, unflagged."""
    names = set(datasets[0].data_vars)
    for d in datasets[1:]:
        other = set(d.data_vars)
        if other != names:
            first = str(datasets[0].attrs.get("unit_name", datasets[0].period.values[0]))
            this = str(d.attrs.get("unit_name", d.period.values[0]))
            raise ValueError(f"periods {first!r} and {this!r} hold different variables (only in {first!r}: "
                             f"{sorted(names - other)}; only in {this!r}: {sorted(other - names)}): stored by "
                             f"two versions or settings of the scene, never mixed; allowed: one run's periods "
                             f"(remove the stored periods to recompute them)")


def combine_periods(datasets, *, fill=None):
    """One Dataset from one-period Datasets, concatenated along ``period`` in index order.

    Variables without a ``period`` dimension (theory on ``k``) are taken from
    the first; series of shorter periods are padded (floats with NaN,
    integers with 0, or ``fill[name]``).  Per-period attributes become JSON
    maps keyed by period name (``field_reasons``, ``timing``; a unit of
    several rows, a cycling conical period, by its ``unit_name``).  Every
    other attribute, and the set of variables, must be the same in all
    periods (ValueError otherwise: periods of two runs are never mixed).
    """
    import numpy as np
    import xarray as xr

    # fixed-width strings read back from files would be cut to the first period's width
    datasets = [d.copy() for d in sorted(datasets, key=lambda d: int(d.attrs["period_index"]))]
    for d in datasets:
        for name, var in d.variables.items():
            if var.dtype.kind in "US":
                d[name] = var.astype(object)
    _check_same_variables(datasets)
    fill = dict(fill or {})
    for name, var in datasets[0].data_vars.items():
        if "period" in var.dims and name not in fill and var.dtype != object:
            fill[name] = 0 if np.issubdtype(var.dtype, np.integer) else np.nan
    out = xr.concat(datasets, dim="period", data_vars="minimal", coords="minimal", compat="override",
                    join="outer", fill_value=fill, combine_attrs="override")
    # concat's outer join may promote padded integers to float; restore the first period's types
    for name, var in datasets[0].data_vars.items():
        if var.dtype.kind in "iub" and out[name].dtype != var.dtype:
            out[name] = out[name].astype(var.dtype, keep_attrs=True)
    attrs = {k: v for k, v in datasets[0].attrs.items() if k not in PERIOD_ATTRS}
    _check_same_scene(datasets, attrs)
    names = [str(d.attrs.get("unit_name", d.period.values[0])) for d in datasets]
    attrs["field_reasons"] = json.dumps({n: d.attrs.get("field_reason", "") for n, d in zip(names, datasets)})
    attrs["timing"] = json.dumps({n: json.loads(d.attrs.get("timing", "{}")) for n, d in zip(names, datasets)})
    out.attrs = attrs
    return out
