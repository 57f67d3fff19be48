"""The nacelle lidar's preview timing: the preview-shifted estimate and the rotor's REWS line up (issue 33).

The pairing under test is the one a nacelle period does
(:func:`cwlidar_sim.campaign.periods.nacelle.run_unit`): the sensor's time
stamps (:mod:`cwlidar_sim.sensors.nacelle`), the trailing revolution average,
the preview ``r cos a / U`` less the average's delay and its rounding to a
sample (:func:`cwlidar_sim.analysis.rews.align_preview`), and the REWS's own
times (:func:`cwlidar_sim.analysis.rews.rews_from_box`).  The series are
taken exactly as the period hands them to
:func:`cwlidar_sim.analysis.rews.coherence_estimate` (a spy on that
function), so a shift anywhere along that path moves them.  The coherence
the results hold is a magnitude and does not see a delay; this test does.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import csd, welch

import cwlidar_sim.analysis.rews as rews_mod
from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.periods.nacelle import run_unit

U, HALF_ANGLE, FOCUS, SEGMENT = 10.0, 15.0, 40.0, 60.0
SCENE = f"""
name = "preview_timing"
kind = "nacelle"
seed = 4
duration = 1800.0
[scan]
half_angle_deg = {HALF_ANGLE}
focus_distances = [{FOCUS}]
rotor_radius = 20.0
spacing = 8.0
segment_duration = {SEGMENT}
k_min = 0.01
k_max = 0.3
n_k = 5
theory_beams = 0
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.1
length_scale = 20.0
gamma = 3.9
[[period]]
name = "frozen"
mean_speed = {U}
"""


def _paired_series(monkeypatch):
    """The (REWS, lidar) pairs the period hands to coherence_estimate, and their sampling rate [Hz]."""
    seen = []
    real = rews_mod.coherence_estimate

    def spy(rotor_t, lidar_t, **kw):
        seen.append((np.array(rotor_t), np.array(lidar_t), kw["fs"]))
        return real(rotor_t, lidar_t, **kw)

    monkeypatch.setattr(rews_mod, "coherence_estimate", spy)
    run_unit(loads_scene(SCENE), 0)
    assert len(seen) == 2  # tier1 and main (identical at tier 'los')
    np.testing.assert_array_equal(seen[0][1], seen[1][1])
    return seen[0]


def test_preview_shifted_estimate_lines_up_with_the_rews(monkeypatch):
    r"""Frozen turbulence, tier 'los': the delay between the paired series is the cone's own, not a second.

    Expected delay.  The estimate is ``u_b = los / n_x`` assuming v = w = 0,
    so ``u_b = u - tan a (v cos phi + w sin phi)`` on a beam at azimuth phi.
    Over the revolution the transverse term is the circle's mean outward
    flow, by the divergence theorem ``(rho / 2)`` times the disc's mean of
    ``dv/dy + dw/dz = -du/dx`` (incompressible), with ``rho = r sin a``:
    ``u_b ~ u + delta du/dx = u(x + delta)``, ``delta = r sin a tan a / 2``
    (1.39 m at 40 m, 15 deg).  The lidar thus sees air ``delta`` nearer the
    rotor than its focus, and the correctly paired estimate lags the REWS
    by ``tau0 = delta / U`` = 0.139 s (7 samples of 20 ms), at wavenumbers
    where the circle and the disc see the same u (here k rho <= 0.5).  At
    zero lag the test would fail (by 3-5 standard errors); at 80 m, where the
    cone's radius reaches the rotor's, the circle decorrelates from the
    REWS faster than the disc's du/dx does and the delay grows beyond
    tau0, so the test stays at 40 m.

    Tolerances.  Cross-spectrum from Hann segments of 60 s (Welch, 50 %
    overlap), K = T / 60 s = 30 counted as independent averages (the
    overlap's gain left out: conservative).  Phase of a bin with coherence
    g2: standard deviation ``sqrt((1 - g2) / (2 K g2))`` (Bendat & Piersol
    9.52).  (1) The phase slope: ``phi_f = -omega_f tau`` fitted by weighted
    least squares over the bins with k <= 0.05 rad/m (4 bins, g2 >= 0.9);
    its standard error ``1 / sqrt(sum omega^2 / var phi)`` (0.04-0.05 s).
    (2) The peak of the cross-correlation (the inverse transform of the
    averaged cross-spectrum, parabolic interpolation): for a small delay it
    is the slope estimate with weights ``omega^2 |S|`` over all bins, its
    linearised standard error ``sqrt(sum (omega |S|)^2 var phi) / sum
    omega^2 |S|`` (about 0.03 s).  Both within 4 standard errors of tau0
    (seeds 1-4 gave |z| <= 2.6).  A preview off by 1 s misses by 20-40
    standard errors.
    """
    rotor_t, lidar_t, fs = _paired_series(monkeypatch)
    dt = 1.0 / fs
    assert np.all(np.isfinite(rotor_t)) and np.all(np.isfinite(lidar_t))
    a = math.radians(HALF_ANGLE)
    tau0 = FOCUS * math.sin(a) * math.tan(a) / (2.0 * U)
    nseg = int(round(SEGMENT * fs))
    f, s_rl = csd(rotor_t, lidar_t, fs=fs, nperseg=nseg, window="hann")  # conj(R) L: phase -omega tau
    _, s_rr = welch(rotor_t, fs=fs, nperseg=nseg, window="hann")
    _, s_ll = welch(lidar_t, fs=fs, nperseg=nseg, window="hann")
    g2 = np.abs(s_rl) ** 2 / (s_rr * s_ll)
    n_avg = rotor_t.size * dt / SEGMENT
    var_phi = (1.0 - g2) / (2.0 * n_avg * g2)
    omega = 2.0 * math.pi * f
    # (1) the low-wavenumber phase slope
    low = (f > 0) & (omega / U <= 0.05)
    assert low.sum() == 4 and g2[low].min() > 0.9, g2[low]
    w = 1.0 / var_phi[low]
    tau_slope = -np.sum(w * omega[low] * np.angle(s_rl[low])) / np.sum(w * omega[low] ** 2)
    se_slope = 1.0 / math.sqrt(np.sum(w * omega[low] ** 2))
    # and the phase itself is near zero there: within 4 sd of -omega tau0 bin by bin
    z_phase = (np.angle(s_rl[low]) + omega[low] * tau0) / np.sqrt(var_phi[low])
    # (2) the cross-correlation's peak
    c = np.fft.irfft(s_rl, nseg)
    lag = np.fft.fftfreq(nseg, 1.0 / nseg)
    i = int(np.argmax(c))
    y0, y1, y2 = c[i - 1], c[i], c[(i + 1) % nseg]
    tau_peak = (lag[i] + 0.5 * (y0 - y2) / (y0 - 2.0 * y1 + y2)) * dt
    pos = f > 0
    wp = omega[pos] ** 2 * np.abs(s_rl[pos])
    se_peak = math.sqrt(np.sum((omega[pos] * np.abs(s_rl[pos])) ** 2 * var_phi[pos])) / np.sum(wp)
    report = (f"tau0 {tau0:.3f} s; phase slope {tau_slope:.3f} +- {se_slope:.3f} s; "
              f"correlation peak {tau_peak:.3f} +- {se_peak:.3f} s; phase z {np.round(z_phase, 2)}")
    assert se_slope < 0.08 and se_peak < 0.06, report  # informative: a 1-s error is >= 12 standard errors
    assert abs(tau_slope - tau0) < 4.0 * se_slope, report
    assert abs(tau_peak - tau0) < 4.0 * se_peak, report
    assert np.all(np.abs(z_phase) < 4.0), report
    # the peak is the cone's delay, not zero: within a few samples of tau0, never a second away
    assert abs(tau_peak) < 0.5, report
