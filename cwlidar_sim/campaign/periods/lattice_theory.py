"""The lattice theory of a conical unit: its lidar/cup standard-deviation ratio as the unit's own box holds it.

Beside the continuum theory (:mod:`cwlidar_sim.campaign.periods.conical_theory`,
``std_ratio_theory`` ...), every unit of a conical scene with ``[scan]
theory = "lattice"`` also carries ``std_ratio_theory_lattice``, ``lidar_std_theory_lattice`` and
``cup_std_theory_lattice``: the same statistics, to first order in the
turbulence intensity, over the boxes the simulation draws for that unit --
the sum over the box's own modes
(:func:`cwlidar_sim.analysis.linear_theory.lattice_spectra`: its generated
shape, before the lateral doubling's crop, its spacing, its cell correction
and Nyquist modes), read as the simulation reads it:

* the lidar: the continuum theory's functional (the VAD fit's u of one
  revolution, sub-dwells merged, the scene's weighting) through the sampler's
  trilinear interpolation (``interpolation="linear"``, ``aliases=0``: the
  gains ``sinc^2(k d / 2)`` per axis; the aliases beyond move the lidar's
  variance by about 2e-5, studies/theory_vs_simulation.py); an n-revolution
  scan the mean of n one-revolution fits (the continuum's comb, on the lines);
* the cup: u at its node (the simulation puts it on the nearest node across
  the wind) read between the nodes along x as the box is advected past it,
  on its samples, through its response
  (:func:`~cwlidar_sim.campaign.periods.theory.node_interpolated_variance`);
* the period: each line's expected sample variance about the period's mean
  (:func:`~cwlidar_sim.analysis.linear_theory.period_variance` with
  ``lines=True``), times ``N / (N - 1)``.

``*_theory_lattice - *_theory`` is what the box (grid, size, lateral
doubling, sensors between nodes) moves each statistic by against the
continuum.

Numerics (:data:`DENSE_ROWS`, :data:`ROW_RATIO`): the lidar's lines are
computed on every row up to ``DENSE_ROWS`` and on rows a factor
``ROW_RATIO`` apart above (each rounded to the box's own row), the rest
interpolated log-log between them (the lidar's spectrum is smooth in k1 on
that scale: its features lie ~45 rows apart at the CS scene's 100 m); against
every row this moves the CS scene's ratios by 9e-5 and the lidar's sigma by
1.2e-4 (600-s periods: 40 m, 66 rows of 1250; 100 m, 58 of 562; 1e-5 for a
60-s box at 40 m: tests/campaign/periods/test_lattice_theory.py), stated as
1e-4.  One height of the CS scene's 600-s periods costs about 20 s on 2
loaded cores (100 m: 22 s against 247 s for every row; 40 m: 19 s against
664 s).  The box's effect there (lattice minus continuum, 1-s / 3-s scans):
+0.0009 / +0.0022 at 40 m, +0.0059 / +0.0065 at 100 m.  The fused kernel runs for the focused beam's
exact weighting (its table is checked where the box's wavenumbers reach).  Not for a box read from a file
or conditioned on records (no ensemble of Mann boxes): the variables are then
NaN and their attributes say why.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ...analysis import linear_theory as lt
from . import theory as th
from .conical_theory import _CACHE, _CACHE_SIZE, _merge_sub_dwells

__all__ = ["LATTICE_VARS", "DENSE_ROWS", "ROW_RATIO", "sparse_rows", "unit_lattice_theory", "add_lattice_theory",
           "unit_variables"]

#: The lattice variables: per scan length (``True``) or per unit, units, long name.
LATTICE_VARS = {
    "std_ratio_theory_lattice": (True, "1", "linear theory of the lidar / cup {span} standard deviation, "
                                            "over the unit's box (lattice)"),
    "lidar_std_theory_lattice": (True, "m s-1", "linear theory of the lidar {span} standard deviation (VAD u), "
                                                "over the unit's box (lattice)"),
    "cup_std_theory_lattice": (False, "m s-1", "linear theory of the cup {span} standard deviation, over the "
                                               "unit's box (lattice)"),
}
#: Rows of the lidar's lines computed one by one (module notes).
DENSE_ROWS = 24
#: Ratio between successive computed rows above DENSE_ROWS (module notes).
ROW_RATIO = 1.1


def sparse_rows(n_rows: int, dense: int | None = None, ratio: float | None = None) -> np.ndarray:
    """Every row from 1 to ``dense``, then rows about ``ratio`` apart up to ``n_rows`` (included), increasing.

    Defaults: :data:`DENSE_ROWS` and :data:`ROW_RATIO`.
    """
    n_rows = int(n_rows)
    dense = DENSE_ROWS if dense is None else int(dense)
    ratio = ROW_RATIO if ratio is None else float(ratio)
    r = list(range(1, min(dense, n_rows) + 1))
    x = float(r[-1])
    while x < n_rows:
        x *= ratio
        r.append(min(n_rows, int(round(x))))
    return np.unique(np.array(r, dtype=np.int64))


def _fill(k_c, F_c, k_all):
    """Log-log interpolation of positive densities ``F_c`` on ``k_c`` at ``k_all`` (both increasing, same ends)."""
    lf = np.log(np.maximum(F_c, 1e-300))
    return np.exp(np.interp(np.log(k_all), np.log(k_c), lf))


def unit_lattice_theory(lidar, height: float, mean_speed: float, duration: float, params, scan_revs, cup, shape,
                        spacing, *, hf_compensation: bool = False, all_rows: bool = False,
                        probe: str = "continuous") -> dict:
    """The lattice theory of one unit's height over its box (module notes), cached on what it depends on.

    Parameters
    ----------
    lidar, height, mean_speed, duration, params, scan_revs
        As for :func:`~cwlidar_sim.campaign.periods.conical_theory.unit_theory`.
    cup : Cup
        The cup, on a node of the box across the wind.
    shape : (N1, N2, N3)
        The generated box's shape (laterally doubled where the simulation doubles it).
    spacing : (dx, dy, dz)
        Its spacing [m].
    hf_compensation : bool
        The box's high-frequency compensation.
    all_rows : bool
        Every row of the lidar's lines computed (the reference of the tests), not :func:`sparse_rows`.
    probe : {"continuous", "cells"}
        The beams' weighting as the continuum theory takes it (the results': their difference is then the
        box's alone) or the simulation's range cells (:func:`~cwlidar_sim.campaign.periods.theory.conical_functionals`).

    Returns
    -------
    dict
        ``cup_std`` [m/s], ``scans`` (per n: ``lidar_std`` [m/s], ``std_ratio``), ``wall_s``, ``rows`` (computed).
    """
    key = ("lattice", repr(lidar), float(height), float(mean_speed), float(duration), repr(params),
           tuple(scan_revs), repr(cup), tuple(int(n) for n in shape), tuple(float(d) for d in spacing),
           bool(hf_compensation), bool(all_rows), str(probe), DENSE_ROWS, ROW_RATIO)
    return th.cached(key, lambda: _unit_lattice_theory(lidar, height, mean_speed, duration, params, scan_revs, cup,
                                                       shape, spacing, hf_compensation, all_rows, probe),
                     store=_CACHE, size=_CACHE_SIZE)


def _unit_lattice_theory(lidar, height, mean_speed, duration, params, scan_revs, cup, shape, spacing,
                         hf_compensation, all_rows, probe) -> dict:
    t0 = time.perf_counter()
    z, U, T = float(height), float(mean_speed), float(duration)
    shape, spacing = tuple(int(n) for n in shape), tuple(float(d) for d in spacing)
    vad = th.conical_functionals(lidar, z, U, revolutions=1, probe=probe)
    one = _merge_sub_dwells(vad, lidar.sub_dwells)
    n_rows = shape[0] // 2
    rows = np.arange(1, n_rows + 1) if all_rows else sparse_rows(n_rows)
    kw = dict(correction="cell", hf_compensation=hf_compensation)
    s = lt.lattice_spectra(params, one, U, shape, spacing, rows=rows, interpolation="linear", aliases=0, **kw)
    dk1 = 2.0 * math.pi / (shape[0] * spacing[0])
    k_all = dk1 * np.arange(1, n_rows + 1)
    F = _fill(s.k1_k, s.spectrum("u"), k_all)
    # the cup: u on its node (the same rows), read between the nodes along x on its samples
    point = lt.lattice_spectra(params, lt.point_functional(cup.position, ("u",)), U, shape, spacing, rows=rows, **kw)
    t_c = cup.times(T)
    var_c = th.node_interpolated_variance(k_all, _fill(point.k1_k, point.spectrum("u"), k_all) * dk1, U, t_c,
                                          spacing[0], distance_constant=cup.distance_constant)
    var_c *= t_c.size / (t_c.size - 1)
    out = {"cup_std": math.sqrt(var_c), "scans": {}, "rows": int(rows.size)}
    for n in scan_revs:
        dt = n * lidar.revolution_time
        n_s = int(T // dt)
        # each scan the mean of n one-revolution fits: the comb |sum_m exp(i m k1 U T_rev)|^2 / n^2, exact on lines
        var = lt.period_variance(k_all, F, U, n_s * dt, sample_interval=dt, lines=True,
                                 repeat=(n, lidar.revolution_time))["within"] * n_s / (n_s - 1)
        out["scans"][n] = {"lidar_std": math.sqrt(var), "std_ratio": math.sqrt(var / var_c)}
    out["wall_s"] = time.perf_counter() - t0
    return out


def lattice_attrs(shape, spacing, lateral_doubling, hf_compensation, rows=None, reason=None) -> dict:
    """The lattice variables' attributes: the box (shape, spacing, correction, doubling) and the numerics."""
    if reason is not None:
        return {"theory_box": f"lattice: not computed ({reason})"}
    return {"theory_box": (f"lattice: the unit's box {'x'.join(map(str, shape))} at "
                           f"{'/'.join(f'{d:g}' for d in spacing)} m (generated"
                           f"{', laterally doubled' if lateral_doubling else ''}), cell correction, "
                           f"hf_compensation {bool(hf_compensation)}; the lidar read trilinearly, the cup between "
                           f"the nodes along x; campaign.periods.lattice_theory"),
            "theory_lattice_numerics": json.dumps({"rows_dense": DENSE_ROWS, "row_ratio": ROW_RATIO,
                                                   "rows_computed": rows, "aliases": 0,
                                                   "accuracy_ratio": 1e-4})}


