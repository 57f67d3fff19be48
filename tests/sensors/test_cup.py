"""Cup anemometer: first-order response against its transfer function and a slow reference."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.sensors.cup import Cup, cup_response, cup_transfer, sample_cup


def test_kernel_matches_convolution_reference():
    from reference import cup_first_order

    rng = np.random.default_rng(2)
    V = 8.0 + rng.standard_normal(40)
    for dep in (False, True):
        got = cup_response(V, 0.1, 2.3, mean_speed=8.0, speed_dependent=dep)
        np.testing.assert_allclose(got, cup_first_order(V, 0.1, 2.3, 8.0, dep), rtol=1e-10)


@pytest.mark.parametrize("f", [0.02, 0.2, 0.7, 2.0])
def test_sinusoid_follows_first_order_transfer_function(f):
    U, l0, h = 10.0, 2.3, 0.01
    tau = l0 / U
    t = np.arange(int(60 / h)) * h
    S = cup_response(U + 0.5 * np.sin(2 * np.pi * f * t), h, l0, mean_speed=U)
    m = t > 10 * tau + 5.0  # past the start-up transient
    X = np.stack([np.sin(2 * np.pi * f * t[m]), np.cos(2 * np.pi * f * t[m]), np.ones(m.sum())], 1)
    c = np.linalg.lstsq(X, S[m], rcond=None)[0]
    H = cup_transfer(f, tau)
    # the input is linear between samples: its fundamental is the sinusoid's times sinc^2(f h)
    # (the triangle kernel's transform), a relative (pi f h)^2 / 3 = 1.3e-3 at the highest f
    interp = np.sinc(f * h) ** 2
    assert 2 * np.hypot(c[0], c[1]) == pytest.approx(abs(H) * interp, rel=2e-4)
    assert math.atan2(c[1], c[0]) == pytest.approx(np.angle(H), abs=2e-4)
    assert c[2] == pytest.approx(U, rel=1e-6)


def test_sample_cup_and_validation():
    n = 256
    x = 0.5 * np.arange(n)
    u = np.sin(2 * np.pi * x / 64.0)
    z = np.zeros(n)
    fld = xr.Dataset({"u": ("x", u), "v": ("x", z + 3.0), "w": ("x", z)}, coords={"x": x})
    cup = Cup(position=(0.0, 0.0, 0.0), distance_constant=2.0, rate=20.0)
    assert Cup.from_dict(cup.as_dict()) == cup
    t = cup.times(20.0)
    S = sample_cup(fld, cup, t, 8.0)
    vh = np.hypot(8.0 + np.interp((-8.0 * t) % 128.0, x, u, period=128.0), 3.0)
    np.testing.assert_allclose(S, cup_response(vh, 0.05, 2.0), rtol=1e-6)
    with pytest.raises(ValueError, match="distance_constant=0"):
        Cup(position=(0, 0, 0), distance_constant=0)
    with pytest.raises(ValueError, match="unknown key.*'lag'"):
        Cup.from_dict({"position": (0, 0, 0), "lag": 1})
    with pytest.raises(ValueError, match="uniformly spaced"):
        sample_cup(fld, cup, [0.0, 0.1, 0.3], 8.0)
