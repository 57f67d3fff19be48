"""Mann parameters of the atmospheric surface layer over flat terrain, neutral and by stability.

Neutral (``obukhov_length=None``, the default): ``u* = kappa U(z) / ln(z / z0)``
(log law, kappa = 0.4), then Mann's (1994, J. Fluid Mech. 273) fit of his
tensor to Kaimal's neutral spectra, ``alpha eps^(2/3) = 3.2 u*^2 z^(-2/3)``,
``L = 0.59 z``, ``Gamma = 3.9``, or IEC 61400-1 Annex C (the numbers the
conical scenes used before stability was added, bit for bit).

Stability (``obukhov_length`` = the Obukhov length L_MO [m]; zeta = z / L_MO,
negative unstable, positive stable), by Monin-Obukhov similarity:

* the wind profile ``U(z) = (u* / kappa) (ln(z / z0) - psi_m(zeta))`` gives u*,
  with the Businger-Dyer functions (Dyer & Hicks 1970; Businger et al.
  1971; Dyer 1974) ``phi_m = (1 - 16 zeta)^(-1/4)`` (unstable),
  ``1 + 5 zeta`` (stable), and Paulson's (1970) integral of the unstable one,
  ``psi_m = 2 ln((1 + x)/2) + ln((1 + x^2)/2) - 2 atan x + pi/2``,
  x = (1 - 16 zeta)^(1/4); ``psi_m = -5 zeta`` (stable);
* the dissipation of the local TKE balance (shear production plus buoyancy,
  transport neglected): ``eps = u*^3 (phi_m(zeta) - zeta) / (kappa z)``, so the
  inertial-range level scales as ``(phi_m - zeta)^(2/3)`` about the neutral
  fit: ``alpha eps^(2/3) = 3.2 u*^2 z^(-2/3) (phi_m - zeta)^(2/3)``;
* the length scale follows the mixing length ``l = kappa z / phi_m``: Pena,
  Gryning & Mann (2010, QJRMS 136) find at Hoevsoere (10-160 m) the
  turbulence length scale, from the w-spectrum peak or a 3-D spectral model,
  linearly proportional to l over a range of stability conditions (slightly
  nonlinear only under very unstable conditions above 100 m), so
  ``L = 0.59 z / phi_m(zeta)``, the neutral fit's constant;
* Gamma stays 3.9: no stability dependence of Gamma is modelled here.

What is *not* encoded: the Hoevsoere fits of (alpha eps^(2/3), L, Gamma) by
stability class of Sathe, Mann, Barlas, Bierbooms & van Bussel (2013, Wind
Energy 16) and their class frequencies could not be checked against the
source when this module was written, so no class table (and no default
stability mix) is given; :func:`stability_mix` takes the weights from the
caller.  Validity: the surface layer, |zeta| up to about 1 (Businger-Dyer),
heights well below the boundary-layer height.
"""

from __future__ import annotations

import functools
import math

from .._validation import check_choice, check_real

#: von Karman constant of the log law.
KAPPA = 0.4
#: Businger-Dyer coefficients (Dyer 1974): phi_m = (1 - 16 zeta)^(-1/4), 1 + 5 zeta.
_BD_UNSTABLE = 16.0
_BD_STABLE = 5.0
#: Largest |zeta| accepted (Businger-Dyer's range; beyond, similarity fails).
_ZETA_MAX = 2.0


def phi_m(zeta: float) -> float:
    """Dimensionless wind shear kappa z / u* dU/dz of Businger-Dyer [-] (see the module notes)."""
    zeta = check_real("zeta", zeta, lo=-_ZETA_MAX, hi=_ZETA_MAX)
    return _phi_m(zeta)


def _phi_m(zeta):
    if zeta < 0.0:
        return (1.0 - _BD_UNSTABLE * zeta) ** -0.25
    return 1.0 + _BD_STABLE * zeta


def psi_m(zeta: float) -> float:
    """Integrated stability correction of the wind profile, integral of (1 - phi_m(x)) / x dx [-]."""
    zeta = check_real("zeta", zeta, lo=-_ZETA_MAX, hi=_ZETA_MAX)
    return _psi_m(zeta)


def _psi_m(zeta):
    if zeta < 0.0:
        x = (1.0 - _BD_UNSTABLE * zeta) ** 0.25
        return 2.0 * math.log(0.5 * (1.0 + x)) + math.log(0.5 * (1.0 + x * x)) - 2.0 * math.atan(x) + 0.5 * math.pi
    return -_BD_STABLE * zeta


def phi_epsilon(zeta: float) -> float:
    """Dimensionless dissipation kappa z eps / u*^3 of the local TKE balance, phi_m - zeta [-]."""
    zeta = check_real("zeta", zeta, lo=-_ZETA_MAX, hi=_ZETA_MAX)
    return _phi_m(zeta) - zeta


