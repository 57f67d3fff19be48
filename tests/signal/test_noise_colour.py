"""Tier 3's RIN and 0 Hz reflection as a colouring of the shot noise (heterodyne.noise_filter).

Shot noise plus the AR(1) components is one stationary Gaussian process; tier 3 draws it as
``y = a0 z + u_1 + u_2``, ``u_c[n] = rho_c u_c[n-1] + b_c z[n]``, from the shot-noise normals.
Checked: the filter's correlation against ``noise_correlation`` (exact, from the impulse
response), the blocked scan against the plain-Python reference (bit for bit) and the serial
recursion, the samples' correlation and each estimate's stationary start against the theory
(tolerances: standard errors from the scatter between independent estimates), the averaged
periodogram's mean and variance against tier 2's exact moments, and bits that do not depend
on threads or chunks.
"""

import math
import threading

import numpy as np
import pytest

from cwlidar_sim import _config
from cwlidar_sim._fft import rfft_rows
from cwlidar_sim.signal import CS_SERIES, PROTOTYPE_2003, noise_floor, simulate_signal_spectra, synthesize_samples
from cwlidar_sim.signal import _kernels as K
from cwlidar_sim.signal.heterodyne import _filter_powers, _InOrder, _tone_tables, noise_filter
from cwlidar_sim.signal.spectral import continuum_moments, noise_correlation

import reference  # noqa: E402

SHOT = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)


def _instruments():
    yield PROTOTYPE_2003
    yield CS_SERIES
    yield SHOT.replace(rin_level=10.0, rin_corner=3e5)
    yield SHOT.replace(reflection_level=1000.0)
    yield SHOT.replace(rin_level=20.0, rin_corner=2e6, reflection_level=500.0, reflection_corner=4e4)
    # equal corners are one component; nearly equal ones stay two, well conditioned
    yield SHOT.replace(rin_level=10.0, rin_corner=3e4, reflection_level=1000.0, reflection_corner=3e4)
    yield SHOT.replace(rin_level=10.0, rin_corner=3.0001e4, reflection_level=1000.0, reflection_corner=3e4)
    # extremes of the allowed ranges
    yield SHOT.replace(rin_level=1e12, rin_corner=50e6, reflection_level=1e12, reflection_corner=50.0)
    yield SHOT.replace(rin_level=1e-6, rin_corner=1e6, reflection_level=1e9, reflection_corner=51.0)


@pytest.mark.parametrize("inst", list(_instruments()), ids=lambda i: f"{i.rin_level:g}@{i.rin_corner:g}"
                         f"+{i.reflection_level:g}@{i.reflection_corner:g}")
def test_filter_spectrum_is_the_noise_spectrum(inst):
    # |a0 + sum_c b_c / (1 - rho_c e^{-iw})|^2 = 1 + sum_c var_c (1 - rho_c^2) / |1 - rho_c e^{-iw}|^2 at all w
    cf = noise_filter(inst)
    w = np.concatenate([[0.0], np.geomspace(1e-9, np.pi, 400)])
    e = np.exp(-1j * w)
    h = cf[0] + cf[1] / (1 - cf[3] * e) + cf[2] / (1 - cf[4] * e)
    want = np.ones_like(w)
    for p0, fc in ((inst.rin_level, inst.rin_corner), (inst.reflection_level, inst.reflection_corner)):
        rho = math.exp(-2 * math.pi * fc / inst.sample_rate)
        want += p0 * (1 - rho) / (1 + rho) * (1 - rho**2) / np.abs(1 - rho * e) ** 2
    assert np.allclose(np.abs(h) ** 2, want, rtol=1e-10, atol=0)
    # the stationary covariance's Cholesky factor
    b, rho = cf[1:3], cf[3:5]
    cov = np.outer(b, b) / (1 - np.outer(rho, rho))
    L = np.array([[cf[5], 0.0], [cf[6], cf[7]]])
    assert np.allclose(L @ L.T, cov, rtol=1e-12, atol=1e-14 * cov.max())


@pytest.mark.parametrize("inst", [PROTOTYPE_2003, CS_SERIES], ids=["prototype", "cs"])
def test_filter_correlation_is_the_noise_correlation(inst):
    # in the lag domain, from the filter's impulse response (plain Python reference)
    cf = noise_filter(inst)
    lags = np.unique(np.concatenate([np.arange(40), np.geomspace(40, 40000, 12).astype(int)]))
    r = reference.signal_noise_filter_correlation(cf, lags)
    want = noise_correlation(inst, int(lags.max()) + 1)[lags]
    want[0] += 1.0
    assert np.allclose(r, want, rtol=1e-10, atol=1e-12 * want[0])


