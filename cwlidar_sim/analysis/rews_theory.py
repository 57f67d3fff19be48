"""Analytic spectra and coherence of the REWS and its cw-lidar estimate, from the Mann tensor.

Schlipf et al. (2013, J. Atmos. Oceanic Technol. 30) and Simley et al.
(2014, Wind Energy 17): the rotor's and the lidar's estimates of the
rotor-effective wind speed are linear functionals of the wind field, so
under Taylor's hypothesis their cross-spectra are integrals of the spectral
tensor against the two spatial weightings.  Frame and estimator as in
:mod:`.rews`.

Transfer vectors
----------------
A frozen field ``u(x) = integral u_hat(k) exp(i k.x) d^3k`` seen at rest at
``x - U t`` makes any linear functional ``A(t) = integral exp(-i k1 U t)
g_A(k) . u_hat(k) d^3k``.  With the hub at the origin of (y, z):

* rotor (:class:`~cwlidar_sim.analysis.rews.RotorDisc`):
  ``g_R = e1 D(|(k2, k3)|)``; on a grid of nodes ``g_R = e1 sum_n w_n
  exp(i (k2 y_n + k3 z_n))``;
* lidar, beam b with direction n_b, focus p_b = o + r_b n_b, weight c_b in
  the scan average, weighting phi_b along the beam
  (``phi_hat(q) = integral phi(s) exp(-i q s) ds``), its sample taken
  ``tau_b`` before the estimate and shifted by the preview ``T_b``:
  ``g_L = sum_b c_b (n_b / n_bx) exp(i (k1 (p_bx + U (T_b + tau_b)) + k2 p_by
  + k3 p_bz)) conj(phi_hat_b(k . n_b))``; with ``T_b = -p_bx / U`` (each
  beam's own preview, the default) the focus's x drops out.

Two-sided spectra in k1 here, internally (``S(f) = (4 pi / U) S(k1)``, the one-sided PSD in f):
``S_AB(k1) = integral g_A^H Phi g_B dk2 dk3``, the same ordering as the
estimated ``E[X_A X_B^*]``.  Coherence ``gamma^2 = |S_RL|^2 / (S_RR S_LL)``.

Evolving turbulence (:class:`~cwlidar_sim.turbulence.evolution.EddyLifetimeEvolution`):
the beams are grouped by the x of their focus (one evolving plane each,
as :func:`~cwlidar_sim.turbulence.evolution.generate_evolving_boxes` builds
them) and every term between planes ``x_p`` and ``x_q`` is multiplied by
``rho(k, |x_p - x_q| / U)``; a beam's own probe volume is frozen.

A scanning lidar's estimate at full rate is cyclostationary (the newest
sample moves round the circle); its spectra are the average over the scan's
phases, each phase a set of delays ``tau_b`` (:func:`circular_scan`).

Quadrature
----------
Continuous tensor: polar coordinates (kappa, psi) in (k2, k3).  An inner
disc ``kappa <= K`` resolves the phases: 6-node Gauss-Legendre panels in
kappa, geometric from ``1e-3 min(k1, 1/L)`` and no wider than ``1 / X``
(X the larger of the rotor radius and half the lidar's lateral span S),
and ``64 + 1.5 kappa S`` uniform angles (128 + ... for ``k1 L < 0.2``,
where the sheared tensor's angular structure sharpens);
``K = max(resolution / X, 6 max(k1, 1/L))``.  Beyond K, geometric panels
to ``1e5 max(k1, 1/L)`` with 128 angles carry the smooth part (the beams'
own terms, a point's whole spectrum); the oscillating cross terms are left
to that coarse grid, where they nearly cancel (Riemann-Lebesgue).
Accuracy (tests): a point's F11 to 3e-6; the point-to-disc spectra to
1e-3 where they are above 1e-2 of F11; doubling ``resolution`` moves the
coherence of a 4-beam scan by 1e-6.  Cost: 5e4 to 2e5 nodes per k1
(more at high k1 and for wide scans), each evaluated once per beam and
scan phase; measured about 3 s per k1 for 20 beams, 5e4 nodes and one
phase on a loaded 2-core machine.  Box-discrete (``box_grid``): the sum over a box's
(k2, k3) modes, which is what a box's rows hold.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_real
from ..beam import BeamOptics, ConicalScanGeometry, ProbeVolume, RangeCells
from .rews import RotorDisc

__all__ = ["LidarBeams", "circular_scan", "scan_beams", "beam_transfer", "RewsSpectra", "rews_spectra", "rotor_spectrum",
           "estimated_spectra"]

_GL_X, _GL_W = np.polynomial.legendre.leggauss(6)
_OUTER_ANGLES = 128
#: Fewest angles of the inner polar grid: the sheared tensor's angular structure
#: sharpens as k1 L -> 0 (measured: with 64 angles F11 is off by 2e-4 at k1 L = 0.01,
#: with 128 by 3e-6; 64 leave 5e-6 at k1 L = 0.06 and suffice from k1 L = 0.2).
_MIN_ANGLES = 64
#: The inner disc reaches at least this many times max(k1, 1/L), where the tensor has
#: fallen by (1 + 6^2)^(-17/6) ~ 4e-5 from its peak.
_TAIL_FACTOR = 6.0
_MIN_ANGLES_LOW_K = 128


def _cis(x):
    """``exp(i x)`` for real x, as cos + i sin (several times faster than numpy's complex exp)."""
    x = np.asarray(x, dtype=float)
    out = np.empty(x.shape, dtype=complex)
    out.real = np.cos(x)
    out.imag = np.sin(x)
    return out


# --------------------------------------------------------------------------
# the lidar's geometry
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class LidarBeams:
    """Beams of a nacelle lidar and how their samples enter the REWS estimate.

    Attributes
    ----------
    direction_bc : ndarray, shape (n_b, 3)
        Unit beam directions [-] (n_x < 0 looks upwind).
    focus_b : ndarray, shape (n_b,)
        Focus distances r_b [m], > 0.
    weight_b : ndarray, shape (n_b,)
        Weights of the beams' u estimates in the scan average [-], sum 1.
    delay_pb : ndarray, shape (n_phases, n_b)
        Age tau_b [s] of beam b's sample when the estimate is formed, one row
        per scan phase (spectra are averaged over the rows).
    origin : tuple of float
        Lidar position (x, y, z) [m] relative to the hub at the rotor plane.
    """

    direction_bc: np.ndarray
    focus_b: np.ndarray
    weight_b: np.ndarray
    delay_pb: np.ndarray
    origin: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        n = np.array(self.direction_bc, dtype=float, ndmin=2)
        if n.ndim != 2 or n.shape[1] != 3 or not np.all(np.isfinite(n)):
            raise ValueError(f"direction_bc must be finite, shape (n_beams, 3), got {n.shape}")
        if np.any(np.abs(np.linalg.norm(n, axis=1) - 1.0) > 1e-6):
            raise ValueError("direction_bc must hold unit vectors")
        if np.any(np.abs(n[:, 0]) < 1e-6):
            raise ValueError("every beam needs n_x != 0 to estimate u (v = w = 0); allowed: |n_x| >= 1e-6")
        nb = n.shape[0]
        r = np.broadcast_to(np.asarray(self.focus_b, dtype=float), (nb,)).copy()
        if not np.all(np.isfinite(r) & (r > 0)):
            raise ValueError("focus_b must be finite distances > 0 m")
        w = np.broadcast_to(np.asarray(self.weight_b, dtype=float), (nb,)).copy()
        if not np.all(np.isfinite(w)) or abs(w.sum() - 1.0) > 1e-9:
            raise ValueError(f"weight_b must be finite and sum to 1, got sum {w.sum()!r}")
        d = np.array(self.delay_pb, dtype=float, ndmin=2)
        if d.shape[1:] != (nb,) or not np.all(np.isfinite(d)) or np.any(d < 0):
            raise ValueError(f"delay_pb must be finite ages >= 0 s of shape (n_phases, {nb}), got {d.shape}")
        o = tuple(check_real(f"origin[{i}]", v) for i, v in enumerate(self.origin))
        if len(o) != 3:
            raise ValueError("origin must be (x, y, z) [m]")
        for name, a in (("direction_bc", n), ("focus_b", r), ("weight_b", w), ("delay_pb", d)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "origin", o)

    @property
    def focus_points_bc(self) -> np.ndarray:
        """Focus positions ``origin + r_b n_b`` [m]."""
        return np.asarray(self.origin) + self.focus_b[:, None] * self.direction_bc


def circular_scan(n_beams: int, half_angle_deg: float, focus, *, revolution_time: float = 0.0,
                  azimuth0_deg: float = 0.0, all_phases: bool = True, origin=(0.0, 0.0, 0.0)) -> LidarBeams:
    """A forward-looking circular scan discretised into N beams, averaged over one revolution.

    :func:`scan_beams` of the :class:`~cwlidar_sim.beam.ConicalScanGeometry`
    ``(half_angle_deg, 'upwind', revolution_time, azimuth0_deg)``: beam b
    looks upwind at ``half_angle`` from the rotor axis, azimuth
    ``azimuth0 + 360 b / N`` (from +y toward +z):
    ``n_b = (-cos a, sin a cos phi_b, sin a sin phi_b)``.

    Parameters
    ----------
    n_beams : int
        N >= 1.
    half_angle_deg : float
        Cone half-angle [deg], in [0, 90).
    focus : float or array_like
        Focus distance(s) [m].
    revolution_time : float
        Time of one revolution [s], >= 0.
    azimuth0_deg : float
    all_phases : bool
    origin : (x, y, z)
        Lidar position relative to the hub [m].
    """
    geometry = ConicalScanGeometry(half_angle_deg=half_angle_deg, axis="upwind", revolution_time=revolution_time,
                                   azimuth0_deg=azimuth0_deg)
    return scan_beams(geometry, n_beams, focus, all_phases=all_phases, origin=origin)


def scan_beams(geometry: ConicalScanGeometry, n_beams: int, focus, *, all_phases: bool = True,
               origin=(0.0, 0.0, 0.0)) -> LidarBeams:
    """The beams of a conical scan discretised into N beams evenly over one revolution.

    Beam b points at azimuth ``azimuth0 + 360 b / N`` of ``geometry``
    (:meth:`~cwlidar_sim.beam.ConicalScanGeometry.direction`).  Its sample
    enters the estimate ``tau = ((m - b) mod N) revolution_time / N`` old
    when the newest sample is beam m; ``all_phases`` averages the spectra
    over the N phases m (a full-rate moving average), otherwise only
    m = N - 1.  ``revolution_time = 0`` is a multi-beam lidar sampling all
    beams at once.

    Parameters
    ----------
    geometry : ConicalScanGeometry
        The cone, its azimuth convention, revolution time and first azimuth.
    n_beams : int
        N >= 1.
    focus : float or array_like
        Focus distance(s) [m].
    all_phases : bool
    origin : (x, y, z)
        Lidar position relative to the hub [m].
    """
    if not isinstance(geometry, ConicalScanGeometry):
        raise TypeError(f"geometry must be a ConicalScanGeometry, got {type(geometry).__name__}")
    n = check_int("n_beams", n_beams, lo=1, hi=100_000)
    T = geometry.revolution_time
    phi = np.radians(geometry.azimuth0_deg) + 2.0 * math.pi * np.arange(n) / n
    dirs = geometry.direction_rad(phi)
    b = np.arange(n)
    phases = np.arange(n) if all_phases else np.array([n - 1])
    delays = ((phases[:, None] - b[None, :]) % n) * (T / n)
    return LidarBeams(direction_bc=dirs, focus_b=np.broadcast_to(np.asarray(focus, dtype=float), (n,)),
                      weight_b=np.full(n, 1.0 / n), delay_pb=delays, origin=tuple(origin))


# --------------------------------------------------------------------------
# the beam's weighting along the line of sight
# --------------------------------------------------------------------------
def beam_transfer(focus: float, weighting="exact", *, wavelength=None, radius=None):
    """Complex transfer ``phi_hat(q) = integral phi(s) exp(-i q s) ds`` of a beam's weighting, vectorised.

    Parameters
    ----------
    focus : float
        Focus distance r [m].
    weighting : str or Weighting or RangeCells
        A weighting of the registry :data:`cwlidar_sim.beam.WEIGHTINGS`
        or an instance (its :meth:`~cwlidar_sim.beam.Weighting.fourier`):
        "exact", the focused-beam weighting of :func:`cwlidar_sim.beam.weight_exact`
        (Cauchy centred ``s0`` with half-width ``gamma``, cut at the
        telescope): ``(exp(-i q s0 - gamma |q|) - tail(q)) / (1 - eps)`` with
        the part behind the telescope in closed form through the complex
        exponential integral (checked against :func:`cwlidar_sim.beam.fourier_exact`);
        "lorentzian": A2012 Eq. 4 cut at the telescope like the exact one (``exp(-z_R |q|)``
        within O(z_R / r)); "point": 1 (z_R -> 0);
        or a :class:`~cwlidar_sim.beam.RangeCells`: its discrete weights (what
        :func:`cwlidar_sim.beam.los_average` applies), tabulated on a grid of
        q and interpolated (error below 1e-4).
    wavelength, radius : float, optional
        Optics [m] (defaults of :class:`~cwlidar_sim.beam.BeamOptics`).

    Returns
    -------
    callable
        ``q [rad/m] -> phi_hat(q)`` (complex ndarray); ``phi_hat(-q) = conj(phi_hat(q))``.
    """
    kw = {k: v for k, v in (("wavelength", wavelength), ("radius", radius)) if v is not None}
    opt = BeamOptics(focus=focus, **kw)
    if isinstance(weighting, RangeCells):
        return _cells_transfer(weighting)
    return ProbeVolume(opt, weighting).fourier


def _cells_transfer(cells):
    s = np.asarray(cells.s_s, dtype=float)
    w = np.asarray(cells.weight_s, dtype=float)
    # Table in q: phi_hat is band-limited by the span (|s| <= smax); linear interpolation
    # with dq = 0.01 / smax errs by about (dq smax)^2 / 8 < 2e-5.
    smax = float(np.max(np.abs(s)))
    dq = 0.01 / max(smax, 1e-3)
    cache = {}

    def phi_hat(q):
        q = np.asarray(q, dtype=float)
        qmax = float(np.max(np.abs(q), initial=0.0))
        n = int(math.ceil(qmax / dq)) + 2
        if cache.get("n", 0) < n:
            n = max(n, 2 * cache.get("n", 0))  # grow by doubling: few rebuilds
            grid = dq * np.arange(n)
            tab = np.empty(n, dtype=complex)
            for i in range(0, n, 4096):
                tab[i:i + 4096] = np.einsum("qs,s->q", _cis(-np.multiply.outer(grid[i:i + 4096], s)), w)
            cache.update(n=n, grid=grid, tab=tab)
        grid, tab = cache["grid"], cache["tab"]
        qa = np.abs(q)
        val = np.interp(qa, grid, tab.real) + 1j * np.interp(qa, grid, tab.imag)
        return np.where(q < 0, np.conj(val), val)

    return phi_hat


# --------------------------------------------------------------------------
# the spectra
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class RewsSpectra:
    """Two-sided spectra (in k1) of the REWS (R) and its lidar estimate (L), and their coherence.

    Attributes
    ----------
    k1_k : ndarray
        Wavenumbers [rad/m] (f = U k1 / (2 pi) for a sensor at rest).
    rotor_k, lidar_k : ndarray
        ``S_RR``, ``S_LL`` [m^3 s^-2].
    cross_k : ndarray, complex
        ``S_RL`` [m^3 s^-2].
    """

    k1_k: np.ndarray
    rotor_k: np.ndarray
    lidar_k: np.ndarray
    cross_k: np.ndarray

    @property
    def coherence_k(self) -> np.ndarray:
        """Magnitude-squared coherence ``|S_RL|^2 / (S_RR S_LL)`` [-]."""
        return np.abs(self.cross_k) ** 2 / (self.rotor_k * self.lidar_k)

    @property
    def gain_k(self) -> np.ndarray:
        """Wiener preview filter's gain ``|S_RL| / S_LL`` [-]."""
        return np.abs(self.cross_k) / self.lidar_k


def _panels(lo, hi, width):
    """Gauss-Legendre nodes/weights on [lo, hi], panels geometric (ratio 2) from lo, no wider than width."""
    edges = [0.0]
    e = lo
    while e < hi:
        edges.append(e)
        e *= 2.0
    edges.append(hi)
    fine = [edges[0]]
    for a, b in zip(edges[:-1], edges[1:]):
        m = max(1, int(math.ceil((b - a) / width)))
        fine.extend(np.linspace(a, b, m + 1)[1:])
    fine = np.asarray(fine)
    a, b = fine[:-1, None], fine[1:, None]
    return (0.5 * (b - a) * _GL_X + 0.5 * (b + a)).ravel(), (0.5 * (b - a) * _GL_W).ravel()


def _polar_nodes(k1, L, x_rad, span, resolution):
    """(k2, k3, weight) nodes over the plane for one k1 (see the module's Quadrature notes)."""
    s, t = (min(k1, 1.0 / L) if k1 > 0 else 1.0 / L), max(k1, 1.0 / L)
    X = max(x_rad, 1e-12)
    K = max(resolution / X, _TAIL_FACTOR * t)
    width = 1.0 / X if x_rad > 0 else math.inf
    kap_in, w_in = _panels(1e-3 * s, K, width)
    e_out = K * 2.0 ** np.arange(0, int(math.ceil(math.log2(1e5 * t / K))) + 1)
    a, b = e_out[:-1, None], e_out[1:, None]
    kap_out = (0.5 * (b - a) * _GL_X + 0.5 * (b + a)).ravel()
    w_out = (0.5 * (b - a) * _GL_W).ravel()
    k2, k3, ww = [], [], []
    base = _MIN_ANGLES if k1 * L >= 0.2 else _MIN_ANGLES_LOW_K
    for kap, w, nang in ((kap_in, w_in, None), (kap_out, w_out, _OUTER_ANGLES)):
        if kap.size == 0:
            continue
        nn = (np.full(kap.size, nang) if nang else
              2 * np.ceil((base + 1.5 * kap * span) / 2).astype(int))
        for n_a in np.unique(nn):
            sel = nn == n_a
            psi = (np.arange(n_a) + 0.5) * (2.0 * math.pi / n_a)
            kk = kap[sel][:, None]
            k2.append((kk * np.cos(psi)).ravel())
            k3.append((kk * np.sin(psi)).ravel())
            ww.append(np.repeat(kap[sel] * w[sel] * (2.0 * math.pi / n_a), n_a))
    return np.concatenate(k2), np.concatenate(k3), np.concatenate(ww)


def rews_spectra(k1, params, rotor, lidar: LidarBeams, mean_speed: float, *, weighting="exact",
                 evolution=None, preview_shift=None, box_grid=None, resolution: float = 60.0,
                 wavelength=None, radius=None) -> RewsSpectra:
    """Analytic spectra of the REWS and its lidar estimate (see the module notes).

    Parameters
    ----------
    k1 : array_like
        Wavenumbers [rad/m], > 0.
    params : MannParameters
    rotor : RotorDisc or (y_n, z_n, w_n)
        The disc (continuous) or grid nodes relative to the hub [m] with
        weights summing to 1 (:func:`~cwlidar_sim.analysis.rews.rotor_node_weights`).
    lidar : LidarBeams
    mean_speed : float
        U [m/s].
    weighting : str or RangeCells or sequence of them
        Per-beam weighting along the line of sight (:func:`beam_transfer`);
        one value for all beams or one per beam.
    evolution : EddyLifetimeEvolution, optional
        Evolving turbulence; None (default) is frozen.
    preview_shift : array_like, optional
        Time shift T_b [s] applied to each beam's sample; default its own
        preview ``-p_bx / U``.
    box_grid : (shape, spacing), optional
        Integrate as the sum over the (k2, k3) modes of a box of this shape
        and spacing instead of the continuous tensor (what a box's rows hold
        for |k1| outside its corrected region near 0).
    resolution : float
        Inner disc of the polar quadrature in units of 1 / X (see the notes);
        the default 60 gives the coherence to about 1e-3.
    wavelength, radius : float, optional
        Optics [m].

    Returns
    -------
    RewsSpectra
    """
    from ..turbulence.tensor import _check_params, spectral_tensor

    _check_params(params)
    if not isinstance(lidar, LidarBeams):
        raise TypeError(f"lidar must be a LidarBeams, got {type(lidar).__name__}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    resolution = check_real("resolution", resolution, lo=1.0)
    k1 = np.asarray(k1, dtype=float)
    if k1.ndim != 1 or not np.all(np.isfinite(k1) & (k1 > 0)):
        raise ValueError("k1 must be a 1-D array of wavenumbers > 0 rad/m")
    if evolution is not None:
        from ..turbulence.evolution import _check_evolution

        _check_evolution(evolution)
    nb = lidar.focus_b.size
    n_bc = lidar.direction_bc
    p_bc = lidar.focus_points_bc
    shift_b = -p_bc[:, 0] / U if preview_shift is None else np.broadcast_to(
        np.asarray(preview_shift, dtype=float), (nb,))
    ws = list(weighting) if isinstance(weighting, (list, tuple)) else [weighting] * nb
    if len(ws) != nb:
        raise ValueError(f"weighting holds {len(ws)} entries for {nb} beams")
    kw = dict(wavelength=wavelength, radius=radius)
    made = {}  # beams of one focus and weighting share one transfer (and its tables)
    transfers = []
    for r, w in zip(lidar.focus_b, ws):
        key = (float(r), w if isinstance(w, str) else id(w))
        if key not in made:
            made[key] = beam_transfer(r, w, **kw)
        transfers.append(made[key])
    # Beams grouped by the x of their focus: one evolving plane each.
    plane_x, group_b = np.unique(np.round(p_bc[:, 0], 9), return_inverse=True)
    coef_bc = (lidar.weight_b / n_bc[:, 0])[:, None] * n_bc
    disc = isinstance(rotor, RotorDisc)
    if not disc:
        yn, zn, wn = (np.asarray(a, dtype=float) for a in rotor)
    span = 2.0 * float(np.max(np.hypot(p_bc[:, 1], p_bc[:, 2])))
    x_rad = max(rotor.radius if disc else float(np.max(np.hypot(yn, zn), initial=0.0)), 0.5 * span)
    if box_grid is not None:
        from ..turbulence.box import _check_grid

        shape, spacing = _check_grid(*box_grid)
        q2 = 2.0 * math.pi * np.fft.fftfreq(shape[1], spacing[1])
        q3 = 2.0 * math.pi * np.fft.fftfreq(shape[2], spacing[2])
        g2, g3 = np.meshgrid(q2, q3, indexing="ij")
        box_nodes = (g2.ravel(), g3.ravel(), np.full(g2.size, (q2[1] - q2[0]) * (q3[1] - q3[0])))
        if not disc:
            # separable on the grid of modes: sum_n w_n exp(i k2 y_n) exp(i k3 z_n)
            box_rotor = np.einsum("n,an,bn->ab", wn, _cis(np.multiply.outer(q2, yn)),
                                  _cis(np.multiply.outer(q3, zn))).ravel()
    out = np.empty((3, k1.size), dtype=complex)
    for j, kk in enumerate(k1):
        k2, k3, wq = box_nodes if box_grid is not None else _polar_nodes(kk, params.length_scale, x_rad, span,
                                                                         resolution)
        phi = spectral_tensor(kk, k2, k3, params)
        kap = np.hypot(k2, k3)
        if disc:
            gr = rotor.transfer(kap).astype(complex)
        elif box_grid is not None:
            gr = box_rotor  # the same grid of modes at every k1
        else:
            gr = np.einsum("kn,n->k", _cis(np.multiply.outer(k2, yn) + np.multiply.outer(k3, zn)), wn)
        kabs = np.sqrt(kk * kk + k2 * k2 + k3 * k3)
        rho = (None if evolution is None or evolution.frozen else
               {d: evolution.mode_correlation(kabs, d, params)
                for d in set(np.abs(np.subtract.outer(np.append(plane_x, 0.0), np.append(plane_x, 0.0))).ravel())})
        srr = np.sum(wq * np.abs(gr) ** 2 * phi[:, 0, 0])
        base = []  # per beam: the phase-free part of its transfer vector's scalar factor
        for b in range(nb):
            q = kk * n_bc[b, 0] + k2 * n_bc[b, 1] + k3 * n_bc[b, 2]
            ph = _cis(k2 * p_bc[b, 1] + k3 * p_bc[b, 2] + kk * (p_bc[b, 0] + U * shift_b[b]))
            base.append(ph * np.conj(transfers[b](q)))
        srl = 0.0
        sll = 0.0
        n_ph = lidar.delay_pb.shape[0]
        for d_b in lidar.delay_pb:
            # transfer vectors of each focus plane for this phase: (nodes, 3)
            g = np.zeros((plane_x.size, k2.size, 3), dtype=complex)
            for b in range(nb):
                g[group_b[b]] += np.outer(base[b] * complex(_cis(kk * U * d_b[b])), coef_bc[b])
            phig = np.einsum("nij,pnj->pni", phi, g)
            for p in range(plane_x.size):
                r0 = 1.0 if rho is None else rho[abs(plane_x[p])]
                srl += np.sum(wq * np.conj(gr) * phig[p, :, 0] * r0)
                for q_ in range(plane_x.size):
                    rpq = 1.0 if rho is None else rho[abs(plane_x[p] - plane_x[q_])]
                    sll += np.sum(wq * np.einsum("ni,ni->n", np.conj(g[p]), phig[q_]) * rpq)
        out[:, j] = srr, sll / n_ph, srl / n_ph
    return RewsSpectra(k1_k=k1, rotor_k=out[0].real, lidar_k=out[1].real, cross_k=out[2])


def rotor_spectrum(k1, params, rotor: RotorDisc, *, resolution: float = 60.0):
    """Two-sided spectrum of the REWS, ``S_RR(k1) = integral D(kappa)^2 Phi_11 dk2 dk3`` [m^3 s^-2].

    The rotor part of :func:`rews_spectra` without a lidar (same quadrature);
    ``f = U k1 / (2 pi)`` for the rotor at rest, one-sided in f
    ``(4 pi / U) S_RR``.
    """
    from ..turbulence.tensor import _check_params, spectral_tensor

    _check_params(params)
    if not isinstance(rotor, RotorDisc):
        raise TypeError(f"rotor must be a RotorDisc, got {type(rotor).__name__}")
    resolution = check_real("resolution", resolution, lo=1.0)
    k1 = np.asarray(k1, dtype=float)
    if k1.ndim != 1 or not np.all(np.isfinite(k1) & (k1 > 0)):
        raise ValueError("k1 must be a 1-D array of wavenumbers > 0 rad/m")
    out = np.empty(k1.size)
    for j, kk in enumerate(k1):
        k2, k3, wq = _polar_nodes(kk, params.length_scale, rotor.radius, 0.0, resolution)
        out[j] = np.sum(wq * rotor.transfer(np.hypot(k2, k3)) ** 2 * spectral_tensor(kk, k2, k3, params)[:, 0, 0])
    return out


# --------------------------------------------------------------------------
# the spectra as a segment-averaged estimate sees them
# --------------------------------------------------------------------------
def _geometric_sum(delta, n):
    """``sum_{m=0}^{n-1} exp(2 pi i delta m)`` for real ``delta`` (cycles per sample); n at integer delta."""
    d = np.asarray(delta, dtype=float)
    s = np.sin(math.pi * d)
    near = np.abs(s) < 1e-12
    val = _cis(math.pi * d * (n - 1)) * (np.sin(math.pi * d * n) / np.where(near, 1.0, s))
    return np.where(near, complex(n), val)


def _interp_spectrum(k_src, values, k_new, *, complex_):
    """Log-log interpolation of a spectrum (modulus; phase linear in k for a complex one), flat below, power law above."""
    lk = np.log(k_src)
    mag = np.log(np.maximum(np.abs(values), 1e-300))
    x = np.log(np.maximum(k_new, k_src[0]))
    slope = (mag[-1] - mag[-2]) / (lk[-1] - lk[-2])
    out = np.where(x > lk[-1], mag[-1] + slope * (x - lk[-1]), np.interp(x, lk, mag))
    out = np.exp(out)
    if complex_:
        ph = np.unwrap(np.angle(values))
        out = out * _cis(np.interp(np.maximum(k_new, k_src[0]), k_src, ph))
    return out


def estimated_spectra(spectra: RewsSpectra, mean_speed: float, *, fs: float, segment_duration: float,
                      window: str = "hann", f_edges=None, oversample: int = 16, reach: float = 32.0) -> RewsSpectra:
    """What :func:`cwlidar_sim.analysis.rews.coherence_estimate` expects to see of analytic spectra.

    The estimate's spectra are segment periodograms (mean removed, tapered)
    averaged over segments and over the frequencies of each bin; their
    expectation is the true two-sided spectrum ``S(nu) = (2 pi / U) S(k1)``
    weighted by each ordinate's kernel ``|K_j(nu)|^2``,
    ``K_j(nu) = sum_n w_n (exp(2 pi i nu t_n) - m(nu)) exp(-2 pi i j n / N)``
    (``m(nu)`` the segment mean of the mode, ``t_n = n / fs``), scaled as
    :func:`cwlidar_sim.analysis.segment_spectra` scales the periodogram.
    The coherence formed from these expectations is what the estimate
    converges to with many segments: the taper's leakage and the bins'
    averaging of the red spectra included (at 60-s segments the leakage of
    the strongly coherent low frequencies raises the coherence near its
    fall), the estimator's finite-average bias (about ``(1 - c)^2 / n``)
    not.

    Parameters
    ----------
    spectra : RewsSpectra
        Analytic spectra on an increasing grid of k1 [rad/m], fine enough
        for log-log interpolation (about 10 per decade), from below the
        first ordinate ``2 pi / (U T)`` to above the last bin edge; below
        the grid the spectra are held flat, above it extended by the last
        power law; the cross-spectrum's phase is interpolated linearly in k1.
    mean_speed : float
        U [m/s] (k1 = 2 pi f / U).
    fs : float
        Sampling rate [Hz].
    segment_duration : float
        Segment length T [s] (rounded to samples as segment_spectra does).
    window : {"hann", "none"}
    f_edges : array_like, optional
        Frequency bin edges [Hz], as for coherence_estimate; None: every ordinate.
    oversample : int
        Quadrature nodes per ordinate spacing 1/T, >= 4.
    reach : float
        The kernel is integrated over ``|nu| <= f_last + reach / T``: with Hann
        the kernel has fallen by more than 1e-8 there; without a taper its
        ``1 / nu^2`` leakage from farther is left out.

    Returns
    -------
    RewsSpectra
        On the bins' centres ``k = 2 pi sqrt(lo hi) / U`` holding ordinates
        (or every ordinate's k): the expected one-sided PSDs in f
        [m^2 s^-2 / Hz] and cross-spectrum of the estimate.
    """
    if not isinstance(spectra, RewsSpectra):
        raise TypeError(f"spectra must be a RewsSpectra, got {type(spectra).__name__}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    fs = check_real("fs", fs, lo=0.0, lo_open=True)
    T = check_real("segment_duration", segment_duration, lo=0.0, lo_open=True)
    check_choice("window", window, ("none", "hann"))
    oversample = check_int("oversample", oversample, lo=4, hi=1000)
    reach = check_real("reach", reach, lo=1.0)
    k_src = np.asarray(spectra.k1_k, dtype=float)
    if k_src.size < 2 or np.any(np.diff(k_src) <= 0):
        raise ValueError("spectra.k1_k must hold at least 2 increasing wavenumbers")
    n_per = int(round(T * fs))
    if n_per < 2:
        raise ValueError(f"segment_duration * fs = {T * fs:g} samples; allowed: >= 2")
    df = fs / n_per
    j_all = np.arange(1, n_per // 2 + 1)
    f_all = j_all * df
    if f_edges is None:
        groups = [np.array([j]) for j in j_all]
        centres = f_all
    else:
        e = np.asarray(f_edges, dtype=float)
        if e.ndim != 1 or e.size < 2 or np.any(np.diff(e) <= 0):
            raise ValueError("f_edges must be increasing frequency bin edges [Hz]")
        idx = np.searchsorted(e, f_all, side="right") - 1
        keep = [b for b in range(e.size - 1) if np.any(idx == b)]
        groups = [j_all[idx == b] for b in keep]
        centres = np.array([math.sqrt(e[b] * e[b + 1]) for b in keep])
    j_used = np.concatenate(groups)
    nu_max = min(j_used.max() * df + reach / T, 0.5 * fs)  # a sampled series' spectrum: one period of nu
    nu = (np.arange(-int(math.ceil(nu_max / df * oversample)), int(math.ceil(nu_max / df * oversample)) + 1)
          * (df / oversample))
    dnu = df / oversample
    # the two-sided spectra in f at nu (conjugate symmetric)
    kn = 2.0 * math.pi * np.abs(nu) / U
    scale = 2.0 * math.pi / U
    s_rr = scale * _interp_spectrum(k_src, spectra.rotor_k, kn, complex_=False)
    s_ll = scale * _interp_spectrum(k_src, spectra.lidar_k, kn, complex_=False)
    s_rl = scale * _interp_spectrum(k_src, spectra.cross_k, kn, complex_=True)
    s_rl = np.where(nu < 0, np.conj(s_rl), s_rl)
    # kernels: the taper as sum of shifted rectangles
    taps = [(0.0, 1.0)] if window == "none" else [(0.0, 0.5), (1.0, -0.25), (-1.0, -0.25)]
    norm = n_per if window == "none" else float(np.sum((0.5 - 0.5 * np.cos(2 * math.pi * np.arange(n_per) / n_per)) ** 2))
    mean_mode = _geometric_sum(nu / fs, n_per) / n_per
    out = np.empty((3, len(groups)), dtype=complex)
    for b, js in enumerate(groups):
        acc = np.zeros(3, dtype=complex)
        for j in js:
            kj = np.zeros(nu.size, dtype=complex)
            d0 = 0.0 + 0.0j
            for shift, c in taps:
                kj += c * _geometric_sum((nu - (j + shift) * df) / fs, n_per)
                d0 += c * complex(_geometric_sum(np.array([-(j + shift) * df / fs]), n_per)[0])
            kj -= mean_mode * d0
            w = np.abs(kj) ** 2 * dnu
            acc += [np.sum(w * s_rr), np.sum(w * s_ll), np.sum(w * s_rl)]
        out[:, b] = acc * (2.0 / (fs * norm)) / len(js)
    return RewsSpectra(k1_k=2.0 * math.pi * centres / U, rotor_k=out[0].real, lidar_k=out[1].real, cross_k=out[2])
