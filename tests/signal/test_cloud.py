"""A cloud return in the focused beam's far tail: second Doppler peak, flags, biased centroid."""

import json
import math

import numpy as np
import pytest

from cwlidar_sim.cli import main
from cwlidar_sim.signal import PROTOTYPE_2003
from cwlidar_sim.signal.doppler import simulate_uniform

# shot-noise-limited: RIN and reflection off (they are tested in test_continuum)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)


def cauchy_weight(s, r, lam, a0):
    """The exact weighting far from the focus, from its closed form (beam.optics notes):
    a Cauchy density centred at s0 = -r^3 / (r^2 + z_ap^2), half-width
    gamma = r^2 z_ap / (r^2 + z_ap^2), renormalised over s > -r."""
    z_ap = math.pi * a0**2 / lam
    s0 = -r**3 / (r**2 + z_ap**2)
    g = r**2 * z_ap / (r**2 + z_ap**2)
    behind = 0.5 - math.atan((r + s0) / g) / math.pi  # real-line weight behind the telescope
    return g / (math.pi * ((s - s0) ** 2 + g * g)) / (1 - behind)


def test_cloud_fraction_and_los_mean():
    W, R, vc = 3e5, 1600.0, 12.0
    est, info = simulate_uniform(5.0, -15.0, tier="los", n=3, cloud_range=R, cloud_weight=W, cloud_speed=vc)
    w_c = cauchy_weight(R - P.focus, P.focus, P.wavelength, P.telescope_radius) * W
    assert info["cloud_fraction"] == pytest.approx(w_c / (1 + w_c), rel=1e-9)
    np.testing.assert_allclose(est.speed_e, (5.0 + w_c * vc) / (1 + w_c), rtol=1e-12)


def test_cloud_biases_the_centroid_flags_the_peak_and_spares_the_median():
    W, R, vc, v = 6e5, 1600.0, 12.0, 5.0
    kw = dict(n=300, seed=3, cloud_range=R, cloud_weight=W, cloud_speed=vc, exact_background=True, instrument=P)
    cen, info = simulate_uniform(v, 10.0, tier="spectral", estimator="centroid", **kw)
    frac = info["cloud_fraction"]
    assert 0.25 < frac < 0.35
    # coherent speckle scales both lines together, so the centroid is the power-weighted mean;
    # each line's own centroid is off by < 0.2 bin with the rect window (0.015 m/s)
    expected = (1 - frac) * v + frac * vc
    ok = np.isfinite(cen.speed_e)
    assert abs(cen.speed_e[ok].mean() - expected) < 0.015 + 4 * cen.speed_e[ok].std() / math.sqrt(ok.sum())
    # the cloud carries frac / (1 - frac) > 0.2 (second_peak_fraction) of the main peak's power;
    # at 0 dB the rect window's sidelobes between the lines stay below the threshold (at +10 dB
    # they reach it 46 bins out and can bridge the two groups), so every estimate is flagged
    low, _ = simulate_uniform(v, 0.0, tier="spectral", estimator="centroid", **kw)
    assert np.all(low.flags_e & 8)
    med, _ = simulate_uniform(v, 10.0, tier="spectral", estimator="median", **kw)
    # the median stays inside the main line (it holds more than half the power): within 2 bins
    assert abs(np.nanmean(med.speed_e) - v) < 2 * P.bin_speed
    clear, _ = simulate_uniform(v, 10.0, tier="spectral", estimator="centroid", n=300, seed=3, exact_background=True,
                                instrument=P)
    assert not np.any(clear.flags_e & 8)


def test_cloud_input_errors_and_cli(capsys):
    with pytest.raises(ValueError, match="cloud_range"):
        simulate_uniform(5.0, 0.0, cloud_weight=10.0)
    with pytest.raises(ValueError, match="cloud_range"):
        simulate_uniform(5.0, 0.0, cloud_range=-5.0, cloud_weight=10.0)
    with pytest.raises(ValueError, match="cloud_weight"):
        simulate_uniform(5.0, 0.0, cloud_range=1600.0, cloud_weight=-1.0)
    assert main(["doppler", "--speed", "5", "--cnr", "10", "--n", "50", "--estimator", "centroid",
                 "--cloud", "1600", "6e5", "12", "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert 0.25 < rep["cloud_fraction"] < 0.35 and rep["flags"]["SECOND_PEAK"] > 45
