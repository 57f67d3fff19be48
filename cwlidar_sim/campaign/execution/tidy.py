"""The tidy statistics table of a scene's results: one row per period x height x instrument x quantity.

Every run writes ``DIR/<scene>.stats.csv`` beside ``DIR/<scene>.nc`` (and
``DIR/<scene>.stats.parquet`` where pandas has a Parquet engine, pyarrow or
fastparquet; never required), atomically, in the long format mast and lidar
statistics come in, for pandas, R or a spreadsheet::

    period, unit, height_m, instrument, quantity, statistic, value, units, standard_name,
    start_s, end_s, start_time, end_time[, one column per further dimension]

The rows come from the variables the scene's kind names as statistics
(:meth:`cwlidar_sim.campaign.registry.SceneKind.statistics`; a kind that does
not say gets :func:`cwlidar_sim.campaign.registry.default_statistics`), with
no code per kind here:

* a statistic per period (a variable on ``period``, e.g. a conical unit's
  ``std_ratio_unit``): one row per period row and per value of its further
  dimensions (``scan_s``, ``focus``, ``estimate``, ...: a column each, empty
  in the other rows), ``statistic = "value"``;
* a series (a variable on ``period`` and a time dimension: a dimension
  coordinate in ``s`` named ``time...`` or with ``axis = "T"``, e.g. a staring
  scene's ``lidar_10hz`` on ``time_10hz``): its 10-minute blocks from
  the period's start (:data:`BLOCK_S`; a shorter period is one block), each
  block's ``mean``, ``std`` (ddof 1), ``min``, ``max`` and ``count`` of its
  finite samples.

``period`` is the scene's period (``period_name`` where the rows are period x
height), ``unit`` the results' row; ``height_m`` the row's coordinate whose
``standard_name`` is ``height`` (a conical unit's height; empty otherwise);
``start_s`` / ``end_s`` the row's interval from the first period's start
(:func:`cwlidar_sim.campaign.execution.cf.period_intervals`), ``start_time`` /
``end_time`` the same in UTC (ISO 8601, ``Z``) when the scene names
``start_time``.  Values are written in full precision (Python's shortest
round-trip repr), so the table gives the NetCDF's numbers exactly.
"""

from __future__ import annotations

import importlib.util

import numpy as np

from ..._atomic import atomic_open, atomic_path
from ..registry import statistics_of
from .cf import TIME, period_intervals

__all__ = ["statistics_table", "write_statistics", "parquet_engine", "BLOCK_S", "COLUMNS"]

#: Length of a series' statistics blocks [s] (mast and lidar data's 10 minutes).
BLOCK_S = 600.0
#: The table's columns, before those of further dimensions.
COLUMNS = ("period", "unit", "height_m", "instrument", "quantity", "statistic", "value", "units", "standard_name",
           "start_s", "end_s", "start_time", "end_time")


def _time_dim(var, ds):
    """The variable's time dimension, or None: a dimension coordinate in s named ``time...`` or with ``axis = "T"``."""
    for d in var.dims:
        c = ds.coords.get(d)
        if d != "period" and c is not None and c.ndim == 1 and c.attrs.get("units") == "s" and (
                str(d).startswith("time") or c.attrs.get("axis") == "T"):
            return d
    return None


def _iso(t0, seconds) -> str:
    if t0 is None or not np.isfinite(seconds):
        return ""
    return str(t0 + np.timedelta64(int(round(seconds * 1e6)), "us")) + "Z"


def _label(ds, dim, i):
    if dim in ds.coords:
        v = ds[dim].values[i]
        return v.item() if hasattr(v, "item") else v
    return i


