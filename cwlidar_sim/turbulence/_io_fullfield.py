"""What the TurbSim (``.bts``) and Bladed (``.wnd``) readers and writers share.

Both formats hold a time series of y-z planes sampled at the rotor, as
16-bit integers with a per-component scaling, and OpenFAST's InflowWind
reads both into the same grid (``modules/inflowwind/src/InflowWind_IO.f90``:
``IfW_TurbSim_Init``, ``IfW_Bladed_Init``; ``IfW_FlowField.f90``).  From
those readers, in our frame (x downwind, y to the left looking downwind, z
up; see :mod:`cwlidar_sim.turbulence.io`):

* **Value order.**  Time step after time step; within a step z rows, each
  row y points with y fastest, and at each point the three components u, v,
  w interleaved: the C order of an array ``[it, iz, iy, component]``.
* **y.**  File y index j sits at ``Y = j dy - (Ny-1) dy / 2``
  (``PositionXYZ(2) = (iy - 1)*dy - G3D%YHWid``): increasing j is to the
  *left*, as our y, so ``file y index j = our y index j`` (unlike a HAWC2
  box, whose y InflowWind reverses).
* **x and time.**  Time step j reaches the rotor at ``t = j dt``, and a
  point at X (downwind) sees at t what the rotor saw at ``t - X/U``
  (``TimeShifted = t + (InitXPosition - X)/U``, InitXPosition = 0 for a
  periodic file): frozen turbulence convected at U.  Under our Taylor
  convention (a sensor at rest at x0 sees the plane ``x0 - U t``), with the
  sensor at our last plane, ``time step j = our plane Nx-1-j`` and
  ``dx = U dt``: the same x order as the HAWC2 ``convention="openfast"``.
* **Mean.**  The files hold the whole wind: u includes the mean speed U.
  Our Datasets hold fluctuations, so the writers add U to u and the readers
  take it off again (any shear profile a TurbSim file holds stays in u).

Every file written here is periodic in time (a Mann box is periodic in x),
and carries the Dataset's attributes as JSON text (in the TurbSim
description string, in the Bladed summary file) so that a round trip returns
them.
"""

from __future__ import annotations

import math
import struct

import numpy as np

from .._validation import check_memory, check_real
from . import _io_meta
from .io import _LONG_NAMES, _field_arrays

__all__: list = []  # private to the turbulence stage

#: Attributes the readers derive from a file's header; the writers take them from there, not from the JSON.
HEADER_ATTRS = frozenset({"mean_speed", "hub_height", "z_bottom", "dt", "periodic", "description",
                          "turbsim_slope", "turbsim_offset", "turbsim_tower_points", "bladed_ti",
                          "bladed_left_hand_rule", "bladed_clockwise"})
INT16_MIN, INT16_MAX = -32768, 32767


