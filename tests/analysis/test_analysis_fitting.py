"""Least-squares fit of the Mann tensor parameters to one-point spectra."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis import component_spectra, fit_mann, log_bins
from cwlidar_sim.turbulence import MannParameters, generate_line, one_point_spectra

TRUE = MannParameters(0.8, 33.6, 3.9)
EDGES = log_bins(2e-3, 2.0, 5)  # 15 bins: 3 decades about 1/L
K = np.sqrt(EDGES[1:] * EDGES[:-1])


def test_recovers_analytic_spectra_two_sided_with_nan_bins():
    F = np.array(one_point_spectra(K, TRUE))
    F[1, 3] = np.nan  # an empty bin in one component
    F[:, -1] = np.nan  # and a whole empty bin
    fit = fit_mann(K, *F, one_sided=False, initial={"length_scale": 12.0, "gamma": 1.5})
    assert fit.success, fit.message
    assert fit.n_points == 4 * 15 - 1 - 4
    # The model is the data: only the optimiser's tolerance (xtol 1e-6 on
    # ln L and Gamma) limits the recovery.
    assert fit.params.alpha_eps == pytest.approx(TRUE.alpha_eps, rel=1e-4)
    assert fit.params.length_scale == pytest.approx(TRUE.length_scale, rel=1e-4)
    assert fit.params.gamma == pytest.approx(TRUE.gamma, rel=1e-4)
    assert fit.residual_rms < 1e-5
    assert fit.covariance.shape == (3, 3) and fit.covariance_method == "residual"
    assert set(fit.std) == {"alpha_eps", "length_scale", "gamma"}


def _line_fit(seed):
    # A periodic line's periodogram at each of its wavenumbers is the
    # tensor's F_ij(k1) in expectation (generate_line), with chi-square
    # scatter; read as a time series at U = 10 m/s, 1 m spacing is fs = 10 Hz
    # and the whole line is one segment.
    n, U = 2**17, 10.0
    line = generate_line(TRUE, n, 1.0, seed)
    u, v, w = (line[c].values.astype(np.float64) for c in "uvw")
    k, F11, F22, F33, F13, n_k = component_spectra(u, v, w, fs=U, U=U, k_edges=EDGES, segment_duration=n / U)
    np.testing.assert_allclose(k, K)
    return fit_mann(k, F11, F22, F33, F13, n_k=n_k)


def test_recovers_line_realisations_within_reported_std():
    fits = [_line_fit(seed) for seed in range(5)]
    assert all(f.success and f.covariance_method == "chi-square" for f in fits)
    f0 = fits[0]
    for name in ("alpha_eps", "length_scale", "gamma"):
        assert abs(getattr(f0.params, name) - getattr(TRUE, name)) < 3 * f0.std[name], name
    for name in ("length_scale", "gamma"):
        est = np.array([getattr(f.params, name) for f in fits])
        sd = np.sqrt(np.mean([f.std[name] ** 2 for f in fits]))
        # Sample std over 5 seeds against the reported one: 4 s^2 / sd^2 is
        # chi2 with 4 degrees of freedom if sd is right, so s / sd lies in
        # [sqrt(0.207 / 4), sqrt(14.86 / 4)] = [0.23, 1.93] with p = 0.99.
        ratio = est.std(ddof=1) / sd
        assert 0.23 < ratio < 1.93, (name, ratio)
        # No bias beyond the scatter of the mean of 5 (the bins' model is
        # taken at their geometric centres, a < 1 % effect on the spectra).
        assert abs(est.mean() - getattr(TRUE, name)) < 3 * sd / math.sqrt(5), name


def test_bad_input():
    F = np.ones((4, K.size))
    with pytest.raises(ValueError, match="F22_k"):
        fit_mann(K, F[0], F[1][:-1], F[2], F[3])
    with pytest.raises(ValueError, match="k1_k"):
        fit_mann(-K, *F)
    with pytest.raises(ValueError, match="bounds"):
        fit_mann(K, *F, bounds={"alpha_eps": (0.1, 1.0)})
    with pytest.raises(ValueError, match="bounds"):
        fit_mann(K, *F, bounds={"gamma": (3.0, 1.0)})
    with pytest.raises(ValueError, match="initial"):
        fit_mann(K, *F, initial={"L": 3.0})
    with pytest.raises(ValueError, match="weights"):
        fit_mann(K, *F, weights=-np.ones(K.size))
    with pytest.raises(ValueError, match="finite spectral values"):
        fit_mann(K[:2], *np.full((4, 2), np.nan))
    with pytest.raises(TypeError, match="one_sided"):
        fit_mann(K, *F, one_sided="yes")
