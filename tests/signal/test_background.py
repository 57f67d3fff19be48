"""Background calibration: gain mismatch and drift against their analytic effect; the threshold raise readings."""

import math

import numpy as np
import pytest
import xarray as xr
from scipy.stats import gamma

from cwlidar_sim.sensors import StaringLidar, measure_staring
from cwlidar_sim.signal import PROTOTYPE_2003, estimate
from cwlidar_sim.signal.processing import background_gain, raised_level, threshold_levels

# shot-noise-limited: RIN and reflection off (they are tested in test_continuum)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)


def test_background_gain_follows_the_a2012_schedule():
    inst = P.replace(background_mismatch=0.01, background_drift=0.03)
    assert inst.background_interval == 10800.0 and inst.background_duration == 600.0
    g = background_gain(inst, [600.0, 600.0 + 5100.0, 10800.0 - 1e-6, 10800.0 + 600.0, 2 * 10800.0 + 600.0 + 5100.0])
    assert np.allclose(g, [1.01, 1.025, 1.04, 1.01, 1.025])
    with pytest.raises(ValueError, match="background_duration"):
        P.replace(background_duration=10800.0)
    with pytest.raises(ValueError, match="background_mismatch"):
        P.replace(background_mismatch=-0.6)


def _calm(n=4096, dx=0.5):
    z = np.zeros(n)
    return xr.Dataset({"u": ("x", z), "v": ("x", z), "w": ("x", z)}, coords={"x": dx * np.arange(n)})


def _noise_availability(inst, g):
    """Probability that a signal-free spectrum has a bin above the threshold, the floor seen with gain g.

    A bin of the M-block average of noise is Gamma(M, 1/M) (exact background), so it passes
    ``y > t`` when ``g Gamma > 1 + t``; the bins first_bin .. N/2 - 1 are independent.
    """
    m = inst.blocks_per_estimate
    t = threshold_levels(inst)["t"]
    p = gamma.sf(m * (1.0 + t) / g, m)
    nb = inst.n_bins - 1 - inst.first_bin
    return 1.0 - (1.0 - p) ** nb


@pytest.mark.parametrize("mismatch", [0.0, 0.0288, -0.02])
def test_gain_mismatch_against_its_effect_on_the_threshold(mismatch):
    inst = P.replace(background_mismatch=mismatch)
    lid = StaringLidar(instrument=inst, cnr_db=-100.0, cell_length=5.0, exact_background=True, transverse_speed=1.0)
    n = 3000
    rec = measure_staring(_calm(), lid, np.arange(n) / 50.0, 0.0, 11, calibration_time=600.0)
    a = _noise_availability(inst, 1.0 + mismatch)
    tol = 4 * math.sqrt(max(a * (1 - a), 1.0 / n) / n)
    # the law is that of a finite estimate (some bin above the threshold); availability leaves out the
    # false alarms flagged NEAR_ZERO / NEAR_NYQUIST as well
    finite = np.isfinite(rec.speed_e).mean()
    assert finite == pytest.approx(a, abs=tol) and rec.availability <= finite
    if mismatch > 0:
        assert 0.3 < a < 0.9  # the floor lifted by 2.9 % puts the 4-sigma threshold at 2.65 sigma


def test_drift_between_calibrations_against_its_effect():
    # 1 h into the cycle with a drift of 0.04 per 3 h: g = 1 + 0.04 * 3600 / 10200 = 1.0141
    inst = P.replace(background_drift=0.04)
    lid = StaringLidar(instrument=inst, cnr_db=-100.0, cell_length=5.0, exact_background=True, transverse_speed=1.0)
    n = 3000
    t = np.arange(n) / 50.0
    rec = measure_staring(_calm(), lid, t, 0.0, 12, calibration_time=4200.0)
    g = background_gain(inst, t + 4200.0)
    assert g[0] == pytest.approx(1.0 + 0.04 * 3600 / 10200)
    a = np.mean(_noise_availability(inst, g))
    assert np.isfinite(rec.speed_e).mean() == pytest.approx(a, abs=4 * math.sqrt(a * (1 - a) / n))
    assert rec.info["background_gain"][0] == pytest.approx(g[0])


# ---------------------------------------------------------------------------
# threshold raise: two readings, one rule for every kind
# ---------------------------------------------------------------------------
def test_raise_readings():
    thr = threshold_levels(P)
    t = thr["t"]
    lvl = P.replace(threshold_raise_percent=5.0)
    exc = lvl.replace(threshold_raise_reading="excess")
    assert raised_level(t, lvl) == pytest.approx((1 + t) * 1.05 - 1)
    assert raised_level(t, exc) == pytest.approx(1.05 * t)
    k0 = 90
    for excess, ok_level, ok_excess in ((1.04, False, False), (1.06, False, True), (1.0 + 0.05 * (1 + t) / t + 0.01,
                                                                                  True, True)):
        spec = np.ones(P.n_bins)
        spec[k0] = 1 + t * excess
        assert np.isfinite(estimate(spec, P).speed_e[0])
        assert np.isfinite(estimate(spec, lvl).speed_e[0]) == ok_level
        assert np.isfinite(estimate(spec, exc).speed_e[0]) == ok_excess


@pytest.mark.parametrize("kind, value", [("sigma", 4.0), ("snr", 0.3), ("peak_fraction", 0.4)])
@pytest.mark.parametrize("reading", ["level", "excess"])
def test_every_kind_raised_by_the_same_rule(kind, value, reading):
    inst = P.replace(threshold_kind=kind, threshold_value=value, threshold_raise_percent=20.0,
                     threshold_raise_reading=reading)
    spec = np.ones(P.n_bins)
    spec[100] = 3.0  # y = 2, the peak
    base = threshold_levels(inst)["t"] * (2.0 if kind == "peak_fraction" else 1.0)
    lev = raised_level(base, inst)
    # a second bin just above / below the raised level: in or out of the thresholded spectrum,
    # seen by the centroid (the peak bin alone gives bin 100 exactly)
    for d, inside in ((1e-6, True), (-1e-6, False)):
        s = spec.copy()
        s[104] = 1.0 + lev + d
        x = estimate(s, inst, estimator="centroid").frequency_e[0] / P.bin_width
        assert (x > 100.0 + 1e-9) == inside, (kind, reading, d)
