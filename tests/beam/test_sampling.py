"""Line-of-sight sampling: trilinear kernel against the Python reference, geometry, errors."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim._config import get_num_threads, set_num_threads
from cwlidar_sim.beam import conical_scan, direction_from_angles, sample_los, staring_direction

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import reference  # noqa: E402


def make_field(u, v, w, spacing, start=(0.0, 0.0, 0.0), attrs=None):
    dims = ("x", "y", "z")[: u.ndim]
    coords = {d: start[i] + spacing[i] * np.arange(u.shape[i]) for i, d in enumerate(dims)}
    return xr.Dataset({"u": (dims, u), "v": (dims, v), "w": (dims, w)}, coords=coords, attrs=attrs or {})


def random_field(shape, dtype, seed, spacing=(1.5, 2.0, 2.5), start=(3.0, -1.0, 0.5), attrs=None):
    rng = np.random.default_rng(seed)
    u, v, w = (rng.standard_normal(shape).astype(dtype) for _ in range(3))
    return make_field(u, v, w, spacing, start, attrs), (u, v, w)


def as3(a):
    return a.reshape(a.shape + (1,) * (3 - a.ndim))


def random_dirs(rng, n):
    d = rng.standard_normal((n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# -- kernel against the plain-Python reference --------------------------------------
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_box_matches_reference_wrapped(dtype):
    rng = np.random.default_rng(1)
    shape, spacing, start = (8, 6, 5), (1.5, 2.0, 2.5), (3.0, -1.0, 0.5)
    field, (u, v, w) = random_field(shape, dtype, 2, spacing, start)
    origin = np.array([4.0, 2.0, 3.0])
    n_tc = random_dirs(rng, 7)
    range_s = np.linspace(0.0, 40.0, 9)  # far outside the box: exercises wrapping in all axes
    time_t = rng.uniform(-5, 50, 7)
    vel, vlos = sample_los(field, origin, n_tc, range_s, time_t, 7.3, wrap=True, add_mean=True)
    grid = start + spacing
    rv, rl = reference.beam_sample_points(u, v, w, grid, True, origin, n_tc, range_s, time_t, 7.3, add_mean=True)
    np.testing.assert_allclose(vel, rv, rtol=0, atol=1e-12)
    np.testing.assert_allclose(vlos, rl, rtol=0, atol=1e-12)
    np.testing.assert_allclose(vlos, np.einsum("tc,tsc->ts", n_tc, vel), rtol=0, atol=1e-12)


def test_box_matches_reference_bounded():
    rng = np.random.default_rng(3)
    shape, spacing, start = (9, 7, 6), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0)
    field, (u, v, w) = random_field(shape, np.float64, 4, spacing, start)
    origin = np.array([4.0, 3.0, 2.5])
    n_tc = random_dirs(rng, 11)
    range_s = np.linspace(0.0, 2.4, 5)  # stays within y in [0, 6], z in [0, 5]
    time_t = np.linspace(0, 3, 11)
    vel, vlos = sample_los(field, origin, n_tc, range_s, time_t, 2.0)
    rv, rl = reference.beam_sample_points(u, v, w, start + spacing, False, origin, n_tc, range_s, time_t, 2.0)
    np.testing.assert_allclose(vel, rv, rtol=0, atol=1e-12)
    np.testing.assert_allclose(vlos, rl, rtol=0, atol=1e-12)


def test_plane_and_line_match_reference():
    rng = np.random.default_rng(5)
    plane, (u, v, w) = random_field((10, 8), np.float64, 6, (1.0, 2.0), (0.0, 0.0), attrs={"z": 32.0})
    origin = np.array([1.0, 5.0, 32.0])
    az = rng.uniform(0, 360, 6)
    n_tc = direction_from_angles(az, 0.0)
    range_s, time_t = np.linspace(0, 6, 4), np.linspace(0, 10, 6)
    vel, vlos = sample_los(plane, origin, n_tc, range_s, time_t, 3.0, wrap=True)
    grid = np.array([0.0, 0.0, 0.0, 1.0, 2.0, 1.0])
    rv, rl = reference.beam_sample_points(as3(u), as3(v), as3(w), grid, True, origin, n_tc, range_s, time_t, 3.0)
    np.testing.assert_allclose(vel, rv, atol=1e-12)
    np.testing.assert_allclose(vlos, rl, atol=1e-12)

    line, (u, v, w) = random_field((16,), np.float64, 7, (0.5,), (0.0,))
    origin = np.array([2.0, 7.0, 30.0])
    vel, vlos = sample_los(line, origin, [-1.0, 0, 0], np.linspace(0, 20, 7), time_t, 3.0)
    rv, rl = reference.beam_sample_points(
        as3(u), as3(v), as3(w), np.array([0.0, 0, 0, 0.5, 1, 1]), False, origin,
        np.tile([-1.0, 0, 0], (6, 1)), np.linspace(0, 20, 7), time_t, 3.0,
    )
    np.testing.assert_allclose(vel, rv, atol=1e-12)
    np.testing.assert_allclose(vlos, -vel[..., 0], atol=0)


def test_same_bits_whatever_the_thread_count():
    rng = np.random.default_rng(8)
    field, _ = random_field((16, 8, 8), np.float32, 9)
    args = (field, [4.0, 5.0, 6.0], random_dirs(rng, 64), np.linspace(0, 30, 17), np.linspace(0, 9, 64), 8.0)
    old = get_num_threads()
    try:
        set_num_threads(1)
        a = sample_los(*args, wrap=True)
        set_num_threads(2)
        b = sample_los(*args, wrap=True)
    finally:
        set_num_threads(old)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


# -- interpolation accuracy ------------------------------------------------------------
def test_trilinear_exact_for_multilinear_field():
    shape, h = (10, 8, 6), (1.5, 2.0, 2.5)
    x, y, z = np.meshgrid(*(h[i] * np.arange(shape[i]) for i in range(3)), indexing="ij")

    def f(x, y, z):
        # linear in each coordinate separately (includes the xyz cross term)
        return 1.0 + 2.0 * x - 3.0 * y + 0.5 * z + 0.1 * x * y - 0.2 * y * z + 0.05 * x * y * z

    field = make_field(f(x, y, z), f(y, z, x), f(z, x, y), h)
    rng = np.random.default_rng(10)
    centre = np.array([6.75, 7.0, 6.25])
    n_tc = random_dirs(rng, 200)
    range_s = np.linspace(0, 6.0, 13)  # ball of radius 6 m inside [0, 13.5] x [0, 14] x [0, 12.5]
    vel, _ = sample_los(field, centre, n_tc, range_s, np.zeros(200), 0.0)
    p = centre + np.einsum("s,tc->tsc", range_s, n_tc)
    px, py, pz = p[..., 0], p[..., 1], p[..., 2]
    np.testing.assert_allclose(vel[..., 0], f(px, py, pz), rtol=0, atol=1e-11)
    np.testing.assert_allclose(vel[..., 1], f(py, pz, px), rtol=0, atol=1e-11)
    np.testing.assert_allclose(vel[..., 2], f(pz, px, py), rtol=0, atol=1e-11)


def test_trilinear_second_order_on_fourier_mode():
    L = np.array([40.0, 30.0, 20.0])
    k = 2 * np.pi * np.array([1.0, 2.0, 1.0]) / L
    rng = np.random.default_rng(11)
    n_t = 300
    n_tc, time_t = random_dirs(rng, n_t), rng.uniform(0, 10, n_t)
    origin, range_s, U = np.array([5.0, 5.0, 5.0]), np.linspace(0, 50, 11), 6.0
    p = origin + np.einsum("s,tc->tsc", range_s, n_tc)
    p[..., 0] -= U * time_t[:, None]
    exact = np.sin(p @ k + 0.3)
    errs = []
    for n0 in (16, 32, 64):
        shape = (n0, 3 * n0 // 4, n0 // 2)
        h = L / np.array(shape)
        x, y, z = np.meshgrid(*(h[i] * np.arange(shape[i]) for i in range(3)), indexing="ij")
        f = np.sin(k[0] * x + k[1] * y + k[2] * z + 0.3)
        field = make_field(f, f, f, h)
        vel, _ = sample_los(field, origin, n_tc, range_s, time_t, U, wrap=True)
        err = np.max(np.abs(vel[..., 0] - exact))
        # trilinear bound: (1/8) sum_d h_d^2 max|f_dd| = (1/8) sum_d (k_d h_d)^2 for a unit sine
        assert err <= 0.125 * np.sum((k * h) ** 2)
        errs.append(err)
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    # second order: halving h divides the error by 4 (300 x 11 random points sample the maximum well)
    assert np.all((ratios > 3.5) & (ratios < 4.5)), ratios


# -- periodicity, Taylor advection, boundaries --------------------------------------------
def test_taylor_advection_and_x_periodicity():
    field, _ = random_field((12, 6, 6), np.float64, 12, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    n = staring_direction(30.0, 10.0)
    r = np.linspace(0, 3, 4)
    origin = np.array([5.0, 1.0, 1.0])
    t, U = np.array([0.7, 2.9]), 4.1
    moving, _ = sample_los(field, origin, n, r, t, U)
    for i in range(2):
        still, _ = sample_los(field, origin - [U * t[i], 0, 0], n, r, [0.0], 0.0)
        np.testing.assert_allclose(moving[i], still[0], atol=1e-12)
    shifted, _ = sample_los(field, origin + [12.0 * 3, 0, 0], n, r, t, U)  # three periods along x
    np.testing.assert_allclose(shifted, moving, atol=1e-12)


def test_y_z_bounds_raise_unless_wrap():
    field, _ = random_field((8, 6, 5), np.float64, 13, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="in y.*wrap=True"):
        sample_los(field, [1.0, 4.0, 2.0], [0.0, 1.0, 0.0], [0.0, 2.0], [0.0], 0.0)
    with pytest.raises(ValueError, match="in z"):
        sample_los(field, [1.0, 2.0, 2.0], [0.0, 0.0, -1.0], [0.0, 2.5], [0.0], 0.0)
    # wrap: y period 6 m, so y = 6.5 samples like y = 0.5
    a, _ = sample_los(field, [1.0, 4.0, 2.0], [0.0, 1.0, 0.0], [2.5], [0.0], 0.0, wrap=True)
    b, _ = sample_los(field, [1.0, 0.5, 2.0], [0.0, 1.0, 0.0], [0.0], [0.0], 0.0)
    np.testing.assert_allclose(a, b, atol=1e-12)


def test_plane_and_line_placement_errors():
    plane, _ = random_field((8, 6), np.float64, 14, (1.0, 1.0), (0.0, 0.0), attrs={"z": 32.0})
    with pytest.raises(ValueError, match="plane field in z"):
        sample_los(plane, [1.0, 2.0, 33.0], [1.0, 0, 0], [1.0], [0.0], 0.0)
    with pytest.raises(ValueError, match="plane field in z"):
        sample_los(plane, [1.0, 2.0, 32.0], staring_direction(0.0, 5.0), [0.0, 10.0], [0.0], 0.0)
    no_z, _ = random_field((8, 6), np.float64, 14, (1.0, 1.0), (0.0, 0.0))
    with pytest.raises(ValueError, match=r"attrs\['z'\]"):
        sample_los(no_z, [1.0, 2.0, 33.0], [1.0, 0, 0], [1.0], [0.0], 0.0)
    line, _ = random_field((8,), np.float64, 15, (1.0,), (0.0,), attrs={"y": 0.0, "z": 30.0})
    with pytest.raises(ValueError, match="line field in y"):
        sample_los(line, [0.0, 0.0, 30.0], staring_direction(10.0), [0.0, 5.0], [0.0], 0.0)
    with pytest.raises(ValueError, match="line field in z"):
        sample_los(line, [0.0, 0.0, 31.0], [1.0, 0, 0], [5.0], [0.0], 0.0)


def test_input_validation():
    field, _ = random_field((8, 6, 5), np.float64, 16)
    ok = dict(origin=[4.0, 2.0, 3.0], direction=[1.0, 0, 0], ranges=[1.0], times=[0.0], U=1.0)

    def call(**kw):
        a = dict(ok, **kw)
        return sample_los(a.pop("field", field), **a)

    with pytest.raises(ValueError, match="unit vectors"):
        call(direction=[1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="direction must have shape"):
        call(direction=np.ones((3, 3)) / np.sqrt(3))
    with pytest.raises(ValueError, match="ranges must be >= 0"):
        call(ranges=[-1.0])
    with pytest.raises(ValueError, match="times must be a non-empty 1-D"):
        call(times=np.zeros((2, 2)))
    with pytest.raises(ValueError, match="origin must have shape"):
        call(origin=[0.0, 0.0])
    with pytest.raises(ValueError, match="U="):
        call(U=np.inf)
    with pytest.raises(TypeError, match="xarray.Dataset"):
        call(field=np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="lacks data variable"):
        call(field=field.drop_vars("w"))
    with pytest.raises(ValueError, match="dims"):
        call(field=field.rename({"z": "q"}))
    with pytest.raises(TypeError, match="wrap must be a bool"):
        call(wrap=1)


# -- geometry ------------------------------------------------------------------------
def test_conical_scan_geometry_and_uniform_wind():
    scan = conical_scan(100.0, n_rev=3)
    assert scan.focus == pytest.approx(100.0 / math.cos(math.radians(30.0)), rel=1e-15)
    assert scan.circle_diameter == pytest.approx(2 * 100.0 * math.tan(math.radians(30.0)), rel=1e-15)
    assert scan.time_t.size == 150  # 3 s = 150 points (PHYSICS section 5)
    np.testing.assert_allclose(np.diff(scan.time_t), 0.02, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(scan.n_tc, axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(scan.n_tc[:, 2], math.cos(math.radians(30.0)), rtol=1e-15)
    # focus point is at the measurement height
    np.testing.assert_allclose(scan.focus * scan.n_tc[:, 2], 100.0, rtol=1e-14)
    # uniform wind (U0, 0, W): radial speed A cos(theta) + B with A = U0 sin(Phi), B = W cos(Phi)
    U0, W = 8.0, 0.5
    shape = (8, 8, 8)
    field = make_field(np.full(shape, U0), np.zeros(shape), np.full(shape, W), (50.0, 20.0, 20.0))
    origin = [0.0, 80.0, 30.0]  # focus at z = 130 m, circle radius 57.7 m: inside y in [0, 140]
    _, vlos = sample_los(field, origin, scan.n_tc, [scan.focus], scan.time_t, 0.0)
    theta = np.radians(scan.azimuth_t)
    phi = math.radians(30.0)
    np.testing.assert_allclose(vlos[:, 0], U0 * math.sin(phi) * np.cos(theta) + W * math.cos(phi), atol=1e-12)


def test_direction_from_angles():
    np.testing.assert_allclose(staring_direction(), [1.0, 0.0, 0.0])
    np.testing.assert_allclose(direction_from_angles(90.0, 0.0), [0.0, 1.0, 0.0], atol=1e-16)
    np.testing.assert_allclose(direction_from_angles(0.0, 90.0), [0.0, 0.0, 1.0], atol=1e-16)
    assert direction_from_angles([0.0, 45.0], 10.0).shape == (2, 3)
    with pytest.raises(ValueError, match="elevation_deg"):
        staring_direction(0.0, 95.0)
