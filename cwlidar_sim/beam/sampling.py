"""Beam geometry and line-of-sight sampling of a turbulence field.

Geometry
--------
A beam leaves the lidar at ``origin`` (x, y, z) [m] along the unit vector
``n = (n_x, n_y, n_z)`` in the field's frame: x along the mean wind, y lateral,
z up.  :func:`direction_from_angles` builds ``n`` from an azimuth (from +x
toward +y) and an elevation (from the horizontal, up positive).  A point at
range ``r`` [m] is ``origin + r n``; range cells of the probe volume are at
``r = focus + s`` (A2012 Eq. 2).

Taylor's frozen turbulence
--------------------------
The stored field is advected at the mean speed ``U`` [m/s] along +x, so the
velocity at position ``p`` and time ``t`` is the stored field at
``(p_x - U t, p_y, p_z)``.  The stored values are the fluctuations as they are
in the Dataset; ``add_mean=True`` adds ``U`` to the u component (the total
wind ``(U + u, v, w)``).

Interpolation and boundaries
----------------------------
Values between grid nodes are *trilinear* interpolates of the 8 surrounding
nodes (bilinear for a plane, linear for a line): exact for fields that are
linear in each coordinate separately, second-order accurate (error
``<= (1/8) sum_d h_d^2 max|d^2 f / d x_d^2|``) for smooth fields.  The x axis
is always periodic with period ``n_x dx`` (the generated fields are periodic
and Taylor advection runs through the box).  In y and z a point outside
``[y_0, y_{n-1}]`` (resp. z) raises ValueError naming the coordinate, unless
``wrap=True`` is passed, which makes y and z periodic too (valid for periodic
boxes; the cell between the last and the first node is then interpolated
across the period).

Field types
-----------
* box: dims ("x", "y", "z");
* time-resolved box: dims ("t", "x", "y", "z") with a ``t`` coordinate [s]
  (an LES's output): not advected; the velocity at p and t is the linear
  interpolation in time between the two snapshots around t, each sampled at p
  (trilinear), the mean ``U`` still added to u with ``add_mean``
  (:func:`time_weights`); a time outside the snapshots raises ValueError;
* plane: dims ("x", "y") at height ``attrs["z"]``; every point must lie within
  ``offplane_tol`` of that height (only x and y are interpolated);
* line: dims ("x",) at ``attrs["y"]``, ``attrs["z"]`` when present, else at
  the origin's y and z; every point must lie on the line.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._repr import summary_repr
from .._config import apply_numba_threads
from .._validation import check_bool, check_int, check_memory, check_real
from .cells import RangeCells, weight_truncated
from .geometry import ConicalScanGeometry
from .optics import BeamOptics
from .probe import get_weighting

__all__ = [
    "direction_from_angles",
    "staring_direction",
    "ConicalScan",
    "conical_scan",
    "sample_los",
    "is_time_resolved",
    "time_weights",
    "combine_snapshots",
    "LosAverage",
    "los_average",
]

_UNIT_TOL = 1e-6


# ---------------------------------------------------------------------------
# geometry
# ---------------------------------------------------------------------------
def direction_from_angles(azimuth_deg, elevation_deg):
    """Unit beam direction from azimuth and elevation.

    Parameters
    ----------
    azimuth_deg : float or array_like
        Azimuth [deg], measured in the horizontal plane from +x (the mean-wind
        direction) toward +y.
    elevation_deg : float or array_like
        Elevation above the horizontal [deg], in [-90, 90].

    Returns
    -------
    ndarray, shape (..., 3)
        ``(cos el cos az, cos el sin az, sin el)`` [-], broadcast over the inputs.
    """
    az = _finite_array("azimuth_deg", azimuth_deg)
    el = _finite_array("elevation_deg", elevation_deg)
    if np.any(np.abs(el) > 90.0):
        raise ValueError(f"elevation_deg out of range (max |el| = {np.max(np.abs(el))}); allowed: [-90, 90]")
    az, el = np.broadcast_arrays(np.radians(az), np.radians(el))
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)


def staring_direction(azimuth_deg: float = 0.0, elevation_deg: float = 0.0) -> np.ndarray:
    """Direction of a staring beam, shape (3,) [-]; the default stares along +x (with the wind).

    A2012's nacelle lidar stares upwind at a mast: ``azimuth_deg=180`` with
    the mast upwind, or 0 in a frame where the beam points downwind.
    """
    az = check_real("azimuth_deg", azimuth_deg)
    el = check_real("elevation_deg", elevation_deg, lo=-90.0, hi=90.0)
    return direction_from_angles(az, el)


@dataclasses.dataclass(frozen=True)
class ConicalScan:
    """Sampling schedule of a conically scanning lidar (CS; PHYSICS section 5).

    Attributes
    ----------
    time_t : ndarray, shape (n_t,)
        Sample times [s].
    azimuth_t : ndarray, shape (n_t,)
        Beam azimuth [deg] from +x toward +y, unwrapped (increasing).
    n_tc : ndarray, shape (n_t, 3)
        Unit beam directions [-].
    focus : float
        Focus distance r = z / cos(half_angle) [m].
    height : float
        Measurement height above the lidar z [m].
    geometry : ConicalScanGeometry
        The cone (axis 'up'), its half angle, revolution time and first azimuth.
    circle_diameter : float
        Diameter of the scanned circle at the measurement height, 2 z tan(half_angle) [m].
    """

    __repr__ = summary_repr

    time_t: np.ndarray
    azimuth_t: np.ndarray
    n_tc: np.ndarray
    focus: float
    height: float
    geometry: ConicalScanGeometry
    circle_diameter: float


def conical_scan(
    height: float,
    n_rev: int = 1,
    *,
    half_angle_deg: float = 30.0,
    revolution_time: float = 1.0,
    estimates_per_rev: int = 50,
    azimuth0_deg: float = 0.0,
    start_time: float = 0.0,
) -> ConicalScan:
    """Times and directions of a conical scan (ZephIR: 30 deg, 1 rev/s, 50 points per revolution).

    Parameters
    ----------
    height : float
        Measurement height above the lidar z [m]; > 0.
    n_rev : int
        Number of revolutions; >= 1.
    half_angle_deg : float
        Cone half-angle Phi from the vertical [deg]; in (0, 90).
    revolution_time : float
        Time of one revolution [s]; > 0.
    estimates_per_rev : int
        Line-of-sight samples per revolution; >= 1.
    azimuth0_deg : float
        Azimuth of the first sample [deg], from +x toward +y.
    start_time : float
        Time of the first sample [s].

    Returns
    -------
    ConicalScan
        Sample ``j`` is at ``t_j = start_time + j revolution_time / estimates_per_rev``
        and azimuth ``azimuth0 + 360 j / estimates_per_rev``; the beam direction is
        ``(sin Phi cos az, sin Phi sin az, cos Phi)`` and the focus is
        ``z / cos Phi`` (:class:`~cwlidar_sim.beam.ConicalScanGeometry`, axis
        'up').  Each sample is taken as instantaneous (the beam
        sweeps 360/estimates_per_rev degrees during a real 20 ms estimate).
    """
    z = check_real("height", height, lo=0.0, lo_open=True)
    n_rev = check_int("n_rev", n_rev, lo=1, hi=10**8)
    phi = check_real("half_angle_deg", half_angle_deg, lo=0.0, hi=90.0, lo_open=True, hi_open=True)
    T = check_real("revolution_time", revolution_time, lo=0.0, lo_open=True)
    ppr = check_int("estimates_per_rev", estimates_per_rev, lo=1, hi=10**7)
    t0 = check_real("start_time", start_time)
    geo = ConicalScanGeometry(half_angle_deg=phi, axis="up", revolution_time=T, azimuth0_deg=azimuth0_deg)
    j = np.arange(n_rev * ppr)
    time_t = t0 + j * T / ppr
    azimuth_t = geo.azimuth0_deg + 360.0 * j / ppr
    return ConicalScan(
        time_t=time_t,
        azimuth_t=azimuth_t,
        n_tc=geo.direction(azimuth_t),
        focus=geo.focus_at(z),
        height=z,
        geometry=geo,
        circle_diameter=geo.circle_diameter(z),
    )


# ---------------------------------------------------------------------------
# field preparation
# ---------------------------------------------------------------------------
def _finite_array(name, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be real numbers, got {type(value).__name__}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains non-finite values; allowed: finite reals")
    return arr


@dataclasses.dataclass(frozen=True)
class _Field:
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    grid: np.ndarray  # x0, y0, z0, dx, dy, dz
    shape: tuple
    kind: str  # box, plane, line
    fixed: dict  # coordinate -> nominal position for dims the field does not have


def _axis(field, name):
    c = np.asarray(field[name].values, dtype=np.float64)
    if c.ndim != 1 or c.size < 2:
        raise ValueError(f"field coordinate {name!r} must be 1-D with >= 2 points, got shape {c.shape}")
    d = np.diff(c)
    h = d[0]
    if not (h > 0 and np.allclose(d, h, rtol=1e-6, atol=0.0)):
        raise ValueError(f"field coordinate {name!r} must be uniformly increasing; spacings range {d.min()}..{d.max()} m")
    return float(c[0]), float(h)


def _prepare_field(field, origin) -> _Field:
    import xarray as xr
    if not isinstance(field, xr.Dataset):
        raise TypeError(f"field must be an xarray.Dataset with u, v, w, got {type(field).__name__}")
    missing = [c for c in ("u", "v", "w") if c not in field.data_vars]
    if missing:
        raise ValueError(f"field lacks data variable(s) {missing}; required: u, v, w")
    dims = set(field["u"].dims)
    kinds = {frozenset("xyz"): "box", frozenset("xy"): "plane", frozenset("x"): "line"}
    kind = kinds.get(frozenset(dims))
    if kind is None:
        raise ValueError(f"field dims {tuple(field['u'].dims)} not allowed; allowed: (x, y, z), (x, y) or (x,)")
    order = {"box": ("x", "y", "z"), "plane": ("x", "y"), "line": ("x",)}[kind]
    arrs = []
    for c in ("u", "v", "w"):
        da = field[c]
        if set(da.dims) != dims:
            raise ValueError(f"field variable {c!r} has dims {da.dims}, expected {tuple(field['u'].dims)}")
        a = np.asarray(da.transpose(*order).values)
        if a.dtype not in (np.float32, np.float64):
            raise TypeError(f"field variable {c!r} must be float32 or float64, got {a.dtype}")
        a = np.ascontiguousarray(a)
        arrs.append(a.reshape(a.shape + (1,) * (3 - a.ndim)))
    if len({a.dtype for a in arrs}) != 1:
        raise TypeError("field variables u, v, w must share one dtype")
    x0, dx = _axis(field, "x")
    y0, dy, z0, dz = 0.0, 1.0, 0.0, 1.0
    fixed = {}
    if kind in ("box", "plane"):
        y0, dy = _axis(field, "y")
    else:
        fixed["y"] = float(field.attrs.get("y", origin[1]))
    if kind == "box":
        z0, dz = _axis(field, "z")
    else:
        if kind == "plane" and "z" not in field.attrs:
            raise ValueError("plane field needs attrs['z'] (its height [m]) to check that the beam lies in it")
        fixed["z"] = float(field.attrs.get("z", origin[2]))
    grid = np.array([x0, y0, z0, dx, dy, dz])
    return _Field(arrs[0], arrs[1], arrs[2], grid, arrs[0].shape, kind, fixed)


def _prepare_beam(origin, direction, times, ranges):
    origin = _finite_array("origin", origin)
    if origin.shape != (3,):
        raise ValueError(f"origin must have shape (3,) (x, y, z) [m], got {origin.shape}")
    time_t = _finite_array("times", times)
    if time_t.ndim != 1 or time_t.size == 0:
        raise ValueError(f"times must be a non-empty 1-D array [s], got shape {time_t.shape}")
    n = _finite_array("direction", direction)
    if n.shape == (3,):
        n_tc = np.broadcast_to(n, (time_t.size, 3))
    elif n.shape == (time_t.size, 3):
        n_tc = n
    else:
        raise ValueError(f"direction must have shape (3,) or (n_times, 3) = ({time_t.size}, 3), got {n.shape}")
    norm = np.sqrt(np.sum(n_tc**2, axis=1))
    bad = np.abs(norm - 1.0) > _UNIT_TOL
    if np.any(bad):
        raise ValueError(
            f"direction must be unit vectors; |n| = {norm[bad][0]!r} at index {int(np.argmax(bad))}; "
            f"allowed: |n| within {_UNIT_TOL} of 1"
        )
    range_s = _finite_array("ranges", ranges)
    if range_s.ndim == 0:
        range_s = range_s.reshape(1)
    if range_s.ndim != 1 or range_s.size == 0:
        raise ValueError(f"ranges must be a non-empty 1-D array [m], got shape {range_s.shape}")
    if np.any(range_s < 0):
        raise ValueError(f"ranges must be >= 0 m (in front of the telescope), got min {range_s.min()!r}")
    return origin, np.ascontiguousarray(n_tc, dtype=np.float64), time_t, np.ascontiguousarray(range_s)


def _check_extent(fld: _Field, origin, n_tc, range_s, wrap: bool, offplane_tol: float):
    # positions are linear in r along each beam, so the extremes over all cells
    # are reached at the smallest or largest range
    rr = np.array([range_s.min(), range_s.max()])
    for axis, name in ((1, "y"), (2, "z")):
        p = origin[axis] + np.multiply.outer(n_tc[:, axis], rr)
        pmin, pmax = float(p.min()), float(p.max())
        if name in fld.fixed:
            ref = fld.fixed[name]
            dev = max(abs(pmin - ref), abs(pmax - ref))
            if dev > offplane_tol:
                what = "plane" if fld.kind == "plane" else "line"
                raise ValueError(
                    f"beam leaves the {what} field in {name}: {name} spans [{pmin:.6g}, {pmax:.6g}] m, the "
                    f"field is at {name} = {ref:.6g} m; allowed deviation: offplane_tol = {offplane_tol} m"
                )
            continue
        if wrap:
            continue
        n = fld.shape[axis]
        lo = fld.grid[axis]
        hi = lo + (n - 1) * fld.grid[axis + 3]
        slack = 1e-9 * fld.grid[axis + 3]
        if pmin < lo - slack or pmax > hi + slack:
            raise ValueError(
                f"beam leaves the field in {name}: {name} spans [{pmin:.6g}, {pmax:.6g}] m, the field covers "
                f"[{lo:.6g}, {hi:.6g}] m; pass wrap=True to treat {name} as periodic (period "
                f"{n * fld.grid[axis + 3]:.6g} m)"
            )


# ---------------------------------------------------------------------------
# sampling
# ---------------------------------------------------------------------------
def is_time_resolved(field) -> bool:
    """Whether ``field`` is time-resolved: u on ("t", "x", "y", "z") (module notes)."""
    return "t" in getattr(field, "dims", ())


def time_weights(time_k, time_l):
    """``(k_l, a_l)``: the snapshot at or before each time and the next one's weight (linear in t).

    ``time_k``: the snapshots' times [s], at least 2, increasing; ``time_l``
    the sample times [s], each within ``[time_k[0], time_k[-1]]`` (a
    ValueError naming the span otherwise).  The value at ``time_l[l]`` is
    ``(1 - a_l) f[k_l] + a_l f[k_l + 1]``.
    """
    t_k = np.asarray(time_k, dtype=np.float64)
    t_l = np.asarray(time_l, dtype=np.float64)
    if t_k.size < 2 or not np.all(np.diff(t_k) > 0):
        raise ValueError(f"a time-resolved field needs at least 2 increasing snapshot times [s], got {t_k.size}")
    slack = 1e-9 * (t_k[-1] - t_k[0])
    if t_l.size and (t_l.min() < t_k[0] - slack or t_l.max() > t_k[-1] + slack):
        raise ValueError(f"times [{t_l.min():.6g}, {t_l.max():.6g}] s leave the time-resolved field's snapshots "
                         f"[{t_k[0]:.6g}, {t_k[-1]:.6g}] s; allowed: times within them")
    k_l = np.clip(np.searchsorted(t_k, t_l, side="right") - 1, 0, t_k.size - 2)
    a_l = np.clip((t_l - t_k[k_l]) / (t_k[k_l + 1] - t_k[k_l]), 0.0, 1.0)
    return k_l, a_l


def combine_snapshots(field, times, sample):
    """A sampler's outputs on a time-resolved field: the snapshots' outputs at t = 0, weighted linearly in t.

    ``sample(snapshot, zeros, sel)`` samples the frozen ``snapshot`` (dims
    x, y, z) at the times ``times[sel]`` set to 0 (no advection) and
    returns a tuple of arrays whose first axis runs over those times; the
    outputs are linear in the field, so the weighted sum is the sample of the
    field interpolated in time (module notes).
    """
    time_l = np.asarray(times, dtype=np.float64).reshape(-1)
    k_l, a_l = time_weights(field["t"].values, time_l)
    out = None
    for k in np.unique(k_l):
        sel = np.flatnonzero(k_l == k)
        for kk, w in ((k, 1.0 - a_l[sel]), (k + 1, a_l[sel])):
            parts = sample(field.isel(t=int(kk)), np.zeros(sel.size), sel)
            if out is None:
                out = tuple(np.zeros((time_l.size,) + p.shape[1:], dtype=np.float64) for p in parts)
            for o, p in zip(out, parts):
                o[sel] += w.reshape((-1,) + (1,) * (p.ndim - 1)) * p
    return out


def sample_los(
    field,
    origin,
    direction,
    ranges,
    times,
    U: float,
    *,
    wrap: bool = False,
    add_mean: bool = False,
    offplane_tol: float = 1e-6,
):
    """Velocity at points along a beam, with Taylor advection.

    Parameters
    ----------
    field : xarray.Dataset
        Variables ``u``, ``v``, ``w`` [m/s] (float32 or float64) on dims
        ("x", "y", "z"), ("x", "y") or ("x",) with uniform coordinates [m]
        (see the module notes for plane and line fields).
    origin : array_like, shape (3,)
        Lidar position (x, y, z) [m] in the field's frame.
    direction : array_like, shape (3,) or (n_t, 3)
        Unit beam direction [-], fixed or one per time sample.
    ranges : array_like, shape (n_s,)
        Distances from the lidar along the beam [m]; >= 0.
    times : array_like, shape (n_t,)
        Sample times [s].
    U : float
        Advection speed along +x [m/s] (Taylor's hypothesis).
    wrap : bool
        Make y and z periodic (x always is); otherwise a point outside the
        field in y or z raises ValueError naming the coordinate.
    add_mean : bool
        Add ``U`` to the u component.
    offplane_tol : float
        Largest distance [m] allowed between a point and a plane's height or
        a line's position; >= 0.

    Returns
    -------
    vel_tsc : ndarray, shape (n_t, n_s, 3), float64
        (u, v, w) at ``origin + ranges[s] * direction[t]`` and ``times[t]``
        [m/s], interpolated trilinearly from the stored field at
        ``x - U t``.
    vlos_ts : ndarray, shape (n_t, n_s), float64
        Line-of-sight projection ``n . (u, v, w)`` [m/s] (positive away from
        the lidar).
    """
    if is_time_resolved(field):
        return combine_snapshots(field, times, lambda snap, t, sel: sample_los(
            snap, origin, np.asarray(direction)[sel] if np.ndim(direction) == 2 else direction, ranges, t, U,
            wrap=wrap, add_mean=add_mean, offplane_tol=offplane_tol))
    origin, n_tc, time_t, range_s = _prepare_beam(origin, direction, times, ranges)
    fld = _prepare_field(field, origin)
    U = check_real("U", U)
    wrap = check_bool("wrap", wrap)
    add_mean = check_bool("add_mean", add_mean)
    offplane_tol = check_real("offplane_tol", offplane_tol, lo=0.0)
    _check_extent(fld, origin, n_tc, range_s, wrap, offplane_tol)
    n_t, n_s = time_t.size, range_s.size
    check_memory("sample_los output", 32 * n_t * n_s)

    from . import _kernels

    apply_numba_threads()
    vel_tsc, vlos_ts = _kernels.empty_outputs(n_t, n_s)
    _kernels.sample_points_kernel(
        fld.u, fld.v, fld.w, fld.grid, wrap, wrap, origin, n_tc, range_s, time_t, U, add_mean, vel_tsc, vlos_ts
    )
    return vel_tsc, vlos_ts


@dataclasses.dataclass(frozen=True)
class LosAverage:
    """Result of :func:`los_average`.

    Attributes
    ----------
    vlos_t : ndarray, shape (n_t,)
        Probe-volume weighted line-of-sight speed [m/s] (A2012 Eq. 2).
    time_t : ndarray, shape (n_t,)
        Sample times [s].
    cells : RangeCells
        Range cells used: offsets ``s_s`` from the focus [m] and weights.
    kept_fraction : float
        Weight of the probe volume inside the span [-].
    truncated_fraction : float
        Weight of the tails outside the span [-] (``1 - kept_fraction``).
    renormalised : bool
        Whether the weights were divided by ``kept_fraction`` (sum to 1).
    """

    __repr__ = summary_repr

    vlos_t: np.ndarray
    time_t: np.ndarray
    cells: RangeCells
    kept_fraction: float
    truncated_fraction: float
    renormalised: bool


def los_average(
    field,
    optics: BeamOptics,
    origin,
    direction,
    times,
    U: float,
    weighting: str = "exact",
    span: float = 20.0,
    n_cells: int = 401,
    *,
    renormalise: bool = True,
    wrap: bool = False,
    add_mean: bool = False,
    offplane_tol: float = 1e-6,
) -> LosAverage:
    """Probe-volume weighted line-of-sight speed (tier 1, A2012 Eq. 2).

    ``v_r(t) = sum_s w_s n(t) . u(origin + (r + s_s) n(t), t)`` with the range
    cells and weights of :func:`~cwlidar_sim.beam.weight_truncated`:
    each ``w_s`` is the exact integral of the weighting over its cell, the cell
    centres ``s_s`` are sampled by trilinear interpolation, and the field is
    advected at ``U`` along +x (see :func:`sample_los`).

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line field (see :func:`sample_los`).
    optics : BeamOptics
        Beam optics; ``optics.focus`` is the focus distance r [m].
    origin : array_like, shape (3,)
        Lidar position [m].
    direction : array_like, shape (3,) or (n_t, 3)
        Unit beam direction [-].
    times : array_like, shape (n_t,)
        Sample times [s].
    U : float
        Advection speed along +x [m/s].
    weighting : str or Weighting
        Weighting along the beam, a name of :data:`cwlidar_sim.beam.WEIGHTINGS`
        ('exact': A2012 Eq. 3 as corrected in :mod:`cwlidar_sim.beam.optics`,
        'lorentzian': Eq. 4, ...) or a :class:`~cwlidar_sim.beam.Weighting`.
    span : float
        Half-width of the kept span in Rayleigh lengths [-]; the Lorentzian
        misses ``1 - (2/pi) arctan(span)`` of its weight (3.2 % for 20).
    n_cells : int
        Number of range cells over the span; the cell length
        ``2 span z_R / n_cells`` should not exceed the grid spacing much.
    renormalise : bool
        True: weights divided by the kept fraction (a uniform wind is
        returned exactly).  False: weights sum to the kept fraction and the
        truncated tail weight is reported in the result for the caller to
        account for.
    wrap, add_mean, offplane_tol
        As in :func:`sample_los`.

    Returns
    -------
    LosAverage
        ``vlos_t`` [m/s] plus the cells and kept/truncated weight fractions.
    """
    if not isinstance(optics, BeamOptics):
        raise TypeError(f"optics must be a BeamOptics, got {type(optics).__name__}")
    weighting = get_weighting(weighting)
    renormalise = check_bool("renormalise", renormalise)
    cells = weight_truncated(optics, weighting, span=span, n_cells=n_cells, renormalise=renormalise)
    range_s = np.maximum(optics.focus + cells.s_s, 0.0)
    origin, n_tc, time_t, range_s = _prepare_beam(origin, direction, times, range_s)
    fld = _prepare_field(field, origin)
    U = check_real("U", U)
    wrap = check_bool("wrap", wrap)
    add_mean = check_bool("add_mean", add_mean)
    offplane_tol = check_real("offplane_tol", offplane_tol, lo=0.0)
    _check_extent(fld, origin, n_tc, range_s, wrap, offplane_tol)

    from . import _kernels

    apply_numba_threads()
    vlos_t = np.empty(time_t.size)
    weight_s = np.ascontiguousarray(cells.weight_s, dtype=np.float64)
    ns = weight_s.size
    _kernels.los_cells_kernel(
        fld.u, fld.v, fld.w, fld.grid, wrap, wrap, origin, n_tc, range_s, np.ones(ns), np.arange(ns + 1), weight_s,
        0.0, time_t, U, add_mean, False, np.empty((0, 0)), vlos_t
    )
    return LosAverage(
        vlos_t=vlos_t,
        time_t=time_t,
        cells=cells,
        kept_fraction=cells.kept_fraction,
        truncated_fraction=cells.truncated_fraction,
        renormalised=renormalise,
    )
