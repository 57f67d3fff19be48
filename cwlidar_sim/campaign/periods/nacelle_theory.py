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

Numerics (measured on the bundled scene, 100 m): ``resolution`` 20 of the
polar quadrature, one look per dwell at its mid-azimuth (the simulation's
``sub_dwells`` looks sweep 7.2 deg), the rotor on 8 x 24 polar nodes, k1 on
4 log-spaced values per decade from a tenth of the period's first harmonic
to 0.9 of the revolution's (above it the revolution mean's zeros; the
spectra's last power law carries the rest).

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

import math

import numpy as np

from ...analysis import linear_theory as lt
from .scanner_theory import rotor_disc_nodes
from .theory import cached, nacelle_functionals

__all__ = ["nacelle_theory", "paired_statistics", "THEORY_ROTOR_NODES", "THEORY_RESOLUTION", "THEORY_PHASES"]

#: The rotor disc's polar nodes (radial, azimuthal) of the results' theory.
THEORY_ROTOR_NODES = (8, 24)
#: The polar quadrature's resolution of the results' theory (:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`).
THEORY_RESOLUTION = 20.0
#: Scan phases averaged (evenly over the revolution).
THEORY_PHASES = 2
#: k1 per decade of the results' theory grid.
_K_PER_DECADE = 4


def _k1_grid(U: float, T: float, revolution_time: float) -> np.ndarray:
    """k1 [rad/m]: a tenth of the period's first harmonic to 0.9 of the revolution's, 4 per decade."""
    lo = 0.1 * 2.0 * math.pi / (U * T)
    hi = 0.9 * 2.0 * math.pi / (U * revolution_time)
    return np.geomspace(lo, hi, max(8, int(math.ceil(_K_PER_DECADE * math.log10(hi / lo))) + 1))


def nacelle_theory(lidar, focus: float, params, mean_speed: float, period: float, rotor_radius: float, *,
                   rotor_exponent: float = 0.0, preview_shift: float | None = None, phases: int = THEORY_PHASES,
                   sub_dwells: int | None = 1, probe: str = "cells", resolution: float = THEORY_RESOLUTION,
                   rotor_nodes=THEORY_ROTOR_NODES, k1=None) -> dict:
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
    probe, resolution, rotor_nodes, k1
        As :func:`~cwlidar_sim.campaign.periods.theory.nacelle_functionals`,
        :func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`,
        (radial, azimuthal) nodes, the k1 grid [rad/m] (default module notes).

    Returns
    -------
    dict
        ``lidar_std``, ``rotor_std`` [m/s], ``std_ratio``, ``correlation`` [-],
        ``lidar_var``, ``rotor_var``, ``covariance`` [m^2 s^-2].
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
    k = _k1_grid(U, T, lid.revolution_time) if k1 is None else np.asarray(k1, dtype=float)
    spec = lt.functional_spectra(k, params, fs, U, resolution=resolution)
    dt = lid.dwell_time

    def within(F):
        return lt.period_variance(spec.k1_k, F, U, T, sample_interval=dt)["within"]

    F_r = spec.spectrum("0.rotor")
    F_l = [spec.spectrum(f"{i + 1}.lidar") for i in range(phases)]
    # the covariance from the sum's spectrum (F_ll + F_rr + 2 Re F_lr >= 0: interpolated log-log like the others)
    F_s = [F + F_r + 2.0 * spec.cross(f"{i + 1}.lidar", "0.rotor").real for i, F in enumerate(F_l)]
    vr = within(F_r)
    vl = float(np.mean([within(F) for F in F_l]))
    cov = 0.5 * (float(np.mean([within(F) for F in F_s])) - vl - vr)
    return {"lidar_var": vl, "rotor_var": vr, "covariance": cov, "lidar_std": math.sqrt(vl),
            "rotor_std": math.sqrt(vr), "std_ratio": math.sqrt(vl / vr), "correlation": cov / math.sqrt(vl * vr)}


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
