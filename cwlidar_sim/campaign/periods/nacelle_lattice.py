"""The nacelle lidar's lattice theory: its std ratio and correlation as the period's own box holds them.

Beside the continuum theory (:mod:`cwlidar_sim.campaign.periods.nacelle_theory`,
``std_ratio_theory`` ...), every frozen period of a nacelle scene whose box
is generated also carries ``lidar_std_theory_lattice``,
``rotor_std_theory_lattice``, ``std_ratio_theory_lattice`` and
``correlation_theory_lattice``: the same statistics over the boxes the
simulation draws for that period -- the sum over the box's own modes
(:func:`cwlidar_sim.analysis.linear_theory.lattice_spectra`: its generated
shape, before the lateral doubling's crop, its spacing, its cell
correction and Nyquist modes), read as the simulation reads it:

* the lidar: the simulation's own looks (``sub_dwells`` per dwell, their
  azimuths and times), its range cells, ``u = los / m_x`` averaged over the
  revolution, shifted by the pairing's whole-sample delay, ``THEORY_PHASES``
  scan phases averaged (:func:`~cwlidar_sim.campaign.periods.theory.nacelle_functionals`),
  read through the sampler's trilinear interpolation (``aliases=0``: the
  gains ``sinc^2(k d / 2)`` per axis; the aliases beyond move the lidar's
  variance by about 1.2e-4, studies/theory_vs_simulation.py);
* the rotor: the box's own nodes in the disc with the REWS weights
  (:func:`~cwlidar_sim.analysis.rews.rotor_node_weights`, as
  :func:`~cwlidar_sim.analysis.rews.rews_from_box` takes them), read
  linearly along x as the box is advected past the rotor plane;
* the period: each line's expected within-period (co)variance of the
  paired span sampled every dwell
  (:func:`~cwlidar_sim.analysis.linear_theory.period_variance`, ``lines=True``, 1/N).

The correlation is the plain lattice's (no interpolation: the lidar's
trilinear reading is an expectation over the box's offset across the
wind, the rotor's nodes are on the grid, so their cross has no single
interpolation): its covariance half the sum of the lidar's and the rotor's
variances less their difference's (positive, so interpolated like them).
``*_theory_lattice - *_theory`` is what the box (grid, size, lateral
doubling, sensors between nodes) moves each statistic by against the
continuum.  Bundled scene, frozen period, 600 s (box 1920 x 88 x 44 at 4 m,
laterally doubled): see :data:`BUNDLED` for the values and the cost.

Numerics: the lines computed on :func:`~cwlidar_sim.campaign.periods.lattice_theory.sparse_rows`
(every row up to ``DENSE_ROWS``, then a factor ``ROW_RATIO`` apart) and
interpolated log-log between them, as the conical lattice: against every
row (bundled scene, 100 m, 600 s: 63 of 960 rows, about 16 s of CPU per
focus against 226 s) the std ratio moves by 8e-6, the correlation by
1.2e-5, the stds by 1e-5.  The 60-s box of the acceptance study
(studies/theory_vs_simulation.py, 240 x 70 x 35) gives the std ratio 1.1543
and the correlation 0.9050 at 100 m (tests/campaign/periods/test_nacelle_lattice.py).  Not for an
evolving period (the lattice theory is frozen), a box read from a file (no
ensemble of Mann boxes), a moving platform or a paired span shorter than two
revolutions: the variables are then NaN and their attributes say why.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from ...analysis import linear_theory as lt
from ...analysis.rews import RotorDisc, rotor_node_weights
from . import theory as th
from .lattice_theory import DENSE_ROWS, ROW_RATIO, _fill, sparse_rows
from .nacelle_theory import THEORY_PHASES

__all__ = ["nacelle_lattice", "lattice_statistics", "box_rotor_nodes", "period_lattice", "lattice_attrs",
           "LATTICE_VARS", "BUNDLED"]

#: The lattice variables: units and long name.
LATTICE_VARS = {
    "lidar_std_theory_lattice": ("m s-1", "lidar_std, linear theory over the period's box (lattice)"),
    "rotor_std_theory_lattice": ("m s-1", "rotor_std, linear theory over the period's box (lattice)"),
    "std_ratio_theory_lattice": ("1", "std_ratio, linear theory over the period's box (lattice)"),
    "correlation_theory_lattice": ("1", "correlation, linear theory over the period's box (lattice, plain: module "
                                        "notes)"),
}
#: Bundled scene's frozen period (600 s) at 100 m: lattice and continuum, and the lattice's cost (module notes).
BUNDLED = {"box": (1920, 88, 44), "rows": 63, "cpu_s_per_focus": 16.0, "cpu_s_every_row": 226.0,
           "every_row_moves": {"std_ratio": 7.6e-6, "correlation": -1.2e-5, "lidar_std": 9.5e-6},
           "lattice - continuum": {"50": {"std_ratio": -0.0029, "correlation": -0.0110, "lidar_std": -0.0085,
                                          "rotor_std": -0.0049},
                                   "100": {"std_ratio": -0.0041, "correlation": -0.0050, "lidar_std": -0.0086,
                                           "rotor_std": -0.0047},
                                   "150": {"std_ratio": -0.0002, "correlation": -0.0007, "lidar_std": -0.0044,
                                           "rotor_std": -0.0045}}}

_CACHE: dict = {}


def box_rotor_nodes(rotor_radius: float, rotor_exponent: float, y_y, z_z, hub_y: float, hub_z: float) -> tuple:
    """The rotor's nodes ``(y_n, z_n, w_n)`` relative to the hub [m]: the box's grid nodes in the disc, REWS weights.

    ``y_y``, ``z_z``: the box's node coordinates [m]; ``(hub_y, hub_z)``: the hub's [m].
    """
    y, z = np.asarray(y_y, dtype=float), np.asarray(z_z, dtype=float)
    w = rotor_node_weights(RotorDisc(rotor_radius, rotor_exponent), y, z, hub_y, hub_z)
    Y, Z = np.meshgrid(y - hub_y, z - hub_z, indexing="ij")
    keep = w > 0
    return Y[keep], Z[keep], w[keep] / w[keep].sum()


def nacelle_lattice(lidar, focus: float, params, mean_speed: float, period: float, nodes, shape, spacing, *,
                    preview_shift: float, phases: int = THEORY_PHASES, hf_compensation: bool = False,
                    interpolation: str = "linear", aliases: int = 0, all_rows: bool = False) -> dict:
    """The lattice theory of a nacelle focus's paired series over a box (module notes).

    Parameters
    ----------
    lidar : NacelleLidar
        The lidar at tier ``los`` (:class:`cwlidar_sim.sensors.NacelleLidar`), its ``position`` relative to the hub.
    focus : float
        One of ``lidar.focus_distances`` [m].
    params : MannParameters
    mean_speed : float
        U [m/s].
    period : float
        The paired series' span [s] (samples every dwell).
    nodes : (y_n, z_n, w_n)
        The rotor's nodes relative to the hub [m] and weights (:func:`box_rotor_nodes`).
    shape : (N1, N2, N3)
        The generated box's shape (laterally doubled where the simulation doubles it).
    spacing : (dx, dy, dz)
        Its spacing [m].
    preview_shift : float
        The pairing's delay [s].
    phases : int
        Scan phases averaged, >= 1.
    hf_compensation : bool
        The box's high-frequency compensation.
    interpolation : {"linear", "none"}
        The variances' reading of the box: the sampler's (the lidar trilinear, the rotor linear along x) or the
        plain lattice's.
    aliases : int
        Aliases per interpolated axis (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`).
    all_rows : bool
        Every row computed, not :func:`~cwlidar_sim.campaign.periods.lattice_theory.sparse_rows`.

    Returns
    -------
    dict
        ``lidar_std``, ``rotor_std`` [m/s], ``std_ratio``, ``correlation`` [-], ``lidar_var``, ``rotor_var``,
        ``covariance`` [m^2 s^-2] (the plain lattice's), ``rows`` (computed), ``wall_s``.
    """
    t0 = time.perf_counter()
    U = float(mean_speed)
    epr = lidar.estimates_per_rev
    ests = []
    for j in range(phases):
        rotor, est = th.nacelle_functionals(lidar, focus, U, nodes, n_beams=None, preview_shift=preview_shift,
                                            probe="cells", phase=(j * epr) // phases)
        ests.append(est)
    out = lattice_statistics(params, rotor, ests, U, period, lidar.dwell_time, shape, spacing,
                             hf_compensation=hf_compensation, interpolation=interpolation, aliases=aliases,
                             all_rows=all_rows)
    return dict(out, wall_s=time.perf_counter() - t0)


def lattice_statistics(params, rotor, lidars, mean_speed: float, period: float, sample_interval: float, shape,
                       spacing, *, hf_compensation: bool = False, interpolation: str = "linear", aliases: int = 0,
                       all_rows: bool = False) -> dict:
    """The paired series' within-period statistics over a box, from the rotor's and the lidar phases' functionals.

    ``rotor``: the rotor's :class:`~cwlidar_sim.analysis.linear_theory.LinearFunctional` (its nodes on the box's
    grid across the wind); ``lidars``: one functional per scan phase (the lidar's variance their mean);
    ``sample_interval``: the series' [s]; the rest and the result as :func:`nacelle_lattice` (without ``wall_s``).
    """
    U, T, dt = float(mean_speed), float(period), float(sample_interval)
    shape, spacing = tuple(int(n) for n in shape), tuple(float(d) for d in spacing)
    phases = len(lidars)
    n_rows = shape[0] // 2
    rows = np.arange(1, n_rows + 1) if all_rows else sparse_rows(n_rows)
    k_all = 2.0 * math.pi / (shape[0] * spacing[0]) * np.arange(1, n_rows + 1)

    def within(k, F):
        F = F if all_rows else _fill(k, F, k_all)
        return lt.period_variance(k_all, F, U, T, sample_interval=dt, lines=True)["within"]

    kw = dict(rows=rows, correction="cell", hf_compensation=hf_compensation)
    lids = [f"{j + 1}.lidar" for j in range(phases)]
    plain = lt.lattice_spectra(params, [rotor] + list(lidars), U, shape, spacing, **kw)
    k, F_r = plain.k1_k, plain.spectrum("0.rotor")
    vr = within(k, F_r)
    vl = float(np.mean([within(k, plain.spectrum(a)) for a in lids]))
    # the covariance from the lidar less the rotor (its spectrum >= 0, interpolated log-log like theirs)
    vd = float(np.mean([within(k, plain.spectrum(a) + F_r - 2.0 * plain.cross(a, "0.rotor").real) for a in lids]))
    cov = 0.5 * (vl + vr - vd)
    corr = cov / math.sqrt(vl * vr)
    if interpolation != "none":
        s_l = lt.lattice_spectra(params, list(lidars), U, shape, spacing, interpolation=interpolation,
                                 aliases=aliases, **kw)
        vl = float(np.mean([within(s_l.k1_k, s_l.spectrum(f"{j}.lidar" if phases > 1 else "lidar"))
                            for j in range(phases)]))
        s_r = lt.lattice_spectra(params, rotor, U, shape, spacing, interpolation=(interpolation, "none", "none"),
                                 aliases=aliases, **kw)
        vr = within(s_r.k1_k, s_r.spectrum("rotor"))
    return {"lidar_var": vl, "rotor_var": vr, "covariance": cov, "lidar_std": math.sqrt(vl), "rotor_std": math.sqrt(vr),
            "std_ratio": math.sqrt(vl / vr), "correlation": corr, "rows": int(rows.size)}


def _reason(scene, period, lidar, span):
    """Why a period has no lattice theory (None: it has one)."""
    if period.lifetime is not None:
        return "evolving turbulence: the lattice theory is frozen"
    if scene.turbulence.field_source(scene.base_dir) is not None:
        return "a box read from a file is not the Mann lattice's ensemble"
    if lidar.motion is not None:
        return "a moving platform"
    if span < 2 * lidar.revolution_time:
        return "a paired span shorter than two revolutions"
    return None


def period_lattice(scene, period, focus: float, span: float, delay: float, grid) -> dict:
    """:func:`nacelle_lattice` of a scene's period at one focus over its box, once per geometry in a process.

    ``grid``: the rotor's box (``generated_shape``, ``spacing`` (dx, dy, dz) [m], ``y``, ``z`` node coordinates
    [m], ``lateral_doubling``; :func:`cwlidar_sim.campaign.periods.nacelle.period_records`'s ``info``).  Returns the
    statistics (NaN where not taken) and ``attrs``.
    """
    lid = scene.sensor(period, (focus,)).replace(tier="los")
    s = scene.scan
    shape, spacing = tuple(int(n) for n in grid["generated_shape"]), tuple(float(d) for d in grid["spacing"])
    reason = _reason(scene, period, lid, span)
    if reason is not None:
        out = dict.fromkeys(("lidar_std", "rotor_std", "std_ratio", "correlation"), math.nan)
        return dict(out, attrs=lattice_attrs(shape, spacing, grid["lateral_doubling"], reason=reason))
    pos = lid.position
    nodes = box_rotor_nodes(s.rotor_radius, s.rotor_exponent, grid["y"], grid["z"], pos[1], pos[2])
    params, U = scene.period_params(period), period.mean_speed
    lid0 = lid.replace(position=(0.0, 0.0, 0.0))
    key = ("nacelle_lattice", repr(lid0), focus, repr(params), U, round(span, 9), round(delay, 9), shape, spacing,
           tuple(np.round(nodes[0], 9)), tuple(np.round(nodes[1], 9)), s.rotor_exponent, DENSE_ROWS, ROW_RATIO)
    t = th.cached(key, lambda: nacelle_lattice(lid0, focus, params, U, span, nodes, shape, spacing,
                                               preview_shift=delay), store=_CACHE, size=16)
    return dict(t, attrs=lattice_attrs(shape, spacing, grid["lateral_doubling"], rows=t["rows"]))


def lattice_attrs(shape, spacing, lateral_doubling, rows=None, reason=None) -> dict:
    """The lattice variables' attributes: the box (shape, spacing, correction, doubling) and the numerics."""
    if reason is not None:
        return {"theory_box": f"lattice: not computed ({reason})"}
    return {"theory": "general linear theory over the period's box (cwlidar_sim.campaign.periods.nacelle_lattice): "
                      "the simulation's looks (sub_dwells per dwell) and range cells at tier los, u = los / m_x "
                      f"averaged over the revolution, {THEORY_PHASES} scan phases averaged, shifted by the pairing's "
                      "delay; the rotor on the box's nodes in the disc (REWS weights); within-period variances of "
                      "the paired span sampled every dwell (period_variance on the box's lines, 1/N)",
            "theory_box": (f"lattice: the period's box {'x'.join(map(str, shape))} at "
                           f"{'/'.join(f'{d:g}' for d in spacing)} m (generated"
                           f"{', laterally doubled' if lateral_doubling else ''}), cell correction, "
                           "hf_compensation False; the lidar read trilinearly, the rotor linearly along x; the "
                           "correlation the plain lattice's (no interpolation)"),
            "theory_lattice_numerics": json.dumps({"rows_dense": DENSE_ROWS, "row_ratio": ROW_RATIO,
                                                   "rows_computed": rows, "aliases": 0})}
