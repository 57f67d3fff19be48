"""Continuum speckle: the sub-cell spread, per-bin looks, tier 2 against tier 3, convergence in the cell count.

Tolerances are sampling errors with fixed seeds: the relative standard
deviation of a variance estimated from n draws is about sqrt(2 / n), of a
standard deviation sqrt(1 / (2 n)); averaging over b nearly independent bins
divides these by sqrt(b).
"""

import math

import numpy as np
import pytest

from cwlidar_sim.sensors import StaringLidar
from cwlidar_sim.signal import PROTOTYPE_2003, Instrument, estimate, noise_floor, simulate_signal_spectra
from cwlidar_sim.signal.spectral import (
    continuum_lags,
    continuum_moments,
    line_correlation,
    noise_correlation,
    sample_moments,
    window_samples,
)
from cwlidar_sim.turbulence import MannParameters, generate_line, isotropic_spectra, subcell_variance
import reference  # noqa: E402

A2012 = MannParameters(0.06224407174474577, 18.76, 3.9)
M64 = PROTOTYPE_2003.replace(blocks_per_estimate=64)
SHOT = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)
U = 8.0


# ---------------------------------------------------------------------------
# sub-cell spread against the tensor integral
# ---------------------------------------------------------------------------
def test_subcell_variance_isotropic_closed_form():
    from scipy.integrate import quad

    p = MannParameters(0.1, 30.0, 0.0)
    for dx in (0.25, 1.0, 4.0):
        K = math.pi / dx
        tail, _ = quad(lambda k: isotropic_spectra(k, p)[0], K, np.inf, limit=200)  # one-sided: k1 > K only
        assert subcell_variance(p, dx) == pytest.approx(tail, rel=2e-4)


def test_subcell_variance_a2012_inertial_range():
    # at k dx = pi >> 1/L the spectrum is the isotropic inertial range: 2 * int_K^inf (9/55) a k^(-5/3)
    # = (27/55) a K^(-2/3); Gamma = 3.9 still changes F11 by a few per cent at k L = 118
    var = subcell_variance(A2012, 0.5)
    approx = 27.0 / 55.0 * A2012.alpha_eps * (math.pi / 0.5) ** (-2.0 / 3.0)
    assert var == pytest.approx(approx, rel=0.05)
    assert math.sqrt(var) == pytest.approx(0.0947, abs=0.001)
    # halving the spacing removes (1/2)^(2/3) of it
    assert subcell_variance(A2012, 0.25) / var == pytest.approx(0.5 ** (2.0 / 3.0), rel=0.03)


# ---------------------------------------------------------------------------
# the moments against their defining lag sums
# ---------------------------------------------------------------------------
SMALL = Instrument(n_fft=32, blocks_per_estimate=100, estimate_rate=1000.0, rin_level=3.0, rin_corner=2e6)


def test_continuum_moments_against_reference():
    inst = SMALL
    rng = np.random.default_rng(3)
    x = rng.uniform(3.0, 9.0, 5)
    w = rng.uniform(0.1, 1.0, 5)
    w /= w.sum()
    spread, tau = 0.5, 2e-6
    t_max, n_j = continuum_lags(inst, spread, tau)
    assert n_j >= 2
    mean, var, looks = continuum_moments(inst, x * inst.bin_speed, w, 3.0, spread, correlation_time=tau)
    cnr = 10 ** 0.3
    nt = 12 * inst.n_fft
    g = line_correlation(inst, spread, tau, nt)
    g[t_max:] = 0.0
    ref_mean, ref_var = reference.signal_continuum_moments(x, 0.5 * cnr * w, g, noise_correlation(inst, nt),
                                                           window_samples(inst.n_fft, "rect"),
                                                           inst.blocks_per_estimate)
    assert np.allclose(mean[0], ref_mean, rtol=1e-9, atol=1e-12)
    assert np.allclose(var[0], ref_var, rtol=1e-8, atol=1e-14)
    assert np.all((looks >= 1.0) & (looks <= inst.blocks_per_estimate * (1 + 1e-12)))


def test_continuum_refuses_a_spread_too_narrow():
    with pytest.raises(ValueError, match="speed_spread"):
        continuum_lags(PROTOTYPE_2003, 1e-4)


