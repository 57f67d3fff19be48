"""A Mann box that covers a sensor's region for a record: planning and generation, written once.

A sensor states the region it reaches (its cells, its scan, its platform's
motion) as a :class:`Region` in the field frame at ``t = 0``
(e.g. :meth:`cwlidar_sim.sensors.ConicalLidar.box_region`); this module
sizes, places and generates the box that holds it for a record of
``duration`` seconds in a mean wind ``U`` along +x (Taylor advection: the
air the sensor sees over the record lies ``U duration`` upwind of it).  It
knows nothing of sensors: a region is six numbers.

The plan (:func:`plan_box`):

* x: the period ``nx dx`` holds ``|U| duration + length + 4 dx`` (no part of
  the field is seen twice), ``nx`` the next 2-3-5-smooth count
  (``scipy.fft.next_fast_len(n, real=True)``), the first node one step
  upwind of the region (``x0 = x_lo - dx``); or an exact period
  (``period_x``, the virtual twin's) or a physical size (``extent``, a
  paired comparison of spacings, :func:`cwlidar_sim.turbulence.grid_for_extent`);
* y and z: ``ny = ceil(max(2 half_width, min_extent) / dy) + 1`` nodes centred
  on ``y_mid`` (z alike), ``min_extent`` by default twice the tensor's
  length scale, so that the lowest resolved modes are not much shorter
  than the energy-containing eddies.

Lateral doubling (:func:`cover_box`): the box is generated twice as wide in
y and one half kept (hipersim's default), so that the region's two lateral
ends are not each other's periodic image ``W - D`` away (a periodic box of
width W correlates y with y + W); kept boxes are not periodic in y, so a
sensor samples them with ``wrap=False``.  The price is twice the
generation cost.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_bool, check_real, check_tuple
from .parameters import MannParameters

__all__ = ["Region", "BoxPlan", "fast_size", "plan_box", "cover_yz", "cover_box"]


@dataclasses.dataclass(frozen=True)
class Region:
    """A region of the field frame a box must hold at ``t = 0`` [m] (module notes).

    Parameters
    ----------
    x_lo : float
        Its upwind end (lowest x) [m].
    length : float
        Its length along x [m], >= 0.
    y_mid, z_mid : float
        Its lateral and vertical centre [m].
    half_width, half_height : float
        Its half sizes in y and z [m], >= 0.
    """

    x_lo: float
    length: float
    y_mid: float
    half_width: float
    z_mid: float
    half_height: float


@dataclasses.dataclass(frozen=True)
class BoxPlan:
    """Shape, spacing and first node of the kept box (:func:`plan_box`).

    Attributes
    ----------
    shape : (int, int, int)
        ``(nx, ny, nz)`` of the kept box (a laterally doubled box is generated ``2 ny`` wide).
    spacing : (float, float, float)
        ``(dx, dy, dz)`` [m].
    origin : (float, float, float)
        ``(x0, y0, z0)``, the first node [m].
    """

    shape: tuple
    spacing: tuple
    origin: tuple

    def coords(self, ny: int | None = None) -> dict:
        """``{'x', 'y', 'z'}`` node coordinates [m]; ``ny`` y-rows (default the kept box's)."""
        (nx, ny0, nz), (dx, dy, dz), (x0, y0, z0) = self.shape, self.spacing, self.origin
        ny = ny0 if ny is None else ny
        return {"x": x0 + np.arange(nx) * dx, "y": y0 + np.arange(ny) * dy, "z": z0 + np.arange(nz) * dz}


def fast_size(n: int) -> int:
    """Smallest count >= max(n, 2) whose prime factors are 2, 3 and 5 (``scipy.fft.next_fast_len(n, real=True)``)."""
    from scipy.fft import next_fast_len

    return int(next_fast_len(max(2, int(n)), real=True))


def _spacing3(spacing):
    if isinstance(spacing, (int, float, np.integer, np.floating)) and not isinstance(spacing, bool):
        spacing = (spacing,) * 3
    return check_tuple("spacing", spacing, 3, lambda n, v: check_real(n, v, lo=0.0, hi=100.0, lo_open=True))


def _check_region(region):
    if not isinstance(region, Region):
        raise TypeError(f"region must be a Region, got {type(region).__name__}")
    return region


def _lateral(region: Region, dy: float, dz: float, min_extent: float):
    """``(ny, nz, width, height)``: the kept box's node counts and the sizes they must hold [m]."""
    width = max(2.0 * region.half_width, min_extent)
    height = max(2.0 * region.half_height, min_extent)
    return int(math.ceil(width / dy)) + 1, int(math.ceil(height / dz)) + 1, width, height


def _min_extent(params, min_extent):
    if min_extent is None:
        if params is None:
            raise ValueError("min_extent is needed without params (default: 2 params.length_scale)")
        return 2.0 * params.length_scale
    return check_real("min_extent", min_extent, lo=0.0)


def plan_box(region: Region, U: float, duration: float, spacing, *, params=None, min_extent: float | None = None,
             extent=None, period_x: float | None = None) -> BoxPlan:
    """The kept box's shape, spacing and first node for a record (module notes).

    Parameters
    ----------
    region : Region
    U : float
        Mean wind along +x [m/s]; ``|U|`` in [0, 1000].
    duration : float
        Record length [s]; > 0.
    spacing : float or (float, float, float)
        Grid spacing in x, y, z [m] (one value: all three); each in (0, 100].
    params : MannParameters, optional
        The tensor (its length scale sets the default ``min_extent``).
    min_extent : float, optional
        Minimum lateral and vertical size of the kept box [m]; default ``2 params.length_scale``.
    extent : (float, float, float), optional
        Physical size (Lx, Ly, Lz) [m] of the kept box, at least what the
        record and the region need (checked); the shape is then
        :func:`cwlidar_sim.turbulence.grid_for_extent` of it and the spacing,
        the spacing ``L_i / N_i``, and the box centred on the region as its
        physical size, so that grids of one extent place their points alike.
    period_x : float, optional
        The x period [m], exactly (exclusive with ``extent``): ``nx`` is
        ``period_x / dx`` where that is a whole number, else the smallest
        2-3-5-smooth count with ``period_x / nx <= dx``; dx is ``period_x / nx``.
    """
    _check_region(region)
    U = abs(check_real("U", U, lo=-1000.0, hi=1000.0))
    duration = check_real("duration", duration, lo=0.0, lo_open=True)
    dx, dy, dz = _spacing3(spacing)
    ext = _min_extent(params, min_extent)
    ny, nz, width, height = _lateral(region, dy, dz, ext)
    length = U * duration + region.length + 4.0 * dx
    if period_x is not None:
        if extent is not None:
            raise ValueError("give period_x or extent, not both")
        period_x = check_real("period_x", period_x, lo=0.0, hi=1e7, lo_open=True)
    if extent is None:
        if period_x is None:
            nx = fast_size(int(math.ceil(length / dx)))
        else:
            nx = int(round(period_x / dx))
            if abs(nx * dx - period_x) > 1e-9 * period_x:
                nx = fast_size(int(math.ceil(period_x / dx * (1 - 1e-12))))
            dx = period_x / nx
        return BoxPlan((nx, ny, nz), (dx, dy, dz),
                       (region.x_lo - dx, region.y_mid - 0.5 * (ny - 1) * dy, region.z_mid - 0.5 * (nz - 1) * dz))
    from .grids import grid_for_extent

    ext3 = check_tuple("extent", extent, 3, lambda n, v: check_real(n, v, lo=0.0, lo_open=True))
    (nx, ny, nz), (dx, dy, dz) = grid_for_extent(ext3, (dx, dy, dz))
    # the kept box spans (N - 1) d between its first and last points; the x period N dx
    for name, have, need in (("extent[0]", nx * dx, length), ("extent[1]", (ny - 1) * dy, width),
                             ("extent[2]", (nz - 1) * dz, height)):
        if have < need * (1 - 1e-9):
            raise ValueError(f"{name} gives {have:.4g} m, less than the {need:.4g} m the record and the region "
                             f"need; allowed: a larger extent")
    # origins of the physical size, not of the spacing: grids of one extent place their points alike
    return BoxPlan((nx, ny, nz), (dx, dy, dz),
                   (region.x_lo - 0.5 * (ext3[0] - length + 4.0 * dx), region.y_mid - 0.5 * ext3[1],
                    region.z_mid - 0.5 * ext3[2]))


def cover_yz(region: Region, spacing, *, params=None, min_extent: float | None = None,
             lateral_doubling: bool = True):
    """The y and z nodes [m] of the box :func:`cover_box` generates (both lateral halves; default placement).

    They depend neither on the wind nor on the record's length: the virtual
    twin chooses with them the records a box can be conditioned on before
    it sizes the box's x period from those records' mean speed.
    """
    _check_region(region)
    _, dy, dz = _spacing3(spacing)
    ny, nz, _, _ = _lateral(region, dy, dz, _min_extent(params, min_extent))
    ny_gen = 2 * ny if check_bool("lateral_doubling", lateral_doubling) else ny
    y0, z0 = region.y_mid - 0.5 * (ny - 1) * dy, region.z_mid - 0.5 * (nz - 1) * dz
    return y0 + np.arange(ny_gen) * dy, z0 + np.arange(nz) * dz


def cover_box(region: Region, U: float, duration: float, params, seed: int, *, spacing,
              lateral_doubling: bool = True, min_extent: float | None = None, extent=None,
              period_x: float | None = None, hf_compensation: bool = False, dtype=np.float32, condition=None,
              evolution=None, planes=None, source=None):
    """A Mann box holding ``region`` for a record, placed in the field frame (module notes).

    With ``source``, the field a user already has instead: ``source(region,
    U, duration)`` reads and places it, or refuses it naming the sizes
    (:meth:`cwlidar_sim.turbulence.io_source.FieldFile.place`); the
    generation settings then play no part.

    Parameters
    ----------
    region : Region
    U : float
        Mean wind along +x [m/s]; in [0, 1000].
    duration : float
        Record length [s]; > 0.
    params : MannParameters
    seed : int
    spacing, min_extent, extent, period_x
        As for :func:`plan_box`.
    lateral_doubling : bool
        Generate the box twice as wide in y and keep one half (module notes).
    hf_compensation : bool
        The box's high-frequency compensation (:func:`cwlidar_sim.turbulence.generate_box`).
    dtype : float32 or float64
    condition : callable, optional
        ``condition(box) -> box`` applied to the generated box (all of it,
        both lateral halves, placed in the field frame) before one half is
        kept: the virtual twin conditions it there on its records, since the
        kept half of a doubled box does not have a periodic box's
        covariance.  Needs the default placement (no ``extent``) and a frozen box.
    evolution : EddyLifetimeEvolution, optional
        Evolving turbulence: one box per plane of ``planes``
        (:func:`cwlidar_sim.turbulence.evolution.iter_evolving_boxes`).
    planes : sequence of float, optional
        With ``evolution``: the planes' x positions [m], the first the chain's root.
    source : callable, optional
        ``source(region, U, duration) -> xarray.Dataset``: the field read from
        a file and placed (neither ``condition`` nor ``evolution`` with it).

    Returns
    -------
    xarray.Dataset or list of xarray.Dataset
        u, v, w [m/s] on x, y, z (frozen: one box; evolving: one per plane,
        in the order of ``planes``); attrs hold the generation settings and
        ``period_x``, ``lateral_doubling``, ``generated_shape`` (and those
        ``condition`` adds).
    """
    import xarray as xr

    from .box import generate_box, keep_lateral_rows

    if source is not None:
        if condition is not None or evolution is not None:
            raise ValueError("a field read from a file (source) is neither conditioned (condition) nor evolved "
                             "(evolution): give source alone")
        return source(_check_region(region), check_real("U", U, lo=0.0, hi=1000.0), duration)
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be MannParameters, got {type(params).__name__}")
    U = check_real("U", U, lo=0.0, hi=1000.0)
    lateral_doubling = check_bool("lateral_doubling", lateral_doubling)
    hf_compensation = check_bool("hf_compensation", hf_compensation)
    if condition is not None and extent is not None:
        raise ValueError("condition needs the default placement (no extent)")
    if (evolution is None) != (planes is None):
        raise ValueError("evolution and planes go together: give both or neither")
    if condition is not None and evolution is not None:
        raise ValueError("condition needs a frozen box (no evolution)")
    plan = plan_box(region, U, duration, spacing, params=params, min_extent=min_extent, extent=extent,
                    period_x=period_x)
    (nx, ny, nz), d3 = plan.shape, plan.spacing
    gen_shape = (nx, 2 * ny if lateral_doubling else ny, nz)
    if evolution is None:
        boxes = [generate_box(params, gen_shape, d3, seed, hf_compensation=hf_compensation, dtype=dtype)]
    else:
        from .evolution import iter_evolving_boxes

        boxes = [None] * len(planes)
        for p, box in iter_evolving_boxes(params, gen_shape, d3, seed, evolution, planes,
                                          hf_compensation=hf_compensation, dtype=dtype):
            boxes[p] = box
    if condition is not None:
        boxes = [condition(boxes[0].assign_coords(plan.coords(gen_shape[1])))]
    coords = plan.coords()
    out = []
    while boxes:
        box = boxes.pop(0)
        if condition is None and evolution is None:
            keep = lambda a: keep_lateral_rows(a, ny)  # noqa: E731  (in place: the box is spent)
        else:
            keep = lambda a: np.ascontiguousarray(a[:, :ny, :])  # noqa: E731
        data = {c: (("x", "y", "z"), keep(box[c].values)) for c in ("u", "v", "w")}
        attrs = dict(box.attrs)
        attrs.update(period_x=nx * d3[0], lateral_doubling=int(lateral_doubling), generated_shape=gen_shape)
        del box
        out.append(xr.Dataset(data, coords=coords, attrs=attrs))
    return out[0] if evolution is None else out
