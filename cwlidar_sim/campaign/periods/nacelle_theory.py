"""The nacelle lidar's linear theory beside its simulation: the general module's std ratio and correlation.

For each focus of a nacelle period, :func:`nacelle_theory` gives what the
period's paired series -- the lidar's trailing revolution mean and the
rotor's REWS the preview later (:mod:`cwlidar_sim.campaign.periods.nacelle`)
-- should show within the period, from
:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra` (frozen Mann
continuum) of the functionals of
:func:`~cwlidar_sim.campaign.periods.theory.nacelle_functionals`:

* the lidar: the simulation's own looks (``n_beams=None``: every estimate of
  one revolution, their azimuths and times, ``u = los / m_x``), each look's
  probe the simulation's range cells at tier ``los`` (``probe="cells"``: the
  span and the mean-wind tail, which carries no fluctuation), shifted by the
  pairing's whole-sample preview delay;
* the rotor: the disc's REWS weight (``(r / R)^p`` per area) on polar nodes
  (:func:`~cwlidar_sim.campaign.periods.scanner_theory.rotor_disc_nodes`);
* the series' within-period (co)variances
  (:func:`~cwlidar_sim.analysis.linear_theory.period_variance`: samples every
  dwell over the paired span, its mean removed, 1/N), their stds, std ratio
  and correlation coefficient.

The trailing revolution mean at full rate is cyclostationary (the newest
look moves round the circle): its spectra are averaged over scan phases,
here two half a revolution apart (on the bundled scene at 100 m the lattice
theory's lidar variance over 10 phases swings by +/- 0.75 % with one cycle
per revolution; two opposite phases give its average within 2e-4, the std
ratio within 1e-4; the phase-0 functional alone reads the ratio 0.004 high).

Numerics: the spectra on the adaptive k1 grid
(:func:`~cwlidar_sim.analysis.linear_theory.adaptive_spectra`: ``N_START``
log-spaced k1 from ``K1_RANGE[0]`` of the period's first harmonic to
``K1_RANGE[1]`` of the revolution's -- above it the revolution mean's zeros;
the spectra's last power law carries the rest -- bisected until the rotor's,
each phase's lidar and each phase's lidar-less-rotor within-period variance
is settled to ``TOL``; the covariance is half the sum of the parts' less the
difference's, the difference being small where the two are coherent), the
polar quadrature at ``THEORY_RESOLUTION``, one look per dwell at its
mid-azimuth (the simulation's ``sub_dwells`` looks sweep 7.2 deg), the
rotor on ``THEORY_ROTOR_NODES`` polar nodes for the covariance and its
variance from the disc's closed-form transfer (``2 J1(kappa R) / (kappa R)``
for p = 0: :func:`~cwlidar_sim.analysis.rews_theory.rotor_spectrum` on the
same k1): polar nodes alias in azimuth (8 x 24 read the rotor's std
0.08 % high at 100 m, 24 x 72 0.002 %; 12 x 36 and 16 x 48 scatter with the
k1 grid and the plane quadrature's resolution, 16 x 48 by +13 % at
resolution 40), which the covariance, weighted by the lidar's transfer,
hardly sees.  Convergence (``CONVERGENCE``; bundled
scene, 100 m, 600 s; studies/nacelle_theory_convergence.py): the tolerance
/ 4, twice the starting k1, twice the resolution, the grid's top x 3, four
phases, the lidar's own two sub-dwell looks, and 16 x 48 or 24 x 72 rotor
nodes each move the std ratio and the correlation by less than 1e-4 (at most
7.8e-5, the correlation at 24 x 72 nodes); a fixed grid of 161 k1 agrees
within 2e-5.  Not converged in that sense: 12 x 36 rotor nodes move the
correlation by +0.0026 (the plane quadrature's scatter at that node set: its
rotor std is 0.3 % above the closed form's).  Cost: 29 k1, 10.7 s of CPU
per focus (the fixed 4-per-decade grid of before: 16 k1, 7.6 s, its
variances 1.7 % off with linear interpolation, the correlation 0.0024 low;
on 60-s periods up to 0.007 low, a 121-k1 grid agreeing with the adaptive
one within 1e-4).

Evolving turbulence (a period's ``lifetime``): not here -- the general
theory is frozen; the variables are NaN for such a period, whose evolving
theory is the coherence of :mod:`cwlidar_sim.analysis.rews_theory`
(``coherence_theory``; in the frozen limit that coherence is the general
module's within 1e-5, tests/campaign/periods/test_nacelle_theory.py).  A
yawed rotor is taken (the functionals turn the beams), fixed beams too
(their estimates take turns); NaN for a moving platform and for a paired
span shorter than two revolutions.
"""

