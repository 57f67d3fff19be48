"""Failure modes of the Doppler chain (docs/stability.md): NaN with a flag and counted, never a crash,
never an unflagged wild value, never a NaN in a mean."""

import math

import numpy as np
import pytest
from scipy.special import gammaincc

from cwlidar_sim.signal import PROTOTYPE_2003, simulate_uniform
from cwlidar_sim.signal.doppler import uniform_report
from cwlidar_sim.signal.processing import FAIL_FLAGS, SUSPECT_FLAGS, Flag

INST = PROTOTYPE_2003
# tier 3 kept cheap: short estimates (the statistics are those of any M)
INST64 = PROTOTYPE_2003.replace(blocks_per_estimate=64)


def _assert_consistent(est):
    """NaN exactly where a failure flag is set; the summary's mean and std are finite or None."""
    failed = (est.flags_e & np.uint8(FAIL_FLAGS)) != 0
    assert np.array_equal(~np.isfinite(est.speed_e), failed)
    s = est.summary()
    assert s["n_valid"] == int(np.count_nonzero(~failed))
    for key in ("mean", "std"):
        assert s[key] is None or math.isfinite(s[key])


@pytest.mark.parametrize("tier,inst,n", [("spectral", INST, 3000), ("signal", INST64, 60)])
def test_nothing_left_is_nan_flagged_and_counted(tier, inst, n):
    # no signal at all and a 6-sigma threshold (false-alarm probability ~1e-9 per bin): every estimate fails
    est, _ = simulate_uniform(8.0, -100.0, instrument=inst.replace(threshold_value=6.0), tier=tier, n=n, seed=3)
    assert np.all(np.isnan(est.speed_e))
    assert np.all(est.flags_e & np.uint8(Flag.NO_SIGNAL))
    assert est.availability == 0.0 and est.valid_fraction == 0.0
    s = est.summary()
    assert s["n_valid"] == 0 and s["mean"] is None and s["flags"]["NO_SIGNAL"] == n
    _assert_consistent(est)


def test_false_alarms_below_the_cliff_are_exactly_the_threshold_promise():
    # With no signal and the exact floor, each scanned bin's y = S/B - 1 is a Gamma(M, 1/M) - 1 draw;
    # an estimate exists when any bin exceeds t: P = 1 - (1 - Q(M, M (1 + t)))^n_bins.  These are the
    # only unflagged wrong values (the spectrum cannot tell them from a weak line): the threshold sets them.
    inst = INST.replace(threshold_value=3.0)
    n = 4000
    est, _ = simulate_uniform(8.0, -100.0, instrument=inst, n=n, seed=5, exact_background=True)
    from cwlidar_sim.signal import threshold_levels

    t = threshold_levels(inst)["t"]
    m = inst.blocks_per_estimate
    p = gammaincc(m, m * (1.0 + t))
    n_bins = inst.n_bins - 1 - inst.first_bin
    f = 1.0 - (1.0 - p) ** n_bins
    assert 0.02 < f < 0.5  # a regime with false alarms to count
    assert est.valid_fraction == pytest.approx(f, abs=4 * math.sqrt(f * (1 - f) / n))
    _assert_consistent(est)


@pytest.mark.parametrize("tier,inst,n", [("spectral", INST, 2000), ("signal", INST, 10)])
def test_near_zero_is_flagged_and_not_available(tier, inst, n):
    # the case: 0.3 m/s at 10 dB (line inside the blind zone, the 0-Hz reflection lifting the floor
    # there).  Every estimate fails (NaN, NO_SIGNAL) or is finite and flagged NEAR_ZERO, with the median of
    # those at ~0.53 m/s, except noise false alarms at the no-signal rate; none of them counts as available.
    # (the full M: with M = 64 the false alarms are frequent)
    est, _ = simulate_uniform(0.3, 10.0, instrument=inst, tier=tier, n=n, seed=1)
    _assert_consistent(est)
    finite = np.isfinite(est.speed_e)
    near = finite & ((est.flags_e & np.uint8(Flag.NEAR_ZERO)) != 0)
    assert near.any()
    assert np.median(est.speed_e[near]) > 0.3 + 2 * inst.bin_speed  # the wild value is there, and flagged
    noise, _ = simulate_uniform(8.0, -100.0, instrument=inst, tier=tier, n=max(n, 2000) if tier == "spectral" else n,
                                seed=9)
    fa = max(noise.valid_fraction, 1.0 / n)
    assert est.availability <= fa + 4 * math.sqrt(fa * (1 - fa) / n)
    assert est.valid_fraction >= est.availability + near.mean() - 1e-12
    # control: far from both edges every estimate is usable
    ok, _ = simulate_uniform(8.0, 10.0, instrument=inst, tier=tier, n=n, seed=1)
    assert ok.availability == 1.0 and not np.any(ok.flags_e & np.uint8(SUSPECT_FLAGS))


