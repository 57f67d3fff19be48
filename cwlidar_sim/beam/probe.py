"""The probe volume of a lidar: a weighting along the beam and the optics, and the registry of weightings.

A lidar's line-of-sight speed is the weighted average ``v_r = int phi(s)
n.u((r + s) n) ds`` of the wind along its beam (A2012 Eq. 2), ``s`` the
distance from the focus (or the range gate's centre), positive away from
the lidar.  Everything downstream of the weighting -- the range cells of
:mod:`cwlidar_sim.beam.cells`, the tier-1 average of
:func:`cwlidar_sim.beam.los_average`, a cloud's share of the signal, the
transfer functions of the spectral theories
(:func:`cwlidar_sim.analysis.rews_theory.beam_transfer`) -- asks a
:class:`~cwlidar_sim.beam.Weighting` for what it needs, never for its name:

``density(s, optics)``
    ``phi(s)`` [1/m];
``primitive(s, optics)``
    an antiderivative of ``phi`` (only its differences are used: the weight
    of a cell is ``primitive(b) - primitive(a)``), exact, so that cell
    weights are exact integrals however coarse the cells;
``interval(a, b, optics)``
    the weight between ``a`` and ``b`` (by default the primitive's
    difference; the Cauchy forms compute it without cancellation far out,
    where clouds are);
``fourier(k, optics)``, ``transfer(k, optics)``
    ``phi_hat(k) = int phi(s) exp(-i k s) ds`` and ``|phi_hat(k)|^2``;
``scale(optics)``, ``support(optics)``
    the length [m] in which a lidar's ``span`` is counted (``z_R`` for the
    cw weightings) and the interval of ``s`` that holds weight (in front of
    the telescope: ``s > -r``); the cells cover
    ``[max(-span scale, lo), min(span scale, hi)]`` (:meth:`~cwlidar_sim.beam.ProbeVolume.extent`);
``truncated_fraction(lo, hi, kept, optics)``
    the weight outside ``[lo, hi]`` given the weight ``kept`` inside.

Nothing behind the telescope
----------------------------
Every weighting's density is zero outside its support and integrates to 1
over it: there is no air behind the telescope, and the Doppler estimators
normalise the spectrum, so a weighting whose closed form reaches behind the
telescope (the focused beam's Cauchy density, A2012's Lorentzian) is cut at
``s = -r`` and renormalised over ``s > -r``.  That weight is removed, not
handed to the mean-wind tail of :mod:`cwlidar_sim.beam.cells` (which stands
for real air beyond the simulated span, seeing the mean wind): the cells'
``truncated_fraction`` is then only the weight in front of the telescope
beyond the span.  The Cauchy weightings share this cut in one class
(``_CutCauchy``: a subclass gives the centre and half-width, the cut
density, primitive, interval and transform follow).

:class:`~cwlidar_sim.beam.ProbeVolume` binds a weighting to the optics of one focus and is
what the cells, the averages and the theories are built from.

The registry
------------
:data:`~cwlidar_sim.beam.WEIGHTINGS` maps the names a scene's ``lidar.weighting`` accepts to
the classes: ``'exact'`` (the focused Gaussian beam, A2012 Eq. 3 as
corrected in :mod:`cwlidar_sim.beam.optics`), ``'lorentzian'`` (Eq. 4,
cut at the telescope like the exact one), ``'aperture'`` (the beam clipped by the telescope's aperture,
:mod:`cwlidar_sim.beam.aperture`; with its default ``truncation = inf`` it
is the exact weighting computed by numerical diffraction) and ``'point'``
(``z_R -> 0``: the wind at the focus).  A new weighting -- a pulsed
lidar's range gate, a measured table -- is one subclass of
:class:`~cwlidar_sim.beam.Weighting` constructible without arguments, registered with
:func:`~cwlidar_sim.beam.register_weighting`; every sensor, scene and theory then accepts
its name.  Parameterised weightings (an aperture's truncation ratio) are
instances: every function that takes a weighting name also takes a
:class:`~cwlidar_sim.beam.Weighting` instance (:func:`~cwlidar_sim.beam.get_weighting`).
"""

from __future__ import annotations

import abc
import dataclasses
import functools
import math
from typing import ClassVar

import numpy as np

from .._validation import check_real, did_you_mean
from .aperture import TruncatedAperture, cdf_aperture, fourier_aperture, weight_aperture
from .optics import BeamOptics, _cauchy_exact, _cut_cauchy_cdf, _cut_cauchy_density

