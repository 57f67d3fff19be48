"""Processing: thresholds, estimators (bias at high SNR, failure at low SNR), flags, registry."""

import math

import numpy as np
import pytest

from cwlidar_sim.signal import (
    ESTIMATORS,
    PROTOTYPE_2003,
    Flag,
    estimate,
    expected_spectrum,
    fejer,
    simulate_uniform,
    threshold_levels,
)

import reference  # noqa: E402

# shot-noise-limited: RIN and reflection off (they are tested in test_continuum)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)
HANN = P.replace(window="hann")


def _noise_free(inst, v_bins, cnr_db=0.0):
    sig, noise = expected_spectrum(inst, [v_bins * inst.bin_speed], [1.0], cnr_db)
    return sig + noise


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_unbiased_at_bin_centre_high_snr(name):
    # a single speed at a bin centre: every estimator is symmetric about it; with noise and
    # speckle (tier 2, CNR 0 dB: per-bin SNR 256) the mean must stay within a tenth of a bin
    v = 123 * P.bin_speed
    est, _ = simulate_uniform(v, 0.0, instrument=P, n=200, seed=1, estimator=name)
    assert est.availability == 1.0
    assert abs(np.mean(est.speed_e) - v) < 0.1 * P.bin_speed


def _parabola_vertex_offset(line, d):
    """Vertex of the parabola through a line's samples at -1 - d, -d, 1 - d, minus the true offset d."""
    yl, yc, yr = line(-1.0 - d), line(-d), line(1.0 - d)
    return 0.5 * (yl - yr) / (yl - 2.0 * yc + yr) - d


@pytest.mark.parametrize("name", list(ESTIMATORS))
@pytest.mark.parametrize("offset", [0.1, 0.25, 0.4])
def test_bias_off_centre(name, offset):
    """Off a bin centre: 'peak' (window-matched) and 'ml' are unbiased for any window.

    With a Hann window every estimator but the parabolic peak is within a tenth of a bin.
    The parabolic peak's bias is that of a parabola through three samples of the line
    shape: sinc^2(u) for the rectangular window, (sinc(u) / (1 - u^2))^2 for Hann (the
    continuous-time limits of the Fejer kernels; N = 512 makes the difference < 1e-4 bin).
    """
    k0 = 150
    lines = {P: lambda u: np.sinc(u) ** 2, HANN: lambda u: (np.sinc(u) / (1.0 - u * u)) ** 2}
    for inst in (P, HANN):
        spec = _noise_free(inst, k0 + offset)
        e = estimate(spec, inst, estimator=name)
        bias = e.frequency_e[0] / inst.bin_width - (k0 + offset)
        if name in ("peak", "ml") or (inst is HANN and name != "peak_parabolic"):
            assert abs(bias) < 0.1, (inst.window, bias)
        if name == "peak_parabolic":
            # e.g. -0.23 bin (rect) and -0.105 bin (Hann) at offset 0.25
            assert bias == pytest.approx(_parabola_vertex_offset(lines[inst], offset), abs=1e-3), inst.window


@pytest.mark.parametrize("offset", [0.25, 0.4])
def test_centroid_picket_fence_pull_of_the_rect_window(offset):
    """With the rectangular window the sampled sinc^2 line pulls the centroid toward the bin
    centre ("picket fence"): for the centroid of the whole line the pull is
    -sin(2 pi d) / (2 pi) bins (Poisson summation of u sinc^2(u) sampled at unit spacing),
    which a low threshold reproduces."""
    # the line sits mid-band (usable bins 7..255) so that the conditionally convergent
    # sum behind the pull is truncated symmetrically
    low = P.replace(threshold_kind="snr", threshold_value=1e-9)
    kc = (low.first_bin + low.n_bins - 2) // 2
    e = estimate(_noise_free(low, kc + offset), low, estimator="centroid")
    pull = -math.sin(2 * math.pi * offset) / (2 * math.pi)
    # residual: the truncation at +/-124 bins, the mirror line and the periodic aliases, O(1/N)
    assert e.frequency_e[0] / P.bin_width - (kc + offset) == pytest.approx(pull, abs=3e-3)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_flagged_nan_at_very_low_snr(name):
    # CNR -60 dB: per-bin SNR 2.6e-4, far below the 4-sigma threshold 0.09
    est, _ = simulate_uniform(8.0, -60.0, n=100, seed=2, estimator=name)
    failed = ~np.isfinite(est.speed_e)
    assert failed.mean() > 0.9
    assert np.all(est.flags_e[failed] & Flag.NO_SIGNAL)
    assert est.availability == pytest.approx(1 - failed.mean())
    assert est.flag_counts()["NO_SIGNAL"] == failed.sum()


def test_threshold_rule_and_raise():
    thr = threshold_levels(P)
    assert thr["sigma_y"] == pytest.approx(math.sqrt(1 / 1953 + 1 / P.background_blocks))
    assert thr["t"] == pytest.approx(4 * thr["sigma_y"])
    # raising by x % acts on the raw level B(1 + t): a line just above t survives 0 % and not 5 %
    k0 = 90
    spec = np.ones(P.n_bins)
    spec[k0] = 1 + thr["t"] + 0.02
    assert np.isfinite(estimate(spec, P).speed_e[0])
    e = estimate(spec, P.replace(threshold_raise_percent=5.0))
    assert not np.isfinite(e.speed_e[0]) and e.flags_e[0] & Flag.NO_SIGNAL
    # the median of an isolated bin is its centre
    assert estimate(spec, P).frequency_e[0] == pytest.approx(k0 * P.bin_width)


