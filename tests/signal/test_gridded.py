"""Continuum speckle's gridded cosine sums (continuum_moments(method='gridded')) against the exact path.

The exact path sums each cell's cosine over every lag (Chebyshev recurrence); the gridded one
spreads the cells on a grid of angles by a Gaussian, transforms once and divides the
Gaussian out (a type-1 non-uniform FFT).  Its stated accuracy: the cosine sums within about
1e-13 of C(0), so the moments agree to rounding (relative 1e-12 here; the estimates to
1e-12 m/s).  benchmarks/bench_subbin.py measures the error against the chain's scatter.
"""

import math

import numpy as np
import pytest

from cwlidar_sim.signal import PROTOTYPE_2003, estimate
from cwlidar_sim.signal import _kernels as K
from cwlidar_sim.signal import spectral as S
from cwlidar_sim.signal._gridded import gridding
from cwlidar_sim.signal.spectral import continuum_moments, sample_moments

import reference  # noqa: E402

SHOT = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)


def test_gaussian_deposit_against_reference():
    rng = np.random.default_rng(3)
    n = 512
    # speeds anywhere, aliased beyond Nyquist, negative, on the grid's ends (theta near 0 and 2 pi)
    x = np.concatenate([rng.uniform(-700, 1300, (2, 40)), np.array([[0.0, 1e-9, 511.9999999, -1e-9, 256.0] * 8])])
    amp = rng.uniform(0, 1, x.shape[1])
    m, tau, e_j, _ = gridding(484)
    out = np.empty((x.shape[0], m))
    K.gaussian_deposit_rows(x, amp, n, tau, e_j, 0, x.shape[0], out)
    for e in range(x.shape[0]):
        ref = reference.signal_gaussian_deposit(x[e], amp, n, m, tau, S.GRID_HALF_WIDTH)
        # the weights' conditioning: theta ~ 6 carries 1e-15 rad of rounding, and d/dtheta of
        # exp(-d^2 / 4 tau) is d / (2 tau) ~ 1.5e3 times the weight at d ~ 14 h: relative 2e-12
        assert np.allclose(out[e], ref, rtol=5e-12, atol=1e-15 * amp.sum())


@pytest.mark.parametrize("t_used", [484, 512, 1500])
def test_gridded_cosine_sums_against_the_definition(t_used):
    rng = np.random.default_rng(t_used)
    n = 512
    x = rng.uniform(-600, 600, (3, 50))
    amp = rng.uniform(0, 1, 50)
    m, tau, e_j, deconv = gridding(t_used)
    grid = np.empty((3, m))
    K.gaussian_deposit_rows(x, amp, n, tau, e_j, 0, 3, grid)
    c = 2.0 * np.fft.rfft(grid).real[:, :t_used] * deconv
    t = np.arange(t_used)
    for e in range(3):
        ref = 2.0 * (amp[None, :] * np.cos(np.outer(t, 2 * np.pi * np.mod(x[e], n) / n))).sum(1)
        assert np.max(np.abs(c[e] - ref)) < 3e-13 * ref[0]


def _volume(ne):
    from cwlidar_sim.sensors import StaringLidar
    from cwlidar_sim.turbulence import MannParameters, generate_line

    inst = SHOT.replace(focus=67.5)
    cells = StaringLidar(instrument=inst, cell_length=0.5, span=20.0).cells()
    # the line of tests/signal/test_continuum.py (its tensor set-up is then made once per session)
    fld = generate_line(MannParameters(0.06224407174474577, 18.76, 3.9), 8192, 0.125, 7)
    x, u = fld["x"].values, fld["u"].values
    period = x[-1] + 0.125
    pos = inst.focus + cells.s_s[None, :] + 20.0 + 0.16 * np.arange(ne)[:, None]
    return inst, 8.0 + np.interp(np.mod(pos, period), x, u, period=period), cells.weight_s