__all__ = [
    "Weighting",
    "ExactWeighting",
    "LorentzianWeighting",
    "ApertureWeighting",
    "PointWeighting",
    "ProbeVolume",
    "WEIGHTINGS",
    "register_weighting",
    "get_weighting",
]


def _cis(x):
    """``exp(i x)`` for real x, as cos + i sin (several times faster than numpy's complex exp)."""
    x = np.asarray(x, dtype=float)
    out = np.empty(x.shape, dtype=complex)
    out.real = np.cos(x)
    out.imag = np.sin(x)
    return out


# ---------------------------------------------------------------------------
# the protocol
# ---------------------------------------------------------------------------
class Weighting(metaclass=abc.ABCMeta):
    """A weighting along the beam: what the cells, averages and theories need of it (module notes).

    Subclasses implement :meth:`density`, :meth:`primitive` and
    :meth:`fourier`; the rest have defaults for a cw lidar's probe volume
    (span counted in Rayleigh lengths, weight only in front of the
    telescope).  A registered subclass must be constructible without
    arguments (its parameters, if any, with defaults).  ``optics`` is the
    :class:`~cwlidar_sim.beam.BeamOptics` of one focus.
    """

    #: The registry name (set by :func:`~cwlidar_sim.beam.register_weighting`).
    name: ClassVar[str] = ""

    @abc.abstractmethod
    def density(self, s, optics: BeamOptics):
        """``phi(s)`` [1/m] at distances ``s`` [m] from the focus; zero outside :meth:`support`, integrates to 1 over it."""

    @abc.abstractmethod
    def primitive(self, s, optics: BeamOptics):
        """An antiderivative of :meth:`density` at ``s`` [-] (ndarray; only differences are used)."""

    @abc.abstractmethod
    def fourier(self, k, optics: BeamOptics):
        """``phi_hat(k) = int phi(s) exp(-i k s) ds`` [-], complex ndarray, k in rad/m; ``phi_hat(0) = 1``."""

    def transfer(self, k, optics: BeamOptics):
        """Power transfer function ``|phi_hat(k)|^2`` [-], even in k."""
        ph = np.asarray(self.fourier(k, optics))
        return (ph * np.conj(ph)).real

    def scale(self, optics: BeamOptics) -> float:
        """Length in which a lidar's ``span`` is counted [m]: the Rayleigh length z_R."""
        return optics.rayleigh_length

    def support(self, optics: BeamOptics) -> tuple:
        """Interval of ``s`` [m] that can hold weight: ``(-r, inf)``, in front of the telescope."""
        return (-optics.focus, math.inf)

    def interval(self, a: float, b: float, optics: BeamOptics) -> float:
        """Weight between distances ``a <= b`` from the focus [-]."""
        p = np.asarray(self.primitive(np.array([a, b], dtype=float), optics), dtype=float)
        return float(p[1] - p[0])

    def truncated_fraction(self, lo: float, hi: float, kept: float, optics: BeamOptics) -> float:
        """Weight outside ``[lo, hi]`` [-] given the weight ``kept`` inside: ``max(0, 1 - kept)``."""
        return max(0.0, 1.0 - kept)

    def __repr__(self):
        return f"{type(self).__name__}()"


def _cauchy_interval(s0, gam, eps, a, b):
    """``int_a^b`` of a Cauchy density (centre s0, half-width gam) over ``1 - eps`` [-], without cancellation."""
    # arctan((b - s0)/g) - arctan((a - s0)/g) as one arctan (no cancellation far out) where that is exact
    den = gam * gam + (a - s0) * (b - s0)
    if den > 0.0:
        d = math.atan(gam * (b - a) / den)
    else:
        d = math.atan((b - s0) / gam) - math.atan((a - s0) / gam)
    return d / (math.pi * (1.0 - eps))


