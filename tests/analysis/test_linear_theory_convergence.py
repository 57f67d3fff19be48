"""The linear theory's quadrature (analysis/linear_theory.py) against brute-force plain sums, and its convergence."""

import math

import numpy as np
import pytest
import reference

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.analysis import rews_theory as rt
from cwlidar_sim.turbulence import MannParameters

P = MannParameters(alpha_eps=0.1, length_scale=30.0, gamma=3.0)
U = 8.0
ZR, TAU, T_CUP = 2.0, 0.3, 0.2


def _small_case():
    """Four Lorentzian looks on a 12-m circle (a 30-degree cone, each at its own time) fitted for (u, w), and a
    cup (first-order response, delayed, off the axis): the functionals and the same outputs as plain tuples."""
    th = 2.0 * math.pi * (np.arange(4) + 0.5) / 4
    looks = lt.conical_looks(20.0, 30.0, th, time_l=0.7 * (th / (2.0 * math.pi) - 0.5), probe=lt.lorentzian_probe(ZR))
    vad = lt.least_squares_functional(looks, ("u", "w"))
    cup = lt.point_functional((1.0, 0.0, 20.0), ("u",), response=lt.first_order_response(TAU), time=T_CUP)
    plain = [[(vad.weight_olc[o, i], looks.point_lc[i], looks.direction_lc[i], ZR, looks.time_l[i], 0.0)
              for i in range(4)] for o in range(2)]
    plain.append([((1.0, 0.0, 0.0), (1.0, 0.0, 20.0), (1.0, 0.0, 0.0), 0.0, T_CUP, TAU)])
    return [vad, cup], plain


def _brute(k1, plain, h):
    k2, k3, w = reference.log_plane_nodes(k1, P.length_scale, h)
    out = 0.0
    for lo in range(0, k2.size, 200_000):
        sl = slice(lo, lo + 200_000)
        out = out + reference.linear_functional_matrix(k1, k2[sl], k3[sl], w[sl], P.alpha_eps, P.length_scale,
                                                       P.gamma, U, plain)
    return out


def test_plane_quadrature_is_a_brute_force_sum():
    """functional_spectra's polar quadrature (default resolution) against a plain trapezoid sum over a fine
    logarithmic (k2, k3) grid: every spectrum and cross-spectrum (phases of the delays, the probes' kinks, the
    cup's filter) within 1e-3 of sqrt(F_aa F_bb) plus the brute force's own error (its change from step 2h to h)."""
    fs, plain = _small_case()
    k1 = np.array([0.01, 0.1])
    s = lt.functional_spectra(k1, P, fs, U)
    for j, kk in enumerate(k1):
        fine, coarse = _brute(kk, plain, 0.03), _brute(kk, plain, 0.06)
        scale = np.sqrt(np.outer(np.diag(fine).real, np.diag(fine).real))
        err = np.abs(s.matrix_kab[j] - fine) / scale
        own = np.abs(fine - coarse) / scale
        assert np.all(own < 2e-4), own  # the reference itself converged
        assert np.all(err < 1e-3 + own), (kk, err)


def test_lattice_spectra_is_a_plain_sum_over_the_modes():
    """lattice_spectra on a small box (no cell correction: Phi_d = Phi(k) dk1 dk2 dk3) against a plain sum of
    2 g^H Phi g dk2 dk3 over the box's (k2, k3) modes (numpy's fftfreq order) at the rows' k1.  Odd N1, N2, N3: no
    Nyquist modes (the generator's own rules there)."""
    fs, plain = _small_case()
    shape, spacing = (15, 11, 9), (6.0, 5.0, 5.0)
    rows = [1, 3, 7]
    s = lt.lattice_spectra(P, fs, U, shape, spacing, rows=rows, correction="none")
    q2 = 2.0 * math.pi * np.fft.fftfreq(shape[1], spacing[1])
    q3 = 2.0 * math.pi * np.fft.fftfreq(shape[2], spacing[2])
    g2, g3 = (a.ravel() for a in np.meshgrid(q2, q3, indexing="ij"))
    dk2, dk3 = (2.0 * math.pi / (n * d) for n, d in zip(shape[1:], spacing[1:]))
    for j, r in enumerate(rows):
        k1 = 2.0 * math.pi * r / (shape[0] * spacing[0])
        expect = reference.linear_functional_matrix(k1, g2, g3, np.full(g2.size, dk2 * dk3), P.alpha_eps,
                                                    P.length_scale, P.gamma, U, plain)
        assert s.k1_k[j] == pytest.approx(k1, rel=1e-15)
        scale = np.sqrt(np.outer(np.diag(expect).real, np.diag(expect).real))
        assert np.max(np.abs(s.matrix_kab[j] - expect) / scale) < 1e-6  # the package's tensor within 1.2e-7


def _std_ratio(k1, spectra, period=600.0):
    within = [lt.period_variance(k1, spectra.spectrum(a), U, period)["within"] for a in ("0.u", "1.u")]
    return math.sqrt(within[0] / within[1])


def test_period_std_ratio_converges(monkeypatch):
    """A small conical scan (12 looks of the exact weighting, each at its own time) and a cup: the std ratio
    (VAD u over cup, within 600 s, period_variance) of the default quadrature moves < 1e-3 when it is refined
    (twice the resolution, the angles per phase and the outer angles), on one k1 grid (measured 5e-5), and so do
    both spectra at every k1."""
    th = 2.0 * math.pi * (np.arange(12) + 0.5) / 12
    probe = rt.beam_transfer(40.0 / math.cos(math.radians(30.0)), "exact")
    looks = lt.conical_looks(40.0, 30.0, th, time_l=th / (2.0 * math.pi) - 0.5, probe=probe)
    fs = [lt.least_squares_functional(looks, ("u", "v", "w")),
          lt.point_functional((0.0, 0.0, 40.0), ("u",), response=lt.first_order_response(2.3 / U))]
    k1 = np.geomspace(1e-4, 1.0, 21)
    base = lt.functional_spectra(k1, P, fs, U)
    monkeypatch.setattr(lt, "_ANGLES", 2.0 * lt._ANGLES)
    monkeypatch.setattr(lt, "_OUTER_ANGLES", 2 * lt._OUTER_ANGLES)
    refined = lt.functional_spectra(k1, P, fs, U, resolution=120.0)
    assert abs(_std_ratio(k1, refined) - _std_ratio(k1, base)) < 1e-3
    for a in ("0.u", "1.u"):
        F = refined.spectrum(a)
        assert np.all(np.abs(base.spectrum(a) / F - 1.0) < np.where(F > 1e-4 * F.max(), 1e-3, 1e-2))
