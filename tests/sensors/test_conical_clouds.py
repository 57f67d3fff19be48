"""A cloud layer in the conical lidar's far tail: its weight, the biased centroid, SECOND_PEAK, inputs."""

import dataclasses
import math

import numpy as np
import pytest

from cwlidar_sim.sensors.conical import ConicalLidar, measure_conical
from cwlidar_sim.signal import CS_SERIES, Flag

from test_conical import calm_box

PHI = math.radians(30.0)
U = 10.0


def cauchy_interval(a, b, r, lam, a0):
    """Integral of the exact weighting over s in [a, b] from its closed form (beam.optics notes): a Cauchy
    density centred at s0 = -r^3 / (r^2 + z_ap^2) of half-width gamma = r^2 z_ap / (r^2 + z_ap^2),
    renormalised over s > -r (the telescope)."""
    z_ap = math.pi * a0**2 / lam
    s0 = -r**3 / (r**2 + z_ap**2)
    g = r**2 * z_ap / (r**2 + z_ap**2)
    behind = 0.5 - math.atan((r + s0) / g) / math.pi
    return (math.atan((b - s0) / g) - math.atan((a - s0) / g)) / math.pi / (1 - behind)


def look_speeds(azimuth_e, n_sub, speed, direction_deg=0.0):
    """Radial speed of a uniform horizontal motion at every look of every dwell, shape (n_e, n_sub)."""
    off = (np.arange(n_sub) + 0.5) / n_sub - 0.5
    th = np.radians(azimuth_e[:, None] + off[None, :] * 7.2 - direction_deg)
    return math.sin(PHI) * speed * np.cos(th)


def test_cloud_weight_is_the_weighting_integral_over_the_cloud():
    z, base, depth, strength = 40.0, 300.0, 30.0, 3000.0
    lid = ConicalLidar(heights=(z,), cloud_base=base, cloud_strength=strength, cloud_depth=depth)
    r = z / math.cos(PHI)
    a, b = base / math.cos(PHI) - r, (base + depth) / math.cos(PHI) - r
    i_exact = cauchy_interval(a, b, r, CS_SERIES.wavelength, CS_SERIES.telescope_radius)
    assert lid.cloud_weight(z) == pytest.approx(strength * i_exact, rel=1e-9)
    assert lid.cloud_fraction(z) == pytest.approx(strength * i_exact / (1 + strength * i_exact), rel=1e-9)
    # Lorentzian weighting: (arctan(b / z_R) - arctan(a / z_R)) / pi, cut at the telescope: over its weight in
    # front of it, 1/2 + arctan(r / z_R) / pi
    zr = 0.0013 * r**2
    front = 0.5 + math.atan(r / zr) / math.pi
    lor = lid.replace(weighting="lorentzian")
    assert lor.cloud_weight(z) == pytest.approx(
        strength * (math.atan(b / zr) - math.atan(a / zr)) / math.pi / front, rel=1e-9)
    # far tail, thin layer: ~ strength * depth / cos(Phi) * z_R / (pi s^2) / front
    thin = lor.replace(cloud_base=3000.0, cloud_depth=0.01)
    s = 3000.0 / math.cos(PHI) - r
    assert thin.cloud_weight(z) == pytest.approx(strength * 0.01 / math.cos(PHI) * zr / (math.pi * s * s) / front,
                                                 rel=1e-4)
    assert ConicalLidar(heights=(z,)).cloud_weight(z) == 0.0


