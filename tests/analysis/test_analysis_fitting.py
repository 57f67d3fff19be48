"""Least-squares fit of the Mann tensor parameters to one-point spectra."""

import math
import re

import numpy as np
import pytest

from cwlidar_sim.analysis import component_spectra, fit_mann, log_bins
from cwlidar_sim.turbulence import MannParameters, generate_line, one_point_spectra

TRUE = MannParameters(0.8, 33.6, 3.9)
EDGES = log_bins(2e-3, 2.0, 5)  # 15 bins: 3 decades about 1/L
K = np.sqrt(EDGES[1:] * EDGES[:-1])


@pytest.mark.parametrize("one_sided", [True, False])
def test_recovers_analytic_spectra_one_or_two_sided_with_nan_bins(one_sided):
    F = np.array(one_point_spectra(K, TRUE))  # one-sided, the default convention
    if not one_sided:
        F = F / 2.0  # Mann's two-sided spectra
    F[1, 3] = np.nan  # an empty bin in one component
    F[:, -1] = np.nan  # and a whole empty bin
    fit = fit_mann(K, *F, one_sided=one_sided, initial={"length_scale": 12.0, "gamma": 1.5})
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


def test_recovers_a_line_realisation_within_reported_std():
    f = _line_fit(0)
    assert f.success and f.covariance_method == "chi-square"
    for name in ("alpha_eps", "length_scale", "gamma"):
        assert abs(getattr(f.params, name) - getattr(TRUE, name)) < 3 * f.std[name], name