class Grid:
    """A box checked for writing as a time series: arrays [x, y, z], spacing, U, heights."""

    def __init__(self, box, label, mean_speed, hub_height, z_bottom):
        self.arrays = _field_arrays(box, label, allowed=(("x", "y", "z"),))
        self.shape = tuple(int(n) for n in self.arrays[0].shape)
        spacing = _io_meta.box_spacing(box, label)
        for d, s in zip("xyz", spacing):
            if s is None:
                raise ValueError(f"{label} has no spacing along {d}: give it a {d} coordinate of 2 or more evenly "
                                 f"spaced points or attrs['d{d}'] [m]")
        self.spacing = spacing
        attrs = box.attrs
        if mean_speed is None:
            if "mean_speed" not in attrs:
                raise ValueError("mean_speed is needed (the files hold the whole wind, u = U + fluctuation, and "
                                 "dx = U dt): give mean_speed=U [m/s] (or box.attrs['mean_speed'])")
            mean_speed = attrs["mean_speed"]
        self.mean_speed = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True, hi=1e3)
        half = (self.shape[2] - 1) * spacing[2] / 2
        from_attrs = hub_height is None and z_bottom is None and "hub_height" in attrs
        if hub_height is None:
            hub_height = attrs["hub_height"] if from_attrs else half
        self.hub_height = check_real("hub_height", hub_height, lo=0.0, lo_open=True, hi=1e5)
        if z_bottom is None:
            z_bottom = attrs["z_bottom"] if from_attrs and "z_bottom" in attrs else self.hub_height - half
        self.z_bottom = check_real("z_bottom", z_bottom, hi=1e5)
        if self.z_bottom < 0:
            raise ValueError(f"z_bottom={self.z_bottom:g} m: the grid would reach below the ground; allowed: >= 0 "
                             f"(with the grid centred on the hub: hub_height >= {half:g} m)")
        self.json_attrs = {k: v for k, v in attrs.items() if k not in HEADER_ATTRS}

    def step(self, max_chunk_bytes) -> int:
        """Planes per slab: about ``max_chunk_bytes`` of float64 for one component, at least one plane."""
        return max(1, int(max_chunk_bytes) // (8 * self.shape[1] * self.shape[2]))

    def stats(self, max_chunk_bytes):
        """Per component: (min, max, population std, max |value|), in float64, one slab at a time."""
        nx = self.shape[0]
        step = self.step(max_chunk_bytes)
        out = []
        for c, vel_xyz in zip("uvw", self.arrays):
            lo, hi, s1, s2 = math.inf, -math.inf, 0.0, 0.0
            for i0 in range(0, nx, step):
                slab = np.asarray(vel_xyz[i0:i0 + step], dtype=np.float64)
                if not np.isfinite(slab).all():
                    bad = np.argwhere(~np.isfinite(slab))[0]
                    raise ValueError(f"box['{c}'] has a non-finite value at [x={i0 + bad[0]}, y={bad[1]}, z={bad[2]}]; "
                                     f"allowed: finite values")
                lo, hi = min(lo, float(slab.min())), max(hi, float(slab.max()))
                s1 += float(slab.sum())
                s2 += float(np.square(slab).sum())
            n = vel_xyz.size
            std = math.sqrt(max(0.0, s2 / n - (s1 / n) ** 2))
            out.append((lo, hi, std, max(abs(lo), abs(hi))))
        return out

    def time_slabs(self, max_chunk_bytes):
        """Yield ``[u, v, w]`` slabs of time steps, each float64 ``[it, iz, iy]``: time step j = plane Nx-1-j."""
        nx = self.shape[0]
        step = self.step(max_chunk_bytes)
        for t0 in range(0, nx, step):
            t1 = min(nx, t0 + step)
            yield [np.asarray(a[nx - t1: nx - t0][::-1], dtype=np.float64).transpose(0, 2, 1) for a in self.arrays]


def nint16(x):
    """Fortran's NINT (half away from zero) of float64 ``x``, clipped to the int16 range, as '<i2'."""
    r = np.trunc(x + np.copysign(0.5, x))
    return np.clip(r, INT16_MIN, INT16_MAX).astype("<i2")


def interleave(ints):
    """``[[it, iz, iy] for u, v, w]`` int16 -> bytes in the files' order (component fastest)."""
    return np.stack(ints, axis=-1).astype("<i2", copy=False).tobytes()


def unpack(fmt, raw, what, path):
    """struct.unpack of a header, or a one-line ValueError naming the file when it is too short."""
    need = struct.calcsize(fmt)
    if len(raw) < need:
        raise ValueError(f"{what} {str(path)!r} is truncated: its header needs {need} bytes, the file holds "
                         f"{len(raw)}")
    return struct.unpack(fmt, raw[:need])


def check_header_real(value, name, what, path, *, positive=True):
    """A header float that must be finite (and > 0): else a ValueError naming the file and the field."""
    if not math.isfinite(value) or (positive and value <= 0):
        raise ValueError(f"{what} {str(path)!r}: header field {name} = {value!r} is not "
                         f"{'a finite number > 0' if positive else 'finite'}: a corrupt or foreign file")
    return float(value)


def read_ints(path, offset, count, nt, what):
    """``count`` little-endian int16 values from ``offset``, memory checked first."""
    # per value: 2 bytes of int16, 4 of float32 result, a third of a float64 component at a time
    check_memory(f"reading {what} {str(path)!r}", 9 * count)
    data = np.fromfile(path, dtype="<i2", count=count, offset=offset)
    if data.size != count:  # the size was checked; a file shrinking meanwhile
        raise ValueError(f"{what} {str(path)!r} is truncated: {data.size} of {count} values read")
    return data.reshape(nt, -1, 3)


def dataset(vel_tzy, spacing, attrs):
    """The Dataset of three float32 ``[it, iz, iy]`` arrays: plane x = Nx-1-it, dims (x, y, z)."""
    import xarray as xr

    data = {c: (("x", "y", "z"), np.ascontiguousarray(v[::-1].transpose(0, 2, 1)),
                {"units": "m s-1", "long_name": _LONG_NAMES[c]}) for c, v in zip("uvw", vel_tzy)}
    shape = data["u"][1].shape
    coords = {d: (d, np.arange(n) * s, {"units": "m", "long_name": _LONG_NAMES[d]})
              for d, n, s in zip("xyz", shape, spacing)}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def merge_spacing(json_attrs, header_spacing, what, path):
    """(dx, dy, dz): the JSON's exact numbers where they agree with the header's float32 ones, else the header's."""
    out = []
    for d, h in zip("xyz", header_spacing):
        j = json_attrs.get(f"d{d}")
        if isinstance(j, (int, float)) and not isinstance(j, bool) and math.isfinite(j) and j > 0:
            if abs(j - h) > 1e-6 * h:
                raise ValueError(f"{what} {str(path)!r}: its header says d{d} = {h!r} m but its attributes say "
                                 f"{j!r} m: a corrupt file")
            out.append(float(j))
        else:
            out.append(float(h))
    return tuple(out)