@pytest.mark.parametrize("case", ["a2012", "narrow", "aliased", "gain"])
def test_gridded_moments_and_estimates_match_the_exact_path(case):
    inst, v, w = _volume(300)
    spread, tau, kw = 0.0947, inst.speckle_time(0.9), {}
    if case == "narrow":
        # a narrow spread keeps the line correlated over several blocks (J > 1)
        spread = 0.02
        assert S.continuum_lags(inst, spread, tau)[1] > 2
    elif case == "aliased":
        # speeds beyond the Nyquist speed and negative ones
        v = v * np.linspace(-3.0, 3.0, v.shape[0])[:, None]
    elif case == "gain":
        kw["cnr_gain_e"] = np.linspace(0.5, 2.0, v.shape[0])
    m0, v0, l0 = continuum_moments(inst, v, w, -10.0, spread, correlation_time=tau, method="exact", **kw)
    m1, v1, l1 = continuum_moments(inst, v, w, -10.0, spread, correlation_time=tau, method="gridded", **kw)
    assert np.max(np.abs(m1 / m0 - 1)) < 1e-12
    assert np.max(np.abs(v1 / v0 - 1)) < 1e-12
    # looks are ratios of the signal's moments: where there is hardly any signal they are ratios of rounding
    sig = m0 - S.noise_floor(inst)
    sel = sig > 1e-6 * sig.max(axis=1, keepdims=True)
    assert np.max(np.abs(l1[sel] / l0[sel] - 1)) < 1e-9
    key = np.uint64(99)
    e0 = estimate(sample_moments(m0, v0, key), inst).speed_e
    e1 = estimate(sample_moments(m1, v1, key), inst).speed_e
    assert np.array_equal(np.isfinite(e0), np.isfinite(e1))
    assert np.nanmax(np.abs(e1 - e0)) < 1e-12


def test_method_is_checked():
    inst, v, w = _volume(2)
    with pytest.raises(ValueError, match="method"):
        continuum_moments(inst, v, w, -10.0, 0.1, method="fft")
    assert math.isfinite(S.GRID_HALF_WIDTH)
    # the default is the gridded method (what the chain and the estimator theory use)
    for a, b in zip(continuum_moments(inst, v, w, -10.0, 0.1), continuum_moments(inst, v, w, -10.0, 0.1, method="gridded")):
        assert np.array_equal(a, b)


def test_signal_lag_rows_exact_is_lag_sequence_kernel_and_gridded_agrees():
    from cwlidar_sim.signal.spectral import _signal_lag_rows, lag_coefficients

    rng = np.random.default_rng(5)
    inst = PROTOTYPE_2003
    v = rng.uniform(-40, 40, (37, 90))
    amp = rng.uniform(0, 0.05, 90)
    for rho in (1.0, 0.999):
        a_d = lag_coefficients(inst.n_fft, inst.window, rho)
        ref = np.empty((37, inst.n_fft))
        K.lag_sequence_kernel(np.ascontiguousarray(v / inst.bin_speed), amp, a_d, ref)
        assert np.array_equal(_signal_lag_rows(inst, v, amp, a_d, method="exact"), ref)
        g = _signal_lag_rows(inst, v, amp, a_d, method="gridded")
        assert np.max(np.abs(g - ref)) < 3e-13 * 2 * amp.sum()


def test_exp_small_is_exp_to_an_ulp_on_its_range():
    z = np.linspace(-0.25, 0.25, 20001)
    got = np.array([K.exp_small(v) for v in z[::50]])
    want = np.exp(z[::50])
    assert np.max(np.abs(got / want - 1.0)) < 4.5e-16
    # the series is only valid on |z| <= 0.25: at z = 1 the truncation is visible
    assert abs(K.exp_small(1.0) / math.e - 1.0) > 1e-12


@pytest.mark.parametrize("nj", [1, 3])
def test_gridded_fold_is_fold_block_lags_bit_for_bit(nj):
    from cwlidar_sim.signal._gridded import fold_factors

    rng = np.random.default_rng(11)
    n = 64
    t_used = nj * n - 5
    m, _, _, deconv = gridding(t_used)
    g_t = np.zeros((nj + 1) * n)
    g_t[:t_used] = np.exp(-np.arange(t_used) / 50.0)
    r_d = rng.uniform(0.5, 1.0, n)
    f_em = rng.normal(size=(4, m // 2 + 1)) + 1j * rng.normal(size=(4, m // 2 + 1))
    a, b = fold_factors(g_t, r_d, n, nj)
    out = np.empty((4, nj, n))
    K.gridded_lag_rows(f_em, deconv, a, b, 0, 4, np.empty(nj * n), out)
    for e in range(4):
        c_t = np.zeros((nj + 1) * n)
        c_t[:t_used] = 2.0 * f_em[e, :t_used].real * deconv
        ref = np.empty((nj, n))
        K.fold_block_lags(c_t, g_t, r_d, n, ref)
        assert np.array_equal(out[e], ref)
