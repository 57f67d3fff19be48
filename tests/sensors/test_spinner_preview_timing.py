"""The SpinnerLidar's preview timing: the rosette's REWS estimate and the rotor's line up at the cone's lag (issue 31).

The pairing under test is the one a spinner period does
(:func:`cwlidar_sim.campaign.periods.spinner.run_unit`): the sensor's dwell
times and rosettes (:mod:`cwlidar_sim.sensors.spinner`), the disc fit per
rosette (:func:`cwlidar_sim.analysis.disc_fit.fit_disc`), and the rotor's REWS
(:func:`cwlidar_sim.analysis.rews.rews_from_box`) at each rosette's mid-time
plus the preview ``d / U``.  The series are the period's own results
(``rews`` of the ``tier1`` estimate, ``rews_rotor``), so a shift anywhere
along that path moves them.  The REWS error statistics the results hold
(RMSE, correlation) hardly see a fraction of a second; this test does.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import csd, welch

from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.periods.spinner import run_unit

U, FOCUS, SEGMENT = 10.0, 80.0, 60.0
SCENE = f"""
name = "spinner_timing"
kind = "spinner"
seed = 1
duration = 1800.0
[scan]
focus_distance = {FOCUS}
estimates_per_rosette = 246       # a quarter of the instrument's: the fit needs the pattern, not every dwell
sub_dwells = 1
tilt_deg = 0.0
rotor_radius = 40.0
spacing = 8.0
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.1
length_scale = 33.6
gamma = 3.9
[[period]]
name = "frozen"
mean_speed = {U}
rotor_rpm = 16.0
"""


def expected_lag(scene) -> tuple[float, float]:
    """``(d, tau0)``: the preview distance the period uses [m] and the lag of the estimate behind the REWS [s]."""
    p = scene.periods[0]
    lid = scene.sensor(p)
    t_e, _ = lid.schedule(lid.rosette_time)
    c = -(lid.nacelle_direction(t_e) @ lid.yaw_matrix().T)[:, 0]  # cos theta of every look over a rosette
    r = lid.probe_centre
    d = r * c.mean()
    # u0 of the fit is sum(c los) / sum(c^2) (the rosette's symmetry makes its other columns orthogonal to
    # n_x); a look at distance r cos theta sees u there less tan theta times the outward flow (rho / 2) du/dx
    x_eff = np.sum(c**2 * (r * c - r * (1.0 - c**2) / (2.0 * c))) / np.sum(c**2)
    return d, (d - x_eff) / p.mean_speed


def test_rosette_rews_lines_up_with_the_rotor_at_the_cones_lag():
    r"""Frozen turbulence, tier 'los': the delay between the paired series is the rosette's own, not a second.

    Expected delay.  The disc fit's ``u0`` is, by the rosette's symmetry
    (every azimuth at every off-axis angle theta), the ``cos^2 theta``
    weighted mean of each look's ``u_b = los / n_x``.  A look at distance
    ``r`` off the axis by theta sees ``u`` at ``r cos theta`` upwind less
    ``tan theta`` times the outward flow, which over the azimuths at radius
    ``rho = r sin theta`` is, by the divergence theorem and incompressibility,
    ``-(rho / 2) du/dx``: ``u_b ~ u(x + delta)``, ``delta = r sin^2 theta /
    (2 cos theta)`` (the nacelle lidar's cone argument,
    ``tests/sensors/test_nacelle_preview_timing.py``, at every theta of the
    rosette).  So the estimate sees the air at ``x_eff = sum c^2 (r c - delta)
    / sum c^2`` (c = cos theta) while the period previews ``d = r mean(c)``
    (``preview_time``): the estimate lags the REWS by ``tau0 = (d - x_eff) /
    U`` = 0.49 s at 80 m (the cone's delta alone 0.53 s, the weights' shift
    toward the axis -0.04 s).  At zero lag the test fails by 7 standard errors.

    Tolerances.  One REWS per 2-s rosette (0.5 Hz); cross-spectrum from Hann
    segments of 60 s (Welch, 50 % overlap: 59 segments over 1800 s, K = 59 /
    (1 + 2 0.167^2) = 56 independent averages, Welch 1967; the five seeds
    below scatter by 0.035 s, less than the standard error of 0.045 s this
    gives, so it is not optimistic).  Phase sd of a bin with coherence
    g2: ``sqrt((1 - g2) / (2 K g2))`` (Bendat & Piersol 9.52).  The phase
    slope ``phi_f = -omega_f tau`` fitted by weighted least squares over the
    bins with k <= 0.05 rad/m (4 bins, g2 >= 0.7), its standard error
    ``1 / sqrt(sum omega^2 / var phi)`` (0.04-0.05 s); within 4 standard
    errors of tau0, and each bin's phase within 4 sd of ``-omega tau0``
    (seeds 1-5 gave slopes 0.454, 0.450, 0.504, 0.458, 0.405 s, |z| <= 2.1;
    their mean, 0.454 s, lies 0.04 s below tau0, a remainder the one-line
    model leaves; above k = 0.05 the delay grows, as the nacelle's does
    where the scan's circle decorrelates from the disc).  The rotor's series taken 0.3 s
    later misses by 4.3 standard errors, 0.3 s earlier by 6.2 (seed 1); a
    second off, by 20.
    """
    scene = loads_scene(SCENE)
    d, tau0 = expected_lag(scene)
    ds = run_unit(scene, 0)
    assert abs(float(ds.preview_time.values[0]) - d / U) < 1e-9  # the preview the period states: d / U
    assert 0.45 < tau0 < 0.55, tau0
    j = list(ds.estimate.values).index("tier1")
    rotor_t, lidar_t = ds.rews_rotor.values[0], ds.rews.values[0, j]
    assert np.all(np.isfinite(rotor_t)) and np.all(np.isfinite(lidar_t))
    dt = float(np.diff(ds.rosette_time.values[0]).mean())
    fs = 1.0 / dt
    nseg = int(round(SEGMENT * fs))
    f, s_rl = csd(rotor_t, lidar_t, fs=fs, nperseg=nseg, window="hann")  # conj(R) L: phase -omega tau
    _, s_rr = welch(rotor_t, fs=fs, nperseg=nseg, window="hann")
    _, s_ll = welch(lidar_t, fs=fs, nperseg=nseg, window="hann")
    g2 = np.abs(s_rl) ** 2 / (s_rr * s_ll)
    # Welch's averages: 50 %-overlapping Hann segments, each pair correlated by 0.167 (Welch 1967)
    n_avg = (rotor_t.size - nseg) // (nseg // 2) + 1
    n_avg /= 1.0 + 2.0 * 0.167**2
    var_phi = (1.0 - g2) / (2.0 * n_avg * g2)
    omega = 2.0 * math.pi * f
    low = (f > 0) & (omega / U <= 0.05)
    assert low.sum() == 4 and g2[low].min() > 0.7, g2[low]
    w = 1.0 / var_phi[low]
    tau = -np.sum(w * omega[low] * np.angle(s_rl[low])) / np.sum(w * omega[low] ** 2)
    se = 1.0 / math.sqrt(np.sum(w * omega[low] ** 2))
    z_phase = (np.angle(s_rl[low]) + omega[low] * tau0) / np.sqrt(var_phi[low])
    report = f"tau0 {tau0:.3f} s; phase slope {tau:.3f} +- {se:.3f} s; phase z {np.round(z_phase, 2)}"
    assert se < 0.06, report  # informative: 0.3 s is over 4 standard errors
    assert abs(tau - tau0) < 4.0 * se, report
    assert np.all(np.abs(z_phase) < 4.0), report
