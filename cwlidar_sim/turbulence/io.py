"""Turbulence-field interchange: HAWC2 / Mann64bit binary boxes and NetCDF.

HAWC2 (Mann64bit) box format
----------------------------
Three raw files, one per component (u, v, w), each holding ``Nx*Ny*Nz``
little-endian float32 values [m/s] and no header.  Shape and spacing are not
in the files: :func:`write_hawc2` writes them (with the Mann parameters,
seed, layout and all attributes) to a JSON sidecar ``BASE.json``, which
:func:`read_hawc2` reads, and HAWC2's ``begin mann`` block for the files to
``BASE.htc`` (see ``cwlidar_sim.turbulence._io_meta``); without a sidecar
the reader must be told them.  TurbSim and Bladed files:
:mod:`cwlidar_sim.turbulence.io_turbsim`, :mod:`cwlidar_sim.turbulence.io_bladed`.
Default file names are
``BASE_u.bin``, ``BASE_v.bin``, ``BASE_w.bin`` (a trailing ``.bin`` on BASE is
dropped, so ``box.bin`` names ``box_u.bin``..., as ``mannrs`` does); explicit
paths are accepted too (``hipersim`` writes ``BASENAMEu.turb``...).

Conventions (established from the peers, pinned in tests/turbulence/test_io.py)

* **Value order.**  The file is the C-order flattening of the array indexed
  ``[ix, iy, iz]``: z runs fastest, then y, x slowest.  Evidence: ``mannrs``
  2.0 ``Windfield.to_HAWC2`` writes ``np.array(self.U).astype("<f").tofile``
  of ``U`` shaped (Nx, Ny, Nz) (mannrs/Windfield.py, l. 137-139) and names the
  files with ``filename.with_stem(stem + "_u")`` (l. 107-109); ``hipersim``
  0.1.22 ``TurbulenceField.to_hawc2`` writes ``uvw[i].astype('<f').tofile``
  of an (Nx, Ny, Nz) array and ``from_hawc2`` reshapes to ``(3,) + Nxyz``
  (hipersim/_hipersim.py, l. 89-97).  Neither flips any axis or sign, so our
  Dataset ``u[ix, iy, iz]`` is the peer's ``U[ix, iy, iz]`` value for value.
* **Frame and signs.**  x is the mean-wind direction, y is lateral, positive
  to the *left* looking downwind, z is up: a right-handed frame, and u, v, w
  are positive along +x, +y, +z.  hipersim documents this (``to_xarray``,
  hipersim/_hipersim.py l. 68-72: "x: In direction of U, i.e. first yz-plane
  hits wind turbine last; y: to the left, when looking in the direction of the
  wind; z: up").  The tests check it on the peers' own boxes read through
  :func:`read_hawc2`: the spectral divergence ``k1 u + k2 v + k3 w`` nearly
  cancels with these signs and does not if any one term is reversed (that is
  what a reversed axis or a flipped component would do), the u-w covariance
  is negative, and the sheared eddies lean downstream with height (more u and
  w energy at k1*k3 < 0), as the Mann (1994) distortion k3 = k30 - beta*k1 of
  a flow whose speed increases with z requires.  No sign is flipped on
  reading or writing.
* **x and time.**  Under Taylor's hypothesis the box is convected along +x at
  the mean speed U, so a sensor at rest at x0 sees at time t the plane at
  ``x = x0 - U t`` (periodic in x).  A sensor at the last plane,
  ``x0 = (Nx-1) dx``, sees planes Nx-1, Nx-2, ..., 0 at t = 0, dx/U, ...,
  (Nx-1) dx/U: the last plane (largest x) arrives first and file plane 0
  (our ``x = 0``) last.  Time runs against the x index.
* **The "reversed box" complaint.**  HAWC2 before 13.1 and OpenFAST
  InflowWind bring file plane 0 to the rotor first, i.e. they use the box
  reversed in x, which mirrors the sheared eddies' tilt (OpenFAST issue
  #256, where DTU confirmed it; SINTEF's SIMA wind-field documentation cites
  the HAWC2 13.1 release notes: "Mann turbulence box - read in wrong
  direction").  ``reverse_x=True`` writes (or reads) the planes in arrival
  order, ``file plane j = our plane Nx-1-j``, so such a reader convects the
  field the right way round.  Only the x order changes, not u's sign.  The
  default (``False``) keeps the order the generators (Mann64bit, mannrs,
  hipersim) write.

OpenFAST InflowWind's convention (``convention="openfast"``)
------------------------------------------------------------
A box made for OpenFAST (``WindType = 5``) is read by InflowWind with
conventions of its own, pinned here from its source (OpenFAST
``modules/inflowwind/src/InflowWind_IO.f90``: the reader ``IfW_HAWC_Init``
and the writer ``Grid3D_WriteHAWC``; ``IfW_FlowField.f90``: the time shift
of the Grid3D interpolation; weio's ``mannbox_file`` module, part of the
OpenFAST toolbox, describes the same y order: "y from ly/2 to -ly/2").
InflowWind's frame is x downwind, y to the left looking downwind, z up (as
ours):

* **Value order.**  Each file is read plane by plane (``IX = 1..nx``), each
  plane as a Fortran ``(nz, ny)`` array: z fastest, then y, then x, as
  above.
* **x planes.**  File plane ``IX`` is time step ``IX`` of a periodic series
  of step ``dx / URef`` at the rotor (``TimeShifted = t + (X0 - X)/U``): file
  plane 0 reaches the rotor first.  In our frame (a sensor at rest sees
  ``x0 - U t``) that is ``file plane j = our plane Nx-1-j``, what
  ``reverse_x`` does.
* **y.**  The reader stores ``Vel(:, iy, iz, ix) = file(iz, NY:1:-1)``: file
  y index j is InflowWind's ``Y = (Ny-1-j) dy - (Ny-1) dy / 2``, so file y
  runs to the *right* looking downwind, and ``file y index j = our y index
  Ny-1-j``.
* **Signs.**  u, v, w are taken as they are (no sign is flipped for HAWC
  files; contrast the Bladed reader's left-hand-rule flip of v).
* **Mean.**  The files hold fluctuations: InflowWind adds the mean profile
  (``URef``, ``PLExp``/``Z0`` at ``RefHt``) after interpolation, and with
  ``ScaleMethod`` 1 or 2 first subtracts each point's mean of u over x
  (``remove_u_mean=True`` does the same here) after scaling the components
  (scale the Dataset yourself to apply ``SFx`` ... or a target sigma).
  OpenFAST's own writer removes, per height, the mean of u over time at its
  first y column.

With ``convention="openfast"`` :func:`read_hawc2` returns, in our frame and
Taylor convention, the field an InflowWind turbine sees from those files
(our ``y = Y + (Ny-1) dy / 2``, ``z = Z - (RefHt - (Nz-1) dz / 2)``), and
:func:`write_hawc2` writes files from which InflowWind presents our field.
A box written by a generator (Mann64bit, mannrs, hipersim) and handed to
InflowWind unchanged is therefore mirrored in x and in y without u or v
changing sign: read it with the default convention to get what the
generator made, with ``"openfast"`` to get what the OpenFAST turbine saw.

NetCDF
------
:func:`write_netcdf` / :func:`read_netcdf` store a box (x, y, z), plane
(x, y) or line (x,) Dataset with the h5netcdf engine: u, v, w keep their dtype
(float32 by default), carry CF ``units`` ("m s-1") and ``long_name``;
coordinates carry ``units`` "m"; the Dataset attributes (Mann parameters,
seed, spacing, generation settings) become global attributes and are read
back.  Attribute values netCDF cannot hold (bool, None, dict, lists of
strings, integers beyond int64) are stored as JSON text and decoded on
reading, so they round-trip.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._atomic import atomic_paths, check_output_file, write_netcdf_atomic
from .._validation import check_bool, check_int, check_memory, check_real, check_tuple
from . import _io_meta
from ._io_meta import decode_attrs as _decode_attrs, encode_attrs as _encode_attrs

__all__ = ["hawc2_paths", "hawc2_sidecar_paths", "read_hawc2", "read_netcdf", "write_hawc2", "write_netcdf"]

_COMPONENTS = ("u", "v", "w")
#: File conventions: how the file's indices map onto our Dataset's.
CONVENTIONS = ("hawc2", "openfast")
_FIELD_DIMS = (("x", "y", "z"), ("x", "y"), ("x",))
_HAWC2_DTYPE = np.dtype("<f4")
#: Default largest slab copied at once while writing a HAWC2 file [bytes].
_DEFAULT_CHUNK_BYTES = 16 * 2**20

_LONG_NAMES = {
    "u": "longitudinal velocity fluctuation",
    "v": "lateral velocity fluctuation",
    "w": "vertical velocity fluctuation",
    "x": "longitudinal position (along the mean wind)",
    "y": "lateral position (positive to the left looking downwind)",
    "z": "vertical position (positive up)",
}


# ---------------------------------------------------------------------------
# HAWC2 / Mann64bit binary
# ---------------------------------------------------------------------------
def hawc2_paths(base_or_paths) -> tuple[Path, Path, Path]:
    """File names of the u, v, w components of a HAWC2 box.

    Parameters
    ----------
    base_or_paths : str or os.PathLike or sequence of 3 of them
        Either a base name ``BASE`` (giving ``BASE_u.bin``, ``BASE_v.bin``,
        ``BASE_w.bin``; a trailing ``.bin`` on BASE is dropped first, so
        ``box.bin`` gives ``box_u.bin``..., the names ``mannrs`` writes) or the
        three paths, in the order u, v, w.

    Returns
    -------
    tuple of pathlib.Path
        Paths of the u, v and w files.
    """
    if isinstance(base_or_paths, (str, os.PathLike)):
        base = Path(base_or_paths)
        if base.name in ("", ".", ".."):
            raise ValueError(f"base={str(base_or_paths)!r} names no file; allowed: a file base name such as 'out/box'")
        stem = base.name[:-4] if base.name.lower().endswith(".bin") and len(base.name) > 4 else base.name
        return tuple(base.with_name(f"{stem}_{c}.bin") for c in _COMPONENTS)
    if isinstance(base_or_paths, (bytes, bytearray)) or not hasattr(base_or_paths, "__len__"):
        raise TypeError(
            f"base_or_paths must be a path or a sequence of 3 paths (u, v, w), got "
            f"{type(base_or_paths).__name__} {base_or_paths!r}"
        )
    if len(base_or_paths) != 3:
        raise ValueError(f"base_or_paths must hold 3 paths (u, v, w), got {len(base_or_paths)}: {base_or_paths!r}")
    out = []
    for c, p in zip(_COMPONENTS, base_or_paths):
        if not isinstance(p, (str, os.PathLike)):
            raise TypeError(f"path of component {c} must be str or os.PathLike, got {type(p).__name__} {p!r}")
        out.append(Path(p))
    if len(set(out)) != 3:
        raise ValueError(f"base_or_paths must name 3 different files, got {[str(p) for p in out]}")
    return tuple(out)


def hawc2_sidecar_paths(base_or_paths) -> tuple[Path, Path] | None:
    """File names of the JSON sidecar and HTC snippet written with a HAWC2 box.

    Parameters
    ----------
    base_or_paths : str or os.PathLike or sequence of 3 of them
        As for :func:`hawc2_paths`.

    Returns
    -------
    tuple of pathlib.Path or None
        ``(BASE.json, BASE.htc)`` for a base name (a trailing ``.bin`` dropped,
        as for the data files); None for three explicit paths (no sidecar is
        written or looked for then).
    """
    if not isinstance(base_or_paths, (str, os.PathLike)):
        hawc2_paths(base_or_paths)  # the same checks
        return None
    u_path = hawc2_paths(base_or_paths)[0]
    stem = u_path.name[: -len("_u.bin")]
    return u_path.with_name(stem + ".json"), u_path.with_name(stem + ".htc")


def write_hawc2(box, base, *, reverse_x: bool = False, convention: str = "hawc2",
                max_chunk_bytes: int = _DEFAULT_CHUNK_BYTES, sidecar: bool = True):
    """Write a 3-D box as a HAWC2 / Mann64bit binary turbulence box.

    Parameters
    ----------
    box : xarray.Dataset
        Data variables ``u``, ``v``, ``w`` [m/s] on dims ``("x", "y", "z")``
        (any order of those three names; they are written as [x, y, z]).  Any
        real dtype; values are cast to float32 and must be finite after the
        cast.  Views, non-contiguous or dask-backed arrays are fine.
    base : str or os.PathLike or sequence of 3 of them
        Base name or the three paths (u, v, w); see :func:`hawc2_paths`.
        Existing files are overwritten.
    reverse_x : bool, optional
        Write the x planes in reverse order (file plane j = plane Nx-1-j), for
        readers that bring file plane 0 to the rotor first (HAWC2 < 13.1,
        OpenFAST InflowWind).  Default False: file plane j = our plane j, as
        Mann64bit, mannrs and hipersim write.  See the module docstring.
    convention : {"hawc2", "openfast"}, optional
        "hawc2" (default): the generators' layout (with ``reverse_x`` as
        given).  "openfast": the layout OpenFAST's InflowWind reads, so
        that it presents this field to the turbine: x planes in arrival
        order and y reversed (file y index j = our Ny-1-j), u, v, w as they
        are; ``reverse_x`` must then be False (see the module docstring).
    max_chunk_bytes : int, optional
        Largest float32 slab converted at a time [bytes] (at least one x
        plane is always taken).  Memory held by the writer is about this,
        never a contiguous copy of a whole component.
    sidecar : bool, optional
        With a base name (not three explicit paths), also write ``BASE.json``
        (shape, spacing, Mann parameters, seed, convention, reverse_x, the
        package version and every attribute; :func:`read_hawc2` reads it)
        and ``BASE.htc`` (HAWC2's ``begin mann; ... end mann;`` block for
        these files); see :func:`hawc2_sidecar_paths` and
        ``cwlidar_sim.turbulence._io_meta`` for their content.  Default True.
        The spacing comes from ``box.attrs['dx']``... or the coordinates.

    Returns
    -------
    tuple of pathlib.Path
        The u, v and w files written, each ``Nx*Ny*Nz*4`` bytes.

    Raises
    ------
    TypeError
        ``box`` is not an xarray Dataset or a variable is not real.
    ValueError
        Missing component, wrong dims, empty box, or a non-finite value (no
        file is left behind in that case); a target that is not a regular
        file (a directory, ``/dev/null``, a FIFO) or whose folder is missing
        (:class:`cwlidar_sim._preflight.PreflightError`, before anything is
        written).
    OSError
        Writing failed (a full disk): the old files are unchanged
        (:class:`cwlidar_sim._preflight.ResultsWriteError`).

    Notes
    -----
    The data files have no header: shape (Nx, Ny, Nz) and spacing (dx, dy,
    dz) [m] travel in the sidecar (or must be given to the reader).  Each file
    is first written to a temporary file beside it
    (``.NAME.XXXXXXXX.tmp.bin``) and the three (five with the sidecar and
    HTC snippet) are renamed over the targets only when all are complete
    (``cwlidar_sim._atomic.atomic_paths``): a failure leaves the old files.
    """
    asked_reverse_x = check_bool("reverse_x", reverse_x)
    reverse_x, reverse_y = _convention_flips(convention, asked_reverse_x)
    max_chunk_bytes = check_int("max_chunk_bytes", max_chunk_bytes, lo=1)
    sidecar = check_bool("sidecar", sidecar)
    arrays = _field_arrays(box, "box", allowed=(_FIELD_DIMS[0],))
    paths = hawc2_paths(base)
    meta = hawc2_sidecar_paths(base) if sidecar else None
    texts = []
    if meta is not None:
        args = (arrays[0].shape, _io_meta.box_spacing(box, "box"), convention, asked_reverse_x, dict(box.attrs))
        texts = [_io_meta.sidecar_text(paths, meta[0], *args, "box.attrs"), _io_meta.htc_text(paths, meta[1], *args)]
    nx = arrays[0].shape[0]
    plane_bytes = _HAWC2_DTYPE.itemsize * int(np.prod(arrays[0].shape[1:]))
    step = max(1, max_chunk_bytes // plane_bytes)
    for c, p in zip(_COMPONENTS, paths):
        check_output_file(p, label=f"HAWC2 file of component {c}")
    for what, p in zip(("sidecar", "HTC snippet"), meta or ()):
        check_output_file(p, label=f"HAWC2 {what}")
    # All files go to temporary files first, and are synced and renamed only when
    # all are whole, so a failure (a non-finite value, a full disk) leaves the old
    # files as they were.
    with atomic_paths(list(paths) + list(meta or ())) as tmps:
        for text, tmp in zip(texts, tmps[3:]):
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text)
        for c, vel_xyz, tmp in zip(_COMPONENTS, arrays, tmps):
            with open(tmp, "wb") as fh:
                for i0 in range(0, nx, step):
                    i1 = min(nx, i0 + step)
                    src = vel_xyz[nx - i1: nx - i0][::-1] if reverse_x else vel_xyz[i0:i1]
                    if reverse_y:
                        src = src[:, ::-1]
                    # One slab at a time: a contiguous little-endian float32
                    # copy of at most ``step`` planes, never of the component.
                    with np.errstate(over="ignore", invalid="ignore"):  # caught just below
                        slab_xyz = np.ascontiguousarray(np.asarray(src), dtype=_HAWC2_DTYPE)
                    if not np.isfinite(slab_xyz).all():
                        bad = np.argwhere(~np.isfinite(slab_xyz))[0]
                        ix = nx - 1 - (i0 + bad[0]) if reverse_x else i0 + bad[0]
                        iy = slab_xyz.shape[1] - 1 - bad[1] if reverse_y else bad[1]
                        raise ValueError(
                            f"box['{c}'] has a non-finite value (after the cast to float32) at "
                            f"[x={ix}, y={iy}, z={bad[2]}]; allowed: finite values below 3.4e38 m/s"
                        )
                    fh.write(slab_xyz.data)
                    del slab_xyz
    return paths


def read_hawc2(base_or_paths, shape=None, spacing=None, *, reverse_x: bool | None = None,
               convention: str | None = None, remove_u_mean: bool = False, mmap: bool = False, attrs=None):
    """Read a HAWC2 / Mann64bit binary turbulence box.

    Parameters
    ----------
    base_or_paths : str or os.PathLike or sequence of 3 of them
        Base name or the three paths (u, v, w); see :func:`hawc2_paths`.
    shape : sequence of 3 int, optional
        (Nx, Ny, Nz), each >= 1.  Each file must hold exactly
        ``Nx*Ny*Nz*4`` bytes.  Default: from the sidecar ``BASE.json``
        (:func:`hawc2_sidecar_paths`; a base name only); given as well, it
        must equal the sidecar's.
    spacing : sequence of 3 float, optional
        (dx, dy, dz) [m], each > 0 and finite.  Default: from the sidecar;
        given as well, it must equal the sidecar's (to 1e-9 relative).
    reverse_x : bool, optional
        The files hold the planes in reverse order (see :func:`write_hawc2`);
        they are flipped back so that the Dataset is in our convention.
        Default: the sidecar's, else False.  Given, it overrides the
        sidecar's (to read the planes as another reader would).
    convention : {"hawc2", "openfast"}, optional
        "hawc2": the generators' layout.  "openfast": the files as OpenFAST's
        InflowWind reads them (x planes in arrival order, y reversed, signs
        unchanged); the Dataset is then the field the InflowWind turbine
        sees, in our frame.  ``reverse_x`` must be False with "openfast".
        Default: the sidecar's, else "hawc2"; given, it overrides the
        sidecar's.  See the module docstring.
    remove_u_mean : bool, optional
        Subtract from u, at every (y, z), its mean over x, as InflowWind
        does with ``ScaleMethod`` 1 or 2.  Loads the data (not with
        ``mmap``).  Default False.
    mmap : bool, optional
        Map the files read-only (``numpy.memmap``) instead of loading them:
        data are read lazily, only the slices used, and the files must stay in
        place while the Dataset is used.  Default False (load into memory).
    attrs : mapping, optional
        Extra Dataset attributes (e.g. Mann parameters, seed), added to (and
        overriding) the sidecar's; ``dx``, ``dy``, ``dz`` are always set from
        ``spacing``.

    Returns
    -------
    xarray.Dataset
        ``u``, ``v``, ``w`` float32 [m/s] on dims ("x", "y", "z"), coordinates
        ``x = ix*dx``, ``y = iy*dy``, ``z = iz*dz`` [m]; our convention (x
        along the mean wind, y to the left, z up; see the module docstring).

    Raises
    ------
    FileNotFoundError
        A component file is missing.
    ValueError
        Bad shape or spacing, shape or spacing missing (no sidecar) or
        different from the sidecar's (both named), a sidecar that is not one
        (malformed JSON, wrong fields), or a file size that is not
        ``Nx*Ny*Nz*4`` bytes (the message gives the expected and the actual
        size).
    """
    import xarray as xr

    paths = hawc2_paths(base_or_paths)
    meta = hawc2_sidecar_paths(base_or_paths)
    side = _io_meta.read_sidecar(meta[0]) if meta is not None else None
    shape = _from_sidecar("shape", shape, side, meta, lambda n, v: check_int(n, v, lo=1))
    spacing = _from_sidecar("spacing", spacing, side, meta, lambda n, v: check_real(n, v, lo=0.0, lo_open=True))
    if convention is None:
        convention = side["convention"] if side else "hawc2"
    reverse_x = check_bool("reverse_x", reverse_x if reverse_x is not None
                           else (side["reverse_x"] if side and convention == side["convention"] else False))
    reverse_x, reverse_y = _convention_flips(convention, reverse_x)
    remove_u_mean = check_bool("remove_u_mean", remove_u_mean)
    mmap = check_bool("mmap", mmap)
    if mmap and remove_u_mean:
        raise ValueError("remove_u_mean=True changes the data and needs it in memory; allowed with mmap=False only")
    extra = _check_attrs(attrs)
    count = shape[0] * shape[1] * shape[2]
    expected = count * _HAWC2_DTYPE.itemsize
    for c, p in zip(_COMPONENTS, paths):
        if not p.is_file():
            raise FileNotFoundError(f"HAWC2 file for component {c} not found: {str(p)!r}")
        actual = p.stat().st_size
        if actual != expected:
            raise ValueError(
                f"HAWC2 file {str(p)!r} (component {c}) holds {actual} bytes, but shape={shape} "
                f"needs {expected} bytes ({count} float32 values); the file holds "
                f"{actual / _HAWC2_DTYPE.itemsize:g} values. Check shape (Nx, Ny, Nz)."
            )
    if not mmap:
        check_memory("read_hawc2 (3 components)", 3 * expected)
    data = {}
    for c, p in zip(_COMPONENTS, paths):
        if mmap:
            vel_xyz = np.memmap(p, dtype=_HAWC2_DTYPE, mode="r", shape=shape)
        else:
            vel_xyz = np.fromfile(p, dtype=_HAWC2_DTYPE, count=count).reshape(shape)
            # Native byte order for numba kernels; no copy on little-endian hosts.
            vel_xyz = vel_xyz.astype(np.float32, copy=False)
        if reverse_x:
            vel_xyz = vel_xyz[::-1]
        if reverse_y:
            vel_xyz = vel_xyz[:, ::-1]
        if remove_u_mean and c == "u":
            # Per-point mean over x, accumulated in float64 (InflowWind sums in double).
            vel_xyz = (vel_xyz - vel_xyz.mean(axis=0, dtype=np.float64)).astype(np.float32)
        data[c] = (("x", "y", "z"), vel_xyz, {"units": "m s-1", "long_name": _LONG_NAMES[c]})
    coords = {
        d: (d, np.arange(n) * s, {"units": "m", "long_name": _LONG_NAMES[d]})
        for d, n, s in zip("xyz", shape, spacing)
    }
    ds_attrs = dict(side["attrs"]) if side else {}
    ds_attrs.update(extra)
    ds_attrs.update(dx=spacing[0], dy=spacing[1], dz=spacing[2])
    if convention != "hawc2":
        ds_attrs["hawc2_convention"] = convention
    return xr.Dataset(data, coords=coords, attrs=ds_attrs)


# ---------------------------------------------------------------------------
# NetCDF
# ---------------------------------------------------------------------------
def write_netcdf(field, path):
    """Write a turbulence box, plane or line to a NetCDF-4 file (h5netcdf).

    Parameters
    ----------
    field : xarray.Dataset
        Data variables ``u``, ``v``, ``w`` [m/s], real dtype, all on the same
        dims: ``("x", "y", "z")`` (box), ``("x", "y")`` (plane) or ``("x",)``
        (line).  Other variables and coordinates are written as they are.
        Dataset attributes (Mann parameters, seed, spacing, settings) become
        global attributes.
    path : str or os.PathLike
        Output file, in an existing folder; replaced if it exists, only once the
        new file is complete (written beside it, then renamed).

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        ``path`` is not a regular file (a directory, ``/dev/null``, a FIFO) or
        its folder is missing (:class:`cwlidar_sim._preflight.PreflightError`,
        before anything is written); bad ``field``.
    OSError
        Writing failed (a full disk): the old file at ``path`` is unchanged
        (:class:`cwlidar_sim._preflight.ResultsWriteError`).

    Notes
    -----
    Dtypes are kept (float32 stays float32) and no ``_FillValue`` is added, so
    a round trip is bit-exact.  ``units`` ("m s-1" for u, v, w; "m" for the
    x, y, z coordinates) and ``long_name`` are added where missing, in the
    file only: ``field`` is not modified.  Attribute values that netCDF
    cannot hold (bool, None, dict, lists of strings, integers outside int64)
    are written as JSON text and listed in the global attribute
    ``cwlidar_sim_json_attrs``; :func:`read_netcdf` decodes them.
    """
    path = _check_path("path", path)
    _field_dims(field, "field", allowed=_FIELD_DIMS)
    check_output_file(path, label="NetCDF file")
    # A shallow copy: new Variable objects (own attrs and encoding) sharing
    # the data, so the caller's Dataset is left untouched.
    ds = field.copy(deep=False)
    ds.attrs = _encode_attrs(dict(field.attrs), "field.attrs")
    for name, var in ds.variables.items():
        var.attrs = _encode_attrs(dict(field.variables[name].attrs), f"field[{name!r}].attrs")
        var.encoding = {}
    for c in _COMPONENTS:
        ds.variables[c].attrs.setdefault("units", "m s-1")
        ds.variables[c].attrs.setdefault("long_name", _LONG_NAMES[c])
    for d in ds[_COMPONENTS[0]].dims:
        if d in ds.variables:
            ds.variables[d].attrs.setdefault("units", "m")
            ds.variables[d].attrs.setdefault("long_name", _LONG_NAMES[d])
    encoding = {name: {"_FillValue": None} for name in ds.variables}
    # atomically, and a full disk never reaches HDF5 (whose failed close segfaulted at
    # exit): the old file at ``path`` survives any failed write
    write_netcdf_atomic(ds, path, encoding=encoding)
    return path


def read_netcdf(path, *, lazy: bool = False):
    """Read a turbulence box, plane or line written by :func:`write_netcdf`.

    Parameters
    ----------
    path : str or os.PathLike
        NetCDF file.
    lazy : bool, optional
        If True, return the Dataset backed by the open file: values are read
        only when indexed (useful for boxes larger than memory); close it with
        ``ds.close()`` when done.  Default False: everything is loaded and
        the file is closed.

    Returns
    -------
    xarray.Dataset
        ``u``, ``v``, ``w`` [m/s] in the stored dtype, coordinates [m], and
        the global attributes (JSON-encoded ones decoded).

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ValueError
        The file lacks u, v or w, or they are not on (x, y, z), (x, y) or (x,).
    """
    import xarray as xr

    path = _check_path("path", path)
    lazy = check_bool("lazy", lazy)
    if not path.is_file():
        raise FileNotFoundError(f"NetCDF file not found: {str(path)!r}")
    ds = xr.open_dataset(path, engine="h5netcdf", mask_and_scale=False, decode_times=False, cache=False)
    try:
        _field_dims(ds, f"NetCDF file {str(path)!r}", allowed=_FIELD_DIMS)
        if not lazy:
            ds.load()
    except BaseException:
        ds.close()
        raise
    if not lazy:
        ds.close()
    ds.attrs = _decode_attrs(ds.attrs)
    return ds


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------
def _convention_flips(convention, reverse_x) -> tuple[bool, bool]:
    """(reverse x, reverse y) of a file convention."""
    if convention not in CONVENTIONS:
        raise ValueError(f"convention={convention!r} is not allowed; allowed: {', '.join(map(repr, CONVENTIONS))}")
    if convention == "openfast":
        if reverse_x:
            raise ValueError("convention='openfast' already puts the x planes in arrival order; "
                             "allowed: reverse_x=False with it")
        return True, True
    return reverse_x, False


def _from_sidecar(name, given, side, meta, item_check) -> tuple:
    """``shape`` or ``spacing`` of a HAWC2 box: as given, else the sidecar's; both given must agree."""
    stored = side[name] if side else None
    if given is None:
        if stored is None or None in stored:
            where = (f"no sidecar {str(meta[0])!r} was found" if meta and not side
                     else f"the sidecar {str(meta[0])!r} does not hold it" if side
                     else "three explicit paths have no sidecar")
            raise ValueError(f"{name} of the HAWC2 box is needed: {where}; give {name}=(...) explicitly")
        return stored
    given = check_tuple(name, given, 3, item_check)
    if stored is not None and any(s is not None and abs(g - s) > 1e-9 * abs(s) for g, s in zip(given, stored)):
        raise ValueError(f"{name}={given} differs from {name} {tuple(stored)} in the sidecar {str(meta[0])!r}; "
                         f"give the sidecar's {name} (or none), or remove the stale sidecar")
    return given