from __future__ import annotations

import json
import math

import numpy as np

from ...analysis import linear_theory as lt
from ...analysis.rews import RotorDisc
from ...analysis.rews_theory import rotor_spectrum
from .scanner_theory import rotor_disc_nodes
from .theory import cached, nacelle_functionals

__all__ = ["nacelle_theory", "paired_statistics", "k1_range", "THEORY_ROTOR_NODES", "THEORY_RESOLUTION",
           "THEORY_PHASES", "K1_RANGE", "N_START", "TOL", "CONVERGENCE", "theory_attrs"]

#: The rotor disc's polar nodes (radial, azimuthal) of the results' theory.
THEORY_ROTOR_NODES = (8, 24)
#: The polar quadrature's resolution of the results' theory (:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`).
THEORY_RESOLUTION = 20.0
#: The polar quadrature's resolution of the rotor disc's own spectrum
#: (:func:`~cwlidar_sim.analysis.rews_theory.rotor_spectrum`).
ROTOR_RESOLUTION = 60.0
#: Scan phases averaged (evenly over the revolution).
THEORY_PHASES = 2
#: The adaptive k1 grid's span: from ``K1_RANGE[0]`` of the period's first harmonic ``2 pi / (U T)`` to
#: ``K1_RANGE[1]`` of the revolution's ``2 pi / (U T_rev)`` (the revolution mean's first zero) [-].
K1_RANGE = (0.1, 0.9)
#: The adaptive grid's starting log-spaced k1 and the relative tolerance of each variance.
N_START = 9
TOL = 1e-3
#: What refining each numerical choice moves (std ratio, correlation) by, bundled scene, 100 m, 600 s (module
#: notes; studies/nacelle_theory_convergence.py).
CONVERGENCE = {"100": {"tol / 4": (6e-7, 3e-7), "n_start x 2": (7e-7, 3e-7), "resolution x 2": (2e-7, 1.5e-5),
                       "k1 top x 3": (2.2e-6, 2.6e-5), "phases 4": (6.4e-5, 5.2e-5), "sub_dwells own": (1.1e-5, 1.3e-5),
                       "rotor nodes 16 x 48": (1e-7, 5.7e-5), "rotor nodes 24 x 72": (1e-7, 7.8e-5),
                       "rotor nodes 12 x 36 (quadrature scatter)": (0.0, 2.6e-3), "fixed 161 k1": (8e-7, 2e-5)}}


def k1_range(U: float, T: float, revolution_time: float) -> tuple:
    """The adaptive grid's ends [rad/m] for U [m/s], a period T [s] and a revolution [s] (``K1_RANGE``)."""
    return K1_RANGE[0] * 2.0 * math.pi / (U * T), K1_RANGE[1] * 2.0 * math.pi / (U * revolution_time)