def test_flags_second_peak_edges():
    spec = np.ones(P.n_bins)
    spec[60:63] += [2, 4, 2]
    spec[200:202] += [3, 3]
    e = estimate(spec, P, estimator="peak")
    assert e.flags_e[0] & Flag.SECOND_PEAK
    # near Nyquist and near the blind zone
    for k, flag in ((P.n_bins - 3, Flag.NEAR_NYQUIST), (P.first_bin + 1, Flag.NEAR_ZERO)):
        spec = np.ones(P.n_bins)
        spec[k] += 5
        e = estimate(spec, P)
        assert e.flags_e[0] & flag and np.isfinite(e.speed_e[0])
    # nothing inside the blind zone is used
    spec = np.ones(P.n_bins)
    spec[2] += 50
    assert estimate(spec, P).flags_e[0] & Flag.NO_SIGNAL


def test_process_kernel_against_reference():
    rng = np.random.default_rng(7)
    inst = P.replace(n_fft=64, blocks_per_estimate=100, blind_zone_speed=0.2)
    nf = inst.n_bins
    guard = inst.edge_guard_speed / inst.bin_speed
    t = threshold_levels(inst)["t"]
    g = lambda u: float(fejer(u, 64))  # noqa: E731
    for trial in range(6):
        spec = 1 + rng.normal(0, 0.1, nf)
        c = rng.uniform(8, 22)
        spec += 3 * fejer(np.arange(nf) - c, 64) / 64 + 1.5 * fejer(np.arange(nf) + c, 64) / 64 * (trial % 2)
        spec = np.abs(spec)
        for name in ESTIMATORS:
            e = estimate(spec, inst, estimator=name)
            x_ref, f_ref = reference.signal_process_one(spec, np.ones(nf), inst.first_bin, nf - 1, t, name,
                                                        "rect", inst.second_peak_fraction, guard, g)
            x = e.frequency_e[0] / inst.bin_width
            # ml: the kernel's golden-section / table search vs scipy's bounded search
            assert x == pytest.approx(x_ref, abs=2e-3 if name == "ml" else 1e-9), name
            assert int(e.flags_e[0]) == f_ref, name


def test_registry_rejects_unknown_and_bad_spectra():
    with pytest.raises(ValueError, match="allowed: 'median', 'centroid', 'peak'"):
        estimate(np.ones(P.n_bins), P, estimator="mode")
    with pytest.raises(ValueError, match="shape"):
        estimate(np.ones(100), P)
    with pytest.raises(ValueError, match="finite"):
        estimate(np.full(P.n_bins, np.nan), P)
    with pytest.raises(ValueError, match="background_f"):
        estimate(np.ones(P.n_bins), P, np.zeros(P.n_bins))


def test_variants_share_one_reading_and_equal_estimate_bit_for_bit():
    """estimate_variants (the chain's processing of every variant) is estimate per instrument, bit for bit."""
    from cwlidar_sim.signal import estimate_variants

    rng = np.random.default_rng(12)
    inst = P.replace(n_fft=128, blocks_per_estimate=200)
    nf = inst.n_bins
    spec = np.abs(1 + rng.normal(0, 0.08, (300, nf)))
    c = rng.uniform(8, 50, 300)
    spec += 2.0 * fejer(np.arange(nf)[None, :] - c[:, None], 128) / 128
    variants = [inst, inst.replace(threshold_raise_percent=10.0), inst.replace(estimator="centroid"),
                inst.replace(estimator="peak"), inst.replace(threshold_kind="peak_fraction", threshold_value=0.3),
                inst.replace(edge_guard_speed=2.0, second_peak_fraction=0.5)]
    bg = 1.0 + 0.01 * rng.uniform(size=nf)
    got = estimate_variants(spec, variants, bg, estimators=[None, None, None, None, None, "ml"])
    from cwlidar_sim.signal import _kernels as K
    from cwlidar_sim.signal import processing as PR
    from cwlidar_sim.signal.spectral import line_shape_table

    table, over = line_shape_table(inst.n_fft, inst.window)
    for v, (g, est) in enumerate(zip(got, [None, None, None, None, None, "ml"])):
        # the single-processing kernel, one row at a time, with the arguments estimate() always built
        vi = variants[v]
        thr = threshold_levels(vi)
        x = np.empty(spec.shape[0])
        fl = np.empty(spec.shape[0], dtype=np.uint8)
        K.process_rows(spec, 1.0 / bg, vi.first_bin, nf - 1, PR._THR_IDS[vi.threshold_kind], float(vi.threshold_value),
                       thr["raise_factor"], thr["raise_offset"], thr["sigma_y"], thr["detect"],
                       PR.check_estimator(est or vi.estimator), PR._WIN_IDS[vi.window], vi.second_peak_fraction,
                       vi.edge_guard_speed / vi.bin_speed, table, over, vi.n_fft, PR._ML_HALF_WIDTH, 0,
                       spec.shape[0], x, fl)
        assert np.array_equal(g.frequency_e, x * vi.bin_width, equal_nan=True), v
        assert np.array_equal(g.flags_e, fl), v
        assert g.estimator == (est or vi.estimator)
        want = estimate(spec, vi, bg, estimator=est)
        assert np.array_equal(g.speed_e, want.speed_e, equal_nan=True), v
    # the variants differ from each other (the test is not of one processing six times)
    assert len({g.speed_e[np.isfinite(g.speed_e)].sum() for g in got}) == len(got)
    with pytest.raises(ValueError, match="n_fft/window"):
        estimate_variants(spec, [inst, inst.replace(n_fft=256)])
    with pytest.raises(ValueError, match="estimators"):
        estimate_variants(spec, [inst], estimators=[None, None])