def test_reported_std_matches_the_scatter_over_300_synthetic_records(monkeypatch):
    """The chi-square ("sandwich") std against the seed-to-seed std of the estimates, to 15 %.

    Synthetic bin means with exactly the statistics the covariance assumes: in each bin,
    n_k independent circular complex Gaussian (U, W) pairs with cross-spectral matrix
    [[F11, F13], [F13, F33]] of the tensor at the bin centre, and V independent (n_k of a
    2**17-point line, one segment: 25 to 15397 values per bin).  To keep 300 fits fast the
    model the fit evaluates is the tensor's own spectra interpolated biquadratically in
    (ln L, Gamma) from a 3 x 3 grid about the truth (9 evaluations of one_point_spectra;
    within +-0.1 in ln L and +-0.4 in Gamma, i.e. > 5 sd, the interpolation error is far
    below the scatter).  300 seeds give the sample std to 1 / sqrt(600) = 4 %, so 15 % is
    3.6 standard errors; measured ratios 1.03 (alpha_eps), 1.05 (L), 1.00 (Gamma).
    """
    from cwlidar_sim.analysis import fitting

    hL, hg = 0.1, 0.4
    a0, g0 = math.log(TRUE.length_scale), TRUE.gamma
    grid = np.array([[fitting._model_spectra(K, math.exp(a0 + i * hL), g0 + j * hg) for j in (-1, 0, 1)]
                     for i in (-1, 0, 1)])

    def lagrange(x):  # weights of the nodes -1, 0, 1
        return np.array([0.5 * x * (x - 1), 1 - x * x, 0.5 * x * (x + 1)])

    def surrogate(k_k, L, gamma, rule="fine"):
        assert k_k.shape == K.shape
        return np.einsum("i,j,ijck->ck", lagrange((math.log(L) - a0) / hL), lagrange((gamma - g0) / hg), grid)

    monkeypatch.setattr(fitting, "_model_spectra", surrogate)
    n_line = 2**17
    n_k = np.histogram(2 * math.pi * np.arange(1, n_line // 2 + 1) / n_line, EDGES)[0]
    G = TRUE.alpha_eps * grid[1, 1]  # one-sided, as component_spectra measures
    chol = [np.linalg.cholesky([[G[0, b], G[3, b]], [G[3, b], G[2, b]]]) for b in range(K.size)]
    rng = np.random.default_rng(1)
    names = ("alpha_eps", "length_scale", "gamma")
    est, std = [], []
    for _ in range(300):
        F = np.empty((4, K.size))
        for b, n in enumerate(n_k):
            z = (rng.standard_normal((3, n)) + 1j * rng.standard_normal((3, n))) / math.sqrt(2)
            u, w = chol[b] @ z[:2]
            F[:, b] = [np.mean(np.abs(u) ** 2), G[1, b] * np.mean(np.abs(z[2]) ** 2), np.mean(np.abs(w) ** 2),
                       np.mean((u * np.conj(w)).real)]
        f = fit_mann(K, *F, n_k=n_k)
        assert f.success and f.covariance_method == "chi-square"
        est.append([getattr(f.params, c) for c in names])
        std.append([f.std[c] for c in names])
    est, std = np.array(est), np.array(std)
    ratio = est.std(axis=0, ddof=1) / np.sqrt(np.mean(std**2, axis=0))
    assert np.all(np.abs(ratio - 1) < 0.15), dict(zip(names, ratio))
    # unbiased within 4 standard errors of the mean of 300
    truth = np.array([getattr(TRUE, c) for c in names])
    assert np.all(np.abs(est.mean(axis=0) - truth) < 4 * est.std(axis=0, ddof=1) / math.sqrt(300))


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


@pytest.mark.parametrize("seed", [0, 1])
def test_coarse_search_finished_on_the_fine_quadrature_is_the_fine_optimum(seed, monkeypatch):
    """The search runs on the coarse one-point rule (2.5e-4) and one Gauss-Newton step on the fine one
    finishes it: the result is the optimum of a search on the fine rule throughout, to 3e-6 (measured
    4e-7; that search's own tolerance is xtol 1e-6 on ln L and Gamma).  Finishing on the coarse rule
    instead leaves the parameters 1.2e-5 to 3.4e-5 off."""
    from cwlidar_sim.analysis import fitting

    two_stage = _line_fit(seed)
    assert two_stage.nfev == 6 and two_stage.nfev_coarse > 6
    model = fitting._model_spectra
    monkeypatch.setattr(fitting, "_model_spectra", lambda k, L, g, rule="fine": model(k, L, g, "fine"))
    fine = _line_fit(seed)
    for name in ("alpha_eps", "length_scale", "gamma"):
        assert getattr(two_stage.params, name) == pytest.approx(getattr(fine.params, name), rel=3e-6), name
        assert two_stage.std[name] == pytest.approx(fine.std[name], rel=1e-3), name


# ---------------------------------------------------------------------------
# fit_quality: a fit on a bound, failed or far from the spectra is "suspect"
# ---------------------------------------------------------------------------
def _fit(L, g, success=True, rms=0.15):
    from cwlidar_sim.analysis.fitting import MannFit
    from cwlidar_sim.turbulence import MannParameters

    return MannFit(MannParameters(0.05, L, g), {}, np.eye(3), rms, 40, success, "ok")


def test_fit_quality_names_the_parameters_on_a_bound():
    from cwlidar_sim.analysis.fitting import fit_quality

    assert fit_quality(_fit(20.0, 3.9)) == {"quality": "ok", "at_bound": [], "reasons": []}
    q = fit_quality(_fit(0.5, 0.0))  # white noise's fit
    assert q["quality"] == "suspect"
    assert q["at_bound"] == ["length_scale=0.5 (lower bound)", "gamma=0 (lower bound)"]
    assert fit_quality(_fit(5000.0, 8.0))["at_bound"] == ["length_scale=5000 (upper bound)", "gamma=8 (upper bound)"]
    # near but not on a bound (1 % of the log span away) is a fit
    assert fit_quality(_fit(0.5 * (1e4 ** 0.01), 0.1))["at_bound"] == []
    assert fit_quality(_fit(30.0, 2.0), bounds={"length_scale": (1.0, 30.0)})["at_bound"] == [
        "length_scale=30 (upper bound)"]


def test_fit_quality_flags_a_failed_fit_and_a_large_residual():
    from cwlidar_sim.analysis.fitting import MAX_RESIDUAL_RMS, fit_quality

    assert "the optimiser failed" in fit_quality(_fit(20.0, 3.9, success=False))["reasons"][0]
    assert fit_quality(_fit(20.0, 3.9, rms=MAX_RESIDUAL_RMS))["quality"] == "ok"
    assert "residual_rms = 0.8" in fit_quality(_fit(20.0, 3.9, rms=0.8))["reasons"][0]
    assert fit_quality(_fit(20.0, 3.9, rms=float("nan")))["quality"] == "suspect"
    with pytest.raises(TypeError, match="MannFit"):
        fit_quality({"length_scale": 1.0})


@pytest.mark.parametrize("bounds, field", [({"gamma": (0.0, 20.0)}, "bounds['gamma'][1]"),
                                           ({"length_scale": (1.0, 1e5)}, "bounds['length_scale'][1]")])
def test_fit_bounds_stay_inside_the_tensor_s_range(bounds, field):
    """A fit bound beyond what MannParameters accepts (Gamma <= 8, L <= 5000 m) is refused before the fit,
    not after it (where the fitted tensor could not even be built)."""
    k = np.logspace(-2, 0, 20)
    F = np.ones(k.size)
    with pytest.raises(ValueError, match=re.escape(field)):
        fit_mann(k, F, F, F, F, bounds=bounds)