def nacelle_theory(lidar, focus: float, params, mean_speed: float, period: float, rotor_radius: float, *,
                   rotor_exponent: float = 0.0, preview_shift: float | None = None, phases: int = THEORY_PHASES,
                   sub_dwells: int | None = 1, probe: str = "cells", resolution: float = THEORY_RESOLUTION,
                   rotor_nodes=THEORY_ROTOR_NODES, k1=None, n_start: int = N_START, tol: float = TOL,
                   k1_ends: tuple | None = None, max_k1: int = 400, rotor_disc: bool = True) -> dict:
    """The within-period stds of the paired lidar and rotor series, their ratio and correlation (module notes).

    Parameters
    ----------
    lidar : NacelleLidar
        The lidar (:class:`cwlidar_sim.sensors.NacelleLidar`); its ``position`` relative to the hub.
    focus : float
        One of ``lidar.focus_distances`` [m].
    params : MannParameters
    mean_speed : float
        U [m/s].
    period : float
        The paired series' span [s] (samples every dwell).
    rotor_radius : float
        R [m].
    rotor_exponent : float
        p of the REWS weight ``(r / R)^p`` per area.
    preview_shift : float, optional
        The pairing's delay [s] (default the focus's upwind distance over U).
    phases : int
        Scan phases averaged, >= 1.
    sub_dwells : int or None
        Looks per dwell of the theory (None: the lidar's own).
    probe, resolution, rotor_nodes
        The looks' probe (``nacelle_functionals``), the polar quadrature's
        resolution (``functional_spectra``), the rotor's (radial, azimuthal) nodes.
    k1 : array_like, optional
        A fixed k1 grid [rad/m] instead of the adaptive one (a reference).
    n_start, tol, k1_ends, max_k1
        The adaptive grid (:func:`~cwlidar_sim.analysis.linear_theory.adaptive_spectra`):
        starting k1, relative tolerance, ends [rad/m] (default :func:`k1_range`), most k1.
    rotor_disc : bool
        The rotor's variance from the disc's closed-form transfer
        (:func:`~cwlidar_sim.analysis.rews_theory.rotor_spectrum`; module
        notes), else from the nodes (as the covariance always is).

    Returns
    -------
    dict
        ``lidar_std``, ``rotor_std`` [m/s], ``std_ratio``, ``correlation`` [-],
        ``lidar_var``, ``rotor_var``, ``covariance`` [m^2 s^-2]; ``n_k1`` (k1
        evaluated), ``grid_error`` (the refinement's largest bound, relative;
        NaN on a fixed grid), ``converged``; ``rotor_var_nodes`` [m^2 s^-2]
        (the nodes' rotor variance).
    """
    U, T = float(mean_speed), float(period)
    lid = lidar if sub_dwells is None else lidar.replace(sub_dwells=sub_dwells)
    nodes = rotor_disc_nodes(rotor_radius, rotor_exponent, n_radial=rotor_nodes[0], n_azimuth=rotor_nodes[1])
    epr = lid.estimates_per_rev
    fs = []
    for i in range(phases):
        rotor, est = nacelle_functionals(lid, focus, U, nodes, n_beams=None, preview_shift=preview_shift,
                                         probe=probe, phase=(i * epr) // phases)
        fs += [rotor] if not fs else []
        fs.append(est)
    dt = lid.dwell_time
    # per phase the lidar and the lidar less the rotor (its spectrum F_ll + F_rr - 2 Re F_lr >= 0, small where the
    # two are coherent): the covariance from the variances of the difference and its parts
    lids = [f"{i + 1}.lidar" for i in range(phases)]
    stats = [lt.PeriodStatistic("0.rotor", T, dt)]
    stats += [lt.PeriodStatistic(a, T, dt) for a in lids]
    stats += [lt.PeriodStatistic((a, "0.rotor"), T, dt, weights=(1.0, -1.0)) for a in lids]
    if k1 is None:
        ends = k1_range(U, T, lid.revolution_time) if k1_ends is None else k1_ends
        r = lt.adaptive_spectra(params, fs, U, stats, k1_range=ends, n_start=n_start, tol=tol, max_k1=max_k1,
                                resolution=resolution)
        k, within, err, conv = r.spectra.k1_k, r.within, max(r.error), r.converged
    else:
        k = np.asarray(k1, dtype=float)
        spec = lt.functional_spectra(k, params, fs, U, resolution=resolution)
        F_r = spec.spectrum("0.rotor")
        F = [F_r] + [spec.spectrum(a) for a in lids]
        F += [spec.spectrum(a) + F_r - 2.0 * spec.cross(a, "0.rotor").real for a in lids]
        within, err, conv = [st.variance(k, f, U) for st, f in zip(stats, F)], math.nan, True
    vl = float(np.mean(within[1:1 + phases]))
    cov = 0.5 * (vl + within[0] - float(np.mean(within[1 + phases:])))  # the nodes' rotor in both: it cancels
    disc = RotorDisc(rotor_radius, rotor_exponent) if rotor_disc else None
    # the rotor's variance: the disc's closed-form transfer (one-sided: twice rotor_spectrum's), else the nodes'
    vr = within[0] if disc is None else float(stats[0].variance(k, 2.0 * rotor_spectrum(k, params, disc,
                                                                                  resolution=ROTOR_RESOLUTION), U))
    return {"lidar_var": vl, "rotor_var": vr, "covariance": cov, "lidar_std": math.sqrt(vl),
            "rotor_std": math.sqrt(vr), "std_ratio": math.sqrt(vl / vr), "correlation": cov / math.sqrt(vl * vr),
            "rotor_var_nodes": within[0], "n_k1": int(k.size), "grid_error": err, "converged": conv}


def theory_attrs(weighting: str) -> dict:
    """The theory variables' attributes: what the theory is, its box, the probe's weighting and the numerics."""
    return {"theory": "general linear theory (cwlidar_sim.campaign.periods.nacelle_theory): frozen Mann continuum "
                      "(box = continuum), the simulation's looks (one per dwell at its mid-azimuth) and range cells "
                      f"at tier los ('{weighting}' weighting cut to the span, the mean-wind tail without "
                      "fluctuation), u = los / m_x averaged over the revolution, "
                      f"{THEORY_PHASES} scan phases averaged, shifted by the pairing's delay; the rotor's disc on "
                      f"{THEORY_ROTOR_NODES[0]} x {THEORY_ROTOR_NODES[1]} polar nodes; within-period variances of "
                      "the paired span sampled every dwell (period_variance, 1/N) on an adaptive k1 grid, polar "
                      f"resolution {THEORY_RESOLUTION:g}; NaN for evolving turbulence (its theory: coherence_theory) "
                      "or a moving platform",
            "theory_box": "continuum (no box)",
            "theory_weighting": str(weighting),
            "theory_numerics": json.dumps({"k1": "adaptive (analysis.linear_theory.adaptive_spectra)",
                                           "k1_range": "K1_RANGE[0] x 2 pi / (U T) to K1_RANGE[1] x 2 pi / (U T_rev)",
                                           "K1_RANGE": list(K1_RANGE), "n_start": N_START, "tol": TOL,
                                           "resolution": THEORY_RESOLUTION, "rotor_nodes": list(THEORY_ROTOR_NODES),
                                           "phases": THEORY_PHASES, "sub_dwells": 1, "convergence": CONVERGENCE})}


def paired_statistics(rotor_t, lidar_t) -> tuple:
    """``(lidar_std, rotor_std, correlation)`` of paired series over their common finite samples, means removed, 1/N.

    NaN where fewer than two samples are finite in both.
    """
    r, x = np.asarray(rotor_t, dtype=float), np.asarray(lidar_t, dtype=float)
    ok = np.isfinite(r) & np.isfinite(x)
    if ok.sum() < 2:
        return math.nan, math.nan, math.nan
    r, x = r[ok] - r[ok].mean(), x[ok] - x[ok].mean()
    sr, sx = math.sqrt(np.mean(r * r)), math.sqrt(np.mean(x * x))
    return sx, sr, (float(np.mean(r * x)) / (sr * sx) if sr > 0 and sx > 0 else math.nan)


def period_theory(scene, period, focus: float, span: float, delay: float) -> dict:
    """:func:`nacelle_theory` of a scene's period at one focus, once per geometry in a process; NaN where not taken."""
    lid = scene.sensor(period, (focus,))
    s = scene.scan
    nan = dict.fromkeys(("lidar_std", "rotor_std", "std_ratio", "correlation"), math.nan)
    if period.lifetime is not None or lid.motion is not None or span < 2 * lid.revolution_time:
        return nan
    params, U = scene.period_params(period), period.mean_speed
    lid0 = lid.replace(position=(0.0, 0.0, 0.0))
    key = ("nacelle", repr(lid0), focus, repr(params), U, round(span, 9), round(delay, 9), s.rotor_radius,
           s.rotor_exponent)
    return cached(key, lambda: nacelle_theory(lid0, focus, params, U, span, s.rotor_radius,
                                              rotor_exponent=s.rotor_exponent, preview_shift=delay))
