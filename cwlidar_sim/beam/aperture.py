"""Axial weighting of a cw coherent lidar whose Gaussian beam is truncated by a circular aperture.

The untruncated Gaussian beam of :mod:`cwlidar_sim.beam.optics` has the
Lorentzian-like weighting ``phi(s) ~ 1 / w(z)^2``.  A real telescope clips the
beam at its aperture radius R; the clipped pupil diffracts, its focal spot is
larger and its depth of focus longer than those of the Gaussian of the same
e^-2 radius a0.  This module computes the exact axial weighting of the
truncated (optionally aberrated) pupil by numerical diffraction.

Derivation
----------
*Weighting of a monostatic cw coherent lidar* (Siegman 1966's antenna
theorem, Sonnenschein & Horrigan 1971, Rye 1979).  The heterodyne signal of
one scatterer at (rho, z) is proportional to the product of the transmitted
field E_T and of the back-propagated local-oscillator field E_BPLO there;
for randomly placed scatterers the mean signal power from a slab dz is

    dP ~ beta(z) dz  integral of |E_T(rho, z) E_BPLO(rho, z)|^2 d^2 rho,

with both fields normalised to unit power at the aperture (free-space
propagation conserves their power, so no 1/z^2 appears beside them).  In a
monostatic system the local oscillator and the transmitted beam leave the
same fibre mode through the same telescope, so E_BPLO = E_T = E and

    phi(z) ~ integral of |E(rho, z)|^4 d^2 rho.                        (1)

*Field of the truncated pupil* (Fresnel/Huygens integral).  At the
telescope (z = 0) the field is the Gaussian of e^-2 intensity radius a0,
focused at r and clipped at radius R = T a0 (T the truncation ratio),

    E0(rho') = exp(-rho'^2 / a0^2) exp(-i k rho'^2 / (2 r)) exp(i 2 pi W040 (rho'/R)^4),  rho' <= R,

W040 the primary spherical aberration at the aperture edge [waves].  The
Fresnel integral of an axially symmetric pupil is a Hankel transform,

    E(rho, z) = (k / (i z)) exp(i k z + i k rho^2 / (2 z)) integral_0^R E0(rho') exp(i k rho'^2 / (2 z)) J0(k rho rho' / z) rho' drho'.

With x = rho'/a0, v = k a0 rho / z and the defocus parameter

    M(z) = z_ap (1/z - 1/r),    z_ap = k a0^2 / 2 = pi a0^2 / lambda,

E = (k a0^2 / (i z)) exp(...) I(v; M) with

    I(v; M) = integral_0^T exp(-(1 - i M) x^2 + i 2 pi W040 x^4 / T^4) J0(v x) x dx,

and (1) becomes, since d^2 rho = 2 pi (z / (k a0))^2 v dv,

    phi(z) ~ W(M(z)) / z^2,    W(M) = integral_0^inf |I(v; M)|^4 v dv.  (2)

Everything about the pupil is in the one-variable function W(M) of the
truncation ratio (and aberration); r, lambda and a0 only map z to M.

*Normalisation.*  dM = -z_ap dz / z^2, so the integral of (2) over the
aerosol z > 0 (s > -r) is (1/z_ap) times the integral of W over
M > M_inf = -z_ap / r, and

    phi(s) = z_ap W(M(r + s)) / ((r + s)^2 integral_{M_inf}^inf W(M) dM).   (3)

*The untruncated limit.*  For T -> inf, I = exp(-v^2 / (4 (1 - i M))) / (2 (1 - i M)),
|I|^4 = exp(-v^2 / (1 + M^2)) / (16 (1 + M^2)^2) and W = 1 / (32 (1 + M^2)).
Then z^2 (1 + M^2) = z^2 + z_ap^2 (1 - z/r)^2 = z_ap^2 w(z)^2 / a0^2 and (3) is
exactly :func:`~cwlidar_sim.beam.optics.weight_exact` (the Cauchy density of
half-width r^2 z_ap / (r^2 + z_ap^2), renormalised over s > -r); for
r << z_ap the Lorentzian of z_R = r^2 / z_ap = lambda r^2 / (pi a0^2)
(A2012 Eqs. 1, 4).  Far from the focus, geometric optics gives
W -> (1 - exp(-4 T^2)) / (32 M^2) (the pupil intensity squared, integrated),
the limit used to continue the table beyond |M| = ``m_max``.

Numerics
--------
W(M) is tabulated once per pupil (cached) on |M| <= ``m_max`` (default 20):
I(v; M) by composite 16-point Gauss-Legendre in x (panels of at most 8 rad
of the phase 2 x (M + ...) plus the J0 oscillation), the v integral the
same way to the geometric image 2 |M| min(T, 2.5) plus 50 / min(T, 1)
(the diffraction tail of |I|^4 v falls as v^-5); the J0 matrix is shared by
all M of a block (|M| in (2.5, 5], (5, 10], ...), so the table is a few real
matrix products (0.3 s at T = 0.5, 1 s at T = 1.5, 5 s at T = 2.5 on one
core).  Between table points W is a cubic spline in M (steps 0.1
up to |M| = 5, 0.2 to 20, three steps past m_max so that the end
conditions stay outside) -- of log(W (1 + M^2)), constant
for the Gaussian; beyond m_max it is continued by
W = (G + c / |M|) / (32 (1 + M^2)), G = 1 - exp(-4 T^2) the geometric
limit and c matched to the table at +-m_max: exact for the Gaussian (c = 0),
and for T = 1 within 0.3 % of the true W at |M| = 60 (the approach to the
geometric limit is slow, about 0.6 / |M|), which moves the normalisation by
5e-5 and the transfer-function Rayleigh length by 7e-5 between m_max = 20
and 80 (measured, T = 1, A2012's optics).  ``truncation=inf`` uses the closed form
W = 1 / (32 (1 + M^2)).  Accuracy (tested): against an independent
Parseval form of W (the pupil's autocorrelation, a different integral)
within 1e-6 for T = 0.5 .. 2 and |M| <= 20 (measured <= 6e-7, the largest
between table points); doubling the v range and the panel density moves W
by < 3e-7.

Transfer function: phi_hat(k) = integral phi(s) exp(-i k s) ds by composite
Gauss-Legendre over s from -r to 200 r (panels of z_R / 2 near the focus,
growing beyond, never wider than 8 rad of exp(-i k s)), plus the far tail
z > Z = 201 r, where phi = A / z^2 + B / z^3 + ... from W and W' at
M_inf, in closed form (exponential integrals); |phi_hat|^2 is the power
transfer function.

References: Siegman, Proc. IEEE 54 (1966); Sonnenschein & Horrigan, Appl.
Opt. 10 (1971); Rye, Appl. Opt. 18 (1979).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from .._validation import check_keys, check_real
from .optics import BeamOptics

__all__ = [
    "TruncatedAperture",
    "ApertureRayleigh",
    "pupil_function",
    "weight_aperture",
    "cdf_aperture",
    "fourier_aperture",
    "transfer_aperture",
    "effective_rayleigh_length",
]

#: Pupil radius (in a0) whose geometric image bounds the v range.
_X_EFF = 2.5
#: v range added to the geometric image for the diffraction tail (times 1 / min(T, 1)).
_V_PAD = 50.0
#: Largest phase change [rad] over one 16-point Gauss-Legendre panel (error of
#: exp(i theta) over the panel below (4^32 / 32!) ~ 1e-16).
_RAD_PER_PANEL = 8.0
#: Pupil radius (in a0) beyond which the amplitude no longer sets the v resolution.
_X_BAND = 3.0
#: Table blocks (upper |M| of each) and the M step inside each.
_BLOCKS = ((2.5, 0.1), (5.0, 0.1), (10.0, 0.2), (20.0, 0.2), (40.0, 0.4), (80.0, 0.8))
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
#: Elements of a J0 chunk (float64): 32 MB.
_CHUNK = 1 << 22


@dataclasses.dataclass(frozen=True)
class TruncatedAperture:
    """A Gaussian beam clipped by a circular telescope aperture.

    Parameters
    ----------
    truncation : float
        Truncation ratio T = R / a0, the aperture radius over the beam's e^-2
        intensity radius at the telescope [-]; in [0.2, 4], or ``math.inf``
        for the unclipped Gaussian (default).  Coherent lidar telescopes are
        typically built near T = 1 .. 1.5.
    spherical_waves : float
        Primary spherical aberration W040 at the aperture edge [waves]; in
        [-2, 2]; needs a finite truncation (it is defined at the edge).
        Default 0.  A focus error is not a parameter: it moves the focus.
    """

    truncation: float = math.inf
    spherical_waves: float = 0.0

    def __post_init__(self):
        t = check_real("truncation", self.truncation, lo=0.2) if self.truncation != math.inf else math.inf
        if t != math.inf and t > 4.0:
            # Beyond, the clipped edge holds e^-16 of the peak amplitude: use inf.
            raise ValueError(f"truncation={self.truncation!r} is out of range; allowed: [0.2, 4] or inf")
        w = check_real("spherical_waves", self.spherical_waves, lo=-2.0, hi=2.0)
        if w != 0.0 and t == math.inf:
            raise ValueError("spherical_waves needs a finite truncation (the aberration is defined at the "
                             f"aperture edge), got truncation=inf and spherical_waves={w!r}")
        object.__setattr__(self, "truncation", t)
        object.__setattr__(self, "spherical_waves", w)

    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "TruncatedAperture":
        """Build from a mapping; unknown keys are rejected by name, defaults fill the rest."""
        check_keys(cls, d)
        return cls(**d)

    @property
    def transmitted_fraction(self) -> float:
        """Power of the Gaussian passing the aperture, 1 - exp(-2 T^2) [-]."""
        return 1.0 if self.truncation == math.inf else -math.expm1(-2.0 * self.truncation**2)


def _check_aperture(aperture):
    if not isinstance(aperture, TruncatedAperture):
        raise TypeError(f"aperture must be a TruncatedAperture, got {type(aperture).__name__}")
    return aperture


def _check_optics(optics):
    if not isinstance(optics, BeamOptics):
        raise TypeError(f"optics must be a BeamOptics, got {type(optics).__name__}")
    return optics


def _composite_gl(a, b, n_panels):
    edges = np.linspace(a, b, n_panels + 1)
    return _gl_on_edges(edges)


def _gl_on_edges(edges):
    h = 0.5 * np.diff(edges)
    c = 0.5 * (edges[:-1] + edges[1:])
    return (c[:, None] + h[:, None] * _GL_X).ravel(), (h[:, None] * _GL_W).ravel()


def _w_block(m_m, truncation, spherical, m_top):
    """W(M) for the M values m_m, on grids sized for |M| <= m_top (see the module notes)."""
    T = truncation
    x_max = T
    x_eff = min(T, _X_EFF)
    ab = 0.0 if T == math.inf else 4.0 * math.pi * abs(spherical) / T**4  # d(phase)/dx = 2 x (M + ab x^2)
    v_max = 2.0 * x_eff * (m_top + ab * x_eff**2) + _V_PAD / min(x_max, 1.0)
    f_x = 2.0 * x_max * (m_top + ab * x_max**2) + v_max
    x, wx = _composite_gl(0.0, x_max, max(2, math.ceil(x_max * f_x / _RAD_PER_PANEL)))
    v, wv = _composite_gl(0.0, v_max, max(4, math.ceil(v_max * 4.0 * min(x_max, _X_BAND) / _RAD_PER_PANEL)))
    phase = np.multiply.outer(m_m, x * x)
    if spherical != 0.0:
        phase = phase + 2.0 * math.pi * spherical * (x / T) ** 4
    p = (wx * x * np.exp(-x * x)) * np.exp(1j * phase)  # (M, x)
    pr = np.ascontiguousarray(np.concatenate([p.real, p.imag]).T)  # (x, 2 M)
    from scipy.special import j0

    n_m = len(m_m)
    acc = np.zeros(n_m)
    step = max(1, _CHUNK // len(x))
    for lo in range(0, len(v), step):
        vv = v[lo:lo + step]
        iv = j0(np.multiply.outer(vv, x)) @ pr  # (v, 2 M): real and imaginary parts of I(v; M)
        i2 = iv[:, :n_m] ** 2 + iv[:, n_m:] ** 2
        acc += (wv[lo:lo + step] * vv) @ (i2 * i2)
    return acc


def _m_grid(m_max):
    """Blocks (upper |M|, M >= 0 values) of the table up to m_max, plus three steps beyond it so that
    the spline's end conditions stay outside |M| <= m_max."""
    out, lo, step = [], 0.0, 0.1
    for top, step in _BLOCKS:
        if lo >= m_max:
            break
        top = min(top, m_max)
        n = max(1, round((top - lo) / step))
        pts = np.linspace(lo, top, n + 1)[1:] if lo > 0 else np.linspace(0.0, top, n + 1)
        out.append((top, pts))
        lo = top
    step = (out[-1][1][-1] - out[-1][1][-2]) if len(out[-1][1]) > 1 else step
    out.append((lo + 3 * step, lo + step * np.arange(1, 4)))
    return out


