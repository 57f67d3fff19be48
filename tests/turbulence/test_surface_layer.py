"""Surface-layer Mann parameters: one function for the sensors and the campaigns, Monin-Obukhov
similarity by stability, the mix helper, bad input."""

import math

import pytest
from scipy.integrate import quad

from cwlidar_sim.turbulence import surface_layer as sl


# Each distinct 'mann1994' parameter set costs one tensor integral (seconds): one here.
@pytest.mark.parametrize("z, U, kw", [(40.0, 10.0, dict()), (40.0, 10.0, dict(source="iec")),
                                      (100.0, 6.3, dict(source="iec", z0=0.05)),
                                      (10.0, 4.0, dict(source="iec", sigma_u_over_ustar=2.1, gamma=3.2))])
def test_neutral_is_the_default(z, U, kw):
    b = sl.surface_layer_parameters(z, U, **kw)
    assert sl.surface_layer_parameters(z, U, obukhov_length=math.inf, **kw) == b
    assert sl.surface_layer_parameters(z, U, obukhov_length=None, **kw) == b


def test_neutral_fit_is_mann_1994():
    p, su, us = sl.surface_layer_parameters(40.0, 10.0)
    assert us == pytest.approx(0.4 * 10.0 / math.log(40.0 / 0.01), rel=1e-15)
    assert p.length_scale == pytest.approx(0.59 * 40.0, rel=1e-15)
    assert p.alpha_eps == pytest.approx(3.2 * us**2 * 40.0 ** (-2 / 3), rel=1e-15)
    assert p.gamma == 3.9


def test_businger_dyer_functions():
    # psi_m is the integral of (1 - phi_m(x)) / x from 0 to zeta (its definition).
    for zeta in (-1.5, -0.3, -0.01, 0.02, 0.4, 1.0):
        ref = quad(lambda x: (1.0 - sl.phi_m(x)) / x if x != 0 else 0.0, 0.0, zeta, epsabs=1e-13)[0]
        assert sl.psi_m(zeta) == pytest.approx(ref, abs=1e-10)
    assert sl.phi_m(0.0) == 1.0 and sl.psi_m(0.0) == 0.0 and sl.phi_epsilon(0.0) == 1.0
    # Dyer (1974): (1 - 16 zeta)^(-1/4) and 1 + 5 zeta.
    assert sl.phi_m(-1.0) == pytest.approx(17.0 ** -0.25, rel=1e-15)
    assert sl.phi_m(0.5) == 3.5
    # The local TKE balance: shear production phi_m minus the buoyant consumption zeta.
    assert sl.phi_epsilon(0.5) == 3.0 and sl.phi_epsilon(-1.0) == pytest.approx(17.0 ** -0.25 + 1.0)


def test_stability_changes_the_parameters_as_similarity_says():
    z, U = 40.0, 10.0  # the neutral set of the test above: its integral is cached
    p0, s0, u0 = sl.surface_layer_parameters(z, U)
    for L in (-40.0, -200.0, 200.0, 80.0):
        zeta = z / L
        p, su, us = sl.surface_layer_parameters(z, U, obukhov_length=L)
        # Same wind at z: u* from the corrected log law (more mixing unstable, less stable).
        assert us == pytest.approx(0.4 * U / (math.log(z / 0.01) - sl.psi_m(zeta)), rel=1e-14)
        assert (us > u0) == (L < 0)
        # L follows the mixing length kappa z / phi_m; the inertial level the TKE balance.
        assert p.length_scale == pytest.approx(0.59 * z / sl.phi_m(zeta), rel=1e-14)
        assert p.alpha_eps == pytest.approx(3.2 * us**2 * z ** (-2 / 3) * sl.phi_epsilon(zeta) ** (2 / 3), rel=1e-14)
        assert (p.length_scale < p0.length_scale) == (L > 0)
        assert p.gamma == 3.9
    # Continuity at neutral: |L| -> inf approaches the neutral numbers from both sides.
    for L in (-1e7, 1e7):
        p, su, us = sl.surface_layer_parameters(z, U, obukhov_length=L)
        assert su == pytest.approx(s0, rel=1e-4) and us == pytest.approx(u0, rel=1e-4)
    # sigma_u by the tensor's scaling equals the direct integral.
    from cwlidar_sim.turbulence import covariances

    p, su, _ = sl.surface_layer_parameters(z, U, obukhov_length=-200.0)
    assert su == pytest.approx(math.sqrt(covariances(p).uu), rel=1e-6)


def test_stability_mix_normalises_weights_and_keeps_order():
    mix = sl.stability_mix(40.0, 10.0, {-100.0: 1.0, None: 2.0, 150.0: 1.0})
    assert [m[1] for m in mix] == [-100.0, None, 150.0]
    assert [m[0] for m in mix] == [0.25, 0.5, 0.25]
    assert mix[1][2:] == sl.surface_layer_parameters(40.0, 10.0)
    assert mix[2][2:] == sl.surface_layer_parameters(40.0, 10.0, obukhov_length=150.0)


def test_bad_input():
    with pytest.raises(ValueError, match="obukhov_length"):
        sl.surface_layer_parameters(80.0, 8.0, obukhov_length=10.0)  # |z/L| = 8
    with pytest.raises(ValueError, match="obukhov_length"):
        sl.surface_layer_parameters(80.0, 8.0, obukhov_length=math.nan)
    with pytest.raises(TypeError, match="obukhov_length"):
        sl.surface_layer_parameters(80.0, 8.0, obukhov_length="stable")
    with pytest.raises(ValueError, match="iec.*neutral"):
        sl.surface_layer_parameters(80.0, 8.0, source="iec", obukhov_length=100.0)
    with pytest.raises(ValueError, match="height"):
        sl.surface_layer_parameters(0.005, 8.0)
    with pytest.raises(ValueError, match="source"):
        sl.surface_layer_parameters(80.0, 8.0, source="kaimal")
    with pytest.raises(ValueError, match="zeta"):
        sl.phi_m(5.0)
    with pytest.raises(ValueError, match="weights"):
        sl.stability_mix(80.0, 8.0, {100.0: 0.0})
    with pytest.raises(ValueError, match="weights"):
        sl.stability_mix(80.0, 8.0, {100.0: -1.0})
    with pytest.raises(TypeError, match="weights"):
        sl.stability_mix(80.0, 8.0, [100.0])
