"""The tensor against its definition: isotropy, symmetry, divergence, references."""

import numpy as np
import pytest
import reference
from scipy.special import hyp2f1

from cwlidar_sim.turbulence import MannParameters, eddy_lifetime, energy_spectrum, spectral_tensor
from cwlidar_sim.turbulence.tensor import lifetime_table

P = MannParameters(alpha_eps=1.3, length_scale=33.6, gamma=3.9)
RNG = np.random.default_rng(42)
# Wave vectors over five decades, all octants, plus the awkward ones:
# k1 = 0, k2 = 0, k3 = 0, the k1 axis.
K_N3 = np.concatenate(
    [
        RNG.standard_normal((400, 3)) * 10.0 ** RNG.uniform(-3.5, 0.5, (400, 1)),
        [[0.0, 0.05, 0.02], [0.0, 0.0, 0.1], [0.03, 0.0, 0.0], [0.02, 0.0, -0.04], [1e-4, 1e-4, -1e-4],
         [0.02, -0.03, 0.0]],
    ]
)


def test_gamma_zero_is_isotropic_von_karman():
    p0 = MannParameters(1.3, 33.6, 0.0)
    phi = spectral_tensor(K_N3[:, 0], K_N3[:, 1], K_N3[:, 2], p0)
    k2 = (K_N3**2).sum(axis=1)
    E = energy_spectrum(np.sqrt(k2), p0)
    iso = E[:, None, None] / (4 * np.pi * k2[:, None, None] ** 2) * (
        k2[:, None, None] * np.eye(3) - K_N3[:, :, None] * K_N3[:, None, :]
    )
    np.testing.assert_allclose(phi, iso, rtol=1e-10, atol=1e-14 * np.abs(iso).max())


def test_symmetric_psd_divergence_free_and_even():
    phi = spectral_tensor(K_N3[:, 0], K_N3[:, 1], K_N3[:, 2], P)
    scale = np.abs(phi).max(axis=(1, 2))
    np.testing.assert_allclose(phi, np.swapaxes(phi, 1, 2), atol=1e-14 * scale.max())
    assert np.all(np.linalg.eigvalsh(phi).min(axis=1) >= -1e-12 * scale)
    kphi = np.einsum("ni,nij->nj", K_N3, phi)
    kabs = np.linalg.norm(K_N3, axis=1)
    assert np.all(np.abs(kphi).max(axis=1) <= 1e-11 * kabs * scale)
    # Phi(-k) = Phi(k) for a real field with a real tensor.
    np.testing.assert_allclose(spectral_tensor(-K_N3[:, 0], -K_N3[:, 1], -K_N3[:, 2], P), phi,
                               rtol=1e-12, atol=1e-14 * scale.max())


def test_against_plain_python_reference():
    phi = spectral_tensor(K_N3[:, 0], K_N3[:, 1], K_N3[:, 2], P)
    for n in range(0, len(K_N3), 7):
        m = np.array(reference.mann_amplitude(*K_N3[n], P.alpha_eps, P.length_scale, P.gamma))
        ref = m @ m.T
        # The kernel interpolates the lifetime (relative error < 2e-6).
        np.testing.assert_allclose(phi[n], ref, rtol=2e-5, atol=2e-5 * np.abs(ref).max())


def test_k1_zero_limit_is_continuous():
    # zeta1 -> -beta as k1 -> 0 (the lift-up of u by w): no jump at k1 = 0.
    for k2, k3 in [(0.05, 0.02), (-0.3, 0.1), (0.01, -0.02)]:
        a = spectral_tensor(0.0, k2, k3, P)
        b = spectral_tensor(1e-9, k2, k3, P)
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9 * np.abs(a).max())


def test_lifetime_table_accuracy():
    x = np.geomspace(1e-6, 1e6, 2001)
    exact = x ** (-2 / 3) / np.sqrt(hyp2f1(1 / 3, 17 / 6, 4 / 3, -(x**-2)))
    from cwlidar_sim.turbulence._kernels import lifetime_f

    tab = lifetime_table()
    approx = np.array([lifetime_f(v, tab) for v in x])
    assert np.max(np.abs(approx / exact - 1)) < 2e-6
    np.testing.assert_allclose(eddy_lifetime(x / 10.0, MannParameters(1, 10.0, 2.0)), 2.0 * exact, rtol=1e-12)


def test_matches_mannrs_tensor():
    mannrs = pytest.importorskip("mannrs", reason="peer generator mannrs not installed (test extra)")
    t = mannrs.Spectra.Sheared(ae=P.alpha_eps, L=P.length_scale, gamma=P.gamma)
    for n in range(0, 400, 20):
        ours = spectral_tensor(*K_N3[n], P)
        theirs = np.asarray(t.tensor(tuple(K_N3[n])), dtype=float)
        # mannrs works in float32 with its own lifetime approximation.
        np.testing.assert_allclose(theirs, ours, rtol=2e-2, atol=2e-3 * np.abs(ours).max())


def test_quadrature_accumulator_is_the_matrix_form():
    # accumulate_phi_at (the quadratures' inner loop, held in registers) must give the bits of
    # amplitude + _accumulate_phi, and M M^T of the plain-Python reference within its lifetime error.
    from cwlidar_sim.turbulence import _kernels as K

    tab = lifetime_table()
    L, g = P.length_scale, P.gamma
    pre = P.alpha_eps / (4 * np.pi) * L ** (17.0 / 3.0)
    extra = np.array([[0.0, 0.0, 0.0], [0.0, -0.2, 0.3]])
    for n, (k1, k2, k3) in enumerate(np.concatenate([K_N3, extra])):
        w = 0.5 + n
        fused = np.zeros(6)
        K.accumulate_phi_at(k1, k2, k3, L, g, tab, w, fused)
        m = np.empty((3, 3))
        K.amplitude(k1, k2, k3, L, g, tab, m)
        matrix = np.zeros(6)
        K._accumulate_phi(m, w, matrix)
        assert np.array_equal(fused, matrix), (k1, k2, k3)
        if n % 7 == 0 and n < len(K_N3):
            mr = np.array(reference.mann_amplitude(k1, k2, k3, P.alpha_eps, L, g))
            ref = mr @ mr.T
            ref6 = w * np.array([ref[0, 0], ref[1, 1], ref[2, 2], ref[0, 2], ref[0, 1], ref[1, 2]])
            np.testing.assert_allclose(fused * pre, ref6, rtol=2e-5, atol=2e-5 * np.abs(ref6).max())
