"""Evolving planes in a row (turbulence/evolution.py): every pair has the model's coherence at its own separation.

``generate_evolving_boxes`` links each plane to its neighbour toward the
root, not to the root itself; the exponential decay makes the chain Markov,
so planes p and q, however many links apart, must have
``rho(k, |x_p - x_q| / U)`` per Fourier mode.  The tests in
``test_evolution.py`` only pair planes with the root; here three planes
follow the root on one side and all six pairs are checked (issue 33).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from cwlidar_sim.turbulence import MannParameters
from cwlidar_sim.turbulence.evolution import EddyLifetimeEvolution, box_longitudinal_coherence, generate_evolving_boxes
from cwlidar_sim.turbulence.tensor import spectral_tensor

P = MannParameters(alpha_eps=0.05, length_scale=30.0, gamma=3.9)
EV = EddyLifetimeEvolution(lifetime=60.0, mean_speed=10.0)
SHAPE, SPACING = (512, 16, 16), (4.0, 8.0, 8.0)
PLANES = [0.0, -50.0, -100.0, -150.0]  # the root, then three in a row upwind: 50 m (5 s) apart
SEEDS = range(4)


@pytest.fixture(scope="module")
def row_runs():
    """u's full 3-D spectra of each plane, for four seeds."""
    return [[np.fft.fftn(np.asarray(b.u.values, dtype=np.float64)) for b in
             generate_evolving_boxes(P, SHAPE, SPACING, 300 + s, EV, PLANES)] for s in SEEDS]


def test_every_pair_of_planes_in_a_row_has_the_model_coherence_at_its_separation(row_runs):
    r"""Pooled coherence of u per band of k1 rows, for all six pairs (separations 50, 100 and 150 m).

    Per mode with k1 > 0 outside the generator's corrected region
    (:func:`box_longitudinal_coherence`'s rows), the planes' amplitudes X, Y
    are circular complex Gaussians with ``E|X|^2 = E|Y|^2 = a`` (Phi11 at the
    mode, up to one factor) and ``E X Y* = c = rho a``, ``rho = exp(-(dx / U)
    / tau(k))``; modes are independent (their conjugates sit at -k1).  The
    estimate of a band is ``C / sqrt(A B)`` with ``C = sum Re X Y*``,
    ``A = sum |X|^2``, ``B = sum |Y|^2`` over its modes and the seeds
    (n = 4); its expectation to first order is ``sum c / sum a`` and its
    variance by the delta method ``g' S g`` with
    ``g = (1 / Ea, -r / (2 Ea), -r / (2 Ea))``, ``r = Ec / Ea`` and the
    per-mode moments ``Var C = (a^2 + c^2) / 2``, ``Var A = Var B = a^2``,
    ``Cov(A, B) = c^2``, ``Cov(C, A) = Cov(C, B) = a c`` summed over modes
    and seeds.  Every band of every pair within 4 standard errors (48
    bands: a false alarm about 3e-3).  Linking each plane to the root
    would give the pair (-50, -100) ``rho(50) rho(100) = rho(150)``; a
    doubled age would square every rho: both miss by far more than 4
    standard errors in the bands of coherence 0.2-0.7.
    """
    k1_rows, _ = box_longitudinal_coherence(P, SHAPE, SPACING, EV, 50.0)
    dk1 = 2 * math.pi / (SHAPE[0] * SPACING[0])
    rows = np.rint(k1_rows / dk1).astype(int)
    k2 = 2 * math.pi * np.fft.fftfreq(SHAPE[1], SPACING[1])
    k3 = 2 * math.pi * np.fft.fftfreq(SHAPE[2], SPACING[2])
    K1, K2, K3 = np.meshgrid(k1_rows, k2, k3, indexing="ij")
    a_all = spectral_tensor(K1, K2, K3, P)[..., 0, 0]
    kabs = np.sqrt(K1**2 + K2**2 + K3**2)
    bands = np.array_split(np.arange(rows.size), 8)
    n = len(row_runs)
    worst, report, span = 0.0, [], []
    for p, q in itertools.combinations(range(len(PLANES)), 2):
        sep = abs(PLANES[p] - PLANES[q])
        rho_all = EV.mode_correlation(kabs, sep, P)
        X = [run[p][rows] for run in row_runs]
        Y = [run[q][rows] for run in row_runs]
        for b in bands:
            C = sum(np.sum(x[b] * np.conj(y[b])).real for x, y in zip(X, Y))
            A = sum(np.sum(np.abs(x[b]) ** 2) for x in X)
            B = sum(np.sum(np.abs(y[b]) ** 2) for y in Y)
            est = C / math.sqrt(A * B)
            am, cm = a_all[b].ravel(), (rho_all[b] * a_all[b]).ravel()
            Ea, Ec = n * am.sum(), n * cm.sum()
            theory = Ec / Ea
            var_c, var_a, cov_ab, cov_ca = (n * np.sum(am * am + cm * cm) / 2, n * np.sum(am**2),
                                            n * np.sum(cm**2), n * np.sum(am * cm))
            g = np.array([1 / Ea, -theory / (2 * Ea), -theory / (2 * Ea)])
            S = np.array([[var_c, cov_ca, cov_ca], [cov_ca, var_a, cov_ab], [cov_ca, cov_ab, var_a]])
            z = (est - theory) / math.sqrt(g @ S @ g)
            report.append(f"planes {PLANES[p]:g}/{PLANES[q]:g} band {b[0]}: {est:.3f} vs {theory:.3f} (z {z:+.1f})")
            worst = max(worst, abs(z))
            span.append(theory)
    assert worst < 4.0, "\n".join(report)
    # informative: the bands hold coherences well inside (0, 1)
    assert min(span) < 0.2 and max(span) > 0.6, span
