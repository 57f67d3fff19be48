"""Evolving turbulence: eddies that decorrelate as they travel with the mean wind.

Model
-----
Taylor's hypothesis advects a frozen field at the mean speed U along +x.
Here each Fourier mode k of the field, seen in the frame moving with U,
also forgets itself as it ages: after an age ``dt`` its correlation with
its earlier self is

    ``rho(k, dt) = exp(-|dt| / tau(k))``,  ``tau(k) = T f(|k| L)``,
    ``f(x) = x^(-2/3) / sqrt(2F1(1/3, 17/6; 4/3; -x^-2))``,

an exponential (Ornstein-Uhlenbeck) decay with the shape of Mann's (1994)
eddy lifetime (``f(1) = 1.234``; ``f -> 1.205 / x`` for ``x -> 0``: the
large eddies live longest; ``f -> x^(-2/3)`` for ``x -> oo``, the
Kolmogorov turnover time of the inertial range).  ``T`` [s] (the
``lifetime``) sets the time scale; ``T = inf`` is Taylor's frozen
turbulence.  The field at one instant keeps the Mann tensor exactly; only
the correlation between ages changes.

An eddy seen at a point and again ``dx`` further downstream has aged
``dx / U``, so the covariance of the component i at two points on a line
along the mean wind, the downstream series delayed by ``dx / U``, has the
cross-spectrum ``integral of Phi_ii(k) rho(k, dx/U) dk2 dk3`` and the
*longitudinal coherence*

    ``coh_i(k1; dx) = integral Phi_ii(k) exp(-dx / (U tau(k))) dk2 dk3 / F_ii(k1)``,

real, in (0, 1], 1 in the frozen limit; ``coh**2`` is the magnitude-squared
coherence (:func:`longitudinal_coherence`).  ``coh`` falls with ``dx`` at
every k1 and, through the lifetime's shape, faster at high k1.

Sources.  The lidar-assisted-control literature describes the evolution of
turbulence by an eddy lifetime attached to the Mann tensor: de Mare & Mann
(2016, Boundary-Layer Meteorol. 160, "On the space-time structure of
sheared turbulence", combining Mann's distortion with Kristensen's (1979)
decaying eddies) and Guo, Mann, Pena, Schlipf & Cheng (2022, Renewable
Energy, "The space-time structure of turbulence for lidar-assisted wind
turbine control").  The text of the latter was not available when this
module was written, so the form above (exponential decay, Mann's lifetime
shape, one time scale T) is this module's statement of the model, not a
transcription of that paper: check it against the paper before quoting a
fitted T from it.

Generation
----------
A set of planes across the wind at ``x_p`` (the rotor, the lidar's focus
distances) gets one box each.  The first plane of the list is
:func:`~cwlidar_sim.turbulence.generate_box` of ``seed`` itself; the others
follow along a chain outward from it in x, each mode an AR(1) step from the
neighbouring plane toward the first,

    ``S_p(k) = rho_p(k) S_q(k) + sqrt(1 - rho_p(k)^2) B_p(k)``,
    ``rho_p(k) = rho(k, |x_p - x_q| / U)``,

with ``B_p`` the spectrum of an independent box of the same settings
(seed from ``SeedSequence(seed, spawn_key=(p,))``, p the plane's place in
the list).  The exponential decay makes the chain Markov, so every pair of
planes has exactly ``rho(k, |x_p - x_q| / U)`` and every plane keeps each
mode's variance (the box's spectra, the tensor's one-point spectra); a
sensor at rest at ``x_p`` samples box p under Taylor's hypothesis, frozen
within the plane's neighbourhood, and decorrelated from the other planes
by the model.  Cost per extra plane: one box, one forward and one inverse
3-D FFT of u, v, w (``cwlidar_sim._fft.rfftn3``) and one pass over the
modes; memory: the outputs plus at most two chain states (half spectra of
u, v, w), the innovation box and one float32 per mode of the lifetime table.  This is the construction of
Chen, Guo, Schlipf & Cheng (2022, Wind Energ. Sci. 7, evoTurb: independent
3-D fields combined by the Cholesky factor of the longitudinal coherence),
per Fourier mode of a Mann box with the model's coherence instead of an
empirical one.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._seeding import seed_int
from .._validation import check_choice, check_keys, check_real, check_seed
from .parameters import MannParameters
from .tensor import _check_params

__all__ = [
    "EddyLifetimeEvolution",
    "lifetime_shape",
    "longitudinal_coherence",
    "box_longitudinal_coherence",
    "iter_evolving_boxes",
    "generate_evolving_boxes",
]

#: Nodes per decade of the log-log table of the lifetime shape f (linear
#: interpolation; relative error below 2e-6, tested against hyp2f1).
_F_NODES_PER_DECADE = 400


def lifetime_shape(x):
    """Mann's eddy-lifetime shape ``f(x) = x^(-2/3) / sqrt(2F1(1/3, 17/6; 4/3; -x^-2))`` [-].

    Parameters
    ----------
    x : array_like
        ``|k| L`` [-], > 0 (``inf`` is returned at 0).

    Returns
    -------
    ndarray
        f; ``tau(k) = T f(|k| L)``.
    """
    from scipy.special import hyp2f1

    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore"):
        out = x ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(x**-2.0)))
    return np.where(x > 0, out, np.inf)


def _inv_shape_table(x_lo, x_hi):
    """(log x nodes, 1/f at them) for linear interpolation in log x of log(1/f)."""
    lo, hi = math.log(x_lo), math.log(max(x_hi, x_lo * 1.001))
    n = max(8, int(math.ceil((hi - lo) / math.log(10.0) * _F_NODES_PER_DECADE)) + 1)
    lx = np.linspace(lo, hi, n)
    return lx, -np.log(lifetime_shape(np.exp(lx)))


def _inv_shape(x, table):
    """1/f(x) from the table (x in its range), 0 at x = 0."""
    lx, lif = table
    with np.errstate(divide="ignore"):
        out = np.exp(np.interp(np.log(x), lx, lif))
    return np.where(x > 0, out, 0.0)


@dataclasses.dataclass(frozen=True)
class EddyLifetimeEvolution:
    """Eddy-lifetime evolution of turbulence advected at a mean speed (see the module notes).

    Parameters
    ----------
    lifetime : float
        Time scale T [s] of the eddy lifetime ``tau(k) = T f(|k| L)``; > 0,
        ``math.inf`` for frozen turbulence.
    mean_speed : float
        Mean (advection) speed U [m/s]; > 0.  A separation dx along the
        wind is an age ``dx / U``.
    """

    lifetime: float
    mean_speed: float

    def __post_init__(self):
        T = self.lifetime
        if not (isinstance(T, (int, float, np.floating, np.integer)) and not isinstance(T, bool)
                and math.isinf(T) and T > 0):
            T = check_real("lifetime", T, lo=0.0, lo_open=True)
        object.__setattr__(self, "lifetime", float(T))
        object.__setattr__(self, "mean_speed", check_real("mean_speed", self.mean_speed, lo=0.0, lo_open=True))

    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "EddyLifetimeEvolution":
        """Build from a mapping; unknown keys are rejected by name."""
        check_keys(cls, d, required=[f.name for f in dataclasses.fields(cls)])
        return cls(**d)

    @property
    def frozen(self) -> bool:
        """True for Taylor's frozen turbulence (infinite lifetime)."""
        return math.isinf(self.lifetime)

    def eddy_lifetime(self, k, params: MannParameters):
        """``tau(k) = T f(|k| L)`` [s] at wavenumber magnitudes ``k`` [rad/m] (inf at k = 0)."""
        _check_params(params)
        return self.lifetime * lifetime_shape(np.abs(np.asarray(k, dtype=float)) * params.length_scale)

    def mode_correlation(self, k, separation, params: MannParameters):
        """``rho = exp(-|dx| / (U tau(k)))`` [-] of modes of magnitude ``k`` [rad/m] after ``separation`` dx [m]."""
        dx = check_real("separation", separation)
        if self.frozen:
            return np.ones_like(np.asarray(k, dtype=float))
        with np.errstate(divide="ignore"):
            return np.exp(-abs(dx) / (self.mean_speed * self.eddy_lifetime(k, params)))


