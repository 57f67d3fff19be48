"""CS's filter model under stability: its std ratio moves with the length scale as filter theory says.

With Mann's spectra the model's ratio sqrt(int F_u L_lor L_u / int F_u) is a ratio of integrals
of one spectrum, so alpha eps^(2/3) cancels, and the tensor's similarity form F_11(k1) =
alpha_eps L^(5/3) f(k1 L, Gamma) makes it a function of the filter lengths in units of L
(l_az / L, z_R / L) and of Gamma only.  Monin-Obukhov similarity (Pena et al. 2010) shortens L
under stable stratification (L = 0.59 z / phi_m), so more of the u variance lies at scales the
probe volume and the scan remove: the ratio must fall from unstable through neutral to stable.
"""

import math

import pytest

from cwlidar_sim.analysis.cs_model import ZR_COEFFICIENT, model_ratios
from cwlidar_sim.turbulence.parameters import MannParameters
from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

Z, U = 40.0, 10.0
ZR = ZR_COEFFICIENT * (Z / math.cos(math.radians(30.0))) ** 2
# 60 Mann spectrum evaluations per parameter set (n_k // 20): a few seconds each
N_K = 1200


def _ratio(z, u, params, zr, k_lo=1e-6, k_max=1e3):
    return model_ratios(z, u, 1, spectrum="mann", params=params, rayleigh_length=zr, n_k=N_K, k_lo=k_lo,
                        k_max=k_max)["std_ratio"]


def test_model_std_ratio_falls_as_stability_shortens_the_length_scale():
    classes = [surface_layer_parameters(Z, U, obukhov_length=L)[0] for L in (-100.0, None, 100.0)]
    lengths = [p.length_scale for p in classes]
    assert lengths[0] > lengths[1] > lengths[2]  # unstable > neutral > stable (mixing length)
    ratios = [_ratio(Z, U, p, ZR) for p in classes]
    # strictly falling, each step well beyond the model's quadrature error (< 1e-4, tests/analysis pins)
    assert ratios[0] - ratios[1] > 0.01 and ratios[1] - ratios[2] > 0.01
    assert all(0.0 < r < 1.0 for r in ratios)


def test_model_depends_on_stability_only_through_the_filters_in_units_of_the_length_scale():
    # The stable class at 40 m (L_MO = 100 m) against a tensor of the neutral class's length scale
    # and another inertial level, with every length of the problem (the scan's l_az through z and U,
    # z_R, the wavenumber range) stretched by s = L_neutral / L_stable: the same ratio to rounding.
    stable = surface_layer_parameters(Z, U, obukhov_length=100.0)[0]
    neutral = surface_layer_parameters(Z, U)[0]
    s = neutral.length_scale / stable.length_scale
    other = MannParameters(alpha_eps=7.3 * stable.alpha_eps, length_scale=neutral.length_scale, gamma=stable.gamma)
    k_lo, k_max = 1e-4, 1e2
    r_stable = _ratio(Z, U, stable, ZR, k_lo, k_max)
    r_scaled = _ratio(Z * s, U * s, other, ZR * s, k_lo / s, k_max / s)
    assert r_scaled == pytest.approx(r_stable, rel=1e-9)
    # and the stretch matters: the neutral tensor under the unstretched filters gives another ratio
    assert abs(_ratio(Z, U, other, ZR, k_lo, k_max) - r_stable) > 0.05
