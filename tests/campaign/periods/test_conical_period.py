"""One CS period end to end (small): the returned numbers are consistent with each other and with physics."""

import math

import numpy as np
import pytest

from cwlidar_sim.campaign.periods.conical_simulation import _conical_lidar, simulate_conical_period
from cwlidar_sim.campaign.scenes.conical import default_spacing
from cwlidar_sim.turbulence.cover import cover_yz
from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters


def test_short_period_end_to_end():
    r = simulate_conical_period(20.0, 3, speed=8.0, duration=30.0, scan_revs=(1, 3), model=False)
    assert r["n_estimates"] == 30 * 50 and r["spacing"] == default_spacing(20.0) == 1.0
    assert r["box_shape"][1] >= math.ceil(2 * 0.5 * (20 / math.cos(math.radians(30)) + 5 * 0.0013 * 533.3) / 1.0)
    s1, s3 = r["scans"][1], r["scans"][3]
    assert s1["n_scans"] == 30 and s3["n_scans"] == 10
    # the fit's mean speed follows the cup's within a few per cent in 30 s; the lidar filters, the cup hardly
    assert abs(s1["mean_speed_bias"]) < 0.03
    assert 0.3 < s1["std_ratio"] < 1.05 and s1["std_ratio"] == pytest.approx(s1["lidar_std"] / r["cup_std"])
    # two zero crossings per revolution lose a few points each, never a whole scan
    assert 0.02 < r["zero_crossing_loss"] < 0.3 and s1["availability"] == 1.0 and s1["selected"]
    assert s1["points_used_fraction"] == pytest.approx(1 - r["zero_crossing_loss"], abs=0.02)
    assert s1["ambiguity_rate"] == 0.0
    assert s1["radial_variance"] == pytest.approx(s1["radial_variance_ratio"] * r["sonic_radial_variance"])
    # the sonic's projected radial variance: sin^2 Phi (s_u^2 + s_v^2) / 2 + cos^2 Phi s_w^2 > 0
    assert 0 < r["sonic_radial_variance"] < r["sonic_std"] ** 2 * 2
    # the cup and the sonic on the box's nearest node across the wind (midway they would read an average)
    x, y, z = r["in_situ_position"]
    lid = _conical_lidar((20.0,), "los", 1.0, 8, None, 0.0)
    ys, zs = cover_yz(lid.box_region(1.0), 1.0, params=surface_layer_parameters(20.0, 8.0)[0])
    assert x == 0.0 and np.min(np.abs(ys - y)) < 1e-9 and np.min(np.abs(zs - z)) < 1e-9
    assert abs(y) <= 0.5 and abs(z - 20.0) <= 0.5
    # (0, 0, 20) itself is off the nodes of this box: the test would not see a sensor left there
    assert np.min(np.abs(ys)) > 0.1 or np.min(np.abs(zs - 20.0)) > 0.1
    with pytest.raises(ValueError, match=r"scan_revs\[0\]=0"):
        simulate_conical_period(20.0, 3, duration=30.0, scan_revs=(0,))
