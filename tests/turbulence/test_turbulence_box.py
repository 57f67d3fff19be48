"""Box generation: statistics against the tensor, determinism, bad input."""

import math

import numpy as np
import pytest
import reference

from cwlidar_sim import _config
from cwlidar_sim.turbulence import (
    BoxGenerator,
    MannParameters,
    covariances,
    expected_box_covariance,
    generate_box,
    one_point_spectra,
    spectral_tensor,
)
from cwlidar_sim.turbulence.stats import box_spectra

P = MannParameters(alpha_eps=1.0, length_scale=33.6, gamma=3.9)


@pytest.mark.parametrize(
    "shape, spacing",
    [((64, 64, 64), (8.0, 8.0, 8.0)), ((4096, 32, 32), (2.0, 2.0, 2.0)), ((2048, 16, 16), (0.5, 4.0, 4.0))],
)
def test_expected_covariance_is_grid_resolved_integral(shape, spacing):
    # The cell correction makes the sum over the box's modes (plus the
    # central cell removed as the box mean) the tensor integrated over
    # |k_i| <= pi/d_i: within 1 % (quadrature of the singular origin).
    e = expected_box_covariance(P, shape, spacing)
    g = covariances(P, spacing)
    c, m = e.covariances, e.mean_covariances
    for a, b, gg in [(c.uu, m.uu, g.uu), (c.vv, m.vv, g.vv), (c.ww, m.ww, g.ww), (c.uw, m.uw, g.uw)]:
        assert (a + b) / gg == pytest.approx(1.0, abs=0.01)
    # w, blocked by the ground in the model, carries relatively less energy
    # at scales larger than the box than u does.
    assert m.ww / g.ww < m.uu / g.uu


def test_uncorrected_riemann_sum_is_far_off_for_thin_boxes():
    # Documented failure of correction="none": Phi33 ~ 1/|k|^2 near k = 0.
    # docs/guide/turbulence.md: "sigma_w^2 over ten times too large for 4096x32x32" (deterministic sums: 14.2).
    e = expected_box_covariance(P, (4096, 32, 32), (2.0, 2.0, 2.0), correction="none")
    assert e.covariances.ww / covariances(P, (2.0, 2.0, 2.0)).ww > 10


def test_box_mean_cell_holds_about_8_percent_of_u_variance():
    # docs/guide/turbulence.md: the box-mean cell of a 64 m wide box holds about 8 % of sigma_u^2 (the Mann
    # u spectrum keeps rising as k1 -> 0); w, blocked by the ground, far less.  The cell
    # integral is deterministic (7.9 % of the grid-resolved sigma_u^2, 7.7 % of the full one).
    e = expected_box_covariance(P, (4096, 32, 32), (2.0, 2.0, 2.0))
    g = covariances(P, (2.0, 2.0, 2.0))
    assert e.mean_covariances.uu / g.uu == pytest.approx(0.08, abs=0.005)
    assert e.mean_covariances.uu / covariances(P).uu == pytest.approx(0.08, abs=0.005)
    assert e.mean_covariances.ww / g.ww < 0.5 * e.mean_covariances.uu / g.uu


def test_expected_spectrum_matches_grid_resolved_analytic_midband():
    shape, spacing = (2048, 32, 32), (2.0, 2.0, 2.0)
    e = expected_box_covariance(P, shape, spacing)
    band = (e.k1_k > 0.05) & (e.k1_k < 0.5)
    F = np.array(one_point_spectra(e.k1_k[band], P, k2_max=math.pi / 2, k3_max=math.pi / 2)).T
    ratio = e.F_k4[band] / F
    # Riemann sum over (k2, k3) of a smooth integrand at these k1: 3 %.
    assert np.all(np.abs(ratio[:, :3] - 1) < 0.03), ratio[:, :3].min(axis=0)


def test_hf_compensation_restores_full_spectrum():
    shape, spacing = (1024, 16, 16), (1.0, 4.0, 4.0)
    k_nyq = math.pi / spacing[0]
    plain = expected_box_covariance(P, shape, spacing)
    comp = expected_box_covariance(P, shape, spacing, hf_compensation=True)
    i = np.argmin(np.abs(plain.k1_k - 0.64 * k_nyq))
    full = np.array(one_point_spectra(plain.k1_k[i], P))[:3]
    # The coarse lateral grid loses a large part of F11 at 0.64 Nyquist ...
    assert plain.F_k4[i, 0] / full[0] < 0.7
    # ... and the compensation restores the analytic one-point spectra.
    np.testing.assert_allclose(comp.F_k4[i, :3] / full, 1.0, atol=2e-3)


