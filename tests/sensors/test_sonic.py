"""Virtual sonic, A2012's 32 Hz -> 10 Hz resampling (Eqs. 5-7) and the lidar's block average."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.sensors import (
    Sonic,
    block_average,
    nearest_node,
    project,
    resample_a2012,
    resample_a2012_times,
    sample_sonic,
)

import reference  # noqa: E402

N, DX = 1024, 0.5


def line(u, v=None, w=None):
    z = np.zeros(N)
    return xr.Dataset({"u": ("x", u), "v": ("x", z if v is None else v), "w": ("x", z if w is None else w)},
                      coords={"x": DX * np.arange(N)})


# ---------------------------------------------------------------------------
# Sonic parameters
# ---------------------------------------------------------------------------
def test_sonic_dict_round_trip_and_validation():
    s = Sonic(position=(67.5, 0.0, 0.0), noise_std=0.05)
    assert Sonic.from_dict(s.as_dict()) == s
    assert s.rate == 32.0
    with pytest.raises(ValueError, match="unknown key.*'colour'"):
        Sonic.from_dict({"position": (0, 0, 0), "colour": 1})
    with pytest.raises(ValueError, match="missing key.*position"):
        Sonic.from_dict({"rate": 32.0})
    with pytest.raises(ValueError, match="position must have 3 values"):
        Sonic(position=(0.0, 0.0))
    with pytest.raises(ValueError, match="rate"):
        Sonic(position=(0, 0, 0), rate=0.0)
    with pytest.raises(ValueError, match="noise_std"):
        Sonic(position=(0, 0, 0), noise_std=-0.1)
    with pytest.raises(TypeError, match=r"position\[1\]"):
        Sonic(position=(0, "a", 0))
    t = s.times(2.0, start=1.0)
    assert t.size == 64 and t[0] == 1.0 and t[1] - t[0] == pytest.approx(1 / 32, rel=1e-12)


# ---------------------------------------------------------------------------
# sampling
# ---------------------------------------------------------------------------
def test_sonic_sees_the_advected_total_wind():
    rng = np.random.default_rng(3)
    u, v, w = rng.standard_normal((3, N))
    field = line(u, v, w)
    U = 16.0  # U / 32 Hz = 0.5 m = DX: each sample moves the field by exactly one node
    i0 = 300
    sonic = Sonic(position=(i0 * DX, 0.0, 0.0))
    t = sonic.times(40.0)
    vel = sample_sonic(field, sonic, t, U)
    # Taylor: the stored field at x0 - U t, i.e. node i0 - j (periodic); linear interpolation is exact at nodes
    idx = (i0 - np.arange(t.size)) % N
    assert vel.shape == (t.size, 3) and vel.dtype == np.float64
    np.testing.assert_allclose(vel[:, 0], U + u[idx], rtol=0, atol=1e-12)
    np.testing.assert_allclose(vel[:, 1], v[idx], rtol=0, atol=1e-12)
    np.testing.assert_allclose(vel[:, 2], w[idx], rtol=0, atol=1e-12)
    # projected on a unit direction
    n = np.array([math.cos(0.3), math.sin(0.3), 0.0])
    np.testing.assert_allclose(project(vel, n), vel[:, 0] * n[0] + vel[:, 1] * n[1], rtol=1e-15)


def test_a_sonic_between_nodes_reads_their_average_and_on_the_nearest_node_the_node():
    # u alternates +1, -1 from one lateral node to the next: midway a point sensor reads the
    # linear interpolation, 0, and loses the variance; nearest_node puts it on a node.
    ny, nz = 6, 5
    y = 2.0 * np.arange(ny) - 5.0  # nodes at -5, -3, ..., 5: y = 0 lies midway
    zc = 10.0 + 2.0 * np.arange(nz)
    u = np.broadcast_to(np.where(np.arange(ny) % 2 == 0, 1.0, -1.0)[None, :, None], (N, ny, nz)).copy()
    zero = np.zeros((N, ny, nz))
    box = xr.Dataset({c: (("x", "y", "z"), a) for c, a in (("u", u), ("v", zero), ("w", zero))},
                     coords={"x": DX * np.arange(N), "y": y, "z": zc})
    t = Sonic(position=(0.0, 0.0, 14.0)).times(2.0)
    mid = sample_sonic(box, Sonic(position=(10.0, 0.0, 14.0)), t, 3.0)
    np.testing.assert_allclose(mid[:, 0], 3.0, atol=1e-12)
    pos = nearest_node(box, (10.0, 0.0, 14.7))
    assert pos[0] == 10.0 and pos[1] in (-1.0, 1.0) and pos[2] == 14.0
    # node coordinates given as a mapping (e.g. a box's planned nodes) give the same node
    assert nearest_node({"y": y, "z": zc}, (10.0, 0.0, 14.7)) == pos
    on = sample_sonic(box, Sonic(position=pos), t, 3.0)
    np.testing.assert_allclose(np.abs(on[:, 0] - 3.0), 1.0, atol=1e-12)
    # x untouched unless asked; a line has no lateral axes to move along
    assert nearest_node(box, (10.3, 0.2, 13.2), axes=("x",))[0] == pytest.approx(10.5)
    assert nearest_node(line(np.zeros(N)), (1.3, 0.4, 0.7)) == (1.3, 0.4, 0.7)
    with pytest.raises(ValueError, match="axes"):
        nearest_node(box, (0.0, 0.0, 0.0), axes=("q",))


def test_sonic_noise_is_white_seeded_and_of_the_set_level():
    field = line(np.zeros(N))
    sonic = Sonic(position=(10.0, 0.0, 0.0), noise_std=0.2)
    t = sonic.times(600.0)
    with pytest.raises(ValueError, match="seed is required"):
        sample_sonic(field, sonic, t, 8.0)
    a = sample_sonic(field, sonic, t, 8.0, seed=5)
    b = sample_sonic(field, sonic, t, 8.0, seed=5)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, sample_sonic(field, sonic, t, 8.0, seed=6))
    err = a - np.array([8.0, 0.0, 0.0])
    n = err.size
    # sample sd of n Gaussian values has relative standard error 1 / sqrt(2 n); mean has sd 0.2 / sqrt(n)
    assert err.std() == pytest.approx(0.2, rel=4 / math.sqrt(2 * n))
    assert abs(err.mean()) < 4 * 0.2 / math.sqrt(n)
    # white: lag-1 correlation of each component within 4 / sqrt(n_t)
    for c in range(3):
        r1 = np.corrcoef(err[:-1, c], err[1:, c])[0, 1]
        assert abs(r1) < 4 / math.sqrt(t.size)


def test_sonic_leaving_a_line_field_is_an_error():
    with pytest.raises(ValueError, match="beam leaves the line field in y"):
        sample_sonic(line(np.zeros(N)).assign_attrs(y=0.0), Sonic(position=(0.0, 3.0, 0.0)), [0.0], 8.0)
    with pytest.raises(TypeError, match="sonic must be a Sonic"):
        sample_sonic(line(np.zeros(N)), {"position": (0, 0, 0)}, [0.0], 8.0)


# ---------------------------------------------------------------------------
# A2012 resampling
# ---------------------------------------------------------------------------
def test_resample_equals_the_printed_equations():
    rng = np.random.default_rng(1)
    x = rng.standard_normal(16 * 7 + 9)  # trailing partial partition of 9 samples
    y = resample_a2012(x)
    assert y.shape == (35,)
    assert np.array_equal(y, np.array(reference.sensors_resample_a2012(list(x))))
    # along another axis of a multi-column array
    x3 = rng.standard_normal((3, 48))
    y3 = resample_a2012(x3, axis=1)
    assert y3.shape == (3, 15)
    for r in range(3):
        assert np.array_equal(y3[r], reference.sensors_resample_a2012(list(x3[r])))
    assert resample_a2012(np.ones(15)).shape == (0,)


def test_resample_preserves_constants_and_ramps_at_its_time_stamps():
    c = resample_a2012(np.full(160, 7.3))
    np.testing.assert_allclose(c, 7.3, rtol=4e-16)
    t0 = 12.0
    t = t0 + np.arange(32 * 20) / 32.0
    tc = resample_a2012_times(t)
    # the derived centroids: 1.125 + 3.1875 (i - 1) samples into each partition of 16
    p, i = np.divmod(np.arange(tc.size), 5)
    np.testing.assert_allclose(tc, t0 + (16 * p + 1.125 + 3.1875 * i) / 32, rtol=0, atol=1e-12)
    # within 0.025 samples (0.78 ms) of the uniform 10 Hz grid t0 + 0.034375 + 0.1 q
    assert np.max(np.abs(tc - (t0 + 0.034375 + 0.1 * np.arange(tc.size)))) <= 0.025 / 32 + 1e-12
    # a ramp is reproduced exactly at these times (weights are a mean)
    a, b = 3.0, -0.7
    np.testing.assert_allclose(resample_a2012(a + b * t), a + b * tc, rtol=0, atol=1e-12)


def test_resample_transfer_is_one_at_low_frequency():
    """A sinusoid of angular frequency om is returned at the centroid times up to the weights' moments.

    Output = sum_n W_n sin(om (t_c + delta_n)) with sum W_n = 1, sum W_n delta_n = 0:
    |out - sin(om t_c)| <= om^2 m2 / 2 + om^3 m3 / 6, m2 = sum W delta^2, m3 = sum W |delta|^3.
    """
    t = np.arange(32 * 60) / 32.0
    tc = resample_a2012_times(t)
    # moments of every output's weights about its centroid, from the equations themselves
    eye = np.eye(16)
    w_in = np.stack([resample_a2012(eye[j]) for j in range(16)])  # (16 samples, 5 outputs)
    delta = (np.arange(16)[:, None] - (resample_a2012_times(np.arange(16.0)))[None, :]) / 32.0
    m2 = np.max(np.sum(w_in * delta**2, axis=0))
    m3 = np.max(np.sum(w_in * np.abs(delta) ** 3, axis=0))
    for f in (0.05, 0.5, 1.0):
        om = 2 * math.pi * f
        err = np.max(np.abs(resample_a2012(np.sin(om * t)) - np.sin(om * tc)))
        assert err <= om**2 * m2 / 2 + om**3 * m3 / 6 + 1e-12, f
    # the gain at 0.05 Hz is 1 within 1e-4 (om^2 m2 / 2 = 1.6e-5)
    assert 0.05**2 * (2 * math.pi) ** 2 * m2 / 2 < 1e-4


def test_resample_variance_and_lag_one_covariance_of_white_noise():
    """White noise of variance 1 through A2012 Eq. 5 as printed (weights written out here, not the code's).

    Output i = 1..5 of a partition weights {0.2 (6 - i), 1, 1, 0.2 i} / 3.2: mean output variance
    sum_i sum_n w_in^2 / (5 * 3.2^2) = 0.28125.  Neighbours i, i + 1 inside a partition share one
    sample, weighted 0.2 i and 0.2 (5 - i), and outputs of different partitions share none, so
    the mean lag-1 covariance is sum_{i=1..4} 0.04 i (5 - i) / (5 * 3.2^2) = 0.015625 (mirrored
    weights, {0.2 i, 1, 1, 0.2 (6 - i)}, would give the same variance but 0.034375).
    """
    rng = np.random.default_rng(8)
    y = resample_a2012(rng.standard_normal(16 * 40000))
    expected = sum(((6 - i) / 5) ** 2 + 2 + (i / 5) ** 2 for i in range(1, 6)) / (5 * 3.2**2)
    assert expected == pytest.approx(0.28125, rel=1e-15)
    # sample variance of n Gaussian outputs: relative sd sqrt(2/n); neighbours share one sample
    # (covariance <= 0.4 * 0.6 / 3.2^2, correlation < 0.09), which raises that sd by < 1 %: 4.5 sd allowed
    assert y.var() == pytest.approx(expected, rel=4.5 * math.sqrt(2 / y.size))
    lag1 = sum(0.04 * i * (5 - i) for i in range(1, 5)) / (5 * 3.2**2)
    assert lag1 == pytest.approx(0.015625, rel=1e-12)
    # the mean of n products of correlated Gaussians has sd <= sqrt(var^2 + cov^2) / sqrt(n) ~ 0.28 / sqrt(n)
    c1 = np.mean((y[:-1] - y.mean()) * (y[1:] - y.mean()))
    assert c1 == pytest.approx(lag1, abs=4.5 * 0.29 / math.sqrt(y.size))


def test_resample_nan_reaches_only_the_outputs_that_weight_it():
    for j in range(16):
        x = np.ones(32)
        x[16 + j] = np.nan
        y = resample_a2012(x)
        # sample j (0-based) of a partition is weighted by output i (0-based) iff 3 i <= j <= 3 i + 3
        hit = {5 + i for i in range(5) if 3 * i <= j <= 3 * i + 3}
        assert {k for k in range(10) if np.isnan(y[k])} == hit, j
        assert 1 <= len(hit) <= 2


# ---------------------------------------------------------------------------
# block average
# ---------------------------------------------------------------------------
def test_block_average_over_valid_samples_with_flags():
    rng = np.random.default_rng(4)
    x = rng.standard_normal(53)
    x[[3, 10, 11, 12, 13, 14, 40]] = np.nan
    flags = rng.integers(0, 32, size=53).astype(np.uint8)
    mean, nv, fl = block_average(x, 5, flags)
    ref_m, ref_n, ref_f = reference.sensors_block_average(list(x), 5, list(flags))
    assert mean.shape == nv.shape == fl.shape == (10,)  # 3 trailing samples dropped
    np.testing.assert_allclose(mean, ref_m, rtol=1e-15, equal_nan=True)
    assert list(nv) == ref_n and list(fl) == ref_f and fl.dtype == np.uint8
    assert np.isnan(mean[2]) and nv[2] == 0  # samples 10..14 all invalid
    assert nv[0] == 4 and mean[0] == pytest.approx(np.nanmean(x[:5]), rel=1e-15)
    # no flags given: zeros; 2-D input averages each column
    m2, n2, f2 = block_average(np.stack([x, 2 * x], axis=1), 5)
    np.testing.assert_allclose(m2[:, 1], 2 * mean, rtol=1e-15, equal_nan=True)
    assert np.array_equal(n2[:, 0], nv) and not f2.any()
    # the 50 Hz -> 10 Hz time stamps are the block means of the times
    t10, _, _ = block_average(np.arange(50) / 50.0, 5)
    np.testing.assert_allclose(t10, 0.04 + 0.1 * np.arange(10), rtol=0, atol=1e-15)


def test_block_average_bad_input():
    with pytest.raises(ValueError, match="m=0"):
        block_average(np.ones(10), 0)
    with pytest.raises(ValueError, match="flags_t must have shape"):
        block_average(np.ones(10), 5, np.zeros(9, dtype=np.uint8))
    with pytest.raises(TypeError, match="flags_t must be integers"):
        block_average(np.ones(10), 5, np.zeros(10))
    with pytest.raises(ValueError, match=r"\[0, 255\]"):
        block_average(np.ones(10), 5, np.full(10, 300))
