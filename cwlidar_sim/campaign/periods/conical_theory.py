"""The linear theory of a conical scene's lidar/cup standard-deviation ratio, beside its simulation or instead of it.

A conical scene (:mod:`cwlidar_sim.campaign.scenes.conical`) carries by
default (``[scan] theory`` unset, ``"continuum"`` or ``"lattice"``; not in
cycle mode), in every unit and in its summary,
``std_ratio_theory``, ``lidar_std_theory`` and ``cup_std_theory``: the
expected values of what the period measures, to first order in the
turbulence intensity, from the Mann tensor of the unit
(:mod:`cwlidar_sim.analysis.linear_theory`):

* the lidar: the VAD fit's u output of one revolution
  (:func:`cwlidar_sim.campaign.periods.theory.conical_functionals`: every
  estimate at its own azimuth and time, the scene's probe ``weighting``
  along each beam with the instrument's optics, the fit's weights), its
  ``sub_dwells`` looks per estimate merged into one look at their mean
  position and time with their summed weights (exact for a uniform wind; the looks lie
  within 1 m of each other); a scan of n revolutions is the mean of n
  successive one-revolution fits (checked against the n-revolution fit's own
  weights), so its spectrum is the one-revolution spectrum times
  ``|sum_m exp(i m k1 U T_rev)|^2 / n^2`` (:class:`~cwlidar_sim.analysis.linear_theory.PeriodStatistic`'s
  ``repeat``);
* the cup: u at the cup's position with its first-order response (time
  constant ``distance_constant / U``);
* the period: the spectra's expected sample variance about the period's own
  mean (:func:`cwlidar_sim.analysis.linear_theory.period_variance`: scans
  every ``n T_rev``, the cup at its rate, aliasing included), times
  ``N / (N - 1)`` (the simulation's ``ddof = 1``), over the period's duration.

The spectra are computed on an adaptive k1 grid
(:func:`cwlidar_sim.analysis.linear_theory.adaptive_spectra`: from
``N_START`` log-spaced k1 over ``K1_RANGE``, bisected where the
spline interpolation would move the cup's or a scan's period variance by
more than its share of ``TOL``), the plane quadrature at
``RESOLUTION``.  Convergence (``CONVERGENCE``; CS scene, 8 m/s, 600 s): the
tolerance divided by 4, twice the starting k1, twice the resolution and the
400 sub-dwell looks unmerged each move the 1- and 3-revolution std ratios by
less than 0.001 at 40 and 100 m (at most 3.5e-4, the unmerged looks at
40 m); at 100 m a fixed grid of 129 k1 gives 0.76533 / 0.76174 against the
adaptive grid's 0.76543 / 0.76180 from 31 k1.  Cost: 39 k1 at 40 m (2.9 s
of CPU), 31 at 100 m (2.4 s of CPU, 4.0 s of wall at load 3.6 on 2 cores:
benchmarks/bench_linear_theory.py).

The ratio is ``sqrt(E[s_lidar^2] / E[s_cup^2])``; the simulation averages
per-period ratios ``s_lidar / s_cup`` over periods (a second-order
difference).  The theory is the continuum (no box: its grid, size and the
sensors on nodes are the simulation's, not the theory's), frozen turbulence
(Taylor), the horizontal speed taken as U + u, no speckle, noise or
estimator (tier ``los``'s answer; the spectral and signal tiers differ from
it by those).  It depends on the tensor, the height, U, the wind direction,
the scan and the period's duration, not on the seed: it is computed once per
distinct set of these (cached within a process), the periods of one
template sharing it.

Interpolation in U: the std ratio depends on the tensor only through L and
Gamma (the variances are proportional to ``alpha_eps``), and smoothly on U.
Where a scene has many speeds, the units of one height, direction and
duration whose tensors share L and Gamma (a group, :func:`speed_ranges`)
share an interpolant instead of a computation each: :data:`U_NODES`
Chebyshev-Lobatto nodes in ln U over the group's speeds (cut into pieces at
most :data:`U_SPAN` wide), computed at ``alpha_eps = 1``; ln of each
standard deviation is interpolated and scaled by ``sqrt(alpha_eps)``
(:func:`interpolated_theory`).  It is used only where the group has more
distinct speeds than nodes (the CS scene's four speeds per height and
direction are computed each, as before).  Against the theory computed at
off-node speeds (:data:`U_INTERPOLATION`; 4-16 m/s, 600 s, both scans) it
moves the ratios by at most 1.5e-4 at 40 m (the adaptive grid's own jitter
between speeds: 4 nodes give 1.4e-4, 7 give 6e-5) and 2.7e-6 at 100 m;
stated as 2e-4 (tests/campaign/periods/test_conical_theory.py).  The unit's
``theory_u_nodes`` says how many nodes its values came from (0: its own U)
and the variables' ``theory_u`` attribute states the scheme and error.

Cost: one computation takes 2.4-3 s of CPU (about 6 s of wall at load 6 on
2 cores); it is cached per process, so the CS scene's 144 units need 24 (4
heights x 6 period templates: their speeds and directions): 66 s of CPU in
all, 4 % of the scene's simulation (tier spectral: 19, 12, 10 and 9 s of
CPU per unit at 40, 60, 80 and 100 m, about 1650 s for the 144).  The
lattice (``theory = "lattice"``) adds about 7 s of CPU per distinct unit at
100 m and is not interpolated (the box's length follows U).

``theory = "only"`` answers a tier-``los`` scene by the theory alone
(:func:`theory_rows`): the units hold the theory in the simulated variables'
places (``std_ratio``, ``lidar_std``, ``cup_std``; ``cup_mean`` = U), the
statistics the theory cannot give (TP, availability, directions, the mean
speed's bias: not linear, or not in the theory) are NaN, and
``attrs["answer"]`` says so.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time

import numpy as np

from ...analysis import linear_theory as lt
from . import theory as th
from .conical_simulation import _conical_lidar

__all__ = ["THEORY_VARS", "K1_RANGE", "N_START", "TOL", "RESOLUTION", "CONVERGENCE", "U_NODES", "U_SPAN", "U_INTERPOLATION",
           "unit_theory", "u_nodes", "interpolated_theory", "speed_ranges", "scene_theory", "theory_rows",
           "theory_attrs"]

#: The theory's variables: per scan length (``scan=True``) or per unit.
THEORY_VARS = {
    "std_ratio_theory": (True, "1", "linear theory of the lidar / cup {span} standard deviation"),
    "lidar_std_theory": (True, "m s-1", "linear theory of the lidar {span} standard deviation (VAD u)"),
    "cup_std_theory": (False, "m s-1", "linear theory of the cup {span} standard deviation"),
}
#: The adaptive k1 grid (:func:`cwlidar_sim.analysis.linear_theory.adaptive_spectra`): its span [rad/m], its
#: starting log-spaced k1 and the relative tolerance of each variance (module notes: convergence).
K1_RANGE = (1e-4, 1.0)
N_START = 9
TOL = 1e-3
#: The plane quadrature's ``resolution`` (module notes: convergence).
RESOLUTION = 20.0
#: What refining each numerical choice moves the std ratios by, CS scene at 8 m/s, 600 s
#: (benchmarks/bench_linear_theory.py, ``--unmerged``): per height [m] and choice, the largest move over the 1- and
#: 3-revolution scans (all < 0.001).
CONVERGENCE = {
    "40": {"tol / 4": 5e-6, "n_start x 2": 3.3e-5, "resolution x 2": 1e-6, "sub_dwells unmerged": 3.5e-4},
    "100": {"tol / 4": 8.7e-5, "n_start x 2": 1.3e-4, "resolution x 2": 1e-6, "sub_dwells unmerged": 2.8e-4},
}

#: The interpolant in U (module notes): Chebyshev-Lobatto nodes in ln U over a piece of a group's speeds at most
#: ``U_SPAN`` wide (max / min), used where a group (the scene's units sharing height, direction, duration and the
#: tensor's L and Gamma) has more distinct speeds than nodes.
U_NODES = 5
#: The widest piece of a group's speeds one interpolant spans (max / min; module notes).
U_SPAN = 4.0
#: What the interpolant moves the std ratios by against the theory at each U (module notes; largest over the 1- and
#: 3-revolution scans at off-node speeds, CS scene at 40 and 100 m, 600 s, U over [4, 16] m/s).
U_INTERPOLATION = {"nodes": U_NODES, "span": U_SPAN, "range_m_s": [4.0, 16.0], "max_error_std_ratio": 2e-4,
                   "measured": {"40": 1.5e-4, "100": 2.7e-6}}

#: This module's and the lattice's cache (:func:`~cwlidar_sim.campaign.periods.theory.cached` with ``store``): a few
#: numbers per entry, room for every distinct unit and interpolation node of a large scene (the shared cache keeps 32).
_CACHE: dict = {}
_CACHE_SIZE = 4096


def _merge_sub_dwells(vad, nsub: int):
    """The VAD's u output with each estimate's ``nsub`` looks merged into one (module notes)."""
    looks = vad.looks
    n_e = looks.n_looks // nsub
    p = looks.point_lc.reshape(n_e, nsub, 3).mean(axis=1)
    t = looks.time_l.reshape(n_e, nsub).mean(axis=1)
    n = looks.direction_lc.reshape(n_e, nsub, 3).mean(axis=1)
    n_unit = n / np.linalg.norm(n, axis=1, keepdims=True)
    w = vad.weight_olc[:1].reshape(1, n_e, nsub, 3).sum(axis=2)
    merged = lt.Looks(p, n_unit, t, looks.probe_l[0])
    return lt.LinearFunctional(merged, w, ["u"])


def _comb_ok(lidar, z, U, n_rev, one) -> bool:
    """Whether the ``n_rev`` fit is the mean of ``n_rev`` one-revolution fits (azimuths repeating each revolution)."""
    if n_rev == 1:
        return True
    many = th.conical_functionals(lidar, z, U, revolutions=n_rev)
    w = many.weight_olc[:1].reshape(1, n_rev, -1, 3)
    return bool(np.allclose(w * n_rev, one.weight_olc[:1][:, None], atol=1e-9, rtol=0.0))


def unit_theory(lidar, height: float, mean_speed: float, duration: float, params, scan_revs, cup) -> dict:
    """The theory of one unit's height (module notes), cached on what it depends on.

    Parameters
    ----------
    lidar : ConicalLidar
        In the field's frame (the mean wind along +x).
    height : float
        [m], one of ``lidar.heights``.
    mean_speed : float
        U [m/s].
    duration : float
        The period [s].
    params : MannParameters
    scan_revs : tuple of int
        Revolutions per VAD scan.
    cup : Cup
        The cup (its position, distance constant and rate).

    Returns
    -------
    dict
        ``cup_std`` [m/s] and ``scans``: per n, ``lidar_std`` [m/s] and ``std_ratio``; ``wall_s``.
    """
    key = (repr(lidar), float(height), float(mean_speed), float(duration), repr(params), tuple(scan_revs), repr(cup),
           N_START, TOL, K1_RANGE, RESOLUTION)
    return th.cached(key, lambda: _unit_theory(lidar, height, mean_speed, duration, params, scan_revs, cup),
                     store=_CACHE, size=_CACHE_SIZE)


def _unit_theory(lidar, height, mean_speed, duration, params, scan_revs, cup, merge: bool = True) -> dict:
    t0 = time.perf_counter()
    z, U, T = float(height), float(mean_speed), float(duration)
    vad, cupf = th.conical_functionals(lidar, z, U, revolutions=1, cup=cup)
    if merge:
        one = _merge_sub_dwells(vad, lidar.sub_dwells)
    else:
        one = lt.LinearFunctional(vad.looks, vad.weight_olc[:1], ["u"])
    dt_c = 1.0 / cup.rate
    n_c = int(round(T / dt_c))
    stats = [lt.PeriodStatistic("1.u", T, dt_c)]
    for n in scan_revs:
        if not _comb_ok(lidar, z, U, n, vad):
            raise ValueError(f"scan_revs {n}: the lidar's azimuths do not repeat each revolution; the theory "
                             f"takes an n-revolution fit as the mean of n one-revolution fits")
        dt = n * lidar.revolution_time
        stats.append(lt.PeriodStatistic("0.u", int(T // dt) * dt, dt,
                                        repeat=(n, lidar.revolution_time) if n > 1 else None))
    r = lt.adaptive_spectra(params, [one, cupf], U, stats, k1_range=K1_RANGE, n_start=N_START, tol=TOL,
                            resolution=RESOLUTION)
    var_c = r.within[0] * n_c / (n_c - 1)
    out = {"cup_std": math.sqrt(var_c), "scans": {}, "n_k1": int(r.spectra.k1_k.size),
           "grid_error": max(r.error), "converged": r.converged}
    for n, st, w in zip(scan_revs, stats[1:], r.within[1:]):
        n_s = int(round(st.period / st.sample_interval))
        var = w * n_s / (n_s - 1)
        out["scans"][n] = {"lidar_std": math.sqrt(var), "std_ratio": math.sqrt(var / var_c)}
    out["wall_s"] = time.perf_counter() - t0
    return out


def u_nodes(u_min: float, u_max: float, n: int | None = None) -> np.ndarray:
    """``n`` (default :data:`U_NODES`) Chebyshev-Lobatto nodes in ln U over ``[u_min, u_max]`` [m/s], increasing."""
    n = U_NODES if n is None else int(n)
    a, b = math.log(float(u_min)), math.log(float(u_max))
    x = -np.cos(np.pi * np.arange(n) / (n - 1))
    return np.exp(0.5 * (a + b) + 0.5 * (b - a) * x)


def _lobatto_interpolate(nodes, values, u: float) -> float:
    """The polynomial in ln U through ``values`` at the Chebyshev-Lobatto ``nodes``, at ``u`` (barycentric form)."""
    x = np.log(np.asarray(nodes, dtype=float))
    xu = math.log(float(u))
    d = xu - x
    hit = np.flatnonzero(np.abs(d) <= 1e-14 * max(1.0, abs(xu)))
    if hit.size:
        return float(values[hit[0]])
    w = (-1.0) ** np.arange(x.size)
    w[0] *= 0.5
    w[-1] *= 0.5
    q = w / d
    return float(np.dot(q, values) / q.sum())


def interpolated_theory(lidar, height: float, mean_speed: float, duration: float, params, scan_revs, cup,
                        u_range, n: int | None = None) -> dict:
    """:func:`unit_theory` at ``mean_speed`` from its values at :func:`u_nodes` over ``u_range`` (module notes).

    The nodes are computed at ``alpha_eps = 1`` (the variances are proportional to it; the ratios do not depend on
    it) and cached, so every unit of a group shares them; ln of each standard deviation is interpolated in ln U
    and scaled by ``sqrt(alpha_eps)``, the ratio taken from them.

    Returns
    -------
    dict
        As :func:`unit_theory`, with ``u_nodes`` [m/s].
    """
    nodes = u_nodes(u_range[0], u_range[1], n)
    unit = dataclasses.replace(params, alpha_eps=1.0)
    at = [unit_theory(lidar, height, float(u), duration, unit, scan_revs, cup) for u in nodes]
    amp = math.sqrt(float(params.alpha_eps))

    def interp(get):
        return amp * math.exp(_lobatto_interpolate(nodes, np.log([get(t) for t in at]), mean_speed))

    cup_std = interp(lambda t: t["cup_std"])
    out = {"cup_std": cup_std, "scans": {}, "n_k1": max(t["n_k1"] for t in at),
           "grid_error": max(t["grid_error"] for t in at), "converged": all(t["converged"] for t in at),
           "u_nodes": [float(u) for u in nodes], "wall_s": sum(t["wall_s"] for t in at)}
    for m in scan_revs:
        lid = interp(lambda t: t["scans"][m]["lidar_std"])
        out["scans"][m] = {"lidar_std": lid, "std_ratio": lid / cup_std}
    return out


def speed_ranges(scene) -> dict:
    """Per unit index, the speed range ``(lo, hi)`` [m/s] of its group where it is interpolated in U, else None.

    A group: the scene's units of one height, wind direction and period duration whose tensors share L and Gamma
    (the scene's ``turbulence.params(height, speed)``).  Its
    speeds are cut into pieces equally wide in ln U, each at most :data:`U_SPAN` wide, and it is interpolated (each
    unit in its piece's range) where it has more distinct speeds than the pieces' :data:`U_NODES` nodes in all
    (fewer are cheaper computed each).
    """
    key = ("u_groups", json.dumps(scene.as_dict(), sort_keys=True, default=str), U_NODES, U_SPAN)
    return th.cached(key, lambda: _speed_ranges(scene), store=_CACHE, size=_CACHE_SIZE)


def _speed_ranges(scene) -> dict:
    tensors, groups, member = {}, {}, {}
    for i, (p, z) in enumerate(scene.units()):
        U = float(p.mean_speed)
        if (z, U) not in tensors:
            tensors[z, U] = scene.turbulence.params(z, U)
        t = tensors[z, U]
        if t is None:
            continue
        g = (float(z), float(p.toward_deg), float(scene.period_duration(p)), float(t.length_scale), float(t.gamma))
        groups.setdefault(g, set()).add(U)
        member[i] = g
    out = {i: None for i in range(len(scene.units()))}
    units = scene.units()
    for i, g in member.items():
        lo, hi = min(groups[g]), max(groups[g])
        pieces = max(1, math.ceil(math.log(hi / lo) / math.log(U_SPAN) - 1e-9))
        if len(groups[g]) <= U_NODES * pieces:
            continue
        edges = np.exp(np.linspace(math.log(lo), math.log(hi), pieces + 1))
        edges[0], edges[-1] = lo, hi
        j = min(pieces - 1, int(np.searchsorted(edges, float(units[i][0].mean_speed), side="right")) - 1)
        out[i] = (float(edges[j]), float(edges[j + 1]))
    return out


def scene_theory(scene, index: int, tensor, lidar, height: float, cup) -> dict:
    """The theory of unit ``index``: :func:`unit_theory` at its U, or :func:`interpolated_theory` in its group."""
    p, _ = scene.units()[index]
    U, T = float(p.mean_speed), scene.period_duration(p)
    span = speed_ranges(scene)[index]
    if span is None:
        return unit_theory(lidar, height, U, T, tensor, scene.scan.scan_revs, cup)
    return interpolated_theory(lidar, height, U, T, tensor, scene.scan.scan_revs, cup, span)


def theory_attrs(lidar, params) -> dict:
    """The theory variables' attributes: what the theory is, its weighting, tensor, box and numerics."""
    return {"theory": "linear (first order in the turbulence intensity), frozen turbulence, tier los (no speckle, "
                      "noise or estimator); campaign.periods.conical_theory",
            "theory_box": "continuum (no box)",
            "theory_weighting": str(lidar.weighting),
            "theory_tensor": json.dumps(params.as_dict()),
            "theory_numerics": json.dumps({"k1": "adaptive (analysis.linear_theory.adaptive_spectra)",
                                           "k1_range": list(K1_RANGE), "n_start": N_START, "tol": TOL,
                                           "resolution": RESOLUTION, "sub_dwells": "merged",
                                           "convergence": CONVERGENCE}),
            "theory_u": ("at each unit's own U, or, where theory_u_nodes > 0, interpolated in ln U between that many "
                         "Chebyshev-Lobatto nodes over the speeds of the scene's units sharing its height, direction, "
                         "duration, L and Gamma (campaign.periods.conical_theory.interpolated_theory): "
                         + json.dumps(U_INTERPOLATION))}


def scene_lidar(scene, index: int, spacing: float):
    """Unit ``index``'s lidar in the field's frame (as the simulation builds it) and its height."""
    p, z = scene.units()[index]
    kw = scene.lidar_fields(spacing)
    tier, sub = kw.pop("tier"), kw.pop("sub_dwells")
    cell = kw.pop("cell_length")
    return _conical_lidar((z,), tier, cell, sub, kw, p.toward_deg), z


def theory_rows(scene, index: int, tensor, su, ustar) -> list:
    """Unit ``index`` answered by the theory alone (``theory = "only"``): one row as the simulation's dict holds it."""
    from ...sensors import Cup

    p, z = scene.units()[index]
    lidar, z = scene_lidar(scene, index, 1.0)
    U = float(p.mean_speed)
    cup = Cup(position=(0.0, 0.0, z))
    t = scene_theory(scene, index, tensor, lidar, z, cup)
    nan = math.nan
    row = {"height": z, "params": tensor.as_dict(), "u_star": ustar, "sigma_u_target": su,
           "in_situ_position": (0.0, 0.0, z), "cup_mean": U, "cup_std": t["cup_std"], "sonic_std": nan,
           "sonic_radial_variance": nan, "availability": nan, "zero_crossing_loss": nan,
           "second_peak_fraction": nan, "cloud_fraction": nan, "sonic_direction": nan,
           "cost_s": {"theory": t["wall_s"]}, "theory": t, "theory_attrs": theory_attrs(lidar, tensor),
           "answer": "theory", "scans": {}}
    for n, sc in t["scans"].items():
        row["scans"][n] = {"lidar_std": sc["lidar_std"], "std_ratio": sc["std_ratio"], "selected": 1.0,
                           "l_az": nan}
    return [row]


def add_theory(rows, scene, index: int, tensor, lidar_fields_spacing: float) -> None:
    """Put the theory of unit ``index`` (dwell mode) into its simulated ``rows`` (``theory = "continuum"``)."""
    from ...sensors import Cup

    lidar, z = scene_lidar(scene, index, lidar_fields_spacing)
    for r in rows:
        cup = Cup(position=(0.0, 0.0, z))
        r["theory"] = scene_theory(scene, index, tensor, lidar, z, cup)
        r["theory_attrs"] = theory_attrs(lidar, tensor)
