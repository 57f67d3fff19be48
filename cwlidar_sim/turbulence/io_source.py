"""A turbulence field a user already has, as the field a record is sampled from: read, checked, placed.

A scene names a file (``[turbulence] file``,
:mod:`cwlidar_sim.campaign.scenes.turbulence_spec`); :class:`FieldFile`
reads it with the readers of this package and :func:`place_field` puts it
where the record's sensors need it, or refuses it, naming the sizes, when it
is too small.  Every scene kind calls it the same way: its sensors' region
(:class:`cwlidar_sim.turbulence.cover.Region`) for a record of ``duration``
seconds in a mean wind ``U`` along +x.

Formats (``format``; inferred from the suffix when absent)
----------------------------------------------------------
* ``"turbsim"`` (``.bts``): :func:`cwlidar_sim.turbulence.io_turbsim.read_turbsim`;
* ``"bladed"`` (``.wnd`` with its ``.sum``): :func:`cwlidar_sim.turbulence.io_bladed.read_bladed`
  (``left_hand_rule`` when there is no summary);
* ``"hawc2"`` (``BASE_u.bin``..., named by ``BASE``, ``BASE.bin``,
  ``BASE_u.bin`` or the sidecar ``BASE.json``):
  :func:`cwlidar_sim.turbulence.io.read_hawc2`, with ``shape`` and
  ``spacing`` when there is no sidecar, and the orientation ``convention``
  ('hawc2' or 'openfast') and ``reverse_x`` as that reader takes them;
* ``"netcdf"`` (``.nc``, ``.nc4``, ``.cdf``): u, v, w [m/s] on (x, y, z)
  (a frozen box, as :func:`cwlidar_sim.turbulence.io.write_netcdf` writes
  it) or on (t, x, y, z) (time-resolved, an LES's output); ``dims`` maps
  our names to the file's (``{"t": "time", "x": "xc"}``).

What a field means
------------------
u, v, w are fluctuations about the period's mean wind ``U`` along +x (the
scene's ``mean_speed``, which the sensors add to u, as for the generated
fields).

* A **frozen** field (x, y, z) is advected at ``U`` (Taylor, as the generated
  boxes are): a sensor at rest at x sees at time t the plane at ``x - U t``.
  The record needs ``|U| duration + length`` along x (the region's length,
  plus one spacing at each end for the interpolation), and the region's
  width and height across; the file's grid is placed with that span centred
  in it (in x, y and z).  Along x the sampler is periodic, but a placed
  frozen field is never sampled across its end.
* A **time-resolved** field (t, x, y, z) is not advected (its time axis
  holds the flow's evolution and transport): a sensor at p reads the field
  at p, linearly interpolated in space (trilinear) and in time (between the
  two snapshots around t).  Record time 0 is the file's first time; the
  file must last the record (``t[-1] - t[0] >= duration``) and hold the
  region itself, placed centred as above.

Coordinates: the file's own are replaced by the placed ones (the spacing is
kept; the x, y, z of the readers start at 0); a time-resolved field's t
becomes ``t - t[0]`` [s].
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from .._validation import check_bool, check_choice, check_int, check_real, check_str, check_tuple
from .cover import Region

__all__ = ["FieldFile", "FORMATS", "infer_format", "place_field", "field_need"]

#: The formats a field file can be read in.
FORMATS = ("turbsim", "bladed", "hawc2", "netcdf")
_SUFFIXES = {".bts": "turbsim", ".wnd": "bladed", ".nc": "netcdf", ".nc4": "netcdf", ".cdf": "netcdf",
             ".bin": "hawc2", ".json": "hawc2"}
#: The keys each format takes besides ``path`` and ``format``.
FORMAT_OPTIONS = {"turbsim": (), "bladed": ("left_hand_rule",), "hawc2": ("convention", "reverse_x", "shape",
                                                                           "spacing"), "netcdf": ("dims",)}
_DIMS = ("t", "x", "y", "z")


def infer_format(path) -> str:
    """The format of a field file from its suffix (``.bts``, ``.wnd``, ``.nc``, ``.bin``, ``.json``...)."""
    suffix = Path(str(path)).suffix.lower()
    if suffix not in _SUFFIXES:
        raise ValueError(f"the format of {str(path)!r} is not known from its suffix {suffix!r}; give format = one "
                         f"of {', '.join(map(repr, FORMATS))} (suffixes: "
                         f"{', '.join(f'{s} {f}' for s, f in _SUFFIXES.items())})")
    return _SUFFIXES[suffix]


@dataclasses.dataclass(frozen=True)
class FieldFile:
    """A field file and how to read it (module notes).

    Parameters
    ----------
    path : str
        The file (HAWC2: the base name, ``BASE.bin``, ``BASE_u.bin`` or the
        sidecar ``BASE.json``).
    format : {'turbsim', 'bladed', 'hawc2', 'netcdf'}, optional
        Default: from the suffix (:func:`infer_format`).
    convention : {'hawc2', 'openfast'}, optional
        HAWC2 only: the files' layout (:func:`cwlidar_sim.turbulence.io.read_hawc2`).
    reverse_x : bool, optional
        HAWC2 only: the x planes stored in arrival order.
    shape : (int, int, int), optional
        HAWC2 only, without a sidecar: (Nx, Ny, Nz).
    spacing : (float, float, float), optional
        HAWC2 only, without a sidecar: (dx, dy, dz) [m].
    left_hand_rule : bool, optional
        Bladed only, without a ``.sum``: v stored along -y.
    dims : dict, optional
        NetCDF only: our dimension name ('t', 'x', 'y', 'z') -> the file's.
    """

    path: str
    format: str | None = None
    convention: str | None = None
    reverse_x: bool | None = None
    shape: tuple | None = None
    spacing: tuple | None = None
    left_hand_rule: bool | None = None
    dims: dict | None = None

    def __post_init__(self):
        check_str("path", self.path)
        fmt = infer_format(self.path) if self.format is None else self.format
        check_choice("format", fmt, FORMATS)
        object.__setattr__(self, "format", fmt)
        for key in ("convention", "reverse_x", "shape", "spacing", "left_hand_rule", "dims"):
            if getattr(self, key) is not None and key not in FORMAT_OPTIONS[fmt]:
                takes = [f for f, opts in FORMAT_OPTIONS.items() if key in opts]
                raise ValueError(f"{key} = {getattr(self, key)!r} applies to format {' or '.join(map(repr, takes))}, "
                                 f"not {fmt!r}; allowed for {fmt!r}: {list(FORMAT_OPTIONS[fmt]) or 'none'}")
        if self.convention is not None:
            check_choice("convention", self.convention, ("hawc2", "openfast"))
        for key in ("reverse_x", "left_hand_rule"):
            if getattr(self, key) is not None:
                check_bool(key, getattr(self, key))
        if self.shape is not None:
            object.__setattr__(self, "shape", check_tuple("shape", self.shape, 3,
                                                          lambda n, v: check_int(n, v, lo=2)))
        if self.spacing is not None:
            object.__setattr__(self, "spacing", check_tuple("spacing", self.spacing, 3,
                                                            lambda n, v: check_real(n, v, lo=0.0, lo_open=True)))
        if self.dims is not None:
            if not isinstance(self.dims, dict):
                raise TypeError(f"dims must be a table of our dimension names -> the file's, got {self.dims!r}")
            bad = sorted(set(self.dims) - set(_DIMS))
            if bad:
                raise ValueError(f"dims: unknown names {bad}; allowed: {list(_DIMS)} (ours), each -> the file's name")
            for k, v in self.dims.items():
                check_str(f"dims.{k}", v)
            object.__setattr__(self, "dims", dict(self.dims))

    def as_dict(self) -> dict:
        """The keys given (TOML-shaped)."""
        out = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is not None:
                out[f.name] = list(v) if isinstance(v, tuple) else (dict(v) if isinstance(v, dict) else v)
        return out

    # -- the files ----------------------------------------------------------
    def _hawc2_base(self, path: str) -> str:
        for tail in ("_u.bin", ".json"):
            if path.endswith(tail):
                return path[: -len(tail)]
        return path

    def files(self, base_dir: str = ".") -> list:
        """The files this source reads [paths], relative ones taken from ``base_dir``."""
        from .io import hawc2_paths

        path = self.path if os.path.isabs(self.path) else os.path.join(base_dir, self.path)
        if self.format == "hawc2":
            return [str(p) for p in hawc2_paths(self._hawc2_base(path))]
        return [path]

    def check_files(self, base_dir: str = ".", label: str = "file") -> None:
        """Every file exists (a FileNotFoundError naming ``label`` and the path otherwise)."""
        for p in self.files(base_dir):
            if not os.path.isfile(p):
                raise FileNotFoundError(f"{label}: {self.format} field file not found: {p!r}"
                                        + (f" (relative paths are taken from the scene file's folder {base_dir!r})"
                                           if not os.path.isabs(self.path) else ""))

    def read(self, base_dir: str = "."):
        """The field as the reader gives it (cached for the process, keyed by the files' sizes and times)."""
        files = self.files(base_dir)
        key = (self, tuple((os.path.abspath(p), os.stat(p).st_mtime_ns, os.stat(p).st_size) for p in files
                           if os.path.isfile(p)))
        if _CACHE.get("key") != key:
            _CACHE.clear()
            _CACHE["field"] = self._read(files[0] if self.format != "hawc2" else
                                         self._hawc2_base(self.path if os.path.isabs(self.path)
                                                          else os.path.join(base_dir, self.path)))
            _CACHE["key"] = key
        return _CACHE["field"]

    def _read(self, path):
        if self.format == "turbsim":
            from .io_turbsim import read_turbsim

            return read_turbsim(path)
        if self.format == "bladed":
            from .io_bladed import read_bladed

            return read_bladed(path, left_hand_rule=self.left_hand_rule)
        if self.format == "hawc2":
            from .io import read_hawc2

            return read_hawc2(path, self.shape, self.spacing, reverse_x=self.reverse_x, convention=self.convention)
        return _read_netcdf(path, self.dims or {})

    def place(self, region: Region, U: float, duration: float, *, base_dir: str = ".", label: str = "file"):
        """The field read and placed for a record (:func:`place_field`)."""
        return place_field(self.read(base_dir), region, U, duration, label=f"{label} {self.path!r}")


_CACHE: dict = {}


def _read_netcdf(path, dims: dict):
    """u, v, w on (x, y, z) or (t, x, y, z) from a NetCDF file, the file's dimension names mapped by ``dims``."""
    import xarray as xr

    from ._io_meta import decode_attrs

    if not os.path.isfile(path):
        raise FileNotFoundError(f"NetCDF file not found: {str(path)!r}")
    with xr.open_dataset(path, engine="h5netcdf", mask_and_scale=False, decode_times=False, cache=False) as ds:
        missing = [c for c in ("u", "v", "w") if c not in ds.data_vars]
        if missing:
            raise ValueError(f"NetCDF file {str(path)!r} lacks {missing}; allowed: u, v, w [m/s]")
        rename = {v: k for k, v in dims.items() if v != k}
        absent = [v for v in rename if v not in ds.dims]
        if absent:
            raise ValueError(f"dims: {absent} are not dimensions of {str(path)!r} (its dimensions: {list(ds.dims)})")
        ds = ds[["u", "v", "w"]].rename(rename).load()
        attrs = decode_attrs(dict(ds.attrs))
    for c in ("u", "v", "w"):
        if set(ds[c].dims) not in ({"x", "y", "z"}, {"t", "x", "y", "z"}):
            raise ValueError(f"{str(path)!r}: {c} has dims {ds[c].dims}; allowed: (x, y, z) or (t, x, y, z) "
                             f"(name the file's with dims = {{t = ..., x = ...}})")
    order = ("t", "x", "y", "z") if "t" in ds["u"].dims else ("x", "y", "z")
    out = ds.transpose(*order)
    out.attrs = attrs
    return out


def _grid(field, label):
    """``(n, d, t_k)``: node counts and spacings along x, y, z [m], and the times [s] (None: frozen)."""
    n, d = [], []
    for ax in "xyz":
        if ax not in field.dims:
            raise ValueError(f"{label} has no {ax} dimension; allowed: a box (x, y, z) or (t, x, y, z)")
        c = np.asarray(field[ax].values, dtype=np.float64) if ax in field.coords else None
        m = int(field.sizes[ax])
        if m < 2:
            raise ValueError(f"{label} has {m} node along {ax}; allowed: at least 2")
        if c is not None:
            step = np.diff(c)
            h = float(step.mean())
            if not (h > 0 and np.allclose(step, h, rtol=1e-6, atol=0.0)):
                raise ValueError(f"{label}: its {ax} coordinate is not evenly increasing; allowed: uniform nodes")
        elif f"d{ax}" in field.attrs:
            h = float(field.attrs[f"d{ax}"])
        else:
            raise ValueError(f"{label} has no {ax} coordinate nor attrs['d{ax}']: its spacing is unknown")
        n.append(m)
        d.append(h)
    t_k = None
    if "t" in field.dims:
        if "t" not in field.coords:
            raise ValueError(f"{label} has a t dimension without a t coordinate [s]")
        t_k = np.asarray(field["t"].values, dtype=np.float64)
        if t_k.size < 2 or not np.all(np.diff(t_k) > 0):
            raise ValueError(f"{label}: its t coordinate must hold at least 2 increasing times [s]")
    return n, d, t_k


def field_need(region: Region, U: float, duration: float, time_resolved: bool = False) -> tuple:
    """``(x_lo, x_hi, width, height)``: what a record of ``duration`` [s] in a wind U needs of a field [m] (module notes)."""
    reach = 0.0 if time_resolved else abs(float(U)) * float(duration)
    return region.x_lo - reach, region.x_lo + region.length, 2.0 * region.half_width, 2.0 * region.half_height


def place_field(field, region: Region, U: float, duration: float, *, label: str = "field"):
    """``field`` with coordinates that put ``region``'s record in its middle; refused, naming sizes, if too small.

    Parameters
    ----------
    field : xarray.Dataset
        u, v, w on (x, y, z) (frozen) or (t, x, y, z) (time-resolved), with
        their spacing (evenly spaced coordinates or ``attrs['dx']``...).
    region : Region
        What the sensors reach at t = 0, in the field frame [m].
    U : float
        Mean wind along +x [m/s] (a frozen field's advection).
    duration : float
        Record length [s].
    label : str
        How messages name the field.

    Returns
    -------
    xarray.Dataset
        The same data, coordinates placed (module notes); a time-resolved
        field's t counted from its first time.
    """
    if not isinstance(region, Region):
        raise TypeError(f"region must be a Region, got {type(region).__name__}")
    U = check_real("U", U, lo=-1000.0, hi=1000.0)
    duration = check_real("duration", duration, lo=0.0, lo_open=True)
    (nx, ny, nz), (dx, dy, dz), t_k = _grid(field, label)
    x_lo, x_hi, width, height = field_need(region, U, duration, t_k is not None)
    need = (x_hi - x_lo + 2.0 * dx, width, height)
    have = ((nx - 1) * dx, (ny - 1) * dy, (nz - 1) * dz)
    short = [ax for ax, h, n in zip("xyz", have, need) if h < n * (1 - 1e-9)]
    span = None if t_k is None else float(t_k[-1] - t_k[0])
    if short or (span is not None and span < duration * (1 - 1e-9)):
        what = ("|U| duration + the scan's length + 2 dx along x" if t_k is None
                else "the scan's length + 2 dx along x (not advected)")
        msg = (f"{label} is too small for the record: it spans {have[0]:.4g} x {have[1]:.4g} x {have[2]:.4g} m "
               f"({nx} x {ny} x {nz} nodes at {dx:.4g}, {dy:.4g}, {dz:.4g} m) but the record needs "
               f"{need[0]:.4g} x {need[1]:.4g} x {need[2]:.4g} m ({what}: |U| = {abs(U):g} m/s, duration = "
               f"{duration:g} s; the scan's width and height across)")
        if span is not None:
            msg += f"; it lasts {span:.4g} s of the record's {duration:g} s"
        raise ValueError(msg + f"; too small along {', '.join(short) or 't'}: give a larger field or a shorter "
                               f"period")
    x0 = 0.5 * (x_lo + x_hi) - 0.5 * (nx - 1) * dx
    y0 = region.y_mid - 0.5 * (ny - 1) * dy
    z0 = region.z_mid - 0.5 * (nz - 1) * dz
    coords = {"x": x0 + np.arange(nx) * dx, "y": y0 + np.arange(ny) * dy, "z": z0 + np.arange(nz) * dz}
    if t_k is not None:
        coords["t"] = t_k - t_k[0]
    out = field.assign_coords(coords)
    out.attrs = dict(field.attrs, dx=dx, dy=dy, dz=dz)
    return out