def test_tier1_is_the_weighted_mean_of_aerosol_and_cloud():
    lid = ConicalLidar(heights=(40.0,), cell_length=4.0, cloud_base=300.0, cloud_strength=3000.0, cloud_speed=15.0,
                       cloud_direction_deg=40.0)
    rec = measure_conical(calm_box(lid), lid, 1.0, U)
    w = lid.cloud_weight(40.0)
    va = look_speeds(rec.azimuth_e, lid.sub_dwells, U).mean(axis=1)
    vc = look_speeds(rec.azimuth_e, lid.sub_dwells, 15.0, 40.0).mean(axis=1)
    np.testing.assert_allclose(rec.vlos_e, va, atol=1e-12)  # vlos_e stays the clear-air ideal
    mix = np.abs((va + w * vc) / (1 + w))
    ok = np.isfinite(rec.speed_e)
    np.testing.assert_allclose(rec.speed_e[ok], mix[ok], atol=1e-12)
    assert np.all(mix[~ok] < lid.instrument.blind_zone_speed)
    assert rec.info["heights"][40.0]["cloud_fraction"] == pytest.approx(w / (1 + w), rel=1e-12)


def test_low_cloud_biases_the_centroid_by_the_weights_and_raises_second_peak():
    # a uniform wind, a strong low cloud moving at twice its speed: two lines per look, of powers
    # (1 - W) and w_c relative to the aerosol's total (W the weight beyond the span, a pedestal below
    # the threshold and left out of the spectrum: cwlidar_sim.signal.chain); the centroid is their
    # power-weighted mean, look by look
    # RIN and the 0 Hz reflection off: the two-line centroid is about the lines, not the floor near 0 Hz
    quiet = dataclasses.replace(CS_SERIES, rin_level=0.0, reflection_level=0.0)
    kw = dict(heights=(40.0,), tier="spectral", cell_length=2.0, cnr_db=-10.0, exact_background=True, instrument=quiet)
    lid = ConicalLidar(cloud_base=300.0, cloud_strength=3000.0, cloud_speed=2 * U, **kw)
    clear = ConicalLidar(**kw)
    rec = measure_conical(calm_box(lid), lid, 2.0, U, 1)
    ref = measure_conical(calm_box(clear), clear, 2.0, U, 1)
    w = lid.cloud_weight(40.0)
    assert 0.8 < w < 1.1
    k = 1.0 - lid.cells(40.0).tail_weight
    va = np.abs(look_speeds(rec.azimuth_e, lid.sub_dwells, U))
    want = ((k * va + w * 2 * va) / (k + w)).mean(axis=1)
    a = np.abs(np.cos(np.radians(rec.azimuth_e)))
    sel = a > 0.4  # both lines clear of the blind zone
    d = rec.speed_e[sel] - want[sel]
    # each line's centroid through the thresholded rect-window line is off by < 0.2 bin
    tol = 0.2 * CS_SERIES.bin_speed + 4 * d.std() / math.sqrt(d.size)
    assert abs(d.mean()) < tol
    shift = np.mean(rec.speed_e[sel] - ref.speed_e[sel])
    assert shift > 1.5  # the bias itself: w / (1 - W + w) * |v_a|, about 2 m/s here
    # lines 25-32 bins apart: every estimate flagged; none without the cloud
    assert np.all(rec.flags_e[a > 0.8] & Flag.SECOND_PEAK)
    assert not np.any(ref.flags_e & Flag.SECOND_PEAK)
    # near the cross-wind azimuths the lines are within a few bins and merge: not flagged
    assert not np.any(rec.flags_e[a < 0.2] & Flag.SECOND_PEAK)


def test_cloud_moving_with_a_uniform_wind_is_clear_air_with_more_power():
    # every cell and the cloud at n.(U, 0, 0): the cloud only adds its power, w_c of the aerosol's, to the
    # lines' (1 - W) (W beyond the span, out of the spectrum), so the spectrum is the clear-air one at
    # CNR + 10 log10((1 - W + w_c) / (1 - W)) -- the same draws, the same estimates
    kw = dict(heights=(40.0,), tier="spectral", cell_length=4.0, sub_dwells=4)
    lid = ConicalLidar(cloud_base=300.0, cloud_strength=3000.0, cnr_db=-33.0, **kw)
    w = lid.cloud_weight(40.0)
    k = 1.0 - lid.cells(40.0).tail_weight
    rec = measure_conical(calm_box(lid), lid, 2.0, U, 4)
    clear = ConicalLidar(cnr_db=-33.0 + 10 * math.log10((k + w) / k), **kw)
    ref = measure_conical(calm_box(clear), clear, 2.0, U, 4)
    np.testing.assert_array_equal(np.isfinite(rec.speed_e), np.isfinite(ref.speed_e))
    np.testing.assert_allclose(rec.speed_e, ref.speed_e, rtol=1e-9)
    np.testing.assert_array_equal(rec.flags_e, ref.flags_e)
    # and near the detection limit the added power shows: more estimates than the aerosol alone gives
    weak = ConicalLidar(cnr_db=-33.0, **kw)
    assert rec.availability > measure_conical(calm_box(weak), weak, 2.0, U, 4).availability + 0.2