def test_sample_moments_mean_and_variance():
    mean = np.tile(np.linspace(1.0, 5.0, 257), (20000, 1))
    var = mean**2 / np.linspace(2.0, 2000.0, 257)
    x = sample_moments(mean, var, 4)
    n = x.shape[0]
    assert np.all(np.abs(x.mean(0) / mean[0] - 1) < 5 * np.sqrt(var[0] / n) / mean[0])
    assert np.all(np.abs(x.var(0) / var[0] - 1) < 5 * math.sqrt(2 / n) * 1.5)


# ---------------------------------------------------------------------------
# a turbulent probe volume: frozen cell speeds from a Mann line at 0.125 m
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def line():
    fld = generate_line(A2012, 8192, 0.125, 7)
    return fld["x"].values, fld["u"].values


def _volume(line, inst, cell_length):
    x, u = line
    cells = StaringLidar(instrument=inst, cell_length=cell_length).cells()
    pos = np.mod(inst.focus + cells.s_s + 300.0, x[-1] + (x[1] - x[0]))
    v = U + np.interp(pos, x, u, period=x[-1] + (x[1] - x[0]))
    return v, cells.weight_s


SPREAD = math.sqrt(subcell_variance(A2012, 0.125))
TAU = PROTOTYPE_2003.speckle_time(0.9)
CNR = -6.0


def _peak_bins(mean, noise):
    return np.flatnonzero(mean - noise > 2.0 * noise)


def _tier2(inst, v, w, n, seed):
    mean, var, looks = continuum_moments(inst, v, w, CNR, SPREAD, correlation_time=TAU)
    spec = sample_moments(np.repeat(mean, n, 0), np.repeat(var, n, 0), seed)
    return mean[0], var[0], looks[0], spec


def test_tier3_matches_tier2_moments_turbulent(line):
    v, w = _volume(line, M64, 0.5)
    n = 400
    mean, var, looks, s2 = _tier2(M64, v, w, n, 1)
    s3 = simulate_signal_spectra(M64, np.broadcast_to(v, (n, v.size)), w, CNR, 2, correlation_time=TAU,
                                 speed_spread=SPREAD)
    noise = noise_floor(M64)
    b = _peak_bins(mean, noise)
    assert b.size >= 8
    # per-bin mean: each within 4 sigma of sampling, and on average within 4 sigma / sqrt(b)
    se = np.sqrt(var[b] / n)
    assert np.all(np.abs(s3.mean(0)[b] - mean[b]) < 4 * se)
    assert abs(np.mean((s3.mean(0)[b] - mean[b]) / se)) < 4 / math.sqrt(b.size)
    # per-bin relative scatter: tier 3's and tier 2's sampled ones against the moments
    r_mom = np.sqrt(var[b]) / mean[b]
    for s in (s2, s3):
        r = s.std(0, ddof=1)[b] / s.mean(0)[b]
        assert np.mean(r / r_mom) == pytest.approx(1.0, abs=4 * math.sqrt(1 / (2 * n)) / math.sqrt(b.size) + 0.01)
    # the bins decorrelate within a block: nearly M looks in every bin of the line
    assert np.all(looks[b] > 0.9 * M64.blocks_per_estimate)
    # estimator scatter (median): tier 2 and tier 3 within their sampling error
    e2 = estimate(s2, M64).speed_e
    e3 = estimate(s3, M64).speed_e
    sd2, sd3 = np.nanstd(e2, ddof=1), np.nanstd(e3, ddof=1)
    assert sd3 / sd2 == pytest.approx(1.0, abs=4 * math.sqrt(1 / n))
    assert abs(np.nanmean(e3) - np.nanmean(e2)) < 4 * sd2 * math.sqrt(2 / n)


def _record(line, inst, cell_length, n):
    """Cell speeds of n estimates, the line advected by U / 50 = 0.16 m per estimate (Taylor)."""
    x, u = line
    period = x[-1] + (x[1] - x[0])
    cells = StaringLidar(instrument=inst, cell_length=cell_length).cells()
    pos = inst.focus + cells.s_s[None, :] + 300.0 + (U / 50.0) * np.arange(n)[:, None]
    return U + np.interp(np.mod(pos, period), x, u, period=period), cells.weight_s


def _scatter(inst, v, w, spec_of_seed):
    """Per-bin relative scatter (rms over the line's bins) and the median's noise scatter (two seeds)."""
    mean, var, _ = continuum_moments(inst, v, w, CNR, SPREAD, correlation_time=TAU)
    noise = noise_floor(inst)
    peak = mean - noise > 2.0 * noise
    s1, s2 = spec_of_seed(mean, var, 1), spec_of_seed(mean, var, 2)
    rel_model = math.sqrt(np.mean((var / mean**2)[peak]))
    rel_drawn = math.sqrt(np.mean(((s1 - mean) / mean)[peak] ** 2))
    d = estimate(s1, inst).speed_e - estimate(s2, inst).speed_e
    return rel_model, rel_drawn, float(np.nanstd(d, ddof=1) / math.sqrt(2.0)), int(np.count_nonzero(peak))