@functools.lru_cache(maxsize=16)
def _pupil_table(truncation, spherical, m_max):
    """(M grid, W on it) of one pupil, read-only."""
    blocks = _m_grid(m_max)
    if truncation == math.inf:
        # The untruncated Gaussian in closed form (module notes).
        m = np.concatenate([-g[::-1] for _, g in blocks][::-1] + [g for _, g in blocks])
        m = np.unique(m)
        w = 1.0 / (32.0 * (1.0 + m * m))
        for a in (m, w):
            a.setflags(write=False)
        return m, w
    ms, ws = [], []
    for top, pts in blocks:
        m = np.concatenate([-pts[::-1], pts]) if pts[0] > 0 else np.concatenate([-pts[:0:-1], pts])
        ms.append(m)
        ws.append(_w_block(m, truncation, spherical, top))
    m = np.concatenate(ms)
    w = np.concatenate(ws)
    order = np.argsort(m)
    m, w = m[order], w[order]
    if not np.all(np.isfinite(w) & (w > 0)):  # pragma: no cover  (|I|^4 integrals are positive)
        raise RuntimeError("pupil table is not positive")
    for a in (m, w):
        a.setflags(write=False)
    return m, w


@functools.lru_cache(maxsize=16)
def _pupil_spline(truncation, spherical, m_max):
    from scipy.interpolate import CubicSpline

    m, w = _pupil_table(truncation, spherical, m_max)
    # Spline of log(W (1 + M^2)): constant for the Gaussian, slowly varying
    # for any pupil (W ~ 1/M^2 far from the focus), so the interpolation
    # error is that of the pupil's departure from the Gaussian only.
    spl = CubicSpline(m, np.log(w * (1.0 + m * m)))
    # Continuation beyond |M| = m_max: W = (G + c / |M|) / (32 (1 + M^2)), G
    # the geometric-optics limit, c matched to the table at +-m_max (zero for
    # the Gaussian, whose W it then reproduces exactly).
    g = _geometric_limit(truncation)
    c_lo, c_hi = (m_max * (32.0 * (1.0 + m_max * m_max) * float(_w_spline(spl, x)) - g) for x in (-m_max, m_max))
    return spl, g, c_lo, c_hi


