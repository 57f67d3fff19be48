"""Optics of a focused continuous-wave coherent lidar: probe volume and its transfer function.

Conventions
-----------
* ``s`` [m] is the distance along the beam measured from the focus, positive
  away from the lidar: a range cell sits at distance ``r + s`` from the
  telescope (A2012 Eq. 2, ``v_r(r) = int phi(s) n.u((r + s) n) ds``).
* Weighting functions ``phi(s)`` are densities [1/m] that integrate to 1 over
  their domain.
* Fourier transforms of a weighting are ``phi_hat(k) = int phi(s) exp(-i k s) ds``
  (so ``phi_hat(0) = 1``), ``k`` in rad/m.  The *power* transfer function is
  ``|phi_hat(k)|**2``; it is even in ``k`` and multiplies a two-sided (or a
  one-sided) wavenumber spectrum alike.

The exact weighting and A2012 Eq. 3
-----------------------------------
For a Gaussian beam of e^-2 intensity radius ``a0`` at the telescope, focused at
``r``, the beam radius at distance ``z`` is
``w(z)**2 = a0**2 [(1 - z/r)**2 + (z/z_ap)**2]`` with ``z_ap = pi a0**2 / lambda``
(the Rayleigh range of the collimated aperture beam).  The coherent weighting is
proportional to ``1/w(z)**2``.  With ``z = r + s`` this is
``phi(s) ~ 1 / [(s/r)**2 + (r + s)**2 / z_ap**2]``, which is A2012 Eq. 3 with
two differences of convention, both needed to make Eq. 3 consistent with Eq. 1
(``z_R = lambda r**2 / (pi a0**2)``, 5.61 m at r = 67.5 m) in the Lorentzian
limit Eq. 4:

* Eq. 3 writes ``k a0**2`` where the e^-2 radius convention of Eq. 1 needs
  ``k a0**2 / 2 = z_ap`` (as printed, Eq. 3 tends to a Lorentzian of half the
  Eq. 1 Rayleigh length);
* Eq. 3 writes ``(r - s)`` where the ``(r + s) n`` of Eq. 2 needs ``(r + s)``:
  the weighting peaks on the lidar side of the focus (the well-known focal
  shift of a focused Gaussian beam), not beyond it.

Because the denominator is quadratic in ``s``, the exact weighting on the
whole real line is a Cauchy (Lorentzian) density centred at
``s0 = -r**3 / (r**2 + z_ap**2)`` with half-width
``gamma = r**2 z_ap / (r**2 + z_ap**2) = z_R z_ap**2 / (r**2 + z_ap**2)``.
Its asymmetry about the focus is this shift toward the lidar, plus the cut at
the telescope (``s > -r``).  The fraction ``arctan(r / z_ap) / pi`` of the
real-line density lies behind the telescope (2.6 % at r = 67.5 m); aerosols
are only in front of it, and the Doppler estimators normalise the spectrum,
so :func:`weight_exact` renormalises the density over ``s > -r``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_keys, check_real

#: Laser wavelength of the ZephIR prototype [m] (A2012).
WAVELENGTH = 1547.615e-9
#: Effective telescope radius (e^-2 intensity) [m] (A2012).
TELESCOPE_RADIUS = 0.020

__all__ = [
    "WAVELENGTH",
    "TELESCOPE_RADIUS",
    "BeamOptics",
    "rayleigh_length",
    "weight_exact",
    "weight_lorentzian",
    "cdf_exact",
    "cdf_lorentzian",
    "truncated_fraction_lorentzian",
    "transfer_lorentzian",
    "fourier_exact",
    "transfer_exact",
]


# ---------------------------------------------------------------------------
# parameters
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class BeamOptics:
    """Focused Gaussian beam of a cw coherent lidar.

    Parameters
    ----------
    focus : float
        Focus distance r from the telescope [m]; > 0.
    wavelength : float
        Laser wavelength lambda [m]; in (0, 1e-4].  Default 1547.615 nm.
    radius : float
        Effective telescope radius a0 at e^-2 intensity [m]; in (0, 1].
        Default 20 mm.
    """

    focus: float
    wavelength: float = WAVELENGTH
    radius: float = TELESCOPE_RADIUS

    def __post_init__(self):
        object.__setattr__(self, "focus", check_real("focus", self.focus, lo=0.0, lo_open=True))
        object.__setattr__(
            self, "wavelength", check_real("wavelength", self.wavelength, lo=0.0, hi=1e-4, lo_open=True)
        )
        object.__setattr__(self, "radius", check_real("radius", self.radius, lo=0.0, hi=1.0, lo_open=True))

    # -- interchange ---------------------------------------------------
    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "BeamOptics":
        """Build from a mapping; unknown keys are rejected by name, defaults fill the rest."""
        check_keys(cls, d, required=["focus"])
        return cls(**d)

    # -- derived quantities ----------------------------------------------
    @property
    def rayleigh_length(self) -> float:
        """Rayleigh length z_R = lambda r^2 / (pi a0^2) [m] (A2012 Eq. 1)."""
        return self.wavelength * self.focus**2 / (math.pi * self.radius**2)

    @property
    def waist_radius(self) -> float:
        """e^-2 beam radius at the focus, lambda r / (pi a0) [m] (far-field approximation)."""
        return self.wavelength * self.focus / (math.pi * self.radius)

    @property
    def optical_wavenumber(self) -> float:
        """Optical wavenumber k = 2 pi / lambda [rad/m]."""
        return 2.0 * math.pi / self.wavelength

    @property
    def aperture_rayleigh_length(self) -> float:
        """Rayleigh range of the collimated aperture beam, z_ap = pi a0^2 / lambda = k a0^2 / 2 [m].

        The Lorentzian approximation (A2012 Eq. 4) holds for ``r << z_ap``.
        """
        return math.pi * self.radius**2 / self.wavelength


def _optics_args(focus, wavelength, radius) -> BeamOptics:
    return BeamOptics(focus=focus, wavelength=wavelength, radius=radius)


def _cauchy_exact(focus: float, wavelength: float, radius: float):
    """(centre s0 [m], half-width gamma [m], behind-telescope fraction eps) of the exact weighting."""
    r = focus
    zap = math.pi * radius**2 / wavelength
    den = r * r + zap * zap
    s0 = -(r**3) / den
    gamma = r * r * zap / den
    eps = math.atan2(r, zap) / math.pi
    return s0, gamma, eps


def _cut_cauchy_density(s, r, s0, g, eps):
    """Cauchy density (centre s0, half-width g) cut at the telescope, over ``1 - eps``, at s [1/m]."""
    s = np.asarray(s, dtype=float)
    d = s - s0
    phi = g / (math.pi * (1.0 - eps) * (d * d + g * g))
    return np.where(s > -r, phi, 0.0)


def _cut_cauchy_cdf(s, r, s0, g, eps):
    """Its cumulative weight from the telescope (s = -r) to s [-]."""
    s = np.asarray(s, dtype=float)
    lo = math.atan((-r - s0) / g)
    c = (np.arctan((np.maximum(s, -r) - s0) / g) - lo) / (math.pi * (1.0 - eps))
    return np.clip(c, 0.0, 1.0)


def _as_float_array(name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number or array of real numbers, got {type(value).__name__}") from None
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains non-finite values; allowed: finite reals")
    return arr


def _ret(arr: np.ndarray):
    return float(arr) if arr.ndim == 0 else arr


# ---------------------------------------------------------------------------
# weights
# ---------------------------------------------------------------------------
def rayleigh_length(focus, wavelength: float = WAVELENGTH, radius: float = TELESCOPE_RADIUS):
    """Rayleigh length z_R = lambda r^2 / (pi a0^2) (A2012 Eq. 1).

    Parameters
    ----------
    focus : float or array_like
        Focus distance r [m]; > 0.
    wavelength : float
        Laser wavelength [m].
    radius : float
        Telescope e^-2 intensity radius a0 [m].

    Returns
    -------
    float or ndarray
        z_R [m]; 5.61 m at r = 67.5 m with the default optics.
    """
    r = _as_float_array("focus", focus)
    if np.any(r <= 0):
        raise ValueError(f"focus must be > 0 m, got min {r.min()!r}; allowed: > 0")
    wl = check_real("wavelength", wavelength, lo=0.0, hi=1e-4, lo_open=True)
    a0 = check_real("radius", radius, lo=0.0, hi=1.0, lo_open=True)
    return _ret(wl * r**2 / (math.pi * a0**2))


def weight_lorentzian(s, zR: float):
    """Lorentzian weighting phi(s) = (1/pi) z_R / (z_R^2 + s^2) (A2012 Eq. 4).

    Parameters
    ----------
    s : float or array_like
        Distance from the focus along the beam [m].
    zR : float
        Rayleigh length [m]; > 0.

    Returns
    -------
    float or ndarray
        phi(s) [1/m]; integrates to 1 over the real line.
    """
    s = _as_float_array("s", s)
    zR = check_real("zR", zR, lo=0.0, lo_open=True)
    return _ret(zR / (math.pi * (zR * zR + s * s)))


def weight_exact(s, focus: float, wavelength: float = WAVELENGTH, radius: float = TELESCOPE_RADIUS):
    """Exact weighting of a focused Gaussian beam (A2012 Eq. 3, see the module notes).

    ``phi(s) = 1 / (pi z_ap (1 - eps)) / [(s/r)^2 + (r + s)^2 / z_ap^2]`` for
    ``s > -r`` and 0 behind the telescope, with ``z_ap = pi a0^2 / lambda`` and
    ``eps = arctan(r / z_ap) / pi`` the real-line weight behind the telescope,
    divided out so that ``phi`` integrates to 1 over ``s > -r``.

    Parameters
    ----------
    s : float or array_like
        Distance from the focus along the beam, positive away from the lidar [m].
    focus : float
        Focus distance r [m]; > 0.
    wavelength : float
        Laser wavelength [m].
    radius : float
        Telescope e^-2 intensity radius a0 [m].

    Returns
    -------
    float or ndarray
        phi(s) [1/m].  Tends to :func:`weight_lorentzian` with
        ``z_R = lambda r^2 / (pi a0^2)`` for ``r << z_ap``.
    """
    s = _as_float_array("s", s)
    opt = _optics_args(focus, wavelength, radius)
    return _ret(_cut_cauchy_density(s, opt.focus, *_cauchy_exact(opt.focus, opt.wavelength, opt.radius)))


def cdf_lorentzian(s, zR: float):
    """Cumulative weight of the Lorentzian, 1/2 + arctan(s / z_R) / pi [-]."""
    s = _as_float_array("s", s)
    zR = check_real("zR", zR, lo=0.0, lo_open=True)
    return _ret(0.5 + np.arctan(s / zR) / math.pi)


def cdf_exact(s, focus: float, wavelength: float = WAVELENGTH, radius: float = TELESCOPE_RADIUS):
    """Cumulative weight of :func:`weight_exact` from the telescope (s = -r) to ``s`` [-]."""
    s = _as_float_array("s", s)
    opt = _optics_args(focus, wavelength, radius)
    return _ret(_cut_cauchy_cdf(s, opt.focus, *_cauchy_exact(opt.focus, opt.wavelength, opt.radius)))


def truncated_fraction_lorentzian(span: float, zR: float) -> float:
    """Weight of the Lorentzian outside |s| <= span: 1 - (2/pi) arctan(span / z_R) [-].

    Parameters
    ----------
    span : float
        Half-width kept around the focus [m]; >= 0.
    zR : float
        Rayleigh length [m]; > 0.
    """
    span = check_real("span", span, lo=0.0)
    zR = check_real("zR", zR, lo=0.0, lo_open=True)
    # 1 - (2/pi) atan(x) = (2/pi) atan(1/x): the second form keeps precision for x >> 1.
    return (2.0 / math.pi) * math.atan2(zR, span)


# ---------------------------------------------------------------------------
# transfer functions
# ---------------------------------------------------------------------------
def transfer_lorentzian(k, zR: float):
    """Power transfer function of the Lorentzian weighting, |phi_hat(k)|^2 = exp(-2 |k| z_R) (A2012 Eq. 9).

    Parameters
    ----------
    k : float or array_like
        Wavenumber along the beam [rad/m].
    zR : float
        Rayleigh length [m]; > 0.

    Returns
    -------
    float or ndarray
        |phi_hat(k)|^2 [-], even in k; multiplies one- and two-sided spectra alike.
    """
    k = _as_float_array("k", k)
    zR = check_real("zR", zR, lo=0.0, lo_open=True)
    return _ret(np.exp(-2.0 * np.abs(k) * zR))


def fourier_exact(k, focus: float, wavelength: float = WAVELENGTH, radius: float = TELESCOPE_RADIUS):
    """Fourier transform phi_hat(k) = int phi(s) exp(-i k s) ds of :func:`weight_exact`.

    The real-line Cauchy density has the closed form
    ``exp(-i k s0 - gamma |k|)``; the part behind the telescope (s < -r) is
    integrated numerically (QUADPACK's Fourier integral routine QAWF, through
    :func:`scipy.integrate.quad`) and subtracted, and the result is divided by
    the kept weight ``1 - eps``.

    Parameters
    ----------
    k : float or array_like
        Wavenumber along the beam [rad/m].
    focus, wavelength, radius : float
        As in :func:`weight_exact` [m].

    Returns
    -------
    complex or ndarray of complex
        phi_hat(k) [-], with phi_hat(0) = 1 and phi_hat(-k) = conj(phi_hat(k)).
    """
    from scipy.integrate import quad

    k = _as_float_array("k", k)
    opt = _optics_args(focus, wavelength, radius)
    r = opt.focus
    s0, g, eps = _cauchy_exact(r, opt.wavelength, opt.radius)
    a = r + s0  # distance from the Cauchy centre to the telescope, > 0

    def tail_density(v):
        # real-line density at s = -r - v, v >= 0
        return g / (math.pi * ((a + v) ** 2 + g * g))

    kabs_u, inv = np.unique(np.abs(k).ravel(), return_inverse=True)
    out_u = np.empty(kabs_u.shape, dtype=np.complex128)
    for i, kk in enumerate(kabs_u):
        if kk == 0.0:
            out_u[i] = 1.0
            continue
        c, _ = quad(tail_density, 0.0, np.inf, weight="cos", wvar=kk, limlst=200)
        sn, _ = quad(tail_density, 0.0, np.inf, weight="sin", wvar=kk, limlst=200)
        # int_{s<-r} phi_R(s) exp(-i k s) ds = exp(i k r) int_0^inf phi_R(-r-v) exp(i k v) dv
        tail = np.exp(1j * kk * r) * (c + 1j * sn)
        out_u[i] = (np.exp(-1j * kk * s0 - g * kk) - tail) / (1.0 - eps)
    out = out_u[inv].reshape(k.shape)
    out = np.where(k < 0, np.conj(out), out)
    return complex(out) if out.ndim == 0 else out


def transfer_exact(k, focus: float, wavelength: float = WAVELENGTH, radius: float = TELESCOPE_RADIUS):
    """Power transfer function |phi_hat(k)|^2 of the exact weighting (see :func:`fourier_exact`).

    Returns
    -------
    float or ndarray
        |phi_hat(k)|^2 [-], even in k.  Tends to :func:`transfer_lorentzian`
        for ``r << z_ap``; at longer range it is ``exp(-2 gamma |k|)`` with
        ``gamma < z_R`` plus a small contribution of the cut at the telescope.
    """
    ph = np.asarray(fourier_exact(k, focus, wavelength, radius))
    return _ret((ph * np.conj(ph)).real)
