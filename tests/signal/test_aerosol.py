"""Log-normal backscatter modulation along the beam: mean 1, the stated sd of its log, exponential correlation."""

import math

import numpy as np
import pytest

from cwlidar_sim.signal.aerosol import lognormal_modulation


def test_modulation_statistics():
    n, dx, ell, s = 2**16, 0.5, 5.0, 0.5
    m = lognormal_modulation(s, ell)(np.random.default_rng(3), n, dx)
    assert m.shape == (n,) and np.all(m > 0)
    g = np.log(m)
    # n dx / ell = 6554 correlation lengths: ~ 1/sqrt(6554/2) = 1.7 % scatter of the estimates below
    assert np.std(g) == pytest.approx(s, rel=1e-9)            # normalised exactly
    assert np.mean(m) == pytest.approx(1.0, abs=4 * s * math.sqrt(2 * ell / (n * dx)))
    lag = int(ell / dx)
    r = np.mean((g - g.mean()) * (np.roll(g, lag) - g.mean())) / np.var(g)
    assert r == pytest.approx(math.exp(-1.0), abs=0.05)


def test_modulation_bad_input_names_the_field():
    with pytest.raises(ValueError, match="sigma_ln"):
        lognormal_modulation(-1.0, 5.0)
    with pytest.raises(ValueError, match="correlation_length"):
        lognormal_modulation(0.5, 0.0)