def _geometric_limit(truncation):
    # 32 M^2 W as |M| -> inf: the pupil's intensity squared integrated, over the Gaussian's.
    return 1.0 if truncation == math.inf else -math.expm1(-4.0 * truncation**2)


def _continued(M, g, c):
    a = np.abs(M)
    return (g + c / a) / (32.0 * (1.0 + a * a))


def _w_spline(spl, M):
    return np.exp(spl(M)) / (1.0 + M * M)


def pupil_function(M, aperture: TruncatedAperture, *, m_max: float = 20.0):
    """The pupil's defocus function W(M) = integral of |I(v; M)|^4 v dv (module notes, Eq. 2).

    Parameters
    ----------
    M : float or array_like
        Defocus parameter z_ap (1/z - 1/r) [-].
    aperture : TruncatedAperture
    m_max : float
        Largest |M| tabulated [-]; in [5, 80].  Beyond, W is continued by the
        geometric-optics law (module notes).

    Returns
    -------
    float or ndarray
        W(M) [-]; 1 / (32 (1 + M^2)) for the untruncated Gaussian.
    """
    _check_aperture(aperture)
    m_max = check_real("m_max", m_max, lo=5.0, hi=80.0)
    M = np.asarray(M, dtype=np.float64)
    if not np.all(np.isfinite(M)):
        raise ValueError("M contains non-finite values; allowed: finite reals")
    out = _pupil_eval(M, aperture, m_max)
    return float(out) if out.ndim == 0 else out


