"""One conical-scan geometry for the profiling and nacelle lidars, the sampling schedule and the REWS theory."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.rews_theory import circular_scan, scan_beams
from cwlidar_sim.beam import ConicalScanGeometry, conical_scan
from cwlidar_sim.sensors import ConicalLidar, NacelleLidar


@pytest.mark.parametrize("axis, e_a, e_1, e_2", [("up", (0, 0, 1), (1, 0, 0), (0, 1, 0)),
                                                  ("upwind", (-1, 0, 0), (0, 1, 0), (0, 0, 1))])
def test_directions_lie_on_the_cone_at_their_azimuth(axis, e_a, e_1, e_2):
    g = ConicalScanGeometry(half_angle_deg=25.0, axis=axis)
    az = np.linspace(0.0, 720.0, 37)
    n = g.direction(az)
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(n @ np.array(e_a, float), math.cos(math.radians(25.0)), rtol=1e-15)  # on the cone
    # the azimuth is counted from e_1 toward e_2
    lat = np.stack([n @ np.array(e_1, float), n @ np.array(e_2, float)], axis=-1)
    turn = (np.degrees(np.arctan2(lat[:, 1], lat[:, 0])) - az + 180.0) % 360.0 - 180.0
    np.testing.assert_allclose(turn, 0.0, atol=1e-9)
    np.testing.assert_array_equal(g.direction_rad(np.radians(az)), n)


def test_distances_along_the_axis_and_the_circle():
    g = ConicalScanGeometry(half_angle_deg=30.0, revolution_time=2.0, azimuth0_deg=10.0)
    r = g.focus_at(100.0)
    assert r == pytest.approx(100.0 / math.cos(math.radians(30.0)), rel=1e-15)
    assert g.axial_distance(r) == pytest.approx(100.0, rel=1e-15)
    p = r * g.direction(np.array([0.0, 180.0]))  # two foci opposite on the circle
    assert np.linalg.norm(p[0] - p[1]) == pytest.approx(g.circle_diameter(100.0), rel=1e-14)
    assert g.spot_speed(r) == pytest.approx(math.pi * g.circle_diameter(100.0) / 2.0, rel=1e-14)
    assert g.azimuth_at(0.5) == pytest.approx(100.0)
    for bad in (dict(half_angle_deg=90.0), dict(axis="down"), dict(revolution_time=-1.0)):
        with pytest.raises(ValueError, match=list(bad)[0]):
            ConicalScanGeometry(**bad)


def test_the_sensors_the_schedule_and_the_theory_share_one_geometry():
    """The profiler, the sampling schedule, the nacelle lidar and the REWS theory point the same beams."""
    cl = ConicalLidar(half_angle_deg=30.0, revolution_time=1.0, azimuth0_deg=15.0)
    assert cl.geometry == ConicalScanGeometry(30.0, "up", 1.0, 15.0)
    scan = conical_scan(100.0, 2, half_angle_deg=30.0, revolution_time=1.0, estimates_per_rev=50, azimuth0_deg=15.0)
    assert scan.geometry == cl.geometry
    np.testing.assert_array_equal(cl.direction(scan.azimuth_t), scan.n_tc)
    assert scan.focus == cl.focus(100.0) and scan.circle_diameter == cl.circle_diameter(100.0)
    # the sensor's schedule turns as the geometry does
    sch = cl.schedule(2.0)
    np.testing.assert_array_equal(sch.azimuth_e, cl.geometry.azimuth_at(sch.time_e))

    nl = NacelleLidar(half_angle_deg=15.0, revolution_time=1.0, azimuth0_deg=0.0, focus_distances=(80.0,))
    beams = circular_scan(8, 15.0, 80.0, revolution_time=1.0)
    assert scan_beams(nl.geometry, 8, 80.0).direction_bc.tolist() == beams.direction_bc.tolist()
    np.testing.assert_allclose(nl.nacelle_direction(45.0 * np.arange(8)), beams.direction_bc, rtol=0, atol=1e-15)
    assert nl.preview_distance(80.0) == pytest.approx(beams.focus_points_bc[0, 0] * -1.0, rel=1e-15)
    np.testing.assert_allclose(beams.delay_pb[-1], (7 - np.arange(8)) / 8.0)  # the newest is beam 7
