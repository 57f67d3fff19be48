"""The displaced sonic's coherence with the beam's line (method 2 factor Re(rho)^2)."""

import numpy as np

from cwlidar_sim.analysis.offset import _cross_spectrum, offset_coherence
from cwlidar_sim.turbulence import MannParameters, one_point_spectra

P = MannParameters(0.06224407174474577, 18.76, 3.9)
K = np.array([0.02, 0.3])


def test_undisplaced_integral_is_the_one_point_spectrum():
    num, den = _cross_spectrum(K, P, 0.0, 0.0)  # two-sided (k2, k3) integrals
    F11 = one_point_spectra(K, P)[0] / 2.0  # one-sided: twice that
    assert np.allclose(den, F11, rtol=2e-3) and np.allclose(num.real, den, rtol=1e-12)


def test_coherence_symmetries_and_decay():
    up, down = offset_coherence(K, P, 1.0), offset_coherence(K, P, -1.0)
    assert np.allclose(up.real, down.real, rtol=1e-10) and np.allclose(up.imag, -down.imag, rtol=1e-10)
    assert np.all(np.abs(up) < 1.0) and abs(up[1]) < abs(up[0])          # decorrelates faster at higher k
    assert abs(offset_coherence(K, P, 3.0)[1]) < abs(up[1])                  # and with distance
    # no shear, no tilt of the eddies: Phi_11 even in k3, rho real
    iso = offset_coherence(K, MannParameters(P.alpha_eps, P.length_scale, 0.0), 1.0)
    assert np.max(np.abs(iso.imag)) < 1e-10
    # the shear tilts the eddies: a real imaginary part
    assert np.all(np.abs(up.imag) > 1e-3)