def _pupil_eval(M, aperture, m_max):
    spl, g, c_lo, c_hi = _pupil_spline(aperture.truncation, aperture.spherical_waves, m_max)
    inside = np.abs(M) <= m_max
    out = np.empty(M.shape)
    out[inside] = _w_spline(spl, M[inside])
    mo = M[~inside]
    out[~inside] = np.where(mo > 0, _continued(mo, g, c_hi), _continued(mo, g, c_lo))
    return out


@functools.lru_cache(maxsize=64)
def _normaliser(aperture, m_inf, m_max):
    """Integral of W over M > m_inf (tabulated part by Gauss-Legendre, tails in closed form)."""
    spl, g, c_lo, c_hi = _pupil_spline(aperture.truncation, aperture.spherical_waves, m_max)
    a = max(m_inf, -m_max)
    edges = np.linspace(a, m_max, max(8, math.ceil((m_max - a) / 0.25)) + 1)
    x, wq = _gl_on_edges(edges)
    total = float(wq @ _w_spline(spl, x))
    total += _tail_integral(g, c_hi, m_max, math.inf)
    if m_inf < -m_max:
        total += _tail_integral(g, c_lo, m_max, -m_inf)
    return total


def _tail_integral(g, c, lo, hi):
    """Integral over lo < |M| < hi of the continuation (g + c / |M|) / (32 (1 + M^2)), 0 < lo <= hi."""
    log_part = 0.5 * (math.log1p(1.0 / (lo * lo)) - (math.log1p(1.0 / (hi * hi)) if hi < math.inf else 0.0))
    return (g * (math.atan(hi) - math.atan(lo)) + c * log_part) / 32.0