def statistics_table(ds, kind):
    """The tidy statistics table of a scene's results (module notes) as a pandas DataFrame.

    Parameters
    ----------
    ds : xarray.Dataset
        The scene's assembled results (:func:`cwlidar_sim.campaign.run_scene`).
    kind : scene kind
        Its kind (:func:`cwlidar_sim.campaign.registry.kind_of`), asked which variables are statistics.

    Returns
    -------
    pandas.DataFrame
        The columns of :data:`COLUMNS`, then one per further dimension met.
    """
    import pandas as pd

    start_p, end_p, names = period_intervals(ds)
    units_p = [str(u) for u in ds["period"].values]
    height_p = np.full(ds.sizes.get("period", 0), np.nan)
    for c in ds.coords.values():
        if c.dims == ("period",) and c.attrs.get("standard_name") == "height":
            height_p = np.asarray(c.values, dtype=float)
            break
    t0 = None
    if TIME in ds.coords:
        t0 = ds[TIME].values[0].astype("datetime64[us]") - np.timedelta64(int(round(start_p[0] * 1e6)), "us")
    rows, extra = [], []
    for name, instrument in statistics_of(kind, ds).items():
        if name not in ds.data_vars or "period" not in ds[name].dims:
            raise ValueError(f"the {getattr(kind, 'name', kind)!r} kind names {name!r} a statistic, but the results "
                             f"have no such variable on 'period'")
        tdim = _time_dim(ds[name], ds)
        others = [d for d in ds[name].dims if d not in ("period", tdim)]
        var = ds[name].transpose("period", *others, *([tdim] if tdim else []))
        for d in others:
            if d not in extra:
                extra.append(d)
        common = {"instrument": str(instrument), "quantity": name, "units": str(var.attrs.get("units", "")),
                  "standard_name": str(var.attrs.get("standard_name", ""))}
        values = np.asarray(var.values)
        for ip in range(values.shape[0]):
            base = {"period": names[ip], "unit": units_p[ip], "height_m": height_p[ip], **common}
            for idx in np.ndindex(*[var.sizes[d] for d in others]):
                labels = {d: _label(ds, d, i) for d, i in zip(others, idx)}
                if tdim is None:
                    rows.append({**base, **labels, "statistic": "value", "value": values[(ip, *idx)],
                                 "start_s": start_p[ip], "end_s": end_p[ip],
                                 "start_time": _iso(t0, start_p[ip]), "end_time": _iso(t0, end_p[ip])})
                    continue
                series = np.asarray(values[(ip, *idx)], dtype=float)
                rows += _blocks(series, np.asarray(ds[tdim].values, dtype=float), base | labels,
                                start_p[ip], end_p[ip], t0)
    df = pd.DataFrame(rows)
    rename = {d: (d if d not in COLUMNS else f"dim_{d}") for d in extra}
    df = df.rename(columns=rename)
    return df.reindex(columns=[*COLUMNS, *rename.values()])


def _blocks(series, t, base, start, end, t0) -> list:
    """The 10-minute block statistics of one period's series (sample times ``t`` from the period's start)."""
    length = end - start if np.isfinite(end - start) else (float(np.nanmax(t)) if t.size else 0.0)
    out = []
    n_blocks = max(1, int(np.ceil(length / BLOCK_S - 1e-9)))
    for b in range(n_blocks):
        lo, hi = b * BLOCK_S, min((b + 1) * BLOCK_S, length)
        x = series[(t > lo) & (t <= hi) if b else (t >= lo) & (t <= hi)]
        x = x[np.isfinite(x)]
        stats = {"mean": x.mean() if x.size else np.nan, "std": x.std(ddof=1) if x.size > 1 else np.nan,
                 "min": x.min() if x.size else np.nan, "max": x.max() if x.size else np.nan, "count": float(x.size)}
        for stat, v in stats.items():
            units = {"units": "1"} if stat == "count" else {}
            out.append({**base, **units, "statistic": stat, "value": float(v), "start_s": start + lo,
                        "end_s": start + hi,
                        "start_time": _iso(t0, start + lo), "end_time": _iso(t0, start + hi)})
    return out


def parquet_engine():
    """The Parquet engine pandas would use (``"pyarrow"`` or ``"fastparquet"``), or None: no Parquet file."""
    for name in ("pyarrow", "fastparquet"):
        if importlib.util.find_spec(name) is not None:
            return name
    return None


def write_statistics(ds, kind, stem) -> list:
    """Write the tidy table beside the results: ``<stem>.stats.csv`` (and ``.parquet`` when an engine imports).

    Each file atomically (``cwlidar_sim._atomic``).  Returns the paths written.
    """
    df = statistics_table(ds, kind)
    paths = [f"{stem}.stats.csv"]
    with atomic_open(paths[0], "w") as fh:
        df.to_csv(fh, index=False, na_rep="")
    engine = parquet_engine()
    if engine is not None:
        paths.append(f"{stem}.stats.parquet")
        with atomic_path(paths[1]) as tmp:
            df.to_parquet(tmp, engine=engine, index=False)
    return paths