def test_every_estimate_off_the_truth_is_flagged_across_the_speed_range():
    # a sweep from 0 through the near-zero region to just below Nyquist at 10 dB: a finite estimate
    # more than 3 bins from |V| carries NEAR_ZERO or NEAR_NYQUIST, except the noise's false alarms
    # (at 0 m/s the line is in the blind zone and only noise is scanned), whose rate is the one the
    # threshold gives without any signal
    n = 500
    noise, _ = simulate_uniform(8.0, -100.0, instrument=INST, n=4000, seed=9)
    fa = noise.valid_fraction
    assert 0.0 < fa < 0.05
    bound = fa + 4 * math.sqrt(fa * (1 - fa) / n)
    nyq = INST.nyquist_speed
    for v in (0.0, 0.1, 0.5, 1.0, 2.0, 8.0, nyq - 1.0, nyq - 0.3, nyq - 0.05):
        est, _ = simulate_uniform(v, 10.0, instrument=INST, n=n, seed=2)
        _assert_consistent(est)
        wild = np.isfinite(est.speed_e) & (np.abs(est.speed_e - v) > 3 * INST.bin_speed)
        unflagged = wild & ((est.flags_e & np.uint8(SUSPECT_FLAGS)) == 0)
        assert np.count_nonzero(unflagged) / n <= bound, v


def test_beyond_nyquist_is_the_alias_and_the_report_warns():
    nyq = INST.nyquist_speed
    v = 1.1 * nyq
    est, info = simulate_uniform(v, 10.0, instrument=INST, n=500, seed=4)
    # homodyne sampling folds the line about Nyquist: the spectrum shows 2 f_N - f, no flag can know
    assert np.nanmedian(est.speed_e) == pytest.approx(2 * nyq - v, abs=2 * INST.bin_speed)
    rep = uniform_report(est, info, speed=v, cnr_db=10.0, tier="spectral", instrument=INST)
    assert "beyond Nyquist" in rep["warning"]
    ok = uniform_report(*simulate_uniform(8.0, 10.0, n=10, seed=4), speed=8.0, cnr_db=10.0, tier="spectral",
                        instrument=INST)
    assert "warning" not in ok


def test_strong_cloud_estimates_off_the_target_are_flagged():
    # a cloud far beyond the focus, 3 m/s against the aerosol's 8 m/s: estimates pulled off the
    # target by more than 3 bins carry SECOND_PEAK (or are NaN and flagged)
    for w in (1e3, 1e4, 1e5):
        est, info = simulate_uniform(8.0, -10.0, instrument=INST, n=1000, seed=6, cloud_range=1600.0,
                                     cloud_weight=w, cloud_speed=3.0)
        _assert_consistent(est)
        off = np.isfinite(est.speed_e) & (np.abs(est.speed_e - 8.0) > 3 * INST.bin_speed)
        assert np.all(est.flags_e[off] & np.uint8(Flag.SECOND_PEAK)), (w, int(np.count_nonzero(off)))


def test_peak_fraction_threshold_without_signal_fails_and_flags():
    """The peak-relative threshold detects first: noise alone gives NaN flagged NO_SIGNAL, a line is measured.

    With the detection test at 4 sigma_y, a noise-only spectrum's largest excess over the ~250 bins above
    the blind zone passes it with probability about 250 * P(z > 4) = 0.8 % (Gaussian bins of M = 1953
    blocks); 2 % is the bound (binomial 3 sigma over 500 spectra: 0.008 + 3 * 0.004).  Without the test
    (peak_detection_sigma = 0) every noise spectrum yields its highest bin: valid_fraction 1.
    """
    inst = INST.replace(threshold_kind="peak_fraction", threshold_value=0.5)
    est, _ = simulate_uniform(8.0, -100.0, instrument=inst, n=500, seed=7)
    assert est.valid_fraction < 0.02
    assert np.all(est.flags_e[~np.isfinite(est.speed_e)] & np.uint8(Flag.NO_SIGNAL))
    off, _ = simulate_uniform(8.0, -100.0, instrument=inst.replace(peak_detection_sigma=0.0), n=500, seed=7)
    assert off.valid_fraction == 1.0
    # a line well above the detection level is measured as before
    sig, _ = simulate_uniform(8.0, -20.0, instrument=inst, n=500, seed=7)
    assert sig.valid_fraction > 0.99 and abs(np.nanmean(sig.speed_e) - 8.0) < 2 * INST.bin_speed


def test_one_availability_definition_per_flag():
    """usable_mask: finite and no failure or NEAR_ZERO / NEAR_NYQUIST flag; SECOND_PEAK is informational."""
    from cwlidar_sim.signal.processing import usable_fraction, usable_mask, usable_speeds

    speed = np.array([3.0, 0.8, 19.0, 5.0, np.nan, np.nan, 4.0, 2.0])
    flags = np.array([0, Flag.NEAR_ZERO, Flag.NEAR_NYQUIST, Flag.SECOND_PEAK, Flag.NO_SIGNAL, Flag.PAUSED,
                      Flag.SECOND_PEAK | Flag.NEAR_ZERO, 0], dtype=np.uint8)
    want = np.array([True, False, False, True, False, False, False, True])
    np.testing.assert_array_equal(usable_mask(speed, flags), want)
    assert usable_fraction(speed, flags) == 3 / 8
    np.testing.assert_array_equal(usable_speeds(speed, flags), np.where(want, speed, np.nan))
    assert math.isnan(usable_fraction(np.array([]), np.array([], dtype=np.uint8)))
    with pytest.raises(ValueError, match="one shape"):
        usable_mask(speed, flags[:3])
    # DopplerEstimates.availability is the same function
    est, _ = simulate_uniform(0.8, 0.0, n=40, seed=2)  # inside the edge guard: finite, flagged NEAR_ZERO
    assert np.isfinite(est.speed_e).mean() > 0.5 and (est.flags_e & Flag.NEAR_ZERO).any()
    assert est.availability == usable_fraction(est.speed_e, est.flags_e) < est.valid_fraction