def add_lattice_theory(rows, scene, index: int, tensor, lidar_fields_spacing: float, *, box_options=None,
                       condition=None) -> None:
    """Put the lattice theory of unit ``index`` (dwell mode) beside its continuum theory in its simulated ``rows``."""
    from ...sensors import Cup
    from .conical_theory import scene_lidar

    p, _ = scene.units()[index]
    lidar, z = scene_lidar(scene, index, lidar_fields_spacing)
    hf = bool((box_options or {}).get("hf_compensation", False))
    for r in rows:
        ny = r["box_shape"][1] * (2 if r["lateral_doubling"] else 1)
        shape = (r["box_shape"][0], ny, r["box_shape"][2])
        reason = None
        if condition is not None or scene.turbulence.field_source(scene.base_dir) is not None:
            reason = "a box conditioned on records or read from a file is not the Mann lattice's ensemble"
        if reason is not None:
            r["theory_lattice"] = None
            r["theory_lattice_attrs"] = lattice_attrs(shape, r["box_spacing"], r["lateral_doubling"], hf,
                                                      reason=reason)
            continue
        cup = Cup(position=tuple(float(c) for c in r["in_situ_position"]))
        t = unit_lattice_theory(lidar, z, float(p.mean_speed), scene.period_duration(p), tensor,
                                scene.scan.scan_revs, cup, shape, r["box_spacing"], hf_compensation=hf)
        r["theory_lattice"] = t
        r["theory_lattice_attrs"] = lattice_attrs(shape, r["box_spacing"], r["lateral_doubling"], hf, t["rows"])


def unit_variables(rows, revs, span: str) -> dict:
    """The lattice variables of a unit's Dataset (``{name: (dims, values, attrs)}``); empty without the theory."""
    if "theory_lattice_attrs" not in rows[0]:
        return {}
    dv = {}
    # the continuum's description of the functional and tensor (not its k1 grid: the lattice sums the box's lines)
    same = {k: v for k, v in rows[0].get("theory_attrs", {}).items() if k not in ("theory_numerics", "theory_u")}
    for key, (per_scan, units, long) in LATTICE_VARS.items():
        name = key[:-len("_theory_lattice")]
        vals = []
        for r in rows:
            t = r["theory_lattice"]
            if t is None:
                vals.append([math.nan] * len(revs) if per_scan else math.nan)
            else:
                vals.append([t["scans"][n][name] for n in revs] if per_scan else t[name])
        dv[key] = ((("period", "scan_s") if per_scan else ("period",)), np.array(vals, dtype=float),
                   {"units": units, "long_name": long.format(span=span), **same,
                    **rows[0]["theory_lattice_attrs"]})
    return dv