def test_tier2_converges_when_cells_are_halved(line):
    # the prototype (M = 1953) over a 60 s record of volumes advected through the beam
    n = 3000
    out = {}
    for cl in (0.5, 0.25):
        v, w = _record(line, PROTOTYPE_2003, cl, n)
        out[cl] = _scatter(PROTOTYPE_2003, v, w, lambda mean, var, seed: sample_moments(mean, var, seed))
    (ra, da, sa, nb), (rb, db, sb, _) = out[0.5], out[0.25]
    # stated: the per-bin relative scatter changes by less than 2 % (model and drawn), the
    # median's scatter by less than 6 % (its sampling error sqrt(1 / (2 n)) = 1.3 % per run, 4 sigma)
    assert rb / ra == pytest.approx(1.0, abs=0.02)
    assert db / da == pytest.approx(1.0, abs=0.02)
    assert sb / sa == pytest.approx(1.0, abs=0.06)
    # the drawn per-bin scatter is the model's: nearly M independent looks, so about 1 / sqrt(M)
    assert da / ra == pytest.approx(1.0, abs=4 * math.sqrt(1 / (2 * n * nb)) + 0.005)
    assert 1.0 / math.sqrt(PROTOTYPE_2003.blocks_per_estimate) < ra < 1.5 / math.sqrt(
        PROTOTYPE_2003.blocks_per_estimate)


def test_tier3_converges_when_cells_are_halved(line):
    n = 240
    out = {}
    for cl in (0.5, 0.25):
        v, w = _record(line, M64, cl, n)

        def t3(mean, var, seed, v=v, w=w):
            return simulate_signal_spectra(M64, v, w, CNR, seed, correlation_time=TAU, speed_spread=SPREAD)

        out[cl] = _scatter(M64, v, w, t3)
    (ra, da, sa, nb), (_, db, sb, _) = out[0.5], out[0.25]
    assert db / da == pytest.approx(1.0, abs=4 * math.sqrt(1 / (2 * n * nb)) + 0.01)
    assert sb / sa == pytest.approx(1.0, abs=4 * math.sqrt(1 / (2 * n)) * math.sqrt(2))
    # and tier 3's drawn per-bin scatter is tier 2's model
    assert da / ra == pytest.approx(1.0, abs=4 * math.sqrt(1 / (2 * n * nb)) + 0.01)


def test_uniform_target_converges_when_cells_are_halved():
    # one speed in every cell: the relative scatter of the line's power (3 bins about the peak)
    from cwlidar_sim.signal import expected_spectrum, sample_spectra, speckle_looks
    from cwlidar_sim.beam import weight_truncated

    inst, n, v, tau = M64, 500, 9.0, M64.speckle_time(1.0)
    m_eff = speckle_looks(inst.blocks_per_estimate, inst.block_duration, tau)
    res = {}
    for nc in (8, 16):
        w = weight_truncated(inst.optics(), "exact", span=20.0, n_cells=nc, renormalise=True).weight_s
        sig, noise = expected_spectrum(inst, np.full(nc, v), w, -10.0, correlation_time=tau)
        k = int(np.argmax(sig[0]))
        s2 = sample_spectra(sig, noise, inst.blocks_per_estimate, m_eff, 6, n_estimates=4 * n)
        s3 = simulate_signal_spectra(inst, np.full((n, nc), v), w, -10.0, 7 + nc, correlation_time=tau)
        for name, s in (("t2", s2), ("t3", s3)):
            p = s[:, k - 1:k + 2].sum(1)
            res[name, nc] = p.std(ddof=1) / p.mean()
    # tier 2: the spectrum does not depend on the cut at all
    assert res["t2", 16] == pytest.approx(res["t2", 8], rel=1e-6)
    # tier 3: a sum of AR(1) amplitudes at one frequency has the law of one (other samples)
    tol = 4 * math.sqrt(1 / (2 * n)) * math.sqrt(2)
    assert res["t3", 16] / res["t3", 8] == pytest.approx(1.0, abs=tol)
    # and tier 3 agrees with tier 2 (whose relative scatter is about 1 / sqrt(M_eff))
    assert res["t3", 8] / res["t2", 8] == pytest.approx(1.0, abs=tol)
    assert res["t2", 8] == pytest.approx(1 / math.sqrt(m_eff), rel=0.15)