def _check_evolution(evolution):
    if not isinstance(evolution, EddyLifetimeEvolution):
        raise TypeError(f"evolution must be an EddyLifetimeEvolution, got {type(evolution).__name__}")


_COMPONENT = {"u": 0, "v": 1, "w": 2}


def longitudinal_coherence(k1, params: MannParameters, evolution: EddyLifetimeEvolution, separation: float,
                           *, component: str = "u"):
    """Longitudinal coherence of the model, ``coh_i(k1; dx)`` (see the module notes).

    Parameters
    ----------
    k1 : array_like
        Longitudinal wavenumbers [rad/m], any sign (even in k1); frequency
        ``f = U k1 / (2 pi)`` for a sensor at rest.
    params : MannParameters
    evolution : EddyLifetimeEvolution
    separation : float
        Distance dx between the two points along the mean wind [m].
    component : {"u", "v", "w"}

    Returns
    -------
    coh : ndarray
        ``integral Phi_ii rho dk2 dk3 / F_ii(k1)`` [-], in (0, 1]; the
        magnitude-squared coherence is ``coh**2``.  The downstream series
        must be delayed by ``dx / U`` (the preview time) for the phase to
        vanish; the magnitude does not depend on it.

    Notes
    -----
    Tensor-product Gauss-Legendre on geometric panels in k2 (folded: the
    diagonal of Phi is even in k2) and k3, scaled to ``min(|k1|, 1/L)``
    (the panels of :func:`~cwlidar_sim.turbulence.spectra.half_line_nodes`);
    at ``dx = 0`` the numerator is half :func:`one_point_spectra`'s
    (one-sided) F_ii, Mann's two-sided F_ii, which the tests check to 1e-6.
    """
    _check_params(params)
    _check_evolution(evolution)
    dx = check_real("separation", separation)
    check_choice("component", component, tuple(_COMPONENT))
    k1 = np.asarray(k1, dtype=float)
    if not np.all(np.isfinite(k1)):
        raise ValueError("k1 must be finite; allowed: any finite wavenumber in rad/m")
    cross, auto = _cross_spectrum(k1, params, evolution, dx, component)
    return cross / auto


