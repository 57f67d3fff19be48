"""The turbulence a mean wind can carry: Taylor's frozen-turbulence hypothesis as a preflight check.

Every scene advects a frozen Mann field past its sensors at the period's mean
speed U (Taylor's hypothesis): a sensor at rest sees ``u(x - U t)``.  That
holds while the fluctuations are small beside U; Willis and Deardorff (1976)
found it adequate for a turbulence intensity ``sigma_u / U`` below about 0.5,
and above it the eddies' own motion (of order sigma_u) moves them as much as
the mean wind does, so a frozen field's spectra in ``k = 2 pi f / U`` are no
longer what a sensor would see.  A scene asking for more
(``alpha_eps = 1e3`` at 8 m/s: sigma_u ~ 90 m/s) is refused before any
computation, with the largest ``alpha_eps`` that period's U and the
tensor's L and Gamma allow.

``sigma_u`` is the tensor's own (all wave vectors):
``sigma_u^2 = alpha_eps L^(2/3) f_u(Gamma)``, the tensor being self-similar in
L and linear in ``alpha_eps``; ``f_u`` is :func:`cwlidar_sim.turbulence.covariances`
of the unit tensor (0.688 at Gamma = 0, 2.22 at 3.9, 5.56 at 8), computed
once per Gamma (half a second), and skipped when even the largest ``f_u`` of
the accepted Gammas leaves the intensity below the limit (every ordinary scene).
"""

from __future__ import annotations

import functools
import math

from .._validation import check_real, check_str
from .parameters import MannParameters
from .spectra import covariances

__all__ = ["MAX_TURBULENCE_INTENSITY", "longitudinal_std", "check_frozen_turbulence"]

#: Largest sigma_u / U accepted (Taylor's hypothesis, module notes).
MAX_TURBULENCE_INTENSITY = 0.5
#: An upper bound of f_u(Gamma) = sigma_u^2 / (alpha_eps L^(2/3)) over 0 <= Gamma <= GAMMA_MAX
#: (5.556 at Gamma = 8, f_u increasing with Gamma; tests/turbulence/test_limits.py checks both).
_FU_MAX = 5.6


@functools.lru_cache(maxsize=64)
def _fu(gamma: float) -> float:
    """sigma_u^2 of the unit tensor (alpha_eps = 1, L = 1) at ``gamma`` [m^2 s^-2]."""
    return covariances(MannParameters(1.0, 1.0, gamma)).uu


def longitudinal_std(params: MannParameters) -> float:
    """Standard deviation sigma_u of the tensor's longitudinal component, over all wave vectors [m/s].

    Parameters
    ----------
    params : MannParameters
    """
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be a MannParameters, got {type(params).__name__}")
    return math.sqrt(params.alpha_eps * params.length_scale ** (2.0 / 3.0) * _fu(params.gamma))


def check_frozen_turbulence(params: MannParameters, mean_speed: float, what: str = "turbulence") -> None:
    """Refuse a tensor whose ``sigma_u / U`` exceeds :data:`MAX_TURBULENCE_INTENSITY` (module notes).

    Parameters
    ----------
    params : MannParameters
        The field's tensor.
    mean_speed : float
        Mean wind speed U advecting it [m/s]; > 0.
    what : str
        Where the pair comes from, for the message (e.g. ``"period[A]"``).

    Raises
    ------
    ValueError
        Naming ``alpha_eps``, the intensity, U and the largest ``alpha_eps`` allowed.
    """
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be a MannParameters, got {type(params).__name__}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    check_str("what", what)
    limit2 = (MAX_TURBULENCE_INTENSITY * U) ** 2
    scale = params.alpha_eps * params.length_scale ** (2.0 / 3.0)
    if scale * _FU_MAX <= limit2:
        return  # below the limit whatever Gamma (<= GAMMA_MAX): no quadrature
    fu = _fu(params.gamma)
    if scale * fu <= limit2:
        return
    sigma_u = math.sqrt(scale * fu)
    amax = limit2 / (params.length_scale ** (2.0 / 3.0) * fu)
    raise ValueError(
        f"{what}: the tensor alpha_eps={params.alpha_eps:g} (L={params.length_scale:g} m, gamma={params.gamma:g}) "
        f"has sigma_u = {sigma_u:.3g} m/s, a turbulence intensity sigma_u/U = {sigma_u / U:.2f} at mean_speed = "
        f"{U:g} m/s, above the {MAX_TURBULENCE_INTENSITY:g} that Taylor's frozen-turbulence hypothesis carries "
        f"(the eddies would move as much by themselves as with the mean wind); allowed: alpha_eps <= {amax:.3g} "
        f"m^(4/3) s^-2 at this U, L and gamma"
    )