def test_far_or_empty_cloud_changes_nothing():
    kw = dict(heights=(40.0,), tier="spectral", cell_length=4.0, sub_dwells=4)
    clear = ConicalLidar(**kw)
    ref = measure_conical(calm_box(clear), clear, 1.0, U, 2)
    # strength 0: the cloud column has weight 0; the same draws, the same estimates to rounding
    empty = ConicalLidar(cloud_base=1000.0, cloud_strength=0.0, cloud_speed=30.0, **kw)
    rec = measure_conical(calm_box(empty), empty, 1.0, U, 2)
    np.testing.assert_allclose(rec.speed_e, ref.speed_e, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(rec.flags_e, ref.flags_e)
    # a thin cloud at 20 km: w_c ~ 1e-7, far below the speckle noise (1 / sqrt(M_eff) ~ 2 %)
    far = ConicalLidar(cloud_base=19000.0, cloud_strength=1.0, cloud_speed=30.0, **kw)
    assert far.cloud_weight(40.0) < 1e-7
    rec = measure_conical(calm_box(far), far, 1.0, U, 2)
    ok = np.isfinite(ref.speed_e)
    np.testing.assert_array_equal(np.isfinite(rec.speed_e), ok)
    assert np.max(np.abs(rec.speed_e[ok] - ref.speed_e[ok])) < 1e-4
    np.testing.assert_array_equal(rec.flags_e, ref.flags_e)


def test_tier3_sees_the_cloud_line():
    inst = CS_SERIES.replace(blocks_per_estimate=400)
    kw = dict(heights=(40.0,), tier="signal", instrument=inst, cell_length=4.0, sub_dwells=4, cnr_db=-10.0)
    lid = ConicalLidar(cloud_base=300.0, cloud_strength=3000.0, cloud_speed=2 * U, **kw)
    rec = measure_conical(calm_box(lid), lid, 1.0, U, 3)
    w = lid.cloud_weight(40.0)
    k = 1.0 - lid.cells(40.0).tail_weight
    va = np.abs(look_speeds(rec.azimuth_e, lid.sub_dwells, U))
    want = ((k * va + w * 2 * va) / (k + w)).mean(axis=1)
    sel = np.abs(np.cos(np.radians(rec.azimuth_e))) > 0.6
    d = rec.speed_e[sel] - want[sel]
    assert abs(d.mean()) < 0.2 * CS_SERIES.bin_speed + 4 * d.std() / math.sqrt(d.size)
    assert np.mean((rec.flags_e[sel] & Flag.SECOND_PEAK) != 0) > 0.9
    # near the detection limit a cloud moving with the wind adds its power to the aerosol line
    # (+2.8 dB here): availability 0.58 -> 0.92 measured, binomial scatter 0.07 on 50 estimates
    weak = dict(kw, cnr_db=-27.0)
    with_cloud = ConicalLidar(cloud_base=300.0, cloud_strength=3000.0, **weak)
    clear = ConicalLidar(**weak)
    a_cloud = measure_conical(calm_box(clear), with_cloud, 1.0, U, 3).availability
    a_clear = measure_conical(calm_box(clear), clear, 1.0, U, 3).availability
    assert a_cloud > a_clear + 0.15


def test_cloud_inputs_are_validated_by_name():
    lid = ConicalLidar(heights=(40.0, 100.0), cloud_base=1200.0, cloud_strength=1e4, cloud_speed=12.0,
                       cloud_direction_deg=20.0, cloud_depth=40.0)
    assert ConicalLidar.from_dict(lid.as_dict()) == lid
    assert ConicalLidar().cloud_base is None and ConicalLidar().cloud_strength == 0.0
    with pytest.raises(ValueError, match="cloud_strength=100.0 > 0 needs cloud_base"):
        ConicalLidar(cloud_strength=100.0)
    with pytest.raises(ValueError, match="cloud_strength=-1"):
        ConicalLidar(cloud_base=1000.0, cloud_strength=-1.0)
    with pytest.raises(ValueError, match="cloud_base=-5"):
        ConicalLidar(cloud_base=-5.0, cloud_strength=1.0)
    with pytest.raises(ValueError, match="cloud_base=25000"):
        ConicalLidar(cloud_base=25000.0, cloud_strength=1.0)
    # inside the simulated span of the 100 m beam (focus 115 m + 5 z_R = 202 m of range)
    with pytest.raises(ValueError, match=r"cloud_base=150.0 m is inside the simulated span.*allowed: \(175"):
        ConicalLidar(heights=(40.0, 100.0), cloud_base=150.0, cloud_strength=1.0)
    with pytest.raises(ValueError, match="cloud_depth=0"):
        ConicalLidar(cloud_base=1000.0, cloud_depth=0.0)
    with pytest.raises(ValueError, match="cloud_speed=-3"):
        ConicalLidar(cloud_base=1000.0, cloud_speed=-3.0)
    with pytest.raises(TypeError, match="cloud_base"):
        ConicalLidar(cloud_base="low", cloud_strength=1.0)
    with pytest.raises(ValueError, match="unknown key.*'cloud_height'"):
        ConicalLidar.from_dict({"cloud_height": 1000.0})


def test_period_under_a_cloud_moving_with_the_wind():
    from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period

    kw = dict(speed=8.0, duration=30.0, scan_revs=(1,), model=False)
    clear = simulate_conical_period(20.0, 3, **kw)
    cloudy = simulate_conical_period(20.0, 3, lidar_overrides={"cloud_base": 100.0, "cloud_strength": 2e3}, **kw)
    f = cloudy["cloud_fraction"]
    assert f == pytest.approx(ConicalLidar(heights=(20.0,), cell_length=1.0, cloud_base=100.0,
                                           cloud_strength=2e3).cloud_fraction(20.0), rel=1e-12)
    assert 0.5 < f < 0.6 and cloudy["second_peak_fraction"] == 0.0 == clear["second_peak_fraction"]
    a, b = clear["scans"][1], cloudy["scans"][1]
    # tier 1: every speed is (1 - f) v_a + f n.(U, 0, 0), so each scan's horizontal wind vector is
    # (1 - f) the clear one + f (U, 0): the fluctuations shrink by 1 - f, the mean moves toward U
    # (to second order in the direction fluctuations, (sigma_v / U)^2 ~ 1 %)
    assert b["lidar_std"] / a["lidar_std"] == pytest.approx(1 - f, rel=0.02)
    assert b["lidar_mean"] == pytest.approx((1 - f) * a["lidar_mean"] + f * 8.0, abs=0.02)
    # the default fits leave out exactly the unusable points, those availability does not count
    # (NaN, or finite but flagged NEAR_ZERO near the zero crossings)
    assert a["points_used_fraction"] == pytest.approx(clear["availability"], abs=1e-12)
    # excluded_flags=0: the fits keep every finite point, the flagged ones near the zero crossings too
    kept = simulate_conical_period(20.0, 3, excluded_flags=0, **kw)
    assert kept["availability"] == clear["availability"]
    assert kept["scans"][1]["points_used_fraction"] > kept["availability"] + 0.05