def _sample_stats(box):
    u, v, w = (box[c].values.astype(np.float64) for c in "uvw")
    return np.array([u.var(), v.var(), w.var(), ((u - u.mean()) * (w - w.mean())).mean()])


def test_box_statistics_agree_with_expectation_over_seeds():
    shape, spacing = (512, 32, 32), (4.0, 4.0, 4.0)
    gen = BoxGenerator(P, shape, spacing)
    s = np.array([_sample_stats(gen.generate(seed)) for seed in range(8)])
    e = expected_box_covariance(P, shape, spacing).covariances
    exp = np.array([e.uu, e.vv, e.ww, e.uw])
    mean, sem = s.mean(axis=0), s.std(axis=0, ddof=1) / math.sqrt(len(s))
    # Seed-to-seed scatter measured on the same runs: a mean within 4 standard
    # errors (two-sided p < 0.005 for Student's t with 7 dof).
    assert np.all(np.abs(mean - exp) < 4 * sem), (mean / exp, sem / exp)
    # The expectation itself is the grid-resolved value (see above), so this
    # also bounds the generator's bias: means within 3 % + 4 sem.
    assert np.all(np.abs(mean / exp - 1) < 0.03 + 4 * sem / np.abs(exp))


def test_box_one_point_spectra_agree_with_expectation():
    shape, spacing = (1024, 16, 16), (2.0, 2.0, 2.0)
    gen = BoxGenerator(P, shape, spacing)
    e = expected_box_covariance(P, shape, spacing)
    # The box's one-sided x-periodogram (turbulence.stats, what `cwlidar_sim box --plot` draws) against
    # the one-sided expectation: no factor between them.
    specs = np.array([box_spectra(gen.generate(seed))[1][:, :3].T for seed in range(6)])  # seed, component, k
    band = (e.k1_k > 0.05) & (e.k1_k < 0.6)
    est = specs[:, :, band].mean(axis=2)
    exp = e.F_k4[band, :3].mean(axis=0)
    mean, sem = est.mean(axis=0), est.std(axis=0, ddof=1) / math.sqrt(len(est))
    assert np.all(np.abs(mean - exp) < 4 * sem), (mean / exp, sem / exp)


def test_same_seed_same_box_any_thread_count_and_precision():
    args = (P, (96, 20, 18), (2.0, 3.0, 1.5), 123)
    a = generate_box(*args)
    old = _config.get_num_threads()
    try:
        _config.set_num_threads(1)
        b = generate_box(*args)
        _config.set_num_threads(3)
        c = generate_box(*args)
    finally:
        _config.set_num_threads(old)
    for comp in "uvw":
        assert np.array_equal(a[comp].values, b[comp].values)
        assert np.array_equal(a[comp].values, c[comp].values)
    d = generate_box(*args, dtype=np.float64)
    scale = float(np.abs(a.u.values).max())
    assert float(np.abs(d.u.values - a.u.values).max()) < 1e-5 * scale
    st = BoxGenerator(P, (96, 20, 18), (2.0, 3.0, 1.5), cache_stencil=True).generate(123)
    assert float(np.abs(st.w.values - a.w.values).max()) < 1e-5 * scale
    assert not np.array_equal(generate_box(*args[:3], 124).u.values, a.u.values)


def test_odd_sizes_are_real_and_zero_mean():
    b = generate_box(P, (45, 9, 7), (2.0, 2.0, 2.0), 3)
    for comp in "uvw":
        x = b[comp].values
        assert x.shape == (45, 9, 7) and np.all(np.isfinite(x))
        assert abs(float(x.mean())) < 1e-5 * float(x.std())