#: Panel width in M of the cumulative table of :func:`cdf_aperture` (16-point Gauss-Legendre).
_CDF_PANEL = 0.25


@functools.lru_cache(maxsize=16)
def _upper_table(truncation, spherical, m_max):
    """(panel edges G_j on [-m_max, m_max], integral of W from G_j to infinity) of one pupil."""
    spl, g, c_lo, c_hi = _pupil_spline(truncation, spherical, m_max)
    n = math.ceil(2.0 * m_max / _CDF_PANEL)
    edges = np.linspace(-m_max, m_max, n + 1)
    x, wq = _gl_on_edges(edges)
    panel = (wq * _w_spline(spl, x)).reshape(n, -1).sum(axis=1)
    upper = np.concatenate([np.cumsum(panel[::-1])[::-1], [0.0]]) + _tail_integral(g, c_hi, m_max, math.inf)
    for a in (edges, upper):
        a.setflags(write=False)
    return edges, upper


def _upper_integral(M, aperture, m_max):
    """Integral of W from M to infinity [-], vectorised (tabulated panels, a partial panel, closed-form tails)."""
    spl, g, c_lo, c_hi = _pupil_spline(aperture.truncation, aperture.spherical_waves, m_max)
    edges, upper = _upper_table(aperture.truncation, aperture.spherical_waves, m_max)
    M = np.asarray(M, dtype=float)
    out = np.empty(M.shape)
    hi = M >= m_max
    out[hi] = [_tail_integral(g, c_hi, m, math.inf) for m in M[hi]]
    lo = M < -m_max
    out[lo] = [upper[0] + _tail_integral(g, c_lo, m_max, -m) for m in M[lo]]
    mid = ~(hi | lo)
    if np.any(mid):
        m = M[mid]
        j = np.clip(np.searchsorted(edges, m, side="right") - 1, 0, edges.size - 2)
        b = edges[j + 1]
        h = 0.5 * (b - m)
        x = (0.5 * (b + m))[:, None] + h[:, None] * _GL_X
        out[mid] = (h[:, None] * _GL_W * _w_spline(spl, x)).sum(axis=1) + upper[j + 1]
    return out


