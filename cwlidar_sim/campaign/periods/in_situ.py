"""Point sensors (cup, sonic) in a generated field: their sub-grid variance, for every kind that has them.

A cup or a sonic reads the field the grid holds, which lacks the variance
below the grid (:mod:`cwlidar_sim.analysis.point_subgrid`): at the CS
scene's spacing (z / 20) the sonic's sigma is 2.6-2.9 % and the cup's
0.8-1.5 % below their continuum values (docs/convergence.md, *Point sensors
below the grid*).  :func:`field_subgrid_variance` reads the field's grid
(generated shape, spacing, generator settings, the sensor's offset from
the nodes) and gives that variance; a period reports beside the raw
statistic ``<sensor>_std`` its continuum value ``<sensor>_std_continuum =
sqrt(<sensor>_std^2 + subgrid)``, which converges as the grid is refined
(the raw one converges to it).  The simulated series are not changed.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["field_subgrid_variance", "subgrid_unavailable", "continuum_std", "sonic_variables", "UNIT_VARS"]

#: A conical unit's point-sensor variables added beside ``cup_std`` and ``sonic_std`` (units, long name).
UNIT_VARS = {
    "cup_subgrid_variance": ("m2 s-2", "the cup's expected variance below the box's grid (continuum - box; "
                                       "analysis.point_subgrid)"),
    "sonic_subgrid_variance": ("m2 s-2", "the sonic's expected variance below the box's grid (continuum - box)"),
    "cup_std_continuum": ("m s-1", "cup {span} standard deviation with its sub-grid variance restored: "
                                   "sqrt(cup_std^2 + cup_subgrid_variance)"),
    "sonic_std_continuum": ("m s-1", "sonic horizontal-speed standard deviation with its sub-grid variance "
                                     "restored"),
}
#: Per scan length: the lidar against the cup's continuum sigma.
SCAN_VARS = {
    "std_ratio_cup_continuum": ("1", "lidar / cup {span} standard deviation, the cup's sub-grid variance "
                                     "restored (cup_std_continuum)"),
}


_GENERATORS = {"cwlidar_sim.turbulence.generate_box": "box", "cwlidar_sim.turbulence.generate_plane": "plane",
               "cwlidar_sim.turbulence.generate_line": "line"}


def _grid(field):
    """(kind, generated shape, spacing, node origins) of a generated field; None for one read from a file."""
    if subgrid_unavailable(field):
        return None
    kind = _GENERATORS[str(field.attrs["generator"])]
    axes = ("x", "y", "z")[: {"box": 3, "plane": 2, "line": 1}[kind]]
    coords = [np.asarray(field[a].values, dtype=np.float64) for a in axes]
    spacing = tuple(float(c[1] - c[0]) for c in coords)
    shape = tuple(int(n) for n in field.attrs.get("generated_shape", tuple(c.size for c in coords)))
    return kind, shape, spacing, tuple(float(c[0]) for c in coords)


def subgrid_unavailable(field) -> str:
    """Why :func:`field_subgrid_variance` of ``field`` is NaN, or '' when it is not.

    Only a field generated from the tensor (a box, plane or line of
    :mod:`cwlidar_sim.turbulence`) has a known sub-grid variance: one read
    from a file, conditioned on records, or rescaled to a target sigma (or
    its mean kept) has not.
    """
    gen = str(field.attrs.get("generator", ""))
    if gen not in _GENERATORS:
        return (f"NaN: the field ({gen or 'read from a file'}) is not a box, plane or line generated from the "
                "tensor, whose sub-grid variance is known")
    if int(field.attrs.get("keep_mean", 0)) or "sigma_u_target" in field.attrs:
        return "NaN: the field is rescaled to a target sigma_u (or keeps its mean): its sub-grid variance is not known"
    return ""


def field_subgrid_variance(field, position, params, mean_speed: float, duration: float, *,
                           direction=(1.0, 0.0, 0.0), time_constant: float | None = None,
                           sample_interval: float | None = None) -> float:
    """A point sensor's expected sub-grid variance in ``field`` [m^2 s^-2] (NaN: :func:`subgrid_unavailable`).

    Parameters
    ----------
    field : xarray.Dataset
        The generated line, plane or box (its attributes name the generator
        and, for :func:`cwlidar_sim.turbulence.cover.cover_box`, the
        generated shape).
    position : (x, y, z)
        The sensor [m].
    params : MannParameters
    mean_speed, duration : float
        U [m/s] and the period [s].
    direction, time_constant, sample_interval
        As :func:`cwlidar_sim.analysis.point_subgrid.point_subgrid_variance`.
    """
    from ...analysis.point_subgrid import point_subgrid_variance

    g = _grid(field)
    if g is None:
        return math.nan
    kind, shape, spacing, origin = g
    off = [0.0, 0.0]
    for i in range(1, len(shape)):
        f = (float(position[i]) - origin[i]) / spacing[i]
        a = f - math.floor(f)
        off[i - 1] = 0.0 if min(a, 1.0 - a) < 1e-9 else a
    r = point_subgrid_variance(params, mean_speed, duration, kind, shape, spacing, direction=direction,
                               offset=tuple(off), time_constant=time_constant, sample_interval=sample_interval,
                               correction=str(field.attrs.get("correction", "cell")),
                               hf_compensation=bool(int(field.attrs.get("hf_compensation", 0))))
    n = r["n_samples"]
    # the period's ddof = 1 variance: N / (N - 1) times the (1/N) one
    return r["subgrid"] * (n / (n - 1) if n and n > 1 else 1.0)


def continuum_std(std: float, subgrid_variance: float) -> float:
    """``sqrt(std^2 + subgrid_variance)`` [m s-1]: a simulated sigma with its sub-grid variance restored."""
    return math.sqrt(max(0.0, float(std) ** 2 + float(subgrid_variance)))


def sonic_variables(dims, sonic_std, subgrid_variance, reason: str = "", *, along: str = "") -> dict:
    """A period's ``sonic_subgrid_variance`` and ``sonic_std_continuum`` result variables (staring, WindScanner).

    Parameters
    ----------
    dims : tuple of str
        The variables' dimensions (``period`` first).
    sonic_std, subgrid_variance : array_like
        The sonic's simulated sigma [m s-1] and its sub-grid variance [m^2 s^-2]
        (:func:`field_subgrid_variance`), shaped as ``dims``.
    reason : str
        :func:`subgrid_unavailable` of the period's field: when not empty, the
        variance's ``comment`` (why it is NaN).
    along : str
        What the sonic reads, for the long name (e.g. ``" along the beam"``).

    Returns
    -------
    dict
        ``name: (dims, values, attrs)``, sigma with the variance restored elementwise as :func:`continuum_std`.
    """
    std = np.asarray(sonic_std, dtype=np.float64)
    sub = np.asarray(subgrid_variance, dtype=np.float64)
    note = {"comment": reason} if reason else {}
    return {
        "sonic_subgrid_variance": (dims, sub, {"units": "m2 s-2", "long_name": f"the sonic's expected variance{along} "
                                               "below the field's grid (continuum - field; analysis.point_subgrid)",
                                               **note}),
        "sonic_std_continuum": (dims, np.sqrt(np.maximum(0.0, std**2 + sub)),
                                {"units": "m s-1", "long_name": "sonic_std with its sub-grid variance restored: "
                                 "sqrt(sonic_std^2 + sonic_subgrid_variance)"}),
    }