def test_keep_mean_and_sigma_u_rescale():
    b = generate_box(P, (128, 16, 16), (4.0, 4.0, 4.0), 9, sigma_u=1.7)
    u = b.u.values.astype(np.float64)
    assert u.std() == pytest.approx(1.7, rel=1e-5)
    assert b.attrs["sigma_u_target"] == 1.7
    m = generate_box(P, (128, 16, 16), (4.0, 4.0, 4.0), 9, keep_mean=True)
    z = generate_box(P, (128, 16, 16), (4.0, 4.0, 4.0), 9)
    # Same noise, only the k = 0 mode differs.
    np.testing.assert_allclose(m.v.values - m.v.values.mean(), z.v.values, atol=1e-5)


def test_sheared_box_physics():
    b = generate_box(P, (512, 32, 32), (2.0, 2.0, 2.0), 4)
    u, w = b.u.values.astype(float), b.w.values.astype(float)
    assert (u * w).mean() < 0
    # Divergence-free in spectral space away from the corrected modes.
    shape = u.shape
    k = [2 * np.pi * np.fft.fftfreq(n, 2.0) for n in shape]
    K1, K2, K3 = np.meshgrid(k[0], k[1], k[2], indexing="ij")
    U, V, W = (np.fft.fftn(b[c].values.astype(float)) for c in "uvw")
    # The cell-corrected modes (every |k_i| <= 3 max(dk)) are averages of
    # the tensor over a cell and need not be; all others must be.
    dk_max = 2 * np.pi / 64.0
    far = (np.abs(K1) > 3.01 * dk_max) | (np.abs(K2) > 3.01 * dk_max) | (np.abs(K3) > 3.01 * dk_max)
    # Nyquist modes of a real field mix +k and -k: no single k to test.
    nyq = np.zeros(shape, bool)
    nyq[shape[0] // 2], nyq[:, shape[1] // 2], nyq[:, :, shape[2] // 2] = True, True, True
    far &= ~nyq
    div = np.abs(K1 * U + K2 * V + K3 * W)[far]
    mag = (np.sqrt(K1**2 + K2**2 + K3**2) * np.sqrt(np.abs(U) ** 2 + np.abs(V) ** 2 + np.abs(W) ** 2))[far]
    assert np.max(div / np.maximum(mag, 1e-30)) < 1e-4


@pytest.mark.parametrize(
    "kw, field",
    [
        (dict(shape=(0, 8, 8)), "shape"),
        (dict(shape=(8, 8)), "shape"),
        (dict(spacing=(1.0, -1.0, 1.0)), "spacing"),
        (dict(spacing=(1.0, math.nan, 1.0)), "spacing"),
        (dict(seed=-1), "seed"),
        (dict(correction="sinc2"), "correction"),
        (dict(shape=(1 << 20, 1 << 10, 1 << 10)), "GiB"),
    ],
)
def test_bad_input_raises_before_allocation(kw, field):
    args = dict(params=P, shape=(8, 8, 8), spacing=(1.0, 1.0, 1.0), seed=0)
    args.update(kw)
    with pytest.raises(ValueError, match=field):
        generate_box(**args)


def test_bad_types():
    with pytest.raises(TypeError, match="params"):
        generate_box({"alpha_eps": 1}, (8, 8, 8), (1, 1, 1), 0)
    with pytest.raises(TypeError, match="shape"):
        generate_box(P, (8.5, 8, 8), (1, 1, 1), 0)
    with pytest.raises(TypeError, match="dtype"):
        generate_box(P, (8, 8, 8), (1, 1, 1), 0, dtype=np.int32)


# ---------------------------------------------------------------------------
# Counter-based noise of the box (ziggurat on SplitMix64 counters) and the
# tabulated amplitudes.
# ---------------------------------------------------------------------------
def _keys(seed):
    return tuple(np.uint64(k) for k in reference.box_noise_keys(seed))


def test_normals_bit_equal_to_reference_including_rejection_paths():
    from cwlidar_sim.turbulence import _kernels as K

    key, key_b = reference.box_noise_keys(11)
    _, k_tab, _ = reference.box_ziggurat_tables()
    # Counters whose first word fails the ziggurat's fast test (wedge) or
    # lands in the base layer's tail, found with the reference's own hash.
    wedge, tail = [], []
    for c in range(60000):
        w = reference.box_first_word(key, c)
        if (w >> 11) >= k_tab[w & 0xFF]:
            (tail if w & 0xFF == 0 else wedge).append(c)
    assert len(wedge) >= 100 and len(tail) >= 5
    tail = tail[:10]
    counters = list(range(200)) + wedge[:100] + tail + [2**40 + 3, 2**62 + 1, 2**64 - 1]
    got = np.array([K.normal_at(np.uint64(key), np.uint64(key_b), np.uint64(c)) for c in counters])
    ref = np.array([reference.box_normal(key, key_b, c) for c in counters])
    assert np.array_equal(got, ref)
    assert np.all(np.abs(ref[300:300 + len(tail)]) > 3.654)  # the tail draws do come from the tail
    block = np.empty(200)
    K.normals_kernel(np.uint64(key), np.uint64(key_b), np.uint64(0), block)
    assert np.array_equal(block, ref[:200])


def _normals(seed, n, c0=0):
    from cwlidar_sim.turbulence import _kernels as K

    z = np.empty(n)
    K.normals_kernel(*_keys(seed), np.uint64(c0), z)
    return z


def test_normals_moments_ks_and_tails_match_standard_normal():
    from scipy.special import ndtr
    from scipy.stats import kstest

    n = 1_000_000
    z = _normals(3, n, c0=10**9)
    # Sampling distributions under N(0, 1): sd of the mean 1/sqrt(n), of the
    # mean of z^2 sqrt(2/n), of z^3 sqrt(15/n), of z^4 sqrt((105 - 9)/n);
    # each within 5 standard deviations.
    assert abs(z.mean()) < 5 / math.sqrt(n)
    assert abs(np.mean(z**2) - 1) < 5 * math.sqrt(2 / n)
    assert abs(np.mean(z**3)) < 5 * math.sqrt(15 / n)
    assert abs(np.mean(z**4) - 3) < 5 * math.sqrt(96 / n)
    # Kolmogorov: P(sqrt(n) D > x) ~ 2 exp(-2 x^2) = 1e-6 at x = 2.69.
    assert kstest(z, "norm").statistic < 2.69 / math.sqrt(n)
    # Tail counts (binomial, within 5 sd), including beyond the ziggurat's
    # base-layer edge r = 3.654, whose samples come from the tail algorithm.
    for thr in (2.0, 3.0, 3.6541528853610088):
        p = 2 * ndtr(-thr)
        count = np.count_nonzero(np.abs(z) > thr)
        assert abs(count - n * p) < 5 * math.sqrt(n * p * (1 - p)), (thr, count, n * p)


def test_neighbouring_counters_are_independent():
    n = 1_000_000
    z = _normals(4, n)
    other = _normals(5, n)  # same counters, next seed
    # For independent N(0, 1) pairs the sample correlation of z (and of
    # z^2 - 1) has sd 1/sqrt(n): bound 4/sqrt(n).  Lags 1..12 span the six
    # normals of a mode and its neighbours.
    bound = 4 / math.sqrt(n)
    q = z**2 - 1
    for lag in range(1, 13):
        assert abs(np.corrcoef(z[:-lag], z[lag:])[0, 1]) < bound, lag
        assert abs(np.corrcoef(q[:-lag], q[lag:])[0, 1]) < bound, lag
    assert abs(np.corrcoef(z, other)[0, 1]) < bound
    assert abs(np.corrcoef(q, other**2 - 1)[0, 1]) < bound


def test_atan2_poly_matches_the_c_library():
    import numba

    from cwlidar_sim.turbulence import _kernels as K

    @numba.njit
    def run(y, x, out):
        for i in range(y.shape[0]):
            out[i] = K.atan2_poly(y[i], x[i])

    rng = np.random.default_rng(0)
    y = rng.standard_normal(100_000) * 10.0 ** rng.uniform(-8, 8, 100_000)
    x = rng.standard_normal(100_000) * 10.0 ** rng.uniform(-8, 8, 100_000)
    y = np.concatenate([y, [0.0, -0.0, 0.0, 1.0, -1.0, 2.0, 2.0, 1e-300]])
    x = np.concatenate([x, [-1.0, -1.0, 1.0, 0.0, 0.0, 2.0, -2.0, -1.0]])
    out = np.empty_like(y)
    run(y, x, out)
    ref = np.arctan2(y, x)
    assert np.all(np.signbit(out) == np.signbit(ref))
    # Degree-7 polynomial: 7.6e-13 on the reduced interval (measured on a
    # fine grid when it was chosen), plus a few roundings in the reduction.
    assert np.max(np.abs(out - ref) / np.maximum(np.abs(ref), 1e-300)) < 2e-12


def test_box_params_match_the_plain_python_tensor():
    from cwlidar_sim.turbulence import _kernels as K
    from cwlidar_sim.turbulence import box as box_mod

    shape, spacing = (4096, 32, 32), (2.0, 2.0, 2.0)
    ftab, fbase = box_mod._lifetime_nodes_table(P, shape, spacing)
    rng = np.random.default_rng(1)
    n = [rng.integers(-m // 2, m // 2, 150) for m in shape]
    n[0][:10] = 0  # k1 = 0 takes its own branch
    k = np.stack([ni * 2 * math.pi / (m * d) for ni, m, d in zip(n, shape, spacing)], axis=1)
    k = k[np.any(k != 0, axis=1)]
    par = np.empty((len(k), 5))
    K.box_params_many(k[:, 0], k[:, 1], k[:, 2], P.length_scale, P.gamma, ftab, fbase, par)
    pre = math.sqrt(P.alpha_eps / (4 * math.pi)) * P.length_scale ** (17 / 6)
    worst = 0.0
    for (k1, k2, k3), p in zip(k, par):
        m = np.empty((3, 3))
        K.matrix_from_params(*p, k1, k2, m)
        ref = np.array(reference.mann_amplitude(k1, k2, k3, P.alpha_eps, P.length_scale, P.gamma))
        worst = max(worst, np.abs(pre * m - ref).max() / np.abs(ref).max())
    # Tabulated lifetime (3.6e-7), y^(-17/12) (9e-9) and atan2 (1e-14) move
    # M by at most a few times 3.6e-7 of its largest entry.
    assert worst < 2e-6, worst


@pytest.mark.parametrize("shape, spacing", [((6, 5, 4), (2.0, 3.0, 1.5)), ((5, 6, 3), (4.0, 2.0, 2.5))])
def test_box_half_spectrum_equals_plain_python_reference(shape, spacing):
    # Mode by mode: which normals feed which mode and component, the mirror
    # (k1, -k2, k3) sharing of amplitudes, the Hermitian planes n3 = 0 and
    # Nyquist (a non-Hermitian plane, as in mannrs, would show here as
    # (c(k) + c(-k)*) / 2), the zero mean and the scale.
    box = generate_box(P, shape, spacing, 77, correction="none", dtype=np.float64)
    ref = reference.box_half_spectrum(shape, spacing, 77, P.alpha_eps, P.length_scale, P.gamma)
    for i, c in enumerate("uvw"):
        got = np.fft.rfftn(box[c].values) / math.prod(shape)
        # Amplitudes from tables (box_params: < 2e-6 of the largest entry of
        # M); the largest mode is a few rms: 1e-5 of the rms is ample.
        tol = 1e-5 * math.sqrt(np.mean(np.abs(ref[i]) ** 2))
        assert np.max(np.abs(got - ref[i])) < tol, c


def test_box_bit_identical_for_1_2_3_threads_over_several_chunks():
    from cwlidar_sim.turbulence import box as box_mod

    shape, spacing = (512, 32, 16), (2.0, 2.0, 2.0)
    assert len(box_mod._chunk_rows(shape)) >= 3  # several tasks to share out
    old = _config.get_num_threads()
    boxes = []
    try:
        for n in (1, 2, 3):
            _config.set_num_threads(n)
            box_mod._setup.cache_clear()  # the cell integrals and spectra run threaded too
            boxes.append(generate_box(P, shape, spacing, 5, hf_compensation=True))
    finally:
        _config.set_num_threads(old)
    for b in boxes[1:]:
        for comp in "uvw":
            assert np.array_equal(b[comp].values, boxes[0][comp].values)


def test_kz0_and_nyquist_planes_carry_their_expected_power():
    # With correction="none" every mode has E|c(k)|^2 = s(k) = Phi_ii(k)
    # dk1 dk2 dk3 (c = DFT / N), the public tensor's value; the z-Nyquist
    # plane stands for k3 = +-pi/dz and holds the average of the two (a
    # Hermitian pair (k, -k) needs one variance for both).  In a Hermitian
    # plane the pair (k, -k) holds one complex Gaussian twice, so the pair's
    # whitened power |c|^2/s summed over both is 2 Exp(1) (mean 2, variance
    # 4); a self-conjugate mode sqrt(2) Re c gives chi^2_1 (mean 1, variance
    # 2).  Over the plane's n modes: mean n, variance 2 n.  A plane left
    # non-Hermitian (mannrs's defect) loses half its power through the real
    # transform: mean n / 2.
    shape, spacing = (128, 16, 16), (4.0, 4.0, 4.0)
    N1, N2, N3 = shape
    dk = [2 * math.pi / (n * d) for n, d in zip(shape, spacing)]
    k1 = 2 * math.pi * np.fft.fftfreq(N1, spacing[0])
    k2 = 2 * math.pi * np.fft.fftfreq(N2, spacing[1])
    boxes = [generate_box(P, shape, spacing, s, correction="none", dtype=np.float64) for s in range(4)]
    for n3 in (0, N3 // 2):
        k3 = 2 * math.pi * np.fft.fftfreq(N3, spacing[2])[n3]
        K1, K2 = np.meshgrid(k1, k2, indexing="ij")
        phi = spectral_tensor(K1, K2, np.full_like(K1, k3), P)
        if n3 == N3 // 2:
            phi = 0.5 * (phi + spectral_tensor(K1, K2, np.full_like(K1, -k3), P))
        for i, c in enumerate("uvw"):
            s = phi[..., i, i] * dk[0] * dk[1] * dk[2]
            # Modes without this component (w along the k3 axis: divergence)
            # and the box mean (zero) hold nothing to test.
            keep = s > 1e-12 * s.max()
            keep[0, 0] &= n3 != 0
            n = len(boxes) * np.count_nonzero(keep)
            power = [np.abs(np.fft.rfftn(b[c].values)[:, :, n3] / math.prod(shape)) ** 2 for b in boxes]
            got = sum((p[keep] / s[keep]).sum() for p in power)
            z = (got - n) / math.sqrt(2 * n)
            # (a half-power defect would put z at -sqrt(n / 8), about -32 here)
            assert abs(z) < 4, (n3, c, got / n, z)


def test_shared_plan_inverse_fft_matches_numpy_for_any_thread_count():
    from cwlidar_sim import _fft

    rng = np.random.default_rng(2)
    old = _config.get_num_threads()
    try:
        for shape in [(40, 12, 10), (45, 9, 7), (16, 6)]:
            x = rng.standard_normal(shape)
            outs = []
            for n in (1, 2, 3):
                _config.set_num_threads(n)
                spec = _fft.empty_halfspectrum(shape, np.float64)
                spec[...] = np.fft.rfftn(x)  # Hermitian where it must be
                plans = _fft.new_plan_store()
                outs.append(_fft.irfftn_inplace_shared(spec, shape[-1], plans).copy())
            # Unnormalised inverse: N x; double-precision round-off only.
            np.testing.assert_allclose(outs[0], x * math.prod(shape), rtol=0, atol=1e-10 * math.prod(shape))
            assert all(np.array_equal(outs[0], o) for o in outs[1:])
    finally:
        _config.set_num_threads(old)


def test_keeping_a_doubled_box_half_in_its_own_buffer_moves_the_same_numbers():
    """keep_lateral_rows: a generated box's first ny y-rows, moved within its FFT buffer, are a[:, :ny, :] exactly."""
    from cwlidar_sim.turbulence.box import keep_lateral_rows

    p = MannParameters(0.05, 20.0, 3.9)
    for shape in ((32, 24, 10), (30, 16, 9), (20, 12, 16)):
        box = generate_box(p, shape, (2.0, 2.0, 2.0), 7)
        for c in ("u", "v", "w"):
            a = box[c].values
            assert not a.flags.c_contiguous  # padded z-rows: the in-place path
            for ny in (shape[1] // 2, shape[1]):
                want = np.ascontiguousarray(a[:, :ny, :])
                got = keep_lateral_rows(generate_box(p, shape, (2.0, 2.0, 2.0), 7)[c].values, ny)
                assert got.flags.c_contiguous and got.shape == want.shape
                np.testing.assert_array_equal(got, want)
    plain = np.arange(2 * 6 * 3, dtype=np.float32).reshape(2, 6, 3)[:, ::-1, :]  # a layout it does not move
    np.testing.assert_array_equal(keep_lateral_rows(plain, 4), plain[:, :4, :])
