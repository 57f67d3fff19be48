"""The wind from three line-of-sight speeds (analysis/reconstruction.py): exact solves, conditioning, flags, signs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.reconstruction import (DEFAULT_MAX_CONDITION, ReconstructionFlag, homodyne_signs,
                                                 reconstruct_uvw)
from cwlidar_sim.signal import Flag


def random_directions(rng, n):
    d = rng.standard_normal((n, 3, 3))
    return d / np.linalg.norm(d, axis=2)[:, :, None]


def test_random_geometries_return_the_wind_to_round_off():
    rng = np.random.default_rng(5)
    n = random_directions(rng, 200)
    uvw = rng.normal(0.0, 5.0, (200, 3))
    v = np.einsum("kic,kc->ki", n, uvw)
    res = reconstruct_uvw(n, v, max_condition=1e12)
    scale = res.condition_k[:, None] * np.abs(uvw).max()
    assert np.all(np.abs(res.uvw_kc - uvw) <= 1e-13 * scale)
    np.testing.assert_allclose(res.condition_k, [np.linalg.svd(a, compute_uv=False)[[0, 2]] @ [1, 0] /
                                                 np.linalg.svd(a, compute_uv=False)[2] for a in n], rtol=1e-10)


@pytest.mark.parametrize("elev", [10.0, 35.26438968, 60.0])
def test_condition_number_of_three_symmetric_beams(elev):
    e = math.radians(elev)
    az = np.radians([0.0, 120.0, 240.0])
    n = np.stack([math.cos(e) * np.cos(az), math.cos(e) * np.sin(az), math.sin(e) * np.ones(3)], axis=1)
    sv = (math.sqrt(1.5) * math.cos(e), math.sqrt(3.0) * math.sin(e))  # N^T N = diag(1.5 c^2, 1.5 c^2, 3 s^2)
    res = reconstruct_uvw(n, n @ np.array([7.0, -2.0, 0.5]))
    np.testing.assert_allclose(res.condition_k, [max(sv) / min(sv)], rtol=1e-12)
    np.testing.assert_allclose(res.uvw_kc[0], [7.0, -2.0, 0.5], atol=1e-12)
    if abs(elev - 35.26438968) < 1e-6:  # the orthogonal triad (tan e = 1/sqrt 2): perfectly conditioned
        np.testing.assert_allclose(res.condition_k, [1.0], atol=1e-8)


def test_ill_conditioned_steps_are_nan_flagged_counted_and_kept():
    e_ok, e_bad = math.radians(40.0), math.radians(1.0)
    az = np.radians([0.0, 120.0, 240.0])

    def triad(e):
        return np.stack([math.cos(e) * np.cos(az), math.cos(e) * np.sin(az), math.sin(e) * np.ones(3)], axis=1)

    n = np.stack([triad(e_ok), triad(e_bad), triad(e_ok)])
    v = np.einsum("kic,c->ki", n, [8.0, 1.0, 0.2])
    res = reconstruct_uvw(n, v)
    assert res.uvw_kc.shape == (3, 3)
    assert np.all(np.isnan(res.uvw_kc[1])) and np.all(np.isfinite(res.uvw_kc[[0, 2]]))
    assert res.flags_k.tolist() == [0, int(ReconstructionFlag.ILL_CONDITIONED), 0]
    assert res.n_ill_conditioned == 1 and res.n_missing == 0
    assert res.condition_k[1] > DEFAULT_MAX_CONDITION > res.condition_k[0]


def test_chain_flags_are_ored_and_missing_speeds_give_nan():
    n = np.tile(np.eye(3), (3, 1, 1))
    v = np.array([[1.0, 2.0, 3.0], [1.0, np.nan, 3.0], [4.0, 5.0, 6.0]])
    f = np.array([[0, 0, 0], [Flag.NO_SIGNAL, 0, 0], [Flag.NEAR_ZERO, Flag.SECOND_PEAK, 0]], dtype=np.uint8)
    res = reconstruct_uvw(n, v, flags_ki=f)
    np.testing.assert_array_equal(res.uvw_kc[[0, 2]], v[[0, 2]])
    assert np.all(np.isnan(res.uvw_kc[1]))
    assert res.flags_k.tolist() == [0, int(Flag.NO_SIGNAL), int(Flag.NEAR_ZERO | Flag.SECOND_PEAK)]
    assert res.n_missing == 1 and res.n_ill_conditioned == 0


def test_homodyne_signs_follow_the_mean_wind_projection():
    n = np.array([[[1.0, 0.0, 0.0], [-0.6, 0.0, 0.8], [0.0, 1.0, 0.0]]])
    np.testing.assert_array_equal(homodyne_signs(n, (8.0, 0.0, 0.0)), [[1.0, -1.0, 1.0]])
    # homodyne speeds with those signs return the wind when no projection changes sign
    u = np.array([8.0, 0.5, 0.3])
    speed = np.abs(n[0] @ u)
    res = reconstruct_uvw(n, speed[None] * homodyne_signs(n, (8.0, 0.0, 0.0)))
    np.testing.assert_allclose(res.uvw_kc[0], u, atol=1e-12)


@pytest.mark.parametrize("call, match", [
    (lambda: reconstruct_uvw(np.ones((2, 3)), np.ones((1, 3))), r"direction_kic must have shape"),
    (lambda: reconstruct_uvw(2 * np.eye(3), np.ones(3)), r"unit vectors"),
    (lambda: reconstruct_uvw(np.eye(3), np.ones((1, 2))), r"vlos_ki must have shape"),
    (lambda: reconstruct_uvw(np.eye(3), np.ones((1, 3)), max_condition=0.5), r"max_condition"),
    (lambda: reconstruct_uvw(np.eye(3), np.ones((1, 3)), flags_ki=np.zeros((2, 3))), r"flags_ki must have shape"),
    (lambda: homodyne_signs(np.eye(3), (1.0, 0.0)), r"wind_c"),
])
def test_bad_input_is_refused_by_name(call, match):
    with pytest.raises((ValueError, TypeError), match=match):
        call()
