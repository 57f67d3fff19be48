"""Tier 2: line shape (Fejer), homodyne folding, aliasing, speckle looks, the speckle draw."""

import math

import numpy as np
import pytest

from cwlidar_sim.signal import (
    PROTOTYPE_2003,
    expected_spectrum,
    fejer,
    line_shape,
    sample_spectra,
    speckle_looks,
    window_samples,
)

import reference  # noqa: E402

# shot-noise-limited: RIN and reflection off (they are tested in test_continuum)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)


def test_line_shape_is_fejer_and_sums_to_n():
    u = np.linspace(-5.3, 7.9, 301)
    # linear interpolation in a table of step h = 1/256 bin errs by at most h^2 max|G''| / 8,
    # max|G''| = |G''(0)| = 2 pi^2 N / 3: 6.4e-3 for N = 512 (G(0) = 512)
    bound = (1 / 256) ** 2 / 8 * 2 * math.pi**2 * 512 / 3
    assert np.max(np.abs(line_shape(u, 512) - fejer(u, 512))) <= bound
    for x0 in (0.0, 0.3, 17.71):
        k = np.arange(512)
        assert fejer(k - x0, 512).sum() == pytest.approx(512, rel=1e-12)  # Parseval of the Dirichlet kernel
        assert line_shape(k - x0, 512).sum() == pytest.approx(512, rel=1e-4)


@pytest.mark.parametrize("window, rho", [("hann", 1.0), ("rect", 0.98), ("hann", 0.9)])
def test_line_shape_against_double_sum(window, rho):
    n = 32
    w = window_samples(n, window)
    tau = -1.0 / (50e6 * math.log(rho)) if rho < 1 else math.inf
    for u in (0.0, 0.37, 1.5, 9.2):
        ref = reference.signal_line_shape(u, n, list(w), rho)
        assert line_shape(u, n, window, tau, 50e6) == pytest.approx(ref, rel=2e-3, abs=1e-6)


def test_expected_spectrum_power_and_folding():
    cnr_db = -3.0
    cnr = 10 ** (cnr_db / 10)
    w = np.array([0.2, 0.5, 0.3])
    v = np.array([4.0, 5.5, 7.25])
    sig, noise = expected_spectrum(P, v, w, cnr_db)
    # two-sided sum of the signal periodogram = N * signal power (Parseval); the one-sided bins
    # 1..N/2-1 hold half of it, bins 0 and N/2 once
    n = P.n_fft
    two_sided = 2 * sig[0, 1:-1].sum() + sig[0, 0] + sig[0, -1]
    assert two_sided == pytest.approx(n * cnr, rel=1e-4)
    assert np.all(noise == 1.0)
    # homodyne: the sign of the speed is lost
    sig_neg, _ = expected_spectrum(P, -v, w, cnr_db)
    assert np.allclose(sig_neg, sig, rtol=1e-12)
    # a line at a bin centre has per-bin SNR CNR * N / 2 and nothing in the other bins
    k0 = 100
    s1, _ = expected_spectrum(P, [k0 * P.bin_speed], [1.0], 0.0)
    assert s1[0, k0] == pytest.approx(n / 2, rel=1e-4)
    assert np.max(np.delete(s1[0], k0)) < 1e-6 * n


def test_aliasing_beyond_nyquist():
    # a speed beyond Nyquist shows up at f_s - f (the periodic line shape)
    k = 40
    v = (P.n_fft - k) * P.bin_speed
    s, _ = expected_spectrum(P, [v], [1.0], 0.0)
    assert int(np.argmax(s[0])) == k


def test_expected_kernel_against_reference():
    rng = np.random.default_rng(3)
    x = rng.uniform(-300, 300, size=(3, 4))
    amp = rng.uniform(0, 2, size=(3, 4))
    from cwlidar_sim.signal import _kernels as K
    from cwlidar_sim.signal.spectral import line_shape_table

    table, over = line_shape_table(64)
    out = np.empty((3, 33))
    K.expected_signal_kernel(x, amp, table, over, 64, out)
    ref = reference.signal_expected_spectrum(x, amp, lambda u: float(fejer(u, 64)), 33)
    # table interpolation bound per line value (see the Fejer test), two values per cell
    bound = (1 / over) ** 2 / 8 * 2 * math.pi**2 * 64 / 3 * 2 * amp.sum(axis=1)[:, None]
    assert np.all(np.abs(out - ref) <= bound)


def test_speckle_looks_limits_and_sum():
    tb = P.block_duration
    assert speckle_looks(1953, tb, 1e-12) == pytest.approx(1953)
    assert speckle_looks(1953, tb, math.inf) == 1.0
    assert speckle_looks(1, tb, 1e-3) == 1.0
    for m, tau in ((50, 3e-5), (1953, 1.66e-3)):
        r = math.exp(-2 * tb / tau)
        c = 2 * sum((1 - j / m) * r**j for j in range(1, m))
        assert speckle_looks(m, tb, tau) == pytest.approx(m / (1 + c), rel=1e-10)
    # the prototype at 1 m/s across the beam: ~ estimate duration / tau_c correlation times
    assert 10 < speckle_looks(1953, tb, P.speckle_time(1.0)) < 14