# ---------------------------------------------------------------------------
# the built-in weightings
# ---------------------------------------------------------------------------
class _CutCauchy(Weighting):
    """A Cauchy density on the whole line, cut at the telescope and renormalised over ``s > -r``.

    The one place where a Cauchy weighting's weight behind the telescope is
    handled, for every weighting built on it (the exact and the Lorentzian):
    there is no air behind the telescope, so the real-line density's share
    ``eps`` there is removed and the rest divided by ``1 - eps`` -- not given
    to the mean-wind tail, which stands for air beyond the simulated span.
    A subclass gives :meth:`cauchy`; density, primitive, interval and
    transform follow.  The transform is ``(exp(-i k s0 - gamma |k|) -
    tail(k)) / (1 - eps)``, the part behind the telescope in closed form
    through the complex exponential integral (tabulated in log k, error
    below 5e-9; checked against the quadrature of
    :func:`~cwlidar_sim.beam.fourier_exact`).
    """

    @abc.abstractmethod
    def cauchy(self, optics: BeamOptics) -> tuple:
        """(centre s0 [m], half-width gamma [m], real-line weight behind the telescope eps [-])."""

    def density(self, s, optics):
        return _cut_cauchy_density(s, optics.focus, *self.cauchy(optics))

    def primitive(self, s, optics):
        return _cut_cauchy_cdf(s, optics.focus, *self.cauchy(optics))

    def interval(self, a, b, optics):
        s0, gam, eps = self.cauchy(optics)
        return _cauchy_interval(s0, gam, eps, max(a, -optics.focus), max(b, -optics.focus))

    def fourier(self, k, optics):
        r = optics.focus
        s0, g, eps, a, lq_tab, sm_tab = _cut_parts(r, *self.cauchy(optics))
        q = np.asarray(k, dtype=float)
        qa = np.abs(q)
        smooth = np.full(qa.shape, eps, dtype=complex)
        with np.errstate(divide="ignore"):
            lq = np.log(qa)
        mid = (lq >= lq_tab[0]) & (lq <= lq_tab[-1])
        smooth[mid] = np.interp(lq[mid], lq_tab, sm_tab.real) + 1j * np.interp(lq[mid], lq_tab, sm_tab.imag)
        hi = lq > lq_tab[-1]
        smooth[hi] = _tail_smooth(qa[hi], a, g)
        val = (np.exp(-g * qa) * _cis(-qa * s0) - _cis(qa * r) * smooth) / (1.0 - eps)
        return np.where(q < 0, np.conj(val), val)


class ExactWeighting(_CutCauchy):
    """The focused Gaussian beam's weighting (A2012 Eq. 3 corrected, :func:`~cwlidar_sim.beam.weight_exact`).

    A Cauchy density centred ``s0`` (toward the lidar) of half-width
    ``gamma``, cut at the telescope and renormalised over ``s > -r``; its
    transform ``(exp(-i k s0 - gamma |k|) - tail(k)) / (1 - eps)``, the
    part behind the telescope in closed form through the complex exponential
    integral (tabulated in log k, error below 5e-9; checked against the
    quadrature of :func:`~cwlidar_sim.beam.fourier_exact`).
    """

    def cauchy(self, optics):
        return _cauchy_exact(optics.focus, optics.wavelength, optics.radius)


class LorentzianWeighting(_CutCauchy):
    """The Lorentzian ``(1/pi) z_R / (z_R^2 + s^2)`` (A2012 Eq. 4), cut at the telescope and renormalised over ``s > -r``.

    Its real-line share behind the telescope, ``eps = arctan(z_R / r) / pi``
    (the exact weighting's too: ``z_R / r = r / z_ap``; 2.6 % at
    r = 67.5 m, 4.5 % at 115 m), is removed like the exact weighting's, not
    given to the mean-wind tail; its transform tends to A2012's
    ``exp(-z_R |k|)`` within O(eps).
    """

    def cauchy(self, optics):
        zR = optics.rayleigh_length
        return 0.0, zR, math.atan2(zR, optics.focus) / math.pi


