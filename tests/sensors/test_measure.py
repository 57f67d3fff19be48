"""One Sensor protocol, one shared measure, one record type; boxes built from the region a sensor states."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.beam import direction_from_angles
from cwlidar_sim.sensors import (ConicalLidar, Focus, LidarBase, LidarRecord, NacelleLidar, RecordPlan, Sensor,
                                 StaringLidar, measure, measure_conical, measure_nacelle, measure_staring)
from cwlidar_sim.sensors.base import BeamSampler
from cwlidar_sim.turbulence import MannParameters
from cwlidar_sim.turbulence.cover import Region, cover_box, cover_yz, fast_size, plan_box


def uniform_box(x, y, z, v=0.0):
    shape = (x.size, y.size, z.size)
    return xr.Dataset({"u": (("x", "y", "z"), np.zeros(shape)), "v": (("x", "y", "z"), np.full(shape, v)),
                       "w": (("x", "y", "z"), np.zeros(shape))}, coords={"x": x, "y": y, "z": z})


class TwoBeams(LidarBase):
    """A sensor written against the protocol only: two fixed horizontal beams taking turns."""

    azimuths = (165.0, 195.0)

    def plan_record(self, field, U, *, wrap, n):
        inst = self.instrument
        time_e = (np.arange(n) + 0.5) / inst.estimate_rate
        beam_e = np.arange(n) % 2
        cells = self.probe_cells(inst)
        groups = []
        for b, az in enumerate(self.azimuths):
            n3 = direction_from_angles(az, 0.0)
            sampler = BeamSampler(field, (0.0, 0.0, 0.0), inst.focus, cells, U, wrap)
            idx = np.flatnonzero(beam_e == b)

            def sample(lo, hi, idx=idx, n3=n3, sampler=sampler):
                vlos_ls, vlos_l = sampler.sample(time_e[idx[lo:hi]], np.broadcast_to(n3, (hi - lo, 3)))
                return vlos_ls[:, None, :], vlos_l, None

            groups.append(Focus(instrument=inst, index_e=idx, time_e=time_e[idx], cells=cells, n_looks=1,
                                sample=sample, transverse_speed=2.0, field=field))
        return RecordPlan(time_e=time_e, focus_index_e=beam_e, foci=(1.0, 2.0), groups=groups,
                          extras={"beam_e": beam_e})

    def finish_record(self, record, plan, chain):
        return record


def test_every_lidar_gives_the_one_record_type_with_one_focus_index():
    x = np.arange(-300.0, 400.0, 2.0)
    y = z = np.arange(-200.0, 201.0, 4.0)
    box = uniform_box(x, y, z)
    rs = measure_staring(box, StaringLidar(instrument=StaringLidar().instrument.replace(focus=50.0), tier="los"),
                         np.arange(10) / 50.0, 8.0)
    lid = ConicalLidar(heights=(40.0, 60.0), cell_length=4.0, refocus_time=0.0)
    rc = measure_conical(box, lid, 2.0, 8.0)
    rn = measure_nacelle(box, NacelleLidar(focus_distances=(40.0, 60.0), cell_length=4.0), 2.0, 8.0)
    for rec in (rs, rc, rn):
        assert type(rec) is LidarRecord and rec.focus_index_e.shape == rec.time_e.shape
    assert set(rs.focus_index_e) == {0} and rs.foci == (50.0,)
    assert rc.foci == (40.0, 60.0) and np.array_equal(rc.height_e, np.asarray(rc.foci)[rc.focus_index_e])
    assert np.array_equal(rn.focus_e, np.asarray(rn.foci)[rn.focus_index_e])
    # one select for every scanning lidar: a focus's own estimates and arrays
    for rec in (rc, rn):
        sel = rec.select(rec.foci[1])
        assert sel["time_e"].size == np.count_nonzero(rec.focus_index_e == 1) == sel["azimuth_e"].size
    with pytest.raises(ValueError, match=r"focus 50\.0 is not in the record; allowed: \[40\.0, 60\.0\]"):
        rn.select(50.0)
    # a uniform wind along +x: the nacelle lidar looks into it (v_los = -U cos a for every look)
    a = math.radians(NacelleLidar().half_angle_deg)
    np.testing.assert_allclose(rn.vlos_e, -8.0 * math.cos(a), atol=1e-12)


def test_a_sensor_written_against_the_protocol_gets_the_chain_and_the_seeding_rule():
    x = np.arange(-600.0, 200.0, 1.0)
    y = np.arange(-40.0, 40.0, 1.0)
    field = xr.Dataset({c: (("x", "y"), np.zeros((x.size, y.size))) for c in "uw"}
                       | {"v": (("x", "y"), np.ones((x.size, y.size)))}, coords={"x": x, "y": y}, attrs={"z": 0.0})
    lid = TwoBeams(instrument=LidarBase().instrument.replace(focus=60.0), tier="spectral", cell_length=1.0, span=8.0)
    assert isinstance(lid, Sensor) and not isinstance(object(), Sensor)
    rec = measure(field, lid, 8.0, seed=1, wrap=True, n=100)
    # beam b at azimuth 180 -+ 15 deg: v_los = -U cos 15 +- V sin 15 (V = 1 toward +y)
    for b, sign in ((0, 1.0), (1, -1.0)):
        want = abs(-8.0 * math.cos(math.radians(15.0)) + sign * math.sin(math.radians(15.0)))
        assert np.nanmean(rec.speed_e[rec.beam_e == b]) == pytest.approx(want, abs=0.05)
    # a focus list: its groups draw from the root's children, so the same seed gives the same bits
    again = measure(field, lid, 8.0, seed=1, wrap=True, n=100)
    np.testing.assert_array_equal(rec.speed_e, again.speed_e)
    with pytest.raises(ValueError, match="seed is required for tier 'spectral'"):
        measure(field, lid, 8.0, n=100)
    with pytest.raises(TypeError, match="Sensor protocol"):
        measure(field, object(), 8.0)


def test_the_box_holds_the_region_the_sensor_states():
    p = MannParameters(0.05, 10.0, 3.9)
    lid = NacelleLidar(focus_distances=(40.0, 80.0), cell_length=4.0, yaw_misalignment_deg=10.0)
    region = lid.box_region(6.0, rotor_radius=30.0)
    assert isinstance(region, Region) and region.x_lo < lid.position[0] - 80.0 * math.cos(math.radians(15.0))
    plan = plan_box(region, 8.0, 20.0, 6.0, params=p)
    nx, ny, nz = plan.shape
    assert nx == fast_size(nx) and nx * 6.0 >= 8.0 * 20.0 + region.length + 4 * 6.0 > (nx - 1) * 6.0 * 0.8
    # the rotor disc and the beams fit across the wind, centred on the lidar
    y = plan.coords()["y"]
    assert y[0] <= lid.position[1] - 30.0 and y[-1] >= lid.position[1] + 30.0
    assert np.allclose(np.mean(y), lid.position[1])
    box = cover_box(region, 8.0, 20.0, p, 3, spacing=6.0)
    assert box.u.shape == plan.shape and box.attrs["generated_shape"] == (nx, 2 * ny, nz)
    np.testing.assert_array_equal(cover_yz(region, 6.0, params=p)[1], box.z.values)
    rec = measure_nacelle(box, lid, 20.0, 8.0)  # every look of 20 s inside the box: no extent error
    assert np.isfinite(rec.vlos_e).all()
    # 2-3-5-smooth sizes, as the old home-made rule gave them
    assert [fast_size(n) for n in (1, 7, 11, 97, 121, 1001)] == [2, 8, 12, 100, 125, 1024]