def surface_layer_parameters(height: float, speed: float, *, z0: float = 0.01, source: str = "mann1994",
                             sigma_u_over_ustar: float = 2.4, gamma: float = 3.9,
                             obukhov_length: float | None = None):
    """Mann parameters at height z in the surface layer over flat terrain.

    Parameters
    ----------
    height : float
        Height z [m]; > z0.
    speed : float
        Mean wind speed at z [m/s]; > 0.
    z0 : float
        Roughness length [m]; in (0, 2].  Default 0.01 m (grass, Hoevsoere's
        flat farmland).
    source : {'mann1994', 'iec'}
        'mann1994' (default): Mann's (1994) fit to Kaimal's spectra
        (``alpha eps^(2/3) = 3.2 u*^2 z^(-2/3)``, ``L = 0.59 z``, ``Gamma = 3.9``),
        extended by stability as in the module notes; 'iec': IEC 61400-1
        Annex C (:meth:`cwlidar_sim.turbulence.MannParameters.iec`) for ``sigma_u =
        sigma_u_over_ustar u*`` (neutral only).
    sigma_u_over_ustar : float
        sigma_u / u* for 'iec' [-]; in (0, 10].  Default 2.4 (neutral surface
        layer, Panofsky & Dutton 1984).
    gamma : float
        Mann's anisotropy for 'iec' [-].
    obukhov_length : float, optional
        Obukhov length L_MO [m]; |L_MO| >= z / 2 (|zeta| <= 2), negative
        unstable, positive stable; None (default) or +-inf: neutral.

    Returns
    -------
    params : MannParameters
    sigma_u : float
        sigma_u of the tensor ('mann1994', from its one-point spectrum; with
        stability by the tensor's exact scaling sigma_u^2 ~ alpha_eps L^(2/3))
        or the IEC target [m/s].
    u_star : float
        Friction velocity [m/s].
    """
    from .parameters import MannParameters

    z0 = check_real("z0", z0, lo=0.0, hi=2.0, lo_open=True)
    z = check_real("height", height, lo=z0, lo_open=True)
    U = check_real("speed", speed, lo=0.0, lo_open=True)
    check_choice("source", source, ("mann1994", "iec"))
    ratio = check_real("sigma_u_over_ustar", sigma_u_over_ustar, lo=0.0, hi=10.0, lo_open=True)
    zeta = _zeta(z, obukhov_length)
    if zeta == 0.0:
        ustar = 0.4 * U / math.log(z / z0)
    else:
        denom = math.log(z / z0) - _psi_m(zeta)
        if denom <= 0.0:
            raise ValueError(f"obukhov_length={obukhov_length!r} gives no wind profile at height={z!r} "
                             f"over z0={z0!r} (ln(z/z0) - psi_m(z/L) = {denom:.3g} <= 0)")
        ustar = KAPPA * U / denom
    if source == "iec":
        if zeta != 0.0:
            raise ValueError(f"source='iec' is neutral; obukhov_length must be None or inf, got {obukhov_length!r}")
        su = ratio * ustar
        return MannParameters.iec(z, su, gamma=gamma), su, ustar
    from .spectra import covariances

    if zeta == 0.0:
        p = MannParameters(alpha_eps=3.2 * ustar**2 * z ** (-2.0 / 3.0), length_scale=0.59 * z, gamma=3.9)
        return p, math.sqrt(covariances(p).uu), ustar
    pm = _phi_m(zeta)
    p = MannParameters(alpha_eps=3.2 * ustar**2 * z ** (-2.0 / 3.0) * (pm - zeta) ** (2.0 / 3.0),
                       length_scale=0.59 * z / pm, gamma=3.9)
    # The tensor is alpha_eps L^(11/3) times a function of k L and Gamma, so
    # sigma_u^2 = alpha_eps L^(2/3) sigma_u^2(1, 1, Gamma): one integral for all.
    return p, math.sqrt(p.alpha_eps * p.length_scale ** (2.0 / 3.0) * _unit_uu(p.gamma)), ustar


@functools.lru_cache(maxsize=4)
def _unit_uu(gamma):
    from .parameters import MannParameters
    from .spectra import covariances

    return covariances(MannParameters(alpha_eps=1.0, length_scale=1.0, gamma=gamma)).uu


def _zeta(z, obukhov_length):
    if obukhov_length is None:
        return 0.0
    if isinstance(obukhov_length, bool) or not isinstance(obukhov_length, (int, float)):
        raise TypeError(f"obukhov_length must be a real number [m] or None, got {obukhov_length!r}")
    L = float(obukhov_length)
    if math.isinf(L):
        return 0.0
    if not math.isfinite(L) or abs(L) < z / _ZETA_MAX:
        raise ValueError(f"obukhov_length={obukhov_length!r} is out of range; allowed: |L| >= "
                         f"height / {_ZETA_MAX:g} = {z / _ZETA_MAX:g} m (|z/L| <= {_ZETA_MAX:g}), or None / inf")
    return z / L


def stability_mix(height: float, speed: float, weights, **kwargs):
    """Mann parameters for a mix of stability conditions, with their weights normalised.

    Parameters
    ----------
    height, speed
        As for :func:`surface_layer_parameters`.
    weights : mapping of (float or None) -> float
        Obukhov length L_MO [m] (None or inf: neutral) to its relative weight
        (e.g. a site's frequency of that condition) [-]; weights >= 0, not all
        zero.  No default mix is given (see the module notes).
    **kwargs
        Passed to :func:`surface_layer_parameters` (``z0``, ``source``, ...).

    Returns
    -------
    list of (weight, obukhov_length, params, sigma_u, u_star)
        In the order of ``weights``; the weights sum to 1.
    """
    if not hasattr(weights, "items") or len(weights) == 0:
        raise TypeError(f"weights must be a non-empty mapping of Obukhov length -> weight, got {weights!r}")
    w = {L: check_real(f"weights[{L!r}]", v, lo=0.0) for L, v in weights.items()}
    total = sum(w.values())
    if total <= 0.0:
        raise ValueError(f"weights must not all be zero, got {weights!r}")
    out = []
    for L, v in w.items():
        p, su, us = surface_layer_parameters(height, speed, obukhov_length=L, **kwargs)
        out.append((v / total, L, p, su, us))
    return out