def cdf_aperture(s, optics: BeamOptics, aperture: TruncatedAperture, *, m_max: float = 20.0):
    """Cumulative weight of :func:`weight_aperture` from the telescope (s = -r) to ``s`` [-].

    With ``M(z) = z_ap (1/z - 1/r)`` decreasing from +inf at the telescope to
    ``M_inf = -z_ap / r`` far away, the weight up to ``z = r + s`` is
    ``integral_{M(z)}^inf W dM / integral_{M_inf}^inf W dM`` (module notes,
    Eq. 3): panels of 0.25 in M by 16-point Gauss-Legendre, the tails beyond
    ``|M| = m_max`` in closed form.  Equal to
    :func:`~cwlidar_sim.beam.optics.cdf_exact` for ``truncation=inf``.

    Parameters
    ----------
    s : float or array_like
        Distance from the focus along the beam [m].
    optics, aperture, m_max
        As for :func:`weight_aperture`.

    Returns
    -------
    float or ndarray
        In [0, 1]; 0 behind the telescope.
    """
    _check_optics(optics)
    _check_aperture(aperture)
    m_max = check_real("m_max", m_max, lo=5.0, hi=80.0)
    s = _as_array("s", s)
    r, zap = optics.focus, optics.aperture_rayleigh_length
    z = r + s
    ok = z > 0
    M = zap * (1.0 / np.where(ok, z, 1.0) - 1.0 / r)
    total = float(_upper_integral(np.array([-zap / r]), aperture, m_max)[0])
    out = np.where(ok, np.clip(_upper_integral(M, aperture, m_max) / total, 0.0, 1.0), 0.0)
    return float(out) if out.ndim == 0 else out


def _weight(s, optics, aperture, m_max):
    r = optics.focus
    zap = optics.aperture_rayleigh_length
    z = r + s
    ok = z > 0
    zz = np.where(ok, z, 1.0)
    M = zap * (1.0 / zz - 1.0 / r)
    phi = zap * _pupil_eval(M, aperture, m_max) / (zz * zz * _normaliser(aperture, -zap / r, m_max))
    return np.where(ok, phi, 0.0)


def weight_aperture(s, optics: BeamOptics, aperture: TruncatedAperture, *, m_max: float = 20.0):
    """Axial weighting phi(s) of the truncated, focused Gaussian beam (module notes, Eq. 3).

    Parameters
    ----------
    s : float or array_like
        Distance from the focus along the beam, positive away from the lidar [m].
    optics : BeamOptics
        Focus r, wavelength and the e^-2 radius a0 of the Gaussian at the telescope.
    aperture : TruncatedAperture
        Truncation ratio R / a0 and aberration.
    m_max : float
        See :func:`pupil_function`.

    Returns
    -------
    float or ndarray
        phi(s) [1/m], zero behind the telescope (s <= -r), integrating to 1
        over s > -r; equal to :func:`~cwlidar_sim.beam.optics.weight_exact`
        for ``truncation=inf``.
    """
    _check_optics(optics)
    _check_aperture(aperture)
    m_max = check_real("m_max", m_max, lo=5.0, hi=80.0)
    s = _as_array("s", s)
    out = _weight(s, optics, aperture, m_max)
    return float(out) if out.ndim == 0 else out


def _as_array(name, value):
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number or array of real numbers, got {type(value).__name__}") from None
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains non-finite values; allowed: finite reals")
    return a


