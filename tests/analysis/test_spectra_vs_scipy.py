"""The package's segment-averaged spectra against scipy.signal (welch, csd, coherence) to round-off.

The hand-written core is kept (the note in ``analysis/spectra.py``): scipy has no per-segment gap
rejection or interpolation, its ``csd(x, y)`` is ``E[X^* Y]`` where the package's is ``E[X Y^*]``, it
keeps f = 0, and the simulation's results must stay bit-identical.  These tests show that on the
package's own data the two agree to round-off for every option scipy shares: boxcar or Hann window, no
overlap, constant or linear detrend, one-sided density; and that the gap handling is a step before an
ordinary Welch average (the kept segments, filled, give scipy's answer).
"""

import numpy as np
import pytest
from scipy import signal

from cwlidar_sim.analysis import segment_spectra
from cwlidar_sim.analysis.rews import coherence_estimate
from cwlidar_sim.turbulence import MannParameters, generate_line

FS, U = 8.0, 8.0
N_PER = 512  # 64 s segments


@pytest.fixture(scope="module")
def mann():
    """A seeded Mann line sampled as a sonic (u, w) and a lidar-like average of u (a 9-sample running mean + noise)."""
    ln = generate_line(MannParameters(0.05, 20.0, 3.9), 2**13, U / FS, 11, dtype=np.float64)
    u = U + ln["u"].values
    lidar = np.convolve(u, np.ones(9) / 9.0, mode="same") + 0.05 * np.random.default_rng(5).normal(size=u.size)
    return u, ln["w"].values, lidar


def _welch(x, y=None, detrend="constant", window="boxcar", n_per=N_PER):
    kw = dict(fs=FS, window=window, nperseg=n_per, noverlap=0, detrend=detrend, scaling="density",
              return_onesided=True)
    if y is None:
        f, p = signal.welch(x, **kw)
    else:
        f, p = signal.csd(x, y, **kw)
        p = np.conj(p)  # scipy: E[X^* Y]; the package: E[X Y^*]
    return f[1:], p[1:]  # the package leaves out f = 0


@pytest.mark.parametrize("detrend, window", [("mean", "none"), ("linear", "none"), ("mean", "hann"),
                                             ("linear", "hann")])
def test_segment_spectra_are_scipy_welch_and_csd(mann, detrend, window):
    u, w, lidar = mann
    ss = segment_spectra(u, lidar, fs=FS, segment_duration=N_PER / FS, detrend=detrend, window=window)
    sd = {"mean": "constant", "linear": "linear"}[detrend]
    sw = {"none": "boxcar", "hann": "hann"}[window]
    f, pxx = _welch(u, detrend=sd, window=sw)
    _, pyy = _welch(lidar, detrend=sd, window=sw)
    _, pxy = _welch(u, lidar, detrend=sd, window=sw)
    np.testing.assert_allclose(ss.f_f, f, rtol=1e-15)
    np.testing.assert_allclose(ss.psd_xf, pxx, rtol=1e-12, atol=0)
    np.testing.assert_allclose(ss.psd_yf, pyy, rtol=1e-12, atol=0)
    np.testing.assert_allclose(ss.csd_f, pxy, rtol=1e-12, atol=1e-12 * np.abs(pxy).max())
    assert ss.n_segments == u.size // N_PER


def test_an_odd_segment_has_no_nyquist_bin_in_either(mann):
    u, w, _ = mann
    ss = segment_spectra(u, w, fs=FS, segment_duration=511 / FS)
    f, p = _welch(u, n_per=511)
    np.testing.assert_allclose(ss.psd_xf, p, rtol=1e-12, atol=0)
    assert ss.f_f.size == f.size == 255


def test_gap_handling_is_a_step_before_welch(mann):
    """Segments over max_gap_fraction are dropped, the others filled linearly: then scipy's average of the kept."""
    u, _, lidar = mann
    x = u.copy()
    x[3 * N_PER + 10: 3 * N_PER + 60] = np.nan  # 10 % of segment 3: rejected
    x[5 * N_PER + 100: 5 * N_PER + 110] = np.nan  # 2 % of segment 5: filled
    ss = segment_spectra(x, lidar, fs=FS, segment_duration=N_PER / FS, max_gap_fraction=0.05)
    assert (ss.n_rejected, ss.n_interpolated) == (1, 1)
    keep = [k for k in range(u.size // N_PER) if k != 3]
    rows = x[: (u.size // N_PER) * N_PER].reshape(-1, N_PER)[keep].copy()
    bad = ~np.isfinite(rows[4])  # segment 5 is the 5th kept
    j = np.arange(N_PER)
    rows[4, bad] = np.interp(j[bad], j[~bad], rows[4, ~bad])
    y = lidar[: (u.size // N_PER) * N_PER].reshape(-1, N_PER)[keep]
    _, pxx = _welch(rows.ravel())
    _, pxy = _welch(rows.ravel(), y.ravel())
    np.testing.assert_allclose(ss.psd_xf, pxx, rtol=1e-12, atol=0)
    np.testing.assert_allclose(ss.csd_f, pxy, rtol=1e-12, atol=1e-12 * np.abs(pxy).max())


@pytest.mark.parametrize("window", ["none", "hann"])
def test_coherence_estimate_is_scipy_coherence(mann, window):
    u, _, lidar = mann
    ce = coherence_estimate(u, lidar, fs=FS, U=U, segment_duration=N_PER / FS, window=window)
    f, g2 = signal.coherence(u, lidar, fs=FS, window={"none": "boxcar", "hann": "hann"}[window], nperseg=N_PER,
                             noverlap=0, detrend="constant")
    np.testing.assert_allclose(ce.f_f, f[1:], rtol=1e-15)
    np.testing.assert_allclose(ce.coherence_f, g2[1:], rtol=1e-12, atol=0)
    assert 0.5 < np.median(g2[1:20]) <= 1.0  # a lidar-like average of u is coherent with u at low f
