"""Aerosol load varying over a record: the CNR series and its effect on availability."""

import math

import numpy as np
import pytest

from cwlidar_sim.sensors import StaringLidar, measure_staring
from cwlidar_sim.signal.chain import cnr_series
from cwlidar_sim.turbulence import MannParameters, generate_line


def test_cnr_series_is_the_gauss_markov_process():
    n, dt, ts, sd = 40000, 0.5, 5.0, 2.0
    x = cnr_series(np.arange(n) * dt, sd, ts, 3)
    # variance and lag-1, lag-10 correlations, within 4 sigma of their sampling error
    # (effective sample size n (1 - r) / (1 + r) for an AR(1) series)
    r1 = math.exp(-dt / ts)
    neff = n * (1 - r1) / (1 + r1)
    assert x.var() == pytest.approx(sd**2, rel=4 * math.sqrt(2 / neff))
    for lag in (1, 10):
        c = np.corrcoef(x[:-lag], x[lag:])[0, 1]
        assert c == pytest.approx(math.exp(-lag * dt / ts), abs=4 / math.sqrt(neff))
    with pytest.raises(ValueError, match="sorted"):
        cnr_series([1.0, 0.0], 1.0, 1.0, 0)
    with pytest.raises(ValueError, match="cnr_variation_db"):
        StaringLidar(tier="signal", cnr_variation_db=1.0)


def test_cnr_variation_modulates_availability():
    fld = generate_line(MannParameters.iec(100.0, 1.0), 4096, 0.5, 2)
    t = np.arange(3000) / 50.0
    base = StaringLidar(cell_length=2.0, cnr_db=-25.0, transverse_speed=1.0)
    const = measure_staring(fld, base, t, 8.0, 5)
    var = measure_staring(fld, base.replace(cnr_variation_db=3.0, cnr_time_scale=5.0), t, 8.0, 5)
    lo, hi = var.info["cnr_db_range"]
    assert lo < -28.0 and hi > -22.0
    # the same seed draws the same background and speckle: only the CNR differs
    x = cnr_series(t, 3.0, 5.0, np.random.SeedSequence(5).spawn(3)[2])
    assert lo == pytest.approx(-25.0 + x.min()) and hi == pytest.approx(-25.0 + x.max())
    ok = np.isfinite(var.speed_e)
    assert ok[x > 1.5].mean() > const.availability > ok[x < -1.5].mean()