def test_sample_spectra_moments():
    """Mean and variance of every bin against the Gamma/noncentral-chi2 moments."""
    m, m_eff, ne = 40, 8.0, 4000
    sig, noise = expected_spectrum(P, [6.0], [1.0], -22.0)
    out = sample_spectra(sig, noise, m, m_eff, 11, n_estimates=ne)
    mean = sig[0] + noise
    # Var = sig^2 / M_eff + (noise^2 + 2 sig noise) / M (edge bins: twice the noise part)
    dof = np.full(mean.shape, 2.0)
    dof[[0, -1]] = 1.0
    var = sig[0] ** 2 / m_eff + (noise**2 + 2 * sig[0] * noise) * 2 / (dof * m)
    z = (out.mean(axis=0) - mean) / np.sqrt(var / ne)
    assert np.max(np.abs(z)) < 4.5  # 257 bins, P(|z| > 4.5) ~ 7e-6 each
    # the sample variance of a mean of ne draws has relative sd ~ sqrt(2 / ne) (more in the skewed
    # signal bins): 5 sigma = 0.11 for the noise bins; allow 0.2 in every bin
    assert np.allclose(out.var(axis=0) / var, 1.0, atol=0.2)
    # the signal gain is common to all bins of an estimate ('coherent'):
    # Cov(S_k, S_k') = sig_k sig_k' / M_eff; sd of a sample correlation ~ (1 - rho^2) / sqrt(ne) < 0.016
    k = int(np.argmax(sig[0]))
    rho = sig[0, k] * sig[0, k + 1] / m_eff / np.sqrt(var[k] * var[k + 1])
    cc = np.corrcoef(out[:, k], out[:, k + 1])[0, 1]
    assert rho > 0.2 and abs(cc - rho) < 0.08


def test_sample_kernel_against_reference():
    from cwlidar_sim.signal import _kernels as K

    rng = np.random.default_rng(5)
    sig = rng.uniform(0, 3, size=(3, 9))
    noise = rng.uniform(0.5, 2, size=9)
    gain = rng.uniform(0.5, 1.5, size=(3, 9))
    out = np.empty((3, 9))
    K.spectral_sample_kernel(sig, noise, gain, 7.0, np.uint64(1234), 5, out)
    ref = reference.signal_spectral_sample(sig, noise, gain, 7.0, 1234, e0=5)
    # the kernel's normal is a table interpolation (abs error < 1e-4 in z)
    assert np.allclose(out, ref, rtol=2e-4)


def test_bad_inputs():
    with pytest.raises(ValueError, match="cnr_db"):
        expected_spectrum(P, [1.0], [1.0], 500.0)
    with pytest.raises(ValueError, match="weight_s"):
        expected_spectrum(P, [1.0, 2.0], [1.0], 0.0)
    with pytest.raises(ValueError, match="sum"):
        expected_spectrum(P, [1.0, 2.0], [0.9, 0.9], 0.0)
    with pytest.raises(ValueError, match="m_eff"):
        sample_spectra(np.zeros(257), np.ones(257), 10, 20.0, 0)
    with pytest.raises(ValueError, match="speckle"):
        sample_spectra(np.zeros(257), np.ones(257), 10, 2.0, 0, speckle="x")


def test_draw_and_estimate_identical_over_threads_and_chunks():
    """Row tasks on the package's threads give the bits of the prange kernels, for any thread count."""
    from cwlidar_sim import _config
    from cwlidar_sim.signal import _kernels as K
    from cwlidar_sim.signal import estimate
    from cwlidar_sim.signal.processing import _ROWS_PER_TASK, threshold_levels
    from cwlidar_sim.signal.spectral import _draw_rows, _speckle_draws, line_shape_table

    inst = P.replace(n_fft=64, blocks_per_estimate=40)
    ne = 2 * _ROWS_PER_TASK + 37  # three tasks, the last one short
    v = np.linspace(2.0, 12.0, ne)[:, None] + np.array([0.0, 0.3])
    sig, noise = expected_spectrum(inst, v, [0.5, 0.5], -8.0)
    old = _config.get_num_threads()
    draws, ests = [], []
    try:
        for nt in (1, 2, 3):
            _config.set_num_threads(nt)
            for speckle in ("coherent", "independent"):
                draws.append(sample_spectra(sig, noise, 40, 6.0, 17, speckle=speckle))
            ests.append(estimate(draws[-2], inst))
    finally:
        _config.set_num_threads(old)
    for i in range(2, 6):
        assert np.array_equal(draws[i], draws[i % 2])
    for e in ests[1:]:
        assert np.array_equal(e.speed_e, ests[0].speed_e, equal_nan=True)
        assert np.array_equal(e.flags_e, ests[0].flags_e)
    # the same rows drawn in two chunks, and by the prange kernel
    key, gain = _speckle_draws(np.random.default_rng(17), ne, inst.n_bins, 6.0, "coherent")
    a = np.empty((ne, inst.n_bins))
    _draw_rows(sig[:300], noise, 40, gain[:300], key, 0, a[:300])
    _draw_rows(sig[300:], noise, 40, gain[300:], key, 300, a[300:])
    b = np.empty_like(a)
    K.spectral_sample_kernel(sig, noise, gain, 40.0, np.uint64(key), 0, b)
    assert np.array_equal(a, draws[0]) and np.array_equal(b, draws[0])
    # the estimates against the prange processing kernel
    x = np.empty(ne)
    fl = np.empty(ne, dtype=np.uint8)
    thr = threshold_levels(inst)
    table, over = line_shape_table(64, "rect")
    K.process_kernel(a, 1.0 / noise, inst.first_bin, inst.n_bins - 1, 0, float(inst.threshold_value),
                     thr["raise_factor"], thr["raise_offset"], thr["sigma_y"], thr["detect"], 0, 0,
                     inst.second_peak_fraction,
                     inst.edge_guard_speed / inst.bin_speed, table, over, 64, 8, x, fl)
    assert np.array_equal(x * inst.bin_width * inst.speed_per_hz, ests[0].speed_e, equal_nan=True)
    assert np.array_equal(fl, ests[0].flags_e)
