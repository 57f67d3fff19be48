"""Parameters of the Mann (1994) uniform-shear spectral tensor, and the ranges the model was fitted for.

Physical ranges
---------------
``gamma`` is refused above :data:`GAMMA_MAX` = 8: Mann's (1994) fits to
Kaimal's neutral spectra gave Gamma = 3.9, fits to measured spectra give 0 to
about 5-6 (the highest in stable stratification), and the package's own fits (:func:`cwlidar_sim.analysis.fit_mann`)
are bounded to 0..8.  Above that the rapid-distortion tensor has never been
compared with the atmosphere, and its sheared eddies (stretched by Gamma
times their lifetime) need boxes no scene plans for.  ``length_scale`` is
refused above :data:`LENGTH_SCALE_MAX` = 5000 m (the fits' bound): the
energy-containing eddies of the atmospheric boundary layer are a fraction of
its depth (1-2 km); a larger L is a typing slip (m for km).
``alpha_eps`` has no bound of its own: whether a level is physical depends on
the mean wind that advects it, which a scene checks
(:func:`cwlidar_sim.turbulence.limits.check_frozen_turbulence`).
"""

from __future__ import annotations

import dataclasses
import math

from .._validation import check_keys, check_real

# Integral of x**4 / (1 + x**2)**(17/6) over 0..inf = B(5/2, 1/3) / 2; the
# von Karman energy spectrum integrates to alpha_eps * L**(2/3) times this.
_VK_INTEGRAL = 0.5 * math.gamma(2.5) * math.gamma(1.0 / 3.0) / math.gamma(17.0 / 6.0)

__all__ = ["MannParameters", "GAMMA_MAX", "LENGTH_SCALE_MAX"]

#: Largest anisotropy Gamma accepted [-] (module notes: the range the Mann model was fitted for).
GAMMA_MAX = 8.0
#: Largest length scale L accepted [m] (module notes).
LENGTH_SCALE_MAX = 5000.0


@dataclasses.dataclass(frozen=True)
class MannParameters:
    """Parameters of the Mann uniform-shear spectral tensor.

    Parameters
    ----------
    alpha_eps : float
        alpha * epsilon**(2/3), the level of the inertial range [m^(4/3) s^-2];
        > 0.
    length_scale : float
        Length scale L of the energy-containing eddies [m]; in (0, 5000]
        (module notes).
    gamma : float
        Anisotropy (eddy-lifetime) parameter Gamma [-]; in [0, 8] (module
        notes: the range the model was fitted for).  Gamma = 0 is isotropic
        turbulence.

    Notes
    -----
    The energy spectrum is ``E(k) = alpha_eps L^(5/3) (kL)^4 / (1 + (kL)^2)^(17/6)``
    and, for Gamma = 0, every component has variance
    ``(2/3) * integral of E = (2/3) * 1.04394 * alpha_eps * L^(2/3)``.
    """

    alpha_eps: float
    length_scale: float
    gamma: float

    def __post_init__(self):
        object.__setattr__(self, "alpha_eps", check_real("alpha_eps", self.alpha_eps, lo=0.0, lo_open=True))
        L = check_real("length_scale", self.length_scale, lo=0.0, lo_open=True)
        if L > LENGTH_SCALE_MAX:
            raise ValueError(f"length_scale={self.length_scale!r} m is above the {LENGTH_SCALE_MAX:g} m of the "
                             f"largest eddies of an atmospheric boundary layer (1-2 km deep): a length in the wrong "
                             f"unit? allowed: (0, {LENGTH_SCALE_MAX:g}] m")
        object.__setattr__(self, "length_scale", L)
        g = check_real("gamma", self.gamma, lo=0.0)
        if g > GAMMA_MAX:
            raise ValueError(f"gamma={self.gamma!r} is above {GAMMA_MAX:g}, outside the range the Mann model was "
                             f"fitted for (0 to about 5-6 in the atmosphere, 3.9 for Kaimal's neutral spectra); "
                             f"allowed: [0, {GAMMA_MAX:g}]")
        object.__setattr__(self, "gamma", g)

    # -- interchange ---------------------------------------------------
    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "MannParameters":
        """Build from a mapping; unknown keys are rejected by name."""
        check_keys(cls, d, required=[f.name for f in dataclasses.fields(cls)])
        return cls(**d)

    @property
    def isotropic_variance(self) -> float:
        """Variance of each component for Gamma = 0: (2/3) * integral of E(k) dk [m^2 s^-2]."""
        return (2.0 / 3.0) * _VK_INTEGRAL * self.alpha_eps * self.length_scale ** (2.0 / 3.0)

    @classmethod
    def iec(cls, hub_height: float, sigma_u: float, *, gamma: float = 3.9) -> "MannParameters":
        """IEC 61400-1 (Ed. 3 and 4, Annex C) Mann parameters.

        Parameters
        ----------
        hub_height : float
            Hub height z [m]; > 0.
        sigma_u : float
            Target longitudinal standard deviation sigma_1 [m/s]; > 0.
        gamma : float
            Anisotropy, 3.9 in the standard.

        Returns
        -------
        MannParameters
            ``L = 0.8 * Lambda_1`` with ``Lambda_1 = 0.7 z`` for z <= 60 m and
            42 m above, and ``alpha_eps`` such that the isotropic standard
            deviation is ``sigma_iso = 0.55 sigma_u``, using the exact
            integral of the von Karman spectrum.
        """
        z = check_real("hub_height", hub_height, lo=0.0, lo_open=True)
        s = check_real("sigma_u", sigma_u, lo=0.0, lo_open=True)
        lam1 = 0.7 * z if z <= 60.0 else 42.0
        L = 0.8 * lam1
        sigma_iso = 0.55 * s
        alpha_eps = sigma_iso**2 / ((2.0 / 3.0) * _VK_INTEGRAL * L ** (2.0 / 3.0))
        return cls(alpha_eps=alpha_eps, length_scale=L, gamma=gamma)