# ---------------------------------------------------------------------------
# RIN and the 0 Hz reflection
# ---------------------------------------------------------------------------
def test_noise_floor_against_the_definition():
    inst = SHOT.replace(rin_level=20.0, rin_corner=2e6, reflection_level=500.0, reflection_corner=4e4)
    nf = noise_floor(inst)
    n = inst.n_fft
    d = np.arange(-(n - 1), n)
    r = noise_correlation(inst, n)
    k = np.arange(n // 2 + 1)
    # the defining lag sum with the rect window's (1 - |d| / N)
    ref = 1.0 + np.array([np.sum((1 - np.abs(d) / n) * r[np.abs(d)] * np.cos(2 * np.pi * kk * d / n)) for kk in k])
    assert np.allclose(nf, ref, rtol=1e-10)
    # and, for the RIN alone away from 0 Hz (smooth on the scale of a bin), the AR(1) density
    rin = SHOT.replace(rin_level=20.0, rin_corner=2e6)
    rho = math.exp(-2 * math.pi * 2e6 / inst.sample_rate)
    om = 2 * np.pi * k / n
    dens = 20.0 * (1 - rho) ** 2 / (1 - 2 * rho * np.cos(om) + rho**2)
    assert np.allclose(noise_floor(rin)[5:] - 1.0, dens[5:], rtol=0.02)
    # the Lorentzian it approximates below f_s / 10
    f = inst.frequencies_f
    lor = 20.0 / (1 + (f / 2e6) ** 2)
    sel = (k >= 5) & (f < 5e6)
    assert np.allclose(noise_floor(rin)[sel] - 1.0, lor[sel], rtol=0.06)


def test_tier3_noise_matches_noise_floor():
    inst = M64.replace(rin_level=50.0, rin_corner=1e6, reflection_level=800.0, reflection_corner=3e4)
    n = 150
    s3 = simulate_signal_spectra(inst, np.zeros((n, 1)), np.ones(1), -200.0, 8)
    nf = noise_floor(inst)
    rel = s3.mean(0) / nf - 1
    # per bin: 4.5 sigma of sqrt(1 / (n M)) (bins near 0 Hz correlate across blocks: a bit more)
    se = np.sqrt(1.0 / (n * inst.blocks_per_estimate))
    assert np.all(np.abs(rel[1:-1]) < 6 * se)
    assert abs(rel[1:-1].mean()) < 4 * se / math.sqrt(inst.n_bins - 2) * 2


def test_rin_level_100_tier3_works_as_tier2():
    # tier 3 adds the RIN to the signal: the estimates no longer all fail (they did before)
    from cwlidar_sim.signal import simulate_uniform

    inst = M64.replace(rin_level=100.0)
    n = 200
    av = {}
    for tier in ("spectral", "signal"):
        est, _ = simulate_uniform(6.0, -15.0, instrument=inst, tier=tier, n=n, seed=2)
        av[tier] = est.availability
        assert np.nanmedian(est.speed_e) == pytest.approx(6.0, abs=0.1)
    a = av["spectral"]
    assert 0.5 < a < 1.0
    assert abs(av["signal"] - a) < 4 * math.sqrt(2 * a * (1 - a) / n)


def test_tier3_continuum_same_bits_for_any_thread_count_and_chunk():
    from cwlidar_sim import _config

    inst = M64.replace(blocks_per_estimate=16)
    v = np.linspace(7.0, 8.0, 9)
    w = np.full(9, 1 / 9)
    kw = dict(correlation_time=TAU, speed_spread=0.08)
    old = _config.get_num_threads()
    try:
        _config.set_num_threads(1)
        ref = simulate_signal_spectra(inst, np.tile(v, (7, 1)), w, -8.0, 4, **kw)
        _config.set_num_threads(2)
        a = simulate_signal_spectra(inst, np.tile(v, (7, 1)), w, -8.0, 4, chunk_samples=3 * 16 * 512, **kw)
    finally:
        _config.set_num_threads(old)
    assert np.array_equal(ref, a)
    # the first estimates do not depend on how many follow
    b = simulate_signal_spectra(inst, np.tile(v, (3, 1)), w, -8.0, 4, **kw)
    assert np.array_equal(ref[:3], b)