def test_single_component_closed_form():
    # 1 + q / |1 - rho B|^2 = sigma^2 |1 - beta B|^2 / |1 - rho B|^2: beta + 1/beta = (1 + rho^2 + q) / rho,
    # sigma^2 = rho / beta, a0 = sigma beta / rho = sqrt(beta / rho), b = sigma (1 - beta / rho)
    inst = SHOT.replace(rin_level=10.0, rin_corner=3e5)
    rho = math.exp(-2 * math.pi * 3e5 / inst.sample_rate)
    q = 10.0 * (1 - rho) / (1 + rho) * (1 - rho**2)
    c = (1 + rho**2 + q) / rho
    beta = (c - math.sqrt(c * c - 4)) / 2
    cf = noise_filter(inst)
    assert cf[0] == pytest.approx(math.sqrt(beta / rho), rel=1e-13)
    assert cf[1] == pytest.approx(math.sqrt(rho / beta) * (1 - beta / rho), rel=1e-11)
    assert cf[3] == pytest.approx(rho, rel=1e-15) and cf[2] == 0.0 and cf[4] == 0.0
    assert noise_filter(SHOT).shape == (0,)


@pytest.mark.parametrize("n", [16, 18, 512, 1030])
def test_colour_noise_block_against_reference_and_recursion(n):
    cf = noise_filter(PROTOTYPE_2003)
    pw = _filter_powers(cf, n)
    rng = np.random.default_rng(n)
    z = rng.standard_normal((3, n))
    # the kernel takes the normals times b_1
    y = cf[1] * z
    st = np.array([0.7, -1.1])
    ref_st = list(st)
    serial = []
    u1, u2 = st
    for b in range(3):
        w = y[b].copy()
        K.colour_noise_block(y[b], cf, pw, st)
        r, ref_st = reference.signal_colour_noise(w, cf, ref_st)
        # the same IEEE operations in the same order
        assert np.array_equal(y[b], r)
        for v in z[b]:
            u1 = cf[3] * u1 + cf[1] * v
            u2 = cf[4] * u2 + cf[2] * v
            serial.append(cf[0] * v + u1 + u2)
    assert np.array_equal(st, ref_st)
    # the blocked scan against the plain recursion: a few ulp of |y| <~ 10
    assert np.allclose(y.ravel(), serial, rtol=0, atol=1e-13)
    assert np.allclose(st, [u1, u2], rtol=0, atol=1e-14)