def _s_nodes(optics, k_abs_max):
    """Gauss-Legendre nodes and weights over s in (-r, 200 r)."""
    r, zR = optics.focus, optics.rayleigh_length
    cap = math.inf if k_abs_max == 0.0 else _RAD_PER_PANEL / k_abs_max
    edges = [-r]
    while edges[-1] < 200.0 * r:
        e = edges[-1]
        # zR / 2 near the focus, a tenth of the distance from it beyond (the weighting varies on that scale).
        width = min(max(0.5 * zR, 0.1 * abs(e)), cap)
        edges.append(min(e + width, 200.0 * r))
    return _gl_on_edges(np.array(edges))


def fourier_aperture(k, optics: BeamOptics, aperture: TruncatedAperture, *, m_max: float = 20.0):
    """Fourier transform phi_hat(k) = integral phi(s) exp(-i k s) ds of :func:`weight_aperture`.

    Parameters
    ----------
    k : float or array_like
        Wavenumber along the beam [rad/m].
    optics, aperture, m_max
        As for :func:`weight_aperture`.

    Returns
    -------
    complex or ndarray of complex
        phi_hat(k) [-], phi_hat(0) = 1, phi_hat(-k) = conj(phi_hat(k)).
    """
    from scipy.special import exp1

    _check_optics(optics)
    _check_aperture(aperture)
    m_max = check_real("m_max", m_max, lo=5.0, hi=80.0)
    k = _as_array("k", k)
    ku, inv = np.unique(np.abs(k).ravel(), return_inverse=True)
    s, w = _s_nodes(optics, float(ku.max()) if ku.size else 0.0)
    ws = w * _weight(s, optics, aperture, m_max)
    # Far tail z > Z: M(z) = M_inf + z_ap / z, so phi = (z_ap / N) W(M) / z^2
    # ~ A / z^2 + B / z^3 with A = z_ap W(M_inf) / N, B = z_ap^2 W'(M_inf) / N;
    # integral_Z^inf exp(-i k z) z^-n dz = Z^(1-n) E_n(i k Z) (E_2, E_3 from E_1).
    r, zap = optics.focus, optics.aperture_rayleigh_length
    Z = 201.0 * r
    m_inf = -zap / r
    norm = _normaliser(aperture, m_inf, m_max)
    h = 1e-4 * max(1.0, abs(m_inf))
    w3 = _pupil_eval(np.array([m_inf - h, m_inf, m_inf + h]), aperture, m_max)
    A = zap * w3[1] / norm
    B = zap * zap * (w3[2] - w3[0]) / (2.0 * h) / norm
    out = np.empty(ku.shape, complex)
    for i, kk in enumerate(ku):
        body = ws @ np.exp(-1j * kk * s)
        if kk == 0.0:
            tail = A / Z + B / (2.0 * Z * Z)
        else:
            x = 1j * kk * Z
            e1 = exp1(x)
            e2 = np.exp(-x) - x * e1
            e3 = 0.5 * (np.exp(-x) - x * e2)
            tail = np.exp(1j * kk * r) * (A * e2 / Z + B * e3 / (Z * Z))
        out[i] = body + tail
    out = out[inv].reshape(k.shape)
    out = np.where(k < 0, np.conj(out), out)
    return complex(out) if out.ndim == 0 else out


def transfer_aperture(k, optics: BeamOptics, aperture: TruncatedAperture, *, m_max: float = 20.0):
    """Power transfer function |phi_hat(k)|^2 of :func:`weight_aperture` [-], even in k.

    It multiplies one- and two-sided wavenumber spectra alike (the convention
    of :func:`~cwlidar_sim.beam.optics.transfer_exact`, which it equals for
    ``truncation=inf``).
    """
    ph = np.asarray(fourier_aperture(k, optics, aperture, m_max=m_max))
    out = (ph * np.conj(ph)).real
    return float(out) if out.ndim == 0 else out


