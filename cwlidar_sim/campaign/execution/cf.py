"""CF attributes of a scene's results, and their absolute time axis when the scene names its start.

Every results file says ``Conventions = "CF-1.10"``
(``_labels.CF_CONVENTIONS``) and carries CF
``standard_name`` (and ``cell_methods``) attributes on the variables CF has a
name for (``_labels.CF_STANDARD_NAMES``); nothing
else changes: no value, no name, no unit.

Time.  The results' own times are relative: seconds from each period's start
(``time_50hz``, ...).  A scene that names ``start_time`` (any kind's scene
file, :func:`cwlidar_sim.campaign.scenes.start_time.check_start_time`) also gets an
absolute axis: the periods follow one another from ``start_time`` in the
order the results hold them, each lasting its own ``duration`` (the
``[[period]]`` table's, else the scene's), and the rows of one period (a
conical period at each height) share its interval.  ``time(period)`` is the
start of each row's period, CF-encoded (``seconds since 1970-01-01``, UTC,
proleptic Gregorian, ``standard_name = "time"``), with CF bounds
``time_bounds(period, nv)`` (start, end); a series' absolute time is
``time + time_<rate>``.  Without ``start_time`` the file has no ``time``
coordinate and its values are those of a file written before this existed.
"""

from __future__ import annotations

import json
import re

import numpy as np

from .._labels import CF_CONVENTIONS, CF_STANDARD_NAMES, CF_TIME_UNITS

__all__ = ["annotate", "period_intervals", "TIME", "TIME_BOUNDS"]

#: Names of the absolute time coordinate and its bounds.
TIME, TIME_BOUNDS = "time", "time_bounds"


def _row_period_names(ds) -> list:
    """The scene period each row of ``period`` belongs to (``period_name`` where rows are period x height)."""
    names = ds["period_name"].values if "period_name" in ds.coords or "period_name" in ds else ds["period"].values
    return [str(n) for n in names]


def period_intervals(ds):
    """Each row's period as ``(start_s, end_s)`` [s] from the first period's start, and each row's period name.

    The scene's periods (its ``[[period]]`` tables, by name, in the order the
    rows first name them) follow one another; a period's length is its own
    ``duration``, else the scene's.  A name the scene does not list (a
    conical template's later pass ``<template>_<c>``) takes its template's.

    Returns
    -------
    start_p, end_p : ndarray
        Per row of ``period`` [s]; NaN when the scene gives no length.
    names : list of str
    """
    try:
        scene = json.loads(ds.attrs.get("scene", "{}"))
    except (TypeError, ValueError):
        scene = {}
    default = scene.get("duration")
    own = {str(p.get("name")): p.get("duration", default) for p in scene.get("period", []) if isinstance(p, dict)}

    def length(name):
        if name not in own:
            m = re.fullmatch(r"(.+)_\d+", name)
            name = m.group(1) if m and m.group(1) in own else name
        v = own.get(name, default)
        return np.nan if v is None else float(v)

    names = _row_period_names(ds)
    start, t = {}, 0.0
    for n in names:
        if n not in start:
            start[n] = t
            t += length(n)
    s = np.array([start[n] for n in names], dtype=float)
    return s, s + np.array([length(n) for n in names], dtype=float), names


def annotate(ds, start=None):
    """``ds`` with CF attributes and, given the scene's ``start`` (naive UTC datetime), its ``time`` axis.

    Parameters
    ----------
    ds : xarray.Dataset
        A scene's assembled results (on ``period``).
    start : datetime.datetime, optional
        The first period's start, UTC (:func:`cwlidar_sim.campaign.scenes.start_time.start_datetime`).

    Returns
    -------
    xarray.Dataset
        A shallow copy: the same values, attributes added (module notes).
    """
    ds = ds.copy()
    ds.attrs["Conventions"] = CF_CONVENTIONS
    for name, (standard, methods) in CF_STANDARD_NAMES.items():
        if name in ds.variables and "standard_name" not in ds[name].attrs:
            ds[name].attrs["standard_name"] = standard
            if methods and "period" in ds[name].dims:
                ds[name].attrs.setdefault("cell_methods", methods)
    if start is None or "period" not in ds.dims or TIME in ds.variables:
        return ds
    s_p, e_p, _ = period_intervals(ds)
    t0 = np.datetime64(start.isoformat(), "us")
    to_time = lambda sec: t0 + np.round(np.asarray(sec) * 1e6).astype("timedelta64[us]")  # noqa: E731
    ds = ds.assign_coords({
        TIME: ("period", to_time(s_p).astype("datetime64[ns]"),
               {"standard_name": "time", "long_name": "start of the row's period (UTC)", "axis": "T",
                "bounds": TIME_BOUNDS}),
        TIME_BOUNDS: (("period", "nv"), np.stack([to_time(s_p), to_time(e_p)], axis=1).astype("datetime64[ns]"),
                      {"long_name": "start and end of the row's period (UTC)"}),
    })
    for name in (TIME, TIME_BOUNDS):
        ds[name].encoding.update(units=CF_TIME_UNITS, calendar="proleptic_gregorian", dtype="float64")
    ds.attrs["start_time"] = start.isoformat() + "Z"
    return ds