def _check_path(name, value) -> Path:
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"{name} must be str or os.PathLike, got {type(value).__name__} {value!r}")
    p = Path(value)
    if p.name in ("", ".", ".."):
        raise ValueError(f"{name}={str(value)!r} names no file; allowed: a file path such as 'out/box.nc'")
    return p


def _check_attrs(attrs) -> dict:
    if attrs is None:
        return {}
    if not hasattr(attrs, "keys"):
        raise TypeError(f"attrs must be a mapping or None, got {type(attrs).__name__} {attrs!r}")
    return dict(attrs)


def _field_arrays(field, label, *, allowed):
    """Validate a u, v, w Dataset; return its three arrays with dims in canonical order."""
    target = _field_dims(field, label, allowed=allowed)
    out = [field[c].transpose(*target).data for c in _COMPONENTS]
    if len({a.shape for a in out}) != 1:
        raise ValueError(f"{label}: u, v, w shapes differ: {[a.shape for a in out]}")
    return out


def _field_dims(field, label, *, allowed):
    """Validate a u, v, w Dataset without touching its data; return the canonical dims."""
    import xarray as xr

    if not isinstance(field, xr.Dataset):
        raise TypeError(f"{label} must be an xarray.Dataset with variables u, v, w, got {type(field).__name__}")
    missing = [c for c in _COMPONENTS if c not in field.data_vars]
    if missing:
        raise ValueError(
            f"{label} lacks velocity component(s) {missing}; allowed: a Dataset with data variables u, v, w"
        )
    dims0 = field[_COMPONENTS[0]].dims
    target = next((d for d in allowed if sorted(d) == sorted(dims0)), None)
    if target is None:
        raise ValueError(
            f"{label}['u'] has dims {dims0}; allowed: "
            + " or ".join(str(d) for d in allowed)
        )
    for c in _COMPONENTS:
        da = field[c]
        if sorted(da.dims) != sorted(target):
            raise ValueError(f"{label}['{c}'] has dims {da.dims}; allowed: {target}, the same as u")
        if not (np.issubdtype(da.dtype, np.floating) or np.issubdtype(da.dtype, np.integer)):
            raise TypeError(f"{label}['{c}'] must hold real numbers, got dtype {da.dtype}")
        if da.size == 0:
            raise ValueError(f"{label}['{c}'] is empty (shape {da.shape}); allowed: at least one point per dim")
    return target
