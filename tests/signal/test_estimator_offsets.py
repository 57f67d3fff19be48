"""Estimator bias for a single line anywhere between bin centres (high SNR, tier 2).

With a Hann window every estimator is unbiased within a tenth of a bin at any sub-bin
offset.  With the prototype's rectangular window the Fejer line's sidelobes fall below the
threshold asymmetrically about the line, so the median and the centroid of a line narrower
than a bin are pulled toward the nearest bin centre; the pull vanishes at the centre and at
the half-bin point (symmetric cases) and stays below a quarter bin.  Peak (refined with the
window's own line shape) and ml are unbiased with either window.

Tolerance: 200 estimates at +10 dB have a scatter of ~0.01 bin, so the mean is known to
~1e-3 bin; the 0.1-bin criterion is the issue's.
"""

import numpy as np
import pytest

from cwlidar_sim.signal import PROTOTYPE_2003
from cwlidar_sim.signal.doppler import simulate_uniform

# shot-noise-limited: RIN and reflection off (they are tested in test_continuum)
P = PROTOTYPE_2003.replace(rin_level=0.0, reflection_level=0.0)

OFFSETS = (0.0, 0.13, 0.25, 0.37, 0.5)


def bias_bins(inst, est, d):
    b = inst.bin_speed
    v = (100 + d) * b
    e, _ = simulate_uniform(v, 10.0, instrument=inst, tier="spectral", n=200, seed=2, estimator=est,
                            exact_background=True, n_cells=1)
    assert e.availability == 1.0
    return (np.mean(e.speed_e) - v) / b


@pytest.mark.parametrize("est", ["median", "centroid", "peak", "ml"])
def test_hann_window_every_estimator_unbiased(est):
    inst = P.replace(window="hann")
    for d in OFFSETS:
        assert abs(bias_bins(inst, est, d)) < 0.1, (est, d)


@pytest.mark.parametrize("est", ["median", "centroid"])
def test_rect_window_pulls_median_and_centroid_toward_the_bin_centre(est):
    b = np.array([bias_bins(P, est, d) for d in OFFSETS])
    assert abs(b[0]) < 0.01 and abs(b[-1]) < 0.01          # symmetric cases
    assert np.all(b[1:-1] < 0) and np.all(b[1:-1] > -0.25)  # toward the centre below, under a quarter bin


@pytest.mark.parametrize("est", ["peak", "ml"])
def test_rect_window_peak_and_ml_unbiased(est):
    for d in OFFSETS:
        assert abs(bias_bins(P, est, d)) < 0.1