def _cross_spectrum(k1, params, evolution, dx, component):
    """(integral Phi_ii rho, integral Phi_ii) over (k2, k3) at each k1 [m^3 s^-2], two-sided in k1."""
    from .spectra import half_line_nodes
    from .tensor import spectral_tensor

    i = _COMPONENT[component]
    k1 = np.asarray(k1, dtype=float)
    L = params.length_scale
    cross, auto = np.empty(k1.size), np.empty(k1.size)
    for j, kk in enumerate(np.abs(k1.ravel())):
        s, t = (min(kk, 1.0 / L) if kk > 0 else 1.0 / L), max(kk, 1.0 / L)
        q, w = half_line_nodes(s, math.inf, t)
        k2, k3 = np.meshgrid(q, np.concatenate([-q[::-1], q]), indexing="ij")
        wq = np.outer(2.0 * w, np.concatenate([w[::-1], w]))
        phi = wq * spectral_tensor(kk, k2, k3, params)[..., i, i]
        rho = evolution.mode_correlation(np.sqrt(kk * kk + k2 * k2 + k3 * k3), dx, params)
        cross[j], auto[j] = np.sum(phi * rho), np.sum(phi)
    return cross.reshape(k1.shape), auto.reshape(k1.shape)


def _mode_wavenumbers(shape, spacing):
    """|k| [rad/m] of the half-spectrum modes of a box, float64, shape (N1, N2, N3//2 + 1)."""
    n1, n2, n3 = shape
    k1 = 2.0 * math.pi * np.fft.fftfreq(n1, spacing[0])
    k2 = 2.0 * math.pi * np.fft.fftfreq(n2, spacing[1])
    k3 = 2.0 * math.pi * np.fft.rfftfreq(n3, spacing[2])
    return np.sqrt(k1[:, None, None] ** 2 + k2[None, :, None] ** 2 + k3[None, None, :] ** 2)


