"""The turbulence a scene may ask for: the Mann model's fitted range, and Taylor's hypothesis (sigma_u / U <= 0.5)."""

import math

import pytest

from cwlidar_sim.turbulence import MannParameters, covariances
from cwlidar_sim.turbulence import limits
from cwlidar_sim.turbulence.limits import MAX_TURBULENCE_INTENSITY, check_frozen_turbulence, longitudinal_std
from cwlidar_sim.turbulence.parameters import GAMMA_MAX, LENGTH_SCALE_MAX


def test_gamma_and_length_scale_outside_the_fitted_range_are_refused_with_the_reason():
    assert MannParameters(0.05, 20.0, GAMMA_MAX).gamma == 8.0
    with pytest.raises(ValueError, match=r"gamma=8.01 is above 8, outside the range the Mann model was fitted for"):
        MannParameters(0.05, 20.0, 8.01)
    with pytest.raises(ValueError, match=r"gamma=1000"):
        MannParameters(0.05, 20.0, 1000)
    assert MannParameters(0.05, LENGTH_SCALE_MAX, 3.9).length_scale == 5000.0
    with pytest.raises(ValueError, match=r"length_scale=5001.0 m is above the 5000 m .* boundary layer"):
        MannParameters(0.05, 5001.0, 3.9)


def test_longitudinal_std_is_the_tensors_own():
    p = MannParameters(0.31, 29.0, 3.2)
    assert longitudinal_std(p) == pytest.approx(math.sqrt(covariances(p).uu), rel=1e-9)
    # Gamma = 0: the isotropic variance, in closed form
    iso = MannParameters(0.7, 25.0, 0.0)
    assert longitudinal_std(iso) ** 2 == pytest.approx(iso.isotropic_variance, rel=1e-6)


def test_the_shortcut_bound_covers_every_accepted_gamma():
    """check_frozen_turbulence skips the quadrature when alpha_eps L^(2/3) _FU_MAX is below the limit."""
    fu = [covariances(MannParameters(1.0, 1.0, g)).uu for g in (0.0, 2.0, 4.0, 6.0, GAMMA_MAX)]
    assert fu == sorted(fu)  # increasing with Gamma: the largest at GAMMA_MAX
    assert fu[-1] <= limits._FU_MAX < 1.02 * fu[-1]


def test_turbulence_too_strong_for_the_mean_wind_is_refused_with_the_largest_alpha_eps():
    p = MannParameters(0.06224407174474577, 18.76, 3.9)  # A2012: sigma_u = 0.99 m/s
    su = longitudinal_std(p)
    assert su == pytest.approx(0.988, abs=0.002)
    check_frozen_turbulence(p, su / 0.49, "period[A]")  # intensity 0.49: accepted
    with pytest.raises(ValueError) as e:
        check_frozen_turbulence(p, su / 0.51, "period[A]")
    msg = str(e.value)
    for w in ("period[A]", "alpha_eps=0.0622", "sigma_u/U = 0.51", "Taylor's frozen-turbulence hypothesis"):
        assert w in msg, (w, msg)
    # the allowed alpha_eps it names puts the intensity at the limit
    amax = float(msg.split("allowed: alpha_eps <= ")[1].split()[0])
    at_limit = longitudinal_std(MannParameters(amax, p.length_scale, p.gamma)) / (su / 0.51)
    assert at_limit == pytest.approx(MAX_TURBULENCE_INTENSITY, rel=2e-3)


def test_the_issues_alpha_eps_1e3_is_refused():
    # sigma_u scales as sqrt(alpha_eps): A2012's 0.988 m/s times sqrt(1e3 / 0.0622) = 125 m/s
    with pytest.raises(ValueError, match=r"sigma_u = 125 m/s, a turbulence intensity sigma_u/U = 15.6"):
        check_frozen_turbulence(MannParameters(1e3, 18.76, 3.9), 8.0)