@dataclasses.dataclass(frozen=True)
class ApertureRayleigh:
    """Effective Rayleigh lengths of an axial weighting [m].

    Attributes
    ----------
    peak : float
        Position of the weighting's maximum, s from the focus [m] (negative:
        on the lidar side, the focal shift).
    hwhm : float
        Half the full width at half maximum [m].
    core : float
        Half-width gamma of the Lorentzian (centre, gamma, amplitude free)
        fitted by least squares over peak +- 2 hwhm [m].
    transfer : float
        z_R of exp(-2 |k| z_R) fitted to ln |phi_hat(k)|^2 over ``band``
        (through the origin, 24 log-spaced k) [m]: the Rayleigh length a
        transfer-function analysis (A2012 method 2) would see.
    transfer_rms : float
        Rms residual of that fit in ln |phi_hat|^2 [-].
    band : tuple of float
        The k band of the transfer fit [rad/m].
    """

    peak: float
    hwhm: float
    core: float
    transfer: float
    transfer_rms: float
    band: tuple


def effective_rayleigh_length(optics: BeamOptics, aperture: TruncatedAperture, *, band=(0.02, 0.6),
                              m_max: float = 20.0) -> ApertureRayleigh:
    """Effective Rayleigh lengths of the truncated beam's weighting (see :class:`ApertureRayleigh`).

    Parameters
    ----------
    optics, aperture, m_max
        As for :func:`weight_aperture`.
    band : (float, float)
        k band of the transfer-function fit [rad/m], 0 < lo < hi; default
        A2012's 0.02 .. 0.6 rad/m.
    """
    from scipy.optimize import brentq, least_squares, minimize_scalar

    _check_optics(optics)
    _check_aperture(aperture)
    m_max = check_real("m_max", m_max, lo=5.0, hi=80.0)
    lo_k = check_real("band[0]", band[0], lo=0.0, lo_open=True)
    hi_k = check_real("band[1]", band[1], lo=lo_k, lo_open=True)
    r, zR = optics.focus, optics.rayleigh_length

    def phi(x):
        return float(_weight(np.array([x]), optics, aperture, m_max)[0])

    # The maximum: on a grid around the Gaussian's Cauchy centre, then refined.
    s0 = -(r**3) / (r * r + optics.aperture_rayleigh_length**2)
    grid = np.linspace(max(s0 - 4.0 * zR, -r), s0 + 4.0 * zR, 401)
    j = int(np.argmax(_weight(grid, optics, aperture, m_max)))
    j = min(max(j, 1), len(grid) - 2)
    opt = minimize_scalar(lambda x: -phi(x), bounds=(grid[j - 1], grid[j + 1]), method="bounded",
                          options={"xatol": 1e-9 * zR})
    peak, pmax = float(opt.x), phi(float(opt.x))
    half = 0.5 * pmax

    def edge(direction):
        step = zR
        b = peak
        while phi(b + direction * step) > half:
            b += direction * step
        return brentq(lambda x: phi(x) - half, min(b, b + direction * step), max(b, b + direction * step),
                      xtol=1e-10 * zR)

    lo_e, hi_e = edge(-1.0), edge(1.0)
    hwhm = 0.5 * (hi_e - lo_e)
    xs = np.linspace(peak - 2.0 * hwhm, peak + 2.0 * hwhm, 201)
    ys = _weight(xs, optics, aperture, m_max)

    def resid(p):
        c, g, a = p
        return (a * g / (math.pi * ((xs - c) ** 2 + g * g)) - ys) / pmax

    fit = least_squares(resid, [peak, hwhm, 1.0], x_scale=[zR, zR, 1.0], xtol=1e-14, ftol=1e-14)
    kk = np.geomspace(lo_k, hi_k, 24)
    lt = np.log(transfer_aperture(kk, optics, aperture, m_max=m_max))
    zt = float(-(kk @ lt) / (2.0 * (kk @ kk)))
    rms = float(np.sqrt(np.mean((lt + 2.0 * zt * kk) ** 2)))
    return ApertureRayleigh(peak=peak, hwhm=hwhm, core=float(abs(fit.x[1])), transfer=zt, transfer_rms=rms,
                            band=(lo_k, hi_k))
