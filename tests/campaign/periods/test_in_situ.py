"""The conical period's point sensors report their sub-grid variance and their sigma with it restored."""

import math

import pytest

from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period


def test_conical_period_reports_the_cup_and_sonic_below_the_grid():
    r = simulate_conical_period(20.0, 3, speed=8.0, duration=30.0, scan_revs=(1,), model=False)
    # the sonic misses more than the cup, whose response removes most of what the grid cannot hold
    assert 0 < r["cup_subgrid_variance"] < r["sonic_subgrid_variance"] < 0.5 * r["sonic_std"] ** 2  # a 30-s period: mostly small scales
    assert r["cup_std_continuum"] == pytest.approx(math.sqrt(r["cup_std"] ** 2 + r["cup_subgrid_variance"]))
    assert r["sonic_std_continuum"] == pytest.approx(math.sqrt(r["sonic_std"] ** 2 + r["sonic_subgrid_variance"]))
    s = r["scans"][1]
    assert s["std_ratio_cup_continuum"] == pytest.approx(s["lidar_std"] / r["cup_std_continuum"])
    assert s["std_ratio_cup_continuum"] < s["std_ratio"]