@dataclasses.dataclass(frozen=True, repr=True)
class ApertureWeighting(Weighting):
    """The weighting of a Gaussian beam clipped by the telescope's aperture (:mod:`cwlidar_sim.beam.aperture`).

    Parameters
    ----------
    truncation : float
        Aperture radius over the beam's e^-2 radius, T [-]; in [0.2, 4] or
        ``math.inf`` (default: the unclipped beam, equal to
        :class:`ExactWeighting`).
    spherical_waves : float
        Primary spherical aberration at the aperture edge [waves]; in [-2, 2].
    m_max : float
        Largest defocus tabulated (:func:`~cwlidar_sim.beam.aperture.pupil_function`); in [5, 80].
    """

    truncation: float = math.inf
    spherical_waves: float = 0.0
    m_max: float = 20.0

    def __post_init__(self):
        object.__setattr__(self, "m_max", check_real("m_max", self.m_max, lo=5.0, hi=80.0))
        TruncatedAperture(self.truncation, self.spherical_waves)  # its checks, by field name

    @property
    def aperture(self) -> TruncatedAperture:
        """The pupil, :class:`~cwlidar_sim.beam.aperture.TruncatedAperture`."""
        return TruncatedAperture(self.truncation, self.spherical_waves)

    def density(self, s, optics):
        return np.asarray(weight_aperture(s, optics, self.aperture, m_max=self.m_max))

    def primitive(self, s, optics):
        return np.asarray(cdf_aperture(s, optics, self.aperture, m_max=self.m_max))

    def fourier(self, k, optics):
        return np.asarray(fourier_aperture(k, optics, self.aperture, m_max=self.m_max))


class PointWeighting(Weighting):
    """A point at the focus (``z_R -> 0``): ``phi = delta(s)``, ``phi_hat = 1``; its cells put all weight on the focus's."""

    def density(self, s, optics):
        s = np.asarray(s, dtype=float)
        return np.where(s == 0.0, np.inf, 0.0)

    def primitive(self, s, optics):
        return np.where(np.asarray(s, dtype=float) >= 0.0, 1.0, 0.0)

    def fourier(self, k, optics):
        return np.ones(np.shape(k), dtype=complex)


# ---------------------------------------------------------------------------
# a cut Cauchy weighting's transform: the telescope-cut term in closed form
# ---------------------------------------------------------------------------
def _exp_e1(z):
    """``exp(z) E1(z)`` for complex z off the negative real axis, without overflow.

    Direct for ``|z| <= 40``; beyond, the asymptotic series
    ``sum_n (-1)^n n! / z^(n+1)`` to n = 12 (error below 12! / 40^13 = 7e-12).
    """
    from scipy.special import exp1

    z = np.asarray(z, dtype=complex)
    out = np.empty(z.shape, dtype=complex)
    near = np.abs(z) <= 40.0
    out[near] = np.exp(z[near]) * exp1(z[near])
    zf = z[~near]
    term = 1.0 / zf
    acc = term.copy()
    for n in range(1, 13):
        term = -term * n / zf
        acc += term
    out[~near] = acc
    return out


#: Nodes per decade of k of the table of the telescope-cut term's smooth part, linear
#: interpolation in log k (error below 5e-9 against the direct evaluation, tested).
_TAIL_NODES_PER_DECADE = 2000


@functools.lru_cache(maxsize=64)
def _cut_parts(r, s0, g, eps):
    """(s0, gamma, eps, a, table of the smooth part of the telescope-cut term) of a cut Cauchy weighting."""
    a = r + s0  # Cauchy centre to the telescope [m]
    lq = np.linspace(math.log(1e-6 / a), math.log(1e4), int(math.log10(1e10 * a) * _TAIL_NODES_PER_DECADE) + 1)
    sm = _tail_smooth(np.exp(lq), a, g)
    for arr in (lq, sm):
        arr.setflags(write=False)
    return s0, g, eps, a, lq, sm


def _tail_smooth(q, a, g):
    # integral_{s < -r} of the real-line Cauchy density times exp(-i q s) is exp(i q r) times
    # integral_0^inf g / (pi ((a + v)^2 + g^2)) exp(i q v) dv, and by partial fractions and
    # integral_0^inf exp(i q v) / (v + c) dv = exp(-i q c) E1(-i q c) that is
    # sum_(c = a -+ i g) (+-) exp(z) E1(z) / (2 i pi), z = -i q c: smooth in q (-> eps at 0).
    return (_exp_e1(-1j * q * (a - 1j * g)) - _exp_e1(-1j * q * (a + 1j * g))) / (2j * math.pi)


# ---------------------------------------------------------------------------
# the registry
# ---------------------------------------------------------------------------
#: Registered weightings, name -> :class:`~cwlidar_sim.beam.Weighting` subclass (module notes).
WEIGHTINGS: dict = {}


