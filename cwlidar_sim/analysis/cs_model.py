"""CS's filter model of a conically scanning cw lidar's turbulence statistics (CS Eqs. 3-17).

Spectrum convention: in this module spectra are **one-sided** in the
along-wind wavenumber k1 > 0 [rad/m], as CS writes them
(``sigma^2 = integral over 0..inf of F(k1) dk1``), the package's
convention (:func:`cwlidar_sim.turbulence.one_point_spectra`).

Ingredients
-----------
* Kaimal's neutral spectra in wavenumber form (CS Eq. 9 for u; Kaimal et al.
  1972 for v and w), ``f = k1 z / (2 pi)``:
  ``F_u = u*^2 (102 z / 2 pi) / (1 + 33 f)^(5/3)``,
  ``F_v = u*^2 (17 z / 2 pi) / (1 + 9.5 f)^(5/3)``,
  ``F_w = u*^2 (2.1 z / 2 pi) / (1 + 5.3 f^(5/3))``
  (:func:`kaimal_spectra`); or the Mann tensor's one-point spectra F11,
  F22, F33 (:func:`mann_spectra_one_sided`), the spectra the simulation's
  boxes are built from.
* Probe-volume filter (CS Eq. 3, A2012 Eq. 9): ``L_lor = exp(-2 z_R k1)``,
  ``z_R = 0.0013 r^2`` for the series ZephIR (r = z / cos Phi).
* Scan filters over ``l_az = D + U T_rev (n - 1/2)`` (CS Eq. 4; ``D = 2 z
  tan Phi``, n revolutions of ``T_rev`` = 1 s): the weighting functions of
  CS Eqs. 5-7 on ``|x| <= l_az / 2`` -- a rectified sine
  ``|sin(pi x / l_az)|`` for the along-wind component (u is seen where the
  beam points along the wind, at the up- and downwind ends of the circle),
  a rectified cosine ``|cos(pi x / l_az)|`` for the cross-wind component, a
  box-car for the vertical (every azimuth sees w alike) -- each normalised to
  unit integral, Fourier transformed and squared:
  ``L_scan(k1) = |f_hat(k1)|^2`` with ``f_hat(0) = 1`` (:func:`scan_transfer`).

Statistics
----------
* Lidar/cup standard-deviation ratio (CS Eqs. 10-16: the horizontal speed's
  variance taken as the stream-wise turbulence's, filtered by both):
  ``sqrt( int F_u L_lor L_u dk1 / int F_u dk1 )`` (:func:`std_ratio`).
* Radial variance (CS Eq. 17 for u; Eq. 18 combines the three components
  but is not in the seed: we weight them as the beam's projection
  averaged over the azimuth does): the fluctuation left by the fit lies in
  the high-pass complement, so
  ``<v_r'^2> = sin^2 Phi / 2 (I_u + I_v) + cos^2 Phi I_w``,
  ``I_i = int F_i L_lor (1 - L_scan,i) dk1``, and its ratio to the
  sonic-equivalent radial variance ``sin^2 Phi / 2 (s_u^2 + s_v^2) + cos^2 Phi
  s_w^2`` (:mod:`cwlidar_sim.analysis.vad`) is :func:`radial_variance_ratio`.

Integrals run over ``k1`` in ``[k_lo, k_max]`` on a fine logarithmic grid
(trapezoid in ln k1); ``k_max`` may be set to a grid's Nyquist ``pi / d`` to
model what a box of spacing d holds (the Mann spectra then also cut k2, k3
at ``pi / d``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .._validation import check_choice, check_int, check_real

__all__ = [
    "kaimal_spectra",
    "mann_spectra_one_sided",
    "scan_length",
    "scan_transfer",
    "probe_transfer",
    "model_integrals",
    "model_ratios",
    "std_ratio",
    "radial_variance_ratio",
    "SCAN_FILTERS",
    "ZR_COEFFICIENT",
]

#: Weighting shapes of the scan filters (CS Eqs. 5-7).
SCAN_FILTERS = ("rectified_sine", "rectified_cosine", "boxcar")
#: z_R = ZR_COEFFICIENT r^2 for the series ZephIR [1/m] (CS).
ZR_COEFFICIENT = 0.0013


def kaimal_spectra(k1, height: float, u_star: float = 1.0):
    """Kaimal's neutral u, v, w spectra in wavenumber form, one-sided [m^3/s^2] (module notes).

    Parameters
    ----------
    k1 : array_like
        Along-wind wavenumber [rad/m], >= 0.
    height : float
        z [m]; > 0.
    u_star : float
        Friction velocity [m/s]; > 0.
    """
    z = check_real("height", height, lo=0.0, lo_open=True)
    us = check_real("u_star", u_star, lo=0.0, lo_open=True)
    k = np.asarray(k1, dtype=np.float64)
    if np.any(k < 0) or not np.all(np.isfinite(k)):
        raise ValueError("k1 must be finite and >= 0 [rad/m]")
    f = k * z / (2.0 * math.pi)
    c = us * us * z / (2.0 * math.pi)
    Fu = c * 102.0 / (1.0 + 33.0 * f) ** (5.0 / 3.0)
    Fv = c * 17.0 / (1.0 + 9.5 * f) ** (5.0 / 3.0)
    Fw = c * 2.1 / (1.0 + 5.3 * f ** (5.0 / 3.0))
    return Fu, Fv, Fw


def mann_spectra_one_sided(k1, params, *, k_cut: float | None = None):
    """One-sided F11, F22, F33 of the Mann tensor [m^3/s^2]: :func:`~cwlidar_sim.turbulence.one_point_spectra`'s.

    ``k_cut`` restricts k2 and k3 to ``|k| <= k_cut`` (a grid's Nyquist).
    The name keeps the convention in sight beside :func:`kaimal_spectra`;
    every spectrum of the package is one-sided.
    """
    from ..turbulence.spectra import one_point_spectra

    kw = {} if k_cut is None else {"k2_max": k_cut, "k3_max": k_cut}
    F11, F22, F33, _ = one_point_spectra(np.asarray(k1, dtype=np.float64), params, **kw)
    return F11, F22, F33


def scan_length(height: float, speed: float, n_rev: int, *, half_angle_deg: float = 30.0,
                revolution_time: float = 1.0) -> float:
    """Effective scan length ``l_az = D + U T_rev (n - 1/2)`` [m] (CS Eq. 4)."""
    z = check_real("height", height, lo=0.0, lo_open=True)
    U = check_real("speed", speed, lo=0.0)
    n = check_int("n_rev", n_rev, lo=1)
    phi = math.radians(check_real("half_angle_deg", half_angle_deg, lo=0.0, hi=90.0, lo_open=True, hi_open=True))
    T = check_real("revolution_time", revolution_time, lo=0.0, lo_open=True)
    return 2.0 * z * math.tan(phi) + U * T * (n - 0.5)


def scan_transfer(k1, length: float, kind: str):
    """Power transfer function of a scan weighting of length l, normalised to 1 at k1 = 0 [-].

    ``|f_hat(k1)|^2 / f_hat(0)^2`` with ``f_hat(k) = int f(x) exp(-i k x) dx``
    over ``|x| <= a = l / 2`` (f even, ``f_hat`` real), in closed form with
    ``p = pi / l`` (so ``p a = pi / 2``) and ``delta = |k| a - pi / 2``:

    * 'boxcar': ``sinc^2(k a)`` (``sin(x) / x``);
    * 'rectified_sine' (``|sin(p x)|``): ``f_hat / f_hat(0) = p [ (1 + sin ka) / (p + k)
      + (1 - sin ka) / (p - k) ] / 2``, the second term written
      ``-(a delta / 2) sinc^2(delta / 2)`` so that k = p is regular;
    * 'rectified_cosine' (``|cos(p x)|``): ``f_hat / f_hat(0) = p^2 cos(ka) / (p^2 - k^2)
      = p^2 a sinc(delta) / (p + k)``.

    Parameters
    ----------
    k1 : array_like
        Wavenumber [rad/m].
    length : float
        l [m]; > 0.
    kind : {'rectified_sine', 'rectified_cosine', 'boxcar'}
    """
    check_choice("kind", kind, SCAN_FILTERS)
    L = check_real("length", length, lo=0.0, lo_open=True)
    k = np.abs(np.asarray(k1, dtype=np.float64))
    if not np.all(np.isfinite(k)):
        raise ValueError("k1 must be finite [rad/m]")
    a = 0.5 * L
    p = math.pi / L
    if kind == "boxcar":
        return np.sinc(k * a / math.pi) ** 2
    delta = k * a - 0.5 * math.pi
    if kind == "rectified_sine":
        g = 0.5 * p * ((1.0 + np.sin(k * a)) / (p + k) - 0.5 * a * delta * np.sinc(delta / (2.0 * math.pi)) ** 2)
    else:
        g = p * p * a * np.sinc(delta / math.pi) / (p + k)
    return g * g


def probe_transfer(k1, rayleigh_length: float):
    """Probe-volume power transfer function exp(-2 z_R |k1|) [-] (CS Eq. 3)."""
    zr = check_real("rayleigh_length", rayleigh_length, lo=0.0)
    return np.exp(-2.0 * zr * np.abs(np.asarray(k1, dtype=np.float64)))


def _grid(k_lo, k_hi, n):
    k = np.geomspace(k_lo, k_hi, n)
    lk = np.log(k)
    w = np.empty(n)
    w[1:-1] = 0.5 * (lk[2:] - lk[:-2])
    w[0] = 0.5 * (lk[1] - lk[0])
    w[-1] = 0.5 * (lk[-1] - lk[-2])
    return k, w * k  # trapezoid in ln k: dk = k dlnk


@functools.lru_cache(maxsize=32)
def _mann_coarse(params, k_lo, k_max, n, k_cut):
    """Mann one-sided spectra on a coarse log grid (cached: the quadrature costs about 1 s)."""
    kc = np.geomspace(k_lo, k_max, n)
    Fc = mann_spectra_one_sided(kc, params, k_cut=k_cut)
    for a in (kc,) + tuple(Fc):
        a.setflags(write=False)
    return kc, Fc


def model_integrals(height: float, speed: float, n_rev: int, *, spectrum: str = "kaimal", params=None,
                    u_star: float = 1.0, half_angle_deg: float = 30.0, revolution_time: float = 1.0,
                    rayleigh_length: float | None = None, k_lo: float = 1e-6, k_max: float = 1e3,
                    n_k: int = 6000, k_cut_lateral: float | None = None) -> dict:
    """Filtered and unfiltered integrals of the model (module notes) [m^2/s^2].

    Parameters
    ----------
    height, speed, n_rev : float, float, int
        z [m], U [m/s], revolutions per scan.
    spectrum : {'kaimal', 'mann'}
        Kaimal with ``u_star``, or the Mann tensor ``params``.
    params : MannParameters
        Needed for 'mann'.
    rayleigh_length : float, optional
        z_R [m]; default ``0.0013 (z / cos Phi)^2``.
    k_lo, k_max : float
        Integration range [rad/m].
    n_k : int
        Grid points (the Mann spectra are evaluated on 1/20 of them and
        interpolated in log-log).
    k_cut_lateral : float, optional
        For 'mann': restrict k2, k3 to ``|k| <= k_cut_lateral`` (a box's Nyquist).

    Returns
    -------
    dict
        ``var_u, var_v, var_w`` (unfiltered), ``lidar_var_u`` (``F_u L_lor
        L_u``), ``hp_u, hp_v, hp_w`` (``F_i L_lor (1 - L_i)``), ``l_az``,
        ``rayleigh_length``.
    """
    check_choice("spectrum", spectrum, ("kaimal", "mann"))
    z = check_real("height", height, lo=0.0, lo_open=True)
    phi = math.radians(check_real("half_angle_deg", half_angle_deg, lo=0.0, hi=90.0, lo_open=True,
                                  hi_open=True))
    r = z / math.cos(phi)
    zr = ZR_COEFFICIENT * r * r if rayleigh_length is None else check_real("rayleigh_length", rayleigh_length,
                                                                          lo=0.0)
    k_lo = check_real("k_lo", k_lo, lo=0.0, lo_open=True)
    k_max = check_real("k_max", k_max, lo=k_lo, lo_open=True)
    n_k = check_int("n_k", n_k, lo=100, hi=10**6)
    l_az = scan_length(z, speed, n_rev, half_angle_deg=half_angle_deg, revolution_time=revolution_time)
    k, dk = _grid(k_lo, k_max, n_k)
    if spectrum == "kaimal":
        Fu, Fv, Fw = kaimal_spectra(k, z, u_star)
    else:
        from ..turbulence.parameters import MannParameters

        if not isinstance(params, MannParameters):
            raise TypeError(f"spectrum='mann' needs params=MannParameters, got {type(params).__name__}")
        kc, Fc = _mann_coarse(params, k_lo, k_max, max(60, n_k // 20), k_cut_lateral)
        lk = np.log(k)
        Fu, Fv, Fw = (np.exp(np.interp(lk, np.log(kc), np.log(np.maximum(F, 1e-300)))) for F in Fc)
    Llor = probe_transfer(k, zr)
    Lu = scan_transfer(k, l_az, "rectified_sine")
    Lv = scan_transfer(k, l_az, "rectified_cosine")
    Lw = scan_transfer(k, l_az, "boxcar")
    return {
        "var_u": float(np.dot(Fu, dk)), "var_v": float(np.dot(Fv, dk)), "var_w": float(np.dot(Fw, dk)),
        "lidar_var_u": float(np.dot(Fu * Llor * Lu, dk)),
        "hp_u": float(np.dot(Fu * Llor * (1.0 - Lu), dk)),
        "hp_v": float(np.dot(Fv * Llor * (1.0 - Lv), dk)),
        "hp_w": float(np.dot(Fw * Llor * (1.0 - Lw), dk)),
        "l_az": l_az, "rayleigh_length": zr,
    }


def model_ratios(height: float, speed: float, n_rev: int, *, half_angle_deg: float = 30.0, **kw) -> dict:
    """Both model ratios from one evaluation of :func:`model_integrals`.

    Returns
    -------
    dict
        ``std_ratio``: ``sqrt(int F_u L_lor L_u / int F_u)``; ``radial_variance_ratio``:
        ``[sin^2 Phi (I_u + I_v) / 2 + cos^2 Phi I_w] / [sin^2 Phi (s_u^2 + s_v^2) / 2 + cos^2 Phi s_w^2]``
        (module notes); ``l_az`` [m]; ``rayleigh_length`` [m].
    """
    m = model_integrals(height, speed, n_rev, half_angle_deg=half_angle_deg, **kw)
    phi = math.radians(half_angle_deg)
    s2, c2 = math.sin(phi) ** 2, math.cos(phi) ** 2
    num = 0.5 * s2 * (m["hp_u"] + m["hp_v"]) + c2 * m["hp_w"]
    den = 0.5 * s2 * (m["var_u"] + m["var_v"]) + c2 * m["var_w"]
    return {"std_ratio": math.sqrt(m["lidar_var_u"] / m["var_u"]), "radial_variance_ratio": num / den,
            "l_az": m["l_az"], "rayleigh_length": m["rayleigh_length"]}


def std_ratio(height: float, speed: float, n_rev: int, **kw) -> float:
    """CS's lidar/cup standard-deviation ratio ``sqrt(int F_u L_lor L_u / int F_u)`` [-] (:func:`model_ratios`)."""
    return model_ratios(height, speed, n_rev, **kw)["std_ratio"]


def radial_variance_ratio(height: float, speed: float, n_rev: int, **kw) -> float:
    """Model radial variance over the sonic-equivalent radial variance [-] (:func:`model_ratios`)."""
    return model_ratios(height, speed, n_rev, **kw)["radial_variance_ratio"]
