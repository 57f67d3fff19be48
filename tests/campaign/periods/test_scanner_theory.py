"""The WindScanner's and the SpinnerLidar's linear functionals (campaign/periods/scanner_theory.py): their limits, and
the WindScanner's transfer functions against the simulated tier-los ones."""

import dataclasses

import numpy as np
import pytest

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.campaign.periods import scanner_theory as st
from cwlidar_sim.sensors import windscanner as wsm
from cwlidar_sim.sensors.spinner import SpinnerLidar
from cwlidar_sim.sensors.windscanner import WindScanner

RNG = np.random.default_rng(31)
K_RANDOM = RNG.normal(scale=0.05, size=(3, 16))  # (k1, k2, k3) [rad/m]


def _axes_scanner():
    """Three units looking along +x, +y and +z at one point 40 m away."""
    t = (0.0, 0.0, 50.0)
    return WindScanner(positions=((-40.0, 0.0, 50.0), (0.0, -40.0, 50.0), (0.0, 0.0, 10.0)), target=t)


def _g(functional, k, U=8.0, probes=None):
    return np.stack([functional.transfer(k[0, j], k[1, j:j + 1], k[2, j:j + 1], U, probes=probes)
                     for j in range(k.shape[1])])


def test_beams_along_the_axes_with_point_probes_are_the_sonic():
    """zR -> 0 and beams along x, y, z: N is the identity, the reconstruction is the sonic at the target, exactly
    (every wavevector's transfer vector); with the beams' weighting it differs at nonzero k."""
    ws = _axes_scanner()
    assert np.linalg.cond(ws.directions()[0]) == pytest.approx(1.0)
    recon, sonic = st.windscanner_functionals(ws, probe=False)
    assert recon.names == sonic.names == ("u", "v", "w")
    np.testing.assert_allclose(_g(recon, K_RANDOM), _g(sonic, K_RANDOM), atol=1e-12)
    weighted, _ = st.windscanner_functionals(ws)
    assert np.abs(_g(weighted, K_RANDOM) - _g(sonic, K_RANDOM)).max() > 1e-2


def test_a_uniform_field_is_reconstructed_by_every_layout():
    """k -> 0 (a uniform field): every component's transfer vector is the sonic's unit vector, for the published
    layout (three unequal ranges, clock offsets) held or averaged over a Lissajous pattern; so both transfer
    functions tend to 1 as the field's scales outgrow the layout.  A wrong reconstruction row or one beam's sign flipped breaks it."""
    k0 = np.array([[1e-9], [0.0], [0.0]])
    for ws in (WindScanner(time_offsets=(0.0, 0.01, -0.02)),
               WindScanner(pattern="lissajous", points_per_pattern=32, amplitude=5.0)):
        recon, sonic = st.windscanner_functionals(ws)
        np.testing.assert_allclose(_g(recon, k0), _g(sonic, k0), atol=1e-6)


def test_the_limits_fail_on_a_broken_reconstruction(monkeypatch):
    """The checks above see a beam's sign flipped and a wrong reconstruction row."""
    ws = _axes_scanner()
    k0 = np.array([[1e-9], [0.0], [0.0]])
    real = np.linalg.inv
    for broken in (lambda n: real(n * np.array([1.0, -1.0, 1.0])[..., :, None]),  # unit 1's speed sign
                   lambda n: real(n)[..., [0, 2, 1], :]):  # rows v and w swapped
        monkeypatch.setattr(st.np.linalg, "inv", broken)
        recon, sonic = st.windscanner_functionals(ws, probe=False)
        assert np.abs(_g(recon, K_RANDOM) - _g(sonic, K_RANDOM)).max() > 1e-3
        recon, sonic = st.windscanner_functionals(WindScanner())
        assert np.abs(_g(recon, k0) - _g(sonic, k0)).max() > 0.5
        monkeypatch.setattr(st.np.linalg, "inv", real)


def _params():
    from cwlidar_sim.turbulence import MannParameters

    return MannParameters(alpha_eps=0.05, length_scale=33.6, gamma=3.9)


def test_spinner_rews_of_a_uniform_wind_is_the_rotors():
    """k -> 0: the disc fit's u0 over a rosette (blocked estimates left out, yawed and tilted) is the rotor's
    REWS along its axis, u cos gamma + v sin gamma, exactly; without the yaw in the rotor's weights it is not."""
    lid = SpinnerLidar(focus_distance=60.0, yaw_misalignment_deg=10.0, tilt_deg=5.0, n_blades=3, rotor_rpm=16.0,
                       estimates_per_rosette=246, sub_dwells=2)
    rotor, est = st.spinner_functionals(lid, 10.0, 40.0, w_zero=False)
    assert est.looks.n_looks < 246 * 2  # the blades block some
    k0 = np.array([[1e-9], [0.0], [0.0]])
    np.testing.assert_allclose(_g(est, k0), _g(rotor, k0), atol=1e-6)
    # w = 0 assumed (the scene's default): a uniform w leaks into u0 through the tilted rosette, a little
    _, assumed = st.spinner_functionals(lid, 10.0, 40.0)
    leak = _g(assumed, k0)[0, 0, 0] - _g(rotor, k0)[0, 0, 0]
    np.testing.assert_allclose(leak[:2], 0.0, atol=1e-6)
    assert 1e-4 < abs(leak[2]) < 1e-2
    np.testing.assert_allclose(_g(rotor, k0)[0, 0, 0].real, [np.cos(np.radians(10.0)), np.sin(np.radians(10.0)), 0.0],
                               atol=1e-9)
    y, z, w = st.rotor_disc_nodes(40.0, 2.0)
    assert w.sum() == pytest.approx(1.0) and np.hypot(y, z).max() < 40.0
    # the disc's (r/R)^p weight: the mean of r^2 is R^2 (p + 2) / (p + 4)
    assert np.sum(w * (y * y + z * z)) == pytest.approx(1600.0 * 4.0 / 6.0, rel=1e-9)