def register_weighting(name: str, cls) -> type:
    """Register a :class:`~cwlidar_sim.beam.Weighting` subclass under ``name``; returns ``cls``.

    Checks that ``cls`` is a concrete subclass constructible without
    arguments; a name already taken by another class is refused.
    """
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"weighting name {name!r} is not allowed; allowed: an identifier such as 'range_gate'")
    if not (isinstance(cls, type) and issubclass(cls, Weighting)):
        raise TypeError(f"weighting {name!r} must be a subclass of cwlidar_sim.beam.Weighting, got {cls!r}")
    missing = sorted(getattr(cls, "__abstractmethods__", ()))
    if missing:
        raise TypeError(f"weighting {name!r} ({cls.__name__}) does not implement {missing}")
    if WEIGHTINGS.get(name, cls) is not cls:
        raise ValueError(f"weighting name {name!r} is taken by {WEIGHTINGS[name].__name__}")
    try:
        cls()
    except TypeError as e:
        raise TypeError(f"weighting {name!r} ({cls.__name__}) must be constructible without arguments: {e}") from None
    cls.name = name
    WEIGHTINGS[name] = cls
    return cls


def get_weighting(weighting, field: str = "weighting") -> Weighting:
    """The :class:`~cwlidar_sim.beam.Weighting` for a registered name, or ``weighting`` itself if it is one.

    Raises ValueError naming ``field``, the allowed names and the closest one for an unknown name.
    """
    if isinstance(weighting, Weighting):
        return weighting
    if isinstance(weighting, str):
        cls = WEIGHTINGS.get(weighting)
        if cls is None:
            raise ValueError(f"{field}={weighting!r} is not allowed{did_you_mean([weighting], WEIGHTINGS)}; "
                             f"allowed: {', '.join(map(repr, WEIGHTINGS))}")
        return cls()
    raise TypeError(f"{field} must be a weighting name ({', '.join(map(repr, WEIGHTINGS))}) or a Weighting, "
                    f"got {type(weighting).__name__}")


def weighting_name(weighting) -> str:
    """The registry name of a weighting name or instance (its class name if unregistered)."""
    if isinstance(weighting, str):
        return weighting
    return type(weighting).name or type(weighting).__name__


for _name, _cls in (("exact", ExactWeighting), ("lorentzian", LorentzianWeighting),
                    ("aperture", ApertureWeighting), ("point", PointWeighting)):
    register_weighting(_name, _cls)
del _name, _cls


# ---------------------------------------------------------------------------
# the probe volume
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ProbeVolume:
    """A weighting bound to the optics of one focus: what cells, averages and theories are built from.

    Parameters
    ----------
    optics : BeamOptics
        Focus r, wavelength and telescope radius.
    weighting : str or Weighting
        A registered name (:data:`~cwlidar_sim.beam.WEIGHTINGS`) or an instance; stored as the instance.
    """

    optics: BeamOptics
    weighting: Weighting = dataclasses.field(default_factory=ExactWeighting)

    def __post_init__(self):
        if not isinstance(self.optics, BeamOptics):
            raise TypeError(f"optics must be a BeamOptics, got {type(self.optics).__name__}")
        object.__setattr__(self, "weighting", get_weighting(self.weighting))

    @property
    def name(self) -> str:
        """The weighting's registry name."""
        return weighting_name(self.weighting)

    @property
    def scale(self) -> float:
        """Length a ``span`` is counted in [m] (z_R for the cw weightings)."""
        return self.weighting.scale(self.optics)

    def extent(self, span: float) -> tuple:
        """``(lo, hi)`` [m]: ``+/- span`` scales around the focus, clipped to the weighting's support."""
        half = span * self.scale
        lo, hi = self.weighting.support(self.optics)
        return max(-half, lo), min(half, hi)

    def weight(self, s):
        """``phi(s)`` [1/m]."""
        return self.weighting.density(s, self.optics)

    def primitive(self, s):
        """An antiderivative of ``phi`` at ``s`` [-]."""
        return self.weighting.primitive(s, self.optics)

    def interval(self, a: float, b: float) -> float:
        """Weight between ``a <= b`` [-]."""
        return self.weighting.interval(a, b, self.optics)

    def truncated_fraction(self, lo: float, hi: float, kept: float) -> float:
        """Weight outside ``[lo, hi]`` given ``kept`` inside [-]."""
        return self.weighting.truncated_fraction(lo, hi, kept, self.optics)

    def fourier(self, k):
        """``phi_hat(k)`` [-], complex, k in rad/m."""
        return self.weighting.fourier(k, self.optics)

    def transfer(self, k):
        """``|phi_hat(k)|^2`` [-]."""
        return self.weighting.transfer(k, self.optics)