def box_longitudinal_coherence(params: MannParameters, shape, spacing, evolution: EddyLifetimeEvolution,
                               separation: float, *, component: str = "u"):
    """Longitudinal coherence two planes of :func:`generate_evolving_boxes` are built to have.

    The expected cross- and auto-spectra of a box row k1 are sums over its
    (k2, k3) modes of the tensor at the mode (times ``rho`` for the cross
    term); that holds exactly for rows outside the generator's corrected
    region near k = 0 (``|k1| > 3 max(dk)``, see
    :func:`~cwlidar_sim.turbulence.generate_box`), whatever
    ``hf_compensation`` (its per-row gain cancels).  It differs from
    :func:`longitudinal_coherence` by the box's lateral discretisation.

    Returns
    -------
    k1_k : ndarray
        The rows' wavenumbers ``n dk1`` with ``n dk1 > 3 max(dk)``, up to
        the last row below Nyquist [rad/m].
    coh_k : ndarray
        The coherence ``sum Phi_ii rho / sum Phi_ii`` over the row's modes [-].
    """
    from .box import _REGION, _check_grid, _dk
    from .tensor import spectral_tensor

    _check_params(params)
    _check_evolution(evolution)
    shape, spacing = _check_grid(shape, spacing)
    dx = check_real("separation", separation)
    i = _COMPONENT[check_choice("component", component, tuple(_COMPONENT))]
    dk = _dk(shape, spacing)
    n1 = shape[0]
    rows = np.arange(1, (n1 - 1) // 2 + 1)
    rows = rows[rows * dk[0] > _REGION * max(dk) + 1e-12]
    k1 = rows * dk[0]
    k2 = 2.0 * math.pi * np.fft.fftfreq(shape[1], spacing[1])
    k3 = 2.0 * math.pi * np.fft.fftfreq(shape[2], spacing[2])
    K2, K3 = np.meshgrid(k2, k3, indexing="ij")
    coh = np.empty(k1.size)
    for j, kk in enumerate(k1):
        phi = spectral_tensor(kk, K2, K3, params)[..., i, i]
        rho = evolution.mode_correlation(np.sqrt(kk * kk + K2 * K2 + K3 * K3), dx, params)
        coh[j] = np.sum(phi * rho) / np.sum(phi)
    return k1, coh


def _check_planes(plane_x):
    x = np.asarray(plane_x, dtype=float)
    if x.ndim != 1 or x.size < 1:
        raise ValueError(f"plane_x must be a 1-D sequence of at least one position [m], got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("plane_x must be finite positions along the mean wind [m]")
    if np.unique(x).size != x.size:
        raise ValueError(f"plane_x must hold distinct positions, got {x.tolist()}")
    return x


def _chain(x):
    """(plane, its parent toward plane 0) in generation order: outward from plane 0 both ways."""
    order = np.argsort(x, kind="stable")
    pos = int(np.nonzero(order == 0)[0][0])
    up = [(int(order[j]), int(order[j - 1])) for j in range(pos + 1, order.size)]
    down = [(int(order[j]), int(order[j + 1])) for j in range(pos - 1, -1, -1)]
    return up + down


def _plane_seed(seed, p):
    # 63 bits: generate_box takes seeds below 2**63.
    return seed_int(np.random.SeedSequence(seed, spawn_key=(p,)))


def iter_evolving_boxes(params: MannParameters, shape, spacing, seed: int, evolution: EddyLifetimeEvolution,
                        plane_x, *, correction: str = "cell", hf_compensation: bool = False, dtype=np.float32):
    """Boxes of evolving turbulence for planes across the wind, one at a time (see the module notes).

    Parameters
    ----------
    params, shape, spacing, seed, correction, hf_compensation, dtype
        As for :func:`~cwlidar_sim.turbulence.generate_box` (``seed`` is
        the first plane's box seed).
    evolution : EddyLifetimeEvolution
        Lifetime scale T [s] and advection speed U [m/s].
    plane_x : sequence of float
        Positions of the planes along the mean wind [m], distinct; the first
        is the chain's root (e.g. the rotor plane).

    Yields
    ------
    p : int
        Index of the plane in ``plane_x``; plane 0 first, then outward from
        it in x on each side.
    box : xarray.Dataset
        u, v, w [m/s] as from ``generate_box``, the box a sensor at rest at
        ``x = plane_x[p]`` samples (Taylor within the plane's neighbourhood);
        attrs add ``plane_x`` [m], ``lifetime`` [s], ``mean_speed`` [m/s] and
        ``evolution_seed``.  Plane 0 is ``generate_box(seed)`` bit for bit.
        Between yields the generator holds at most two chain states (the
        half spectra of u, v, w of plane 0, until the second side starts,
        and of the last plane) plus the mode table.
    """
    from .box import BoxGenerator, _check_grid

    _check_params(params)
    _check_evolution(evolution)
    shape, spacing = _check_grid(shape, spacing)
    seed = check_seed("seed", seed)
    x = _check_planes(plane_x)
    dt = np.dtype(dtype)
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise TypeError(f"dtype must be float32 or float64, got {dt}")
    gen = BoxGenerator(params, shape, spacing, correction=correction, hf_compensation=hf_compensation)
    # Validated here, at the call; the boxes come when iterated.
    return _iter_boxes(gen, params, shape, spacing, seed, evolution, x, dt)


def _iter_boxes(gen, params, shape, spacing, seed, evolution, x, dtype):
    from .. import _fft
    from .box import _as_dataset

    attrs = dict(lifetime=evolution.lifetime, mean_speed=evolution.mean_speed, evolution_seed=seed)
    box0 = gen.generate(seed, dtype=dtype)
    box0.attrs.update(attrs, plane_x=float(x[0]))
    yield 0, box0
    links = _chain(x)
    if not links:
        return
    # Chain state: the half spectra of u, v, w of every plane, kept for the planes linked to it.
    state = {0: [_fft.rfftn3(box0[c].data) for c in "uvw"]}
    del box0
    need = {}
    for p, q in links:
        need[q] = need.get(q, 0) + 1
    if evolution.frozen:
        inv_f = None
    else:
        kabs = _mode_wavenumbers(shape, spacing) * params.length_scale
        table = _inv_shape_table(max(kabs[kabs > 0].min(), 1e-12), kabs.max())
        inv_f = _inv_shape(kabs, table).astype(np.float32)
        del kabs
    n3 = shape[2]
    norm = 1.0 / (shape[0] * shape[1] * shape[2])
    for p, q in links:
        if inv_f is None:
            spec_p = state[q]  # frozen: the parent's modes unchanged, no innovation drawn
        else:
            age = abs(x[p] - x[q]) / evolution.mean_speed
            fresh = gen.generate(_plane_seed(seed, p), dtype=dtype)
            # rho and its complement per mode (float32, the box's precision)
            rho = np.exp(np.float32(-age / evolution.lifetime) * inv_f)
            comp = np.sqrt(np.maximum(np.float32(1.0) - rho * rho, np.float32(0.0)))
            spec_p = []
            for ci, c in enumerate("uvw"):
                b = _fft.rfftn3(fresh[c].data)
                s = state[q][ci] * rho
                s += b * comp
                del b
                spec_p.append(s)
            del fresh, rho, comp
        need[q] -= 1
        if need[q] == 0:
            del state[q]
        if need.get(p, 0):
            state[p] = spec_p
        out = []
        plans = _fft.new_plan_store()
        for s in spec_p:
            buf = _fft.empty_halfspectrum(shape, dtype)
            np.multiply(s, norm, out=buf)
            out.append(_fft.irfftn_inplace_shared(buf, n3, plans))
        del plans, spec_p
        box_attrs = dict(params.as_dict(), seed=_plane_seed(seed, p), dx=spacing[0], dy=spacing[1], dz=spacing[2],
                         correction=gen.correction, hf_compensation=int(gen.hf_compensation), keep_mean=0,
                         generator="cwlidar_sim.turbulence.iter_evolving_boxes", plane_x=float(x[p]), **attrs)
        yield p, _as_dataset(out, spacing, box_attrs)


def generate_evolving_boxes(params: MannParameters, shape, spacing, seed: int, evolution: EddyLifetimeEvolution,
                            plane_x, *, correction: str = "cell", hf_compensation: bool = False, dtype=np.float32):
    """All the boxes of :func:`iter_evolving_boxes`, in the order of ``plane_x``.

    Returns
    -------
    list of xarray.Dataset
        Box p for ``plane_x[p]`` [m].  Memory: one box per plane plus the
        generator's chain states (:func:`iter_evolving_boxes`).
    """
    from .._validation import check_memory
    from .box import box_nbytes

    x = _check_planes(plane_x)
    check_memory(f"{x.size} evolving boxes of shape {tuple(shape)}", (x.size + 3) * box_nbytes(tuple(shape), dtype))
    boxes = [None] * x.size
    for p, box in iter_evolving_boxes(params, shape, spacing, seed, evolution, x, correction=correction,
                                      hf_compensation=hf_compensation, dtype=dtype):
        boxes[p] = box
    return boxes