def test_synth_blocks_coloured_against_reference():
    rng = np.random.default_rng(11)
    n, n_sub, ns, m, ne = 64, 2, 2, 3, 3
    nb = m * ne
    are = rng.normal(size=(ns, nb * n_sub))
    aim = rng.normal(size=(ns, nb * n_sub))
    phase = rng.uniform(0, 2 * np.pi, (ne, ns))
    dth = rng.uniform(-3.1, 3.1, (ne, ns))
    win = np.ones(n)
    tab, ph_re, ph_im = _tone_tables(phase, dth, n, m)
    cf = noise_filter(PROTOTYPE_2003.replace(n_fft=n))
    pw = _filter_powers(cf, n)
    acc, words, tails = np.empty(n), np.empty(n // 2, dtype=np.uint64), np.empty(n, dtype=np.int64)
    out = np.empty((nb, n), dtype=np.float32)
    state = np.zeros(2)
    # in two calls: the state carries over from the first to the second
    for lo, hi in ((0, 4), (4, nb)):
        K.synth_blocks_kernel(np.uint64(5), 7, lo, hi, m, n_sub, are, aim, tab, ph_re, ph_im, 1.0, win, False,
                              np.empty((0, 0)), np.uint64(77), 10, cf, pw, state, acc, words, tails, out[lo:hi])
    ref_state = [0.0, 0.0]
    ref = reference.signal_synth_blocks(5, 7, 0, nb, m, n_sub, are, aim, phase, dth, 1.0, win,
                                        colour=(77, 10, cf, ref_state))
    # table normals against exact ndtri (|dz| < 1e-4, carried by the filter's gain |H| < 3), float32 (1e-6)
    assert np.allclose(out, ref, rtol=0, atol=5e-4)
    assert np.allclose(state, ref_state, rtol=0, atol=5e-4)


def test_samples_have_the_noise_correlation():
    # 24 estimates of 400 blocks (204 800 samples, ~770 reflection correlation times each), no signal
    inst = PROTOTYPE_2003.replace(blocks_per_estimate=400)
    ne = 24
    x = synthesize_samples(inst, np.zeros((ne, 1)), np.ones(1), -200.0, 5).astype(np.float64).reshape(ne, -1)
    want = noise_correlation(inst, 1201)
    want[0] += 1.0
    for t in (0, 1, 2, 8, 40, 128, 265, 600, 1200):
        per_e = np.mean(x[:, : x.shape[1] - t] * x[:, t:], axis=1)
        se = per_e.std(ddof=1) / math.sqrt(ne)
        assert abs(per_e.mean() - want[t]) < 4.5 * se, t
    # and not the white shot noise (RIN, reflection off): the test can fail
    assert np.mean(x[:, :-100] * x[:, 100:]) > 10 * se


def test_each_estimate_starts_stationary():
    # the first and last sample of each of 3000 short estimates: variance r(0), lag-1 products r(1)
    inst = PROTOTYPE_2003.replace(blocks_per_estimate=2)
    ne = 3000
    x = synthesize_samples(inst, np.zeros((ne, 1)), np.ones(1), -200.0, 6).astype(np.float64).reshape(ne, -1)
    r = noise_correlation(inst, 2)
    r[0] += 1.0
    for col in (0, 1, x.shape[1] - 1):
        v = x[:, col] ** 2
        assert abs(v.mean() - r[0]) < 4.5 * v.std(ddof=1) / math.sqrt(ne), col
    p = x[:, 0] * x[:, 1]
    assert abs(p.mean() - r[1]) < 4.5 * p.std(ddof=1) / math.sqrt(ne)
    # estimates are independent: the last sample of one and the first of the next do not correlate
    c = x[:-1, -1] * x[1:, 0]
    assert abs(c.mean()) < 4.5 * c.std(ddof=1) / math.sqrt(ne - 1)


def test_periodogram_mean_and_variance_match_tier2_moments():
    # the M-block average of noise alone: tier 2's exact mean (noise_floor) and variance (block-lag
    # correlations of the noise, continuum_moments' c^noise_k(j)) against 800 tier-3 estimates
    inst = PROTOTYPE_2003.replace(blocks_per_estimate=32)
    n = 800
    s3 = simulate_signal_spectra(inst, np.zeros((n, 1)), np.ones(1), -200.0, 12)
    mean, var, _ = continuum_moments(inst, np.zeros((1, 1)), np.ones(1), -200.0, 0.5)
    assert np.allclose(mean[0], noise_floor(inst), rtol=1e-12)
    m_emp = s3.mean(0)
    v_emp = s3.var(0, ddof=1)
    z = (m_emp - mean[0]) / np.sqrt(var[0] / n)
    assert np.all(np.abs(z) < 4.5) and abs(z.mean()) < 4.5 / math.sqrt(z.size)
    # relative sd of a variance from n draws of a near-Gamma variable of M ~ 32 looks: sqrt(2 / n) (1.02)
    rel = v_emp / var[0] - 1
    sd = math.sqrt(2.0 / n) * 1.05
    assert np.all(np.abs(rel) < 4.5 * sd)
    # the lowest bins together (the reflection's 5 us correlation reaches across blocks there)
    assert abs(rel[:6].mean()) < 4.5 * sd / math.sqrt(3)


def test_bits_do_not_depend_on_threads_tasks_or_chunks():
    # N = 2048: tasks of 16 blocks, M = 40 -> three tasks per estimate, the filter's state crossing two
    inst = PROTOTYPE_2003.replace(n_fft=2048, blocks_per_estimate=40)
    v = np.linspace(2, 14, 12).reshape(4, 3)
    w = [0.2, 0.3, 0.5]
    kw = dict(correlation_time=4e-6)
    old = _config.get_num_threads()
    res = []
    try:
        for nt, chunk in ((1, 1 << 22), (2, 1), (3, 3 * 40 * 2048)):
            _config.set_num_threads(nt)
            res.append((simulate_signal_spectra(inst, v, w, -3.0, 21, chunk_samples=chunk, **kw),
                        synthesize_samples(inst, v, w, -3.0, 21, **kw)))
    finally:
        _config.set_num_threads(old)
    for a, b in res[1:]:
        assert np.array_equal(a, res[0][0]) and np.array_equal(b, res[0][1])
    # the spectra are those of the synthesised samples; the first estimates do not depend on the others
    p = np.abs(rfft_rows(res[0][1]).astype(np.complex128)) ** 2 / 2048
    assert np.allclose(res[0][0], p.reshape(4, 40, -1).mean(axis=1), rtol=1e-4, atol=0)
    assert np.array_equal(simulate_signal_spectra(inst, v[:2], w, -3.0, 21, **kw), res[0][0][:2])


def test_in_order_runs_each_estimates_tasks_in_order_and_fails_cleanly():
    order = _InOrder(2, True)
    seen = []
    lock = threading.Lock()

    def task(e, r):
        with order.turn(e, r):
            with lock:
                seen.append((e, r))

    threads = [threading.Thread(target=task, args=(e, r)) for r in (2, 1, 0) for e in (1, 0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=10)
    assert not any(t.is_alive() for t in threads)
    for e in (0, 1):
        assert [r for ee, r in seen if ee == e] == [0, 1, 2]
    # a failing task wakes the one waiting for it, which fails too (no hang)
    order = _InOrder(1, True)
    errors = []

    def waiter():
        try:
            with order.turn(0, 1):
                pass
        except RuntimeError as exc:
            errors.append(exc)

    t = threading.Thread(target=waiter)
    t.start()
    with pytest.raises(ZeroDivisionError):
        with order.turn(0, 0):
            1 / 0
    t.join(timeout=10)
    assert not t.is_alive() and len(errors) == 1
