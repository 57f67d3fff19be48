"""studies/cs_attribution.py: its shortcut for the 3-s fit.

The study walks the CS std ratio from CS's filter model to the simulation with the linear theory (minutes,
too long for the suite).  Here: the one piece of logic it adds to the package's theory (the 3-s fit's
spectrum from the 1-s fit's) at reduced size.
"""

import importlib.util
import os

import numpy as np
import pytest

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.campaign import bundled_scene
from cwlidar_sim.campaign.periods import theory as th

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _study():
    spec = importlib.util.spec_from_file_location("cs_attribution", os.path.join(ROOT, "studies", "cs_attribution.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("toward", [0.0, 30.0])
def test_three_revolution_fit_is_the_one_revolution_fit_times_block_gain(toward):
    """The 3-s VAD (150 estimates, every sub-dwell look) is the mean of three 1-s fits one revolution apart:
    under Taylor's hypothesis its spectrum is the 1-s fit's times |sum_j exp(-i j k1 U T)|^2 / 9, for every
    component's response and the cross-terms, at any scan orientation (an x-only field keeps it cheap)."""
    ca = _study()
    scene = bundled_scene("cs")
    z, U = 60.0, 7.0
    params = scene.turbulence.params(z, U)
    lidar = ca.scene_lidar(scene, z, toward)
    one = th.conical_functionals(lidar, z, U, revolutions=1)
    three = th.conical_functionals(lidar, z, U, revolutions=3)
    k1 = np.geomspace(1e-3, 2.0, 25)
    s1 = lt.functional_spectra(k1, params, one, U, quadrature="x_only").matrix_kab
    s3 = lt.functional_spectra(k1, params, three, U, quadrature="x_only").matrix_kab
    gain = ca.block_gain(k1, U, 3, lidar.revolution_time)
    assert gain.min() < 0.01 and gain.max() > 0.99  # the gain's zeros and its low-k 1 are inside the test
    scale = np.abs(s1).max(axis=(1, 2))[:, None, None]
    np.testing.assert_allclose(s3 / scale, s1 * gain[:, None, None] / scale, atol=1e-9)
