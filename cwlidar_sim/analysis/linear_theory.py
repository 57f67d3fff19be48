"""One linear theory for every instrument: spectra of linear functionals of a Mann field.

Every statistic the simulator publishes is, to first order, a linear
functional of the wind field: a staring beam's weighted line-of-sight
average, a VAD fit's harmonics, a nacelle lidar's rotor-effective wind, a
multi-beam reconstruction, a sonic's or a cup's reading.  This module
describes such a functional as plain arrays (no sensor is imported: the
analysis layer sits beside ``sensors``) and gives its spectra, cross-spectra,
coherences and period variances from the Mann tensor, on the continuum or on
a box's own lattice of wavenumbers.

The functional
--------------
A :class:`LinearFunctional` has looks l (:class:`Looks`): a point ``p_l``
[m], a unit direction ``n_l`` along which a probe weighting ``phi_l(s)``
(unit integral) averages the field, a time ``t_l`` [s] at which the look is
taken relative to the statistic's time, and optionally a causal time filter
``h_l`` (a cup's first-order response, a dwell's block average).  Its output
o is ::

    A_o(t) = sum_l sum_c W_olc (h_l * integral phi_l(s) u_c(p_l + s n_l, t + t_l) ds)(t)

with the estimator weights ``W_olc`` [-] (one per output, look and velocity
component): a lidar look enters through ``n_l . u`` (``W_olc = c_ol n_lc``,
:func:`lidar_functional`), a sonic through each component
(:func:`point_functional`).  A staring average, a VAD least-squares fit
(:func:`least_squares_functional`), a nacelle lidar's REWS, a three-beam
reconstruction matrix and a rotor's disc average are all of this form.

Frozen turbulence, Taylor's hypothesis with the mean wind ``U`` along +x:
``u(x, t) = u_0(x - U t e1)`` and ``u_0(x) = integral u_hat(k) exp(i k.x) d^3k``,
``E[u_hat(k) u_hat(k')^H] = Phi(k) delta(k - k')``.  Then
``A_o(t) = integral exp(-i k1 U t) g_o(k) . u_hat(k) d^3k`` with the transfer
vector ::

    g_oc(k) = sum_l W_olc exp(i (k.p_l - k1 U t_l)) conj(phi_hat_l(k.n_l)) H_l(-k1 U),

``phi_hat(q) = integral phi(s) exp(-i q s) ds`` (the package's convention,
:meth:`cwlidar_sim.beam.ProbeVolume.fourier`) and ``H(omega) = integral
h(tau) exp(-i omega tau) d tau``.  A point probe has ``phi_hat = 1``.

Spectrum convention
-------------------
One-sided in k1 [rad/m], as everywhere in :mod:`cwlidar_sim.analysis`:
``F_AB(k1) = 2 integral g_A^H Phi g_B dk2 dk3`` for ``k1 > 0``, so that
``cov(A, B) = Re integral_0^inf F_AB dk1`` and ``var A = integral_0^inf F_AA
dk1``.  ``F_AB`` has the ordering of a measured ``E[X_A X_B^*]`` with
``X(f) = integral x(t) exp(-2 pi i f t) dt`` at ``f = U k1 / (2 pi)`` (a
sensor at rest); per Hz, ``S(f) = (2 pi / U) F(k1)``
(:func:`per_hertz`).  Coherence ``|F_AB|^2 / (F_AA F_BB)``.

Quadrature
----------
``quadrature="plane"`` (default): polar nodes in (k2, k3) after
:mod:`.rews_theory`'s rule (``_polar_nodes``): geometric Gauss-Legendre
panels in ``kappa``, no wider than the smallest of ``3 / (S / 2)``,
``1 / (L / 10)`` and ``1 / ell`` (the probes' scale) inside the disc
``kappa < resolution / X`` that resolves the looks' lateral phases, ``64 +
1.5 kappa S`` angles there (S the looks' lateral span, at least 16 ell);
beyond it panels of ratio 2 (the tensor's own scale, ``6 k1`` and on to
``1e5 max(k1, 1/L)``) with 128 to 256 angles.  The sums over the nodes run
in a fused numba kernel.  Convergence: refining the quadrature (twice the
resolution, the angles and the outer angles) moves the std ratio of a
conical scan's VAD u over a cup within 600 s (:func:`period_variance`) by
5e-5 (tests/analysis/test_linear_theory_convergence.py); the CS scene's 100-m
height (400 looks, 30 k1 over 1e-4..1 rad/m) gives 0.763772 against 0.763773
from the earlier rule with 2.5 times the nodes (each spectrum within 5e-5,
6e-4 of the lidar's at k1 = 1 rad/m where it is 1e-6 of its peak).  The k1
grid: a fixed log grid converges slowly (on that case 30 k1 over 1e-4..1
rad/m move the ratio by 3e-3 when halved: the scan's features near k1 ~ 2 pi
/ (scan diameter) and the revolution's ``2 pi / (U T_rev)``, the knee's
curvature under straight log-log lines); :func:`adaptive_spectra` bisects a
coarse grid where a spline through the spectra would move a
:class:`PeriodStatistic`'s variance by more than its share of a tolerance
(``analysis/_linear_period.py``; the CS scene's 100 m: 31 k1, within 1e-4 of the
ratio from 129).  ``quadrature="x_only"``: the
field taken to vary along x only, ``Phi(k) -> F(k1) delta(k2) delta(k3)``
with F the tensor's two-sided one-point spectra
(:func:`cwlidar_sim.turbulence.one_point_spectra`): the 1-D filter models of
:mod:`.cs_model`.  :func:`lattice_spectra` replaces the integral by the sum
over a box's own modes (the discrete spectra the generator draws,
``turbulence._discrete.DiscreteField``).

Included: frozen turbulence, every look's probe weighting along its own
beam, time offsets (scan timing, preview shifts), per-look causal time
filters.  Not included: evolving turbulence (see :mod:`.rews_theory` for the
eddy-lifetime planes), a box's trilinear interpolation between its nodes
(except :func:`lattice_spectra`'s ``interpolation`` option), the nonlinearity of speeds (|u_h| taken as u, ``U + u'``), speckle, noise and
the estimators' own response (:mod:`.estimator_theory`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_real
from ._linear_functionals import (
    LinearFunctional,
    Looks,
    block_response,
    conical_looks,
    first_order_response,
    least_squares_functional,
    lidar_functional,
    lorentzian_probe,
    point_functional,
)
from ._linear_lattice import PlaneRows, lattice_lines, node_reader, plane_arguments, plane_lines
from ._linear_period import (  # noqa: F401
    _auto, _check_k1, _dirichlet2, _loglog, PeriodStatistic, period_variance, refine_k1)
from .rews_theory import _GL_W, _GL_X, _panels

__all__ = [
    "Looks",
    "LinearFunctional",
    "lidar_functional",
    "point_functional",
    "least_squares_functional",
    "conical_looks",
    "lorentzian_probe",
    "first_order_response",
    "block_response",
    "FunctionalSpectra",
    "functional_spectra",
    "lattice_spectra",
    "per_hertz",
    "period_variance",
    "PeriodStatistic",
    "AdaptiveSpectra",
    "adaptive_spectra",
]

#: Nodes per chunk of the (k2, k3) quadrature (memory: n_looks x chunk complex values).
_CHUNK = 8192
#: The fused numba kernel (:mod:`._linear_kernels`); False: the plain numpy path, the tests' reference.
_FUSED = True
#: Nodes per parallel block of the fused kernel (fixed: the sum's order does not depend on the threads).
_BLOCK = 2048
#: Most angles on one circle of the polar quadrature.
_MAX_ANGLES = 1024
#: Angles per unit of ``kappa S`` on a circle of the polar quadrature (S the looks' lateral span or 16 probe scales).
_ANGLES = 1.5
#: Most angles on a circle beyond the phase-resolving disc (there only the tensor's angular shape is resolved).
_OUTER_ANGLES = 256
#: Panel width of the polar quadrature in units of ``1 / (half the looks' lateral span)`` (the phases' scale).
_PANEL = 3.0


# --------------------------------------------------------------------------
# spectra
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class FunctionalSpectra:
    """One-sided spectra and cross-spectra (in k1) of the outputs of one or more functionals.

    Attributes
    ----------
    k1_k : ndarray, shape (n_k,)
        Wavenumbers [rad/m] (``f = U k1 / (2 pi)``).
    names : tuple of str
        Output names, ``"<functional index>.<output name>"`` when more than
        one functional was given, else the output names.
    matrix_kab : ndarray, complex, shape (n_k, n_a, n_a)
        ``F_ab(k1)`` [m^3 s^-2] (module notes): Hermitian in (a, b), real
        non-negative diagonal.
    """

    k1_k: np.ndarray
    names: tuple
    matrix_kab: np.ndarray

    def _index(self, name):
        if isinstance(name, (int, np.integer)):
            return int(name)
        if name not in self.names:
            raise ValueError(f"no output {name!r}; allowed: {list(self.names)}")
        return self.names.index(name)

    def spectrum(self, a) -> np.ndarray:
        """``F_aa(k1)`` [m^3 s^-2] of output ``a`` (name or index)."""
        i = self._index(a)
        return self.matrix_kab[:, i, i].real.copy()

    def cross(self, a, b) -> np.ndarray:
        """``F_ab(k1)`` [m^3 s^-2], complex."""
        return self.matrix_kab[:, self._index(a), self._index(b)].copy()

    def coherence(self, a, b) -> np.ndarray:
        """Magnitude-squared coherence ``|F_ab|^2 / (F_aa F_bb)`` [-]."""
        return np.abs(self.cross(a, b)) ** 2 / (self.spectrum(a) * self.spectrum(b))


def _check_functionals(functionals):
    fs = [functionals] if isinstance(functionals, LinearFunctional) else list(functionals)
    if not fs:
        raise ValueError("functionals must hold at least one LinearFunctional")
    for i, f in enumerate(fs):
        if not isinstance(f, LinearFunctional):
            raise TypeError(f"functionals[{i}] must be a LinearFunctional, got {type(f).__name__}")
    names = fs[0].names if len(fs) == 1 else tuple(f"{i}.{n}" for i, f in enumerate(fs) for n in f.names)
    return fs, names


class _Table:
    """``phi_hat`` of a probe tabulated on ``|q|`` (log-spaced, 8000 per decade, 13 decades about 1/scale).

    Linear interpolation in ln|q|, ``phi_hat(-q) = conj(phi_hat(q))`` (a real
    weighting), ``phi_hat(0)`` below the table, 0 above it.  Used only where
    the table's midpoints reproduce the function within 1e-5 (``phi_hat(0) =
    1``; else the function itself is used): smooth weightings' transforms.
    The focused beam's exact weighting (CS optics): within 2.0e-6 at 40 m
    and 5.2e-6 at 100 m, the largest errors in its small oscillating tail
    from the cut at the telescope (about ``4e-4 / (q [rad/m])``, oscillating
    as ``exp(i q R)``).  4000 per decade missed the check at 100 m (1.05e-5
    at 56-84 rad/m), which sent the CS theory there to the numpy path, six
    times slower; the ratios are the same to 1e-6.
    """

    def __init__(self, f, scale):
        self.lq = np.linspace(math.log(1e-6 / scale), math.log(1e7 / scale), 104001)
        q = np.exp(self.lq)
        v = np.asarray(f(q), dtype=complex)
        self.re, self.im = v.real.copy(), v.imag.copy()
        self.v0 = complex(np.asarray(f(np.zeros(1)), dtype=complex)[0])
        mid = np.exp(0.5 * (self.lq[1:] + self.lq[:-1]))[::3]
        self.ok = bool(np.max(np.abs(self(mid) - np.asarray(f(mid), dtype=complex))) < 1e-5)

    def __call__(self, q):
        q = np.asarray(q, dtype=float)
        a = np.abs(q)
        lq = self.lq
        u = (np.log(np.maximum(a, 1e-300)) - lq[0]) * ((lq.size - 1) / (lq[-1] - lq[0]))
        i = np.clip(u.astype(np.int64), 0, lq.size - 2)
        t = np.clip(u - i, 0.0, 1.0)
        out = np.empty(q.shape, dtype=complex)
        out.real = self.re[i] + t * (self.re[i + 1] - self.re[i])
        out.imag = self.im[i] + t * (self.im[i + 1] - self.im[i])
        out[u < 0] = self.v0
        out[u > lq.size - 1] = 0.0
        np.conjugate(out, out=out, where=q < 0)
        return out


def _fast_probes(fs, q_max=None):
    """Per functional, its looks' probes with each smooth one replaced by its :class:`_Table` (built once).

    ``q_max`` [rad/m]: a box's, whose modes reach ``|k.n| <= q_max``; a
    table that misses its check beyond it is checked again only up to it.
    """
    made = {}
    out = []
    for f in fs:
        row = []
        for g in f.looks.probe_l:
            if g is not None and id(g) not in made:
                scale = Looks([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], None, g).probe_scale()
                t = _Table(g, max(scale, 1e-3))
                if not t.ok and q_max is not None:
                    mid = np.exp(0.5 * (t.lq[1:] + t.lq[:-1]))
                    mid = mid[mid <= 1.01 * q_max][::3]
                    t.ok = bool(np.max(np.abs(t(mid) - np.asarray(g(mid), dtype=complex)), initial=0.0) < 1e-5)
                made[id(g)] = t if t.ok else g
            row.append(None if g is None else made[id(g)])
        out.append(tuple(row))
    return out


class _Plan:
    """The looks of all functionals as the fused kernel's flat arrays (:mod:`._linear_kernels`); None if it can't.

    Built once per call: every look with a nonzero weight, concatenated over
    the functionals, each probe a :class:`_Table` row (a probe that could not
    be tabulated sends the call to the numpy path).
    """

    def __init__(self, fs, probes):
        tables, rows = [], {}
        pts, dirs, times, tab_l, resp, blocks = [], [], [], [], [], []
        for f, pr in zip(fs, probes):
            used = np.nonzero(np.any(f.weight_olc != 0.0, axis=(0, 2)))[0]
            for i in used:
                g = pr[i]
                if g is None:
                    tab_l.append(-1)
                elif isinstance(g, _Table):
                    if id(g) not in rows:
                        rows[id(g)] = len(tables)
                        tables.append(g)
                    tab_l.append(rows[id(g)])
                else:
                    raise _NoPlan
                resp.append(f.looks.response_l[i])
            pts.append(f.looks.point_lc[used])
            dirs.append(f.looks.direction_lc[used])
            times.append(f.looks.time_l[used])
            blocks.append(f.weight_olc[:, used, :])
        self.p_lc, self.n_lc, self.t_l = (np.concatenate(a) for a in (pts, dirs, times))
        self.table_l = np.array(tab_l, dtype=np.int64)
        self.response_l = resp
        n_a, n_l = sum(b.shape[0] for b in blocks), self.t_l.size
        self.weight_alc = np.zeros((n_a, n_l, 3))
        a0 = l0 = 0
        for b in blocks:
            self.weight_alc[a0:a0 + b.shape[0], l0:l0 + b.shape[1]] = b
            a0, l0 = a0 + b.shape[0], l0 + b.shape[1]
        # the kernel's sparse weights: per look its nonzero (output, component) entries in increasing a * 3 + c
        w_lj = np.transpose(self.weight_alc, (1, 0, 2)).reshape(n_l, n_a * 3)
        nz = w_lj != 0.0
        self.nz_start_l = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int64)
        self.nz_ac_j = np.nonzero(nz)[1].astype(np.int64)
        self.nz_w_j = w_lj[nz]
        if not tables:
            tables = [_Table(lambda q: np.ones(np.shape(q), dtype=complex), 1.0)]
        self.re_tq = np.stack([t.re for t in tables])
        self.im_tq = np.stack([t.im for t in tables])
        self.lq0_t = np.array([t.lq[0] for t in tables])
        self.inv_t = np.array([(t.lq.size - 1) / (t.lq[-1] - t.lq[0]) for t in tables])
        self.v0_t = np.array([t.v0 for t in tables], dtype=complex)

    def __call__(self, k1, k2, k3, w, phi_n33, U, out_ab):
        from .._config import apply_numba_threads
        from ._linear_kernels import accumulate_kernel

        apply_numba_threads()
        resp = np.array([1.0 if h is None else complex(np.asarray(h(np.array([-k1 * U])), dtype=complex).ravel()[0])
                         for h in self.response_l], dtype=complex)
        a_l = k1 * (self.p_lc[:, 0] - U * self.t_l)
        n_a = self.weight_alc.shape[0]
        out = np.zeros(((k2.size + _BLOCK - 1) // _BLOCK, n_a, n_a), dtype=complex)
        accumulate_kernel(float(k1), np.ascontiguousarray(k2, dtype=float), np.ascontiguousarray(k3, dtype=float),
                          np.ascontiguousarray(w, dtype=float), np.ascontiguousarray(phi_n33, dtype=float),
                          a_l, self.p_lc[:, 1].copy(), self.p_lc[:, 2].copy(), self.n_lc[:, 0].copy(),
                          self.n_lc[:, 1].copy(), self.n_lc[:, 2].copy(), self.table_l, resp, self.nz_start_l,
                          self.nz_ac_j, self.nz_w_j,
                          self.re_tq, self.im_tq, self.lq0_t, self.inv_t, self.v0_t, _BLOCK, out)
        out_ab += 2.0 * out.sum(axis=0)


class _NoPlan(Exception):
    """A probe that the fused kernel cannot take (not tabulated)."""


def _plan(fs, probes, fused):
    if not fused:
        return None
    try:
        return _Plan(fs, probes)
    except _NoPlan:
        return None


def _accumulate(fs, k1, k2, k3, w, phi_n33, U, out_ab, probes, plan=None):
    """``out += 2 sum_n w_n g_a^H Phi g_b`` over the nodes: the fused kernel (``plan``) or numpy, chunked."""
    if plan is not None:
        plan(k1, k2, k3, w, phi_n33, U, out_ab)
        return
    for lo in range(0, k2.size, _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        g = np.concatenate([f.transfer(k1, k2[sl], k3[sl], U, probes=pr) for f, pr in zip(fs, probes)], axis=0)
        pg = np.einsum("nij,bnj->bni", phi_n33[sl], g)
        out_ab += 2.0 * np.einsum("ani,bni,n->ab", np.conj(g), pg, w[sl])


def _polar_nodes(k1, L, X, S, resolution, width=None):
    """(k2, k3, weight) over the plane for one k1 (the module's Quadrature notes).

    :mod:`.rews_theory`'s polar rule, cut to what resolves the integrand:
    6-node Gauss-Legendre panels in kappa, geometric from ``1e-3 min(k1,
    1/L)``, no wider than ``width`` (default ``1 / X``) up to ``K_f =
    max(resolution / X, 6 / L)`` (the looks' lateral phases), geometric
    (ratio 2) from there to ``K = max(K_f, 6 k1)`` (the tensor's scale k1)
    and beyond to ``1e5 max(k1, 1/L)``; ``64 + _ANGLES kappa S`` angles
    (128 + ... for ``k1 L < 0.2``), at most :data:`_MAX_ANGLES`, and between
    128 and :data:`_OUTER_ANGLES` beyond ``K_f``.  Here X and S also cover
    the probe weightings' scale, whose kinks (``k.n = 0``) run across the
    plane to infinity.
    """
    s, t = min(k1, 1.0 / L), max(k1, 1.0 / L)
    K_f = max(resolution / X, 6.0 / L)
    K = max(K_f, 6.0 * t)
    kap_in, w_in = _panels(1e-3 * s, K_f, 1.0 / X if width is None else width)
    e_mid = K_f * 2.0 ** np.arange(0, int(math.ceil(math.log2(K / K_f))) + 1)
    e_mid[-1] = K
    e_out = K * 2.0 ** np.arange(0, int(math.ceil(math.log2(1e5 * t / K))) + 1)
    e = np.concatenate([e_mid[:-1], e_out])
    a, b = e[:-1, None], e[1:, None]
    kap = np.concatenate([kap_in, (0.5 * (b - a) * _GL_X + 0.5 * (b + a)).ravel()])
    w = np.concatenate([w_in, (0.5 * (b - a) * _GL_W).ravel()])
    base = 64 if k1 * L >= 0.2 else 128
    nn = np.minimum(2 * np.ceil((base + _ANGLES * kap * S) / 2).astype(int), _MAX_ANGLES)
    nn = np.where(kap > K_f, np.clip(nn, 128, _OUTER_ANGLES), nn)
    k2, k3, ww = [], [], []
    for n_a in np.unique(nn):
        sel = nn == n_a
        psi = (np.arange(n_a) + 0.5) * (2.0 * math.pi / n_a)
        kk = kap[sel][:, None]
        k2.append((kk * np.cos(psi)).ravel())
        k3.append((kk * np.sin(psi)).ravel())
        ww.append(np.repeat(kap[sel] * w[sel] * (2.0 * math.pi / n_a), n_a))
    return np.concatenate(k2), np.concatenate(k3), np.concatenate(ww)


def functional_spectra(k1, params, functionals, mean_speed: float, *, quadrature: str = "plane",
                       resolution: float = 60.0) -> FunctionalSpectra:
    """One-sided spectra and cross-spectra of linear functionals of a frozen Mann field (module notes).

    Parameters
    ----------
    k1 : array_like
        Wavenumbers [rad/m], > 0.
    params : MannParameters
    functionals : LinearFunctional or sequence of them
        Their outputs, concatenated, are the rows and columns of the result.
    mean_speed : float
        U [m/s], > 0, along +x.
    quadrature : {"plane", "x_only"}
        The (k2, k3) integral (module notes), or a field varying along x only.
    resolution : float
        Inner disc of the polar quadrature in units of ``1 / X`` (>= 1); the
        default 60 is what :mod:`.rews_theory` uses; doubling it moves the
        ratios of the tests' cases by less than 1e-3.

    Returns
    -------
    FunctionalSpectra
    """
    from ..turbulence.spectra import one_point_spectra
    from ..turbulence.tensor import _check_params, spectral_tensor

    _check_params(params)
    fs, names = _check_functionals(functionals)
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    check_choice("quadrature", quadrature, ("plane", "x_only"))
    resolution = check_real("resolution", resolution, lo=1.0)
    k1 = _check_k1(k1)
    n_a = sum(f.n_outputs for f in fs)
    out = np.zeros((k1.size, n_a, n_a), dtype=complex)
    probes = _fast_probes(fs)
    plan = _plan(fs, probes, _FUSED)
    if quadrature == "x_only":
        F11, F22, F33, F13 = (0.5 * F for F in one_point_spectra(k1, params))  # two-sided
        zero = np.zeros(1)
        for j, kk in enumerate(k1):
            phi = np.array([[[F11[j], 0.0, F13[j]], [0.0, F22[j], 0.0], [F13[j], 0.0, F33[j]]]])
            _accumulate(fs, kk, zero, zero, np.ones(1), phi, U, out[j], probes, plan)
        return FunctionalSpectra(k1, names, out)
    span = max(f.looks.lateral_span() for f in fs)
    ell = max(f.looks.probe_scale() for f in fs)
    X = max(0.5 * span, 0.1 * params.length_scale, ell)
    S = max(span, 16.0 * ell)
    # panels: 1 / ell across the probes' kinks and fall, 1 / (L / 10) for the tensor, and 3 / (span / 2) for the
    # looks' lateral phases (six Gauss-Legendre nodes integrate 6 rad of phase per panel to 1e-6)
    width = 1.0 / max(0.5 * span / _PANEL, 0.1 * params.length_scale, ell)
    for j, kk in enumerate(k1):
        k2, k3, w = _polar_nodes(float(kk), params.length_scale, X, S, resolution, width)
        _accumulate(fs, kk, k2, k3, w, spectral_tensor(kk, k2, k3, params), U, out[j], probes, plan)
    return FunctionalSpectra(k1, names, out)


def lattice_spectra(params, functionals, mean_speed: float, shape, spacing, *, rows=None, correction: str = "cell",
                    hf_compensation: bool = False, interpolation="none", aliases: int = 2,
                    origin=None) -> FunctionalSpectra:
    """The spectra of :func:`functional_spectra` as a box of this grid holds them: sums over its own modes.

    A box ``u(x) = sum_k S(k) exp(i k.x)`` (periodic, advected through the
    looks at U) makes each output a sum of lines at the box's ``k1_n = 2 pi
    n / (N1 dx)``; row n holds the variance ``2 sum_{k2, k3} g^H Phi_d g``
    (``Phi_d`` the discrete spectral matrix the generator draws each mode
    from, cell corrections and gains included), returned as a density
    (divided by ``dk1``) comparable with the continuum's ``F(k1_n)``; its
    sum over the rows times ``dk1`` is the box's variance of the output.  The
    modes are the generator's (numpy's fftfreq order); a Nyquist index of an
    even axis, which the generator draws at ``-pi / d`` and shares with its
    Hermitian partner, stands for both ``+-pi / d`` at half weight each, the
    symmetric lines of its linear interpolant, so the sum does not depend
    on that sign.

    Parameters
    ----------
    params : MannParameters
    functionals : LinearFunctional or sequence of them
    mean_speed : float
        U [m/s], > 0.
    shape : (N1, N2, N3) or (N1, N2)
        The generated box's shape (before any lateral cropping), or a
        plane's (``generate_plane``: its modes carry the tensor integrated
        over all k3, so every look must lie in one horizontal plane with a
        horizontal direction).
    spacing : (dx, dy, dz) or (dx, dy)
        Its spacing [m].
    rows : array_like of int, optional
        Rows n in ``1 .. N1 // 2``; default all of them.  The Nyquist row
        ``N1 / 2`` (even N1) is a single row and not doubled.
    correction : str
        The box's low-wavenumber correction (``generate_box``'s; a plane
        has its own cell averages: "cell" only).
    hf_compensation : bool
        The box's high-frequency compensation (``generate_box``'s; False for a plane).
    interpolation : {"none", "linear"} or a tuple of three (a plane: two) of them
        How the looks read the box between its nodes, per axis (x, y, z) or
        for all three: ``"none"``, the modes themselves (a point on the
        nodes); ``"linear"``, the sampler's trilinear interpolation
        (:mod:`cwlidar_sim.beam.sampling`, notes below).
    aliases : int
        Aliases m kept per interpolated axis, ``|m| <= aliases`` (>= 0); the
        power left out per axis is below ``2 / (3 pi^4 aliases^3)`` of a
        mode's (2.5e-4 at 3).
    origin : (x0, y0), optional
        A plane's only: the position [m] in the plane's frame (nodes at
        ``(i dx, j dy)``) of the functionals' origin.  Given, with y
        ``"linear"``, each look reads its two nodes across y exactly (its
        own fraction of a cell, ``analysis/_linear_lattice.py``) instead of
        the aliases summed in power (the expectation over the offset); a
        look with a probe must then have no y extent (direction ``n_y =
        0``: expand a slanted beam into point looks).

    Returns
    -------
    FunctionalSpectra
        On the rows' ``k1_n`` [rad/m]; with x interpolated, on the lines
        ``|k1_n + 2 pi m1 / dx|`` the aliases reach.

    Notes
    -----
    Linear interpolation along an axis of spacing d turns a mode's node
    values ``exp(i k x_j)`` into ``sum_m L(k + 2 pi m / d) exp(i (k + 2 pi m
    / d) x)``, ``L(q) = sinc^2(q d / 2)`` (the sampler's tents); along x the
    aliases m1 are lines of their own, across (y, z) they are summed in
    power, exact in expectation over the box's lateral offset against the
    instrument (a point on a node: leave its axes ``"none"``).  The
    derivation is in the notes of ``cwlidar_sim.analysis._linear_lattice``;
    tests/analysis/test_linear_theory_lattice.py checks it against the
    sampler's trilinear readings averaged over the offset.
    """
    from ..turbulence._discrete import discrete_field
    from ..turbulence.box import _check_grid
    from ..turbulence.tensor import _check_params

    _check_params(params)
    fs, names = _check_functionals(functionals)
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    if np.ndim(shape) == 1 and len(shape) == 2:
        return _plane_lattice(params, fs, names, U, shape, spacing, rows, correction, hf_compensation, interpolation,
                              aliases, origin)
    if origin is not None:
        raise ValueError("origin is a plane's (shape (N1, N2)); a box's looks read its aliases summed in power")
    shape, spacing = _check_grid(shape, spacing)
    if len(shape) != 3:
        raise ValueError(f"shape must be a box's (N1, N2, N3), got {shape!r}")
    n1 = shape[0]
    rows = np.arange(1, n1 // 2 + 1) if rows is None else np.array(rows, dtype=np.int64, ndmin=1)
    if rows.ndim != 1 or np.any(rows < 1) or np.any(rows > n1 // 2):
        raise ValueError(f"rows must be row indices in 1 .. {n1 // 2} (N1 // 2)")
    interp = (interpolation,) * 3 if isinstance(interpolation, str) else tuple(interpolation)
    if len(interp) != 3:
        raise ValueError(f"interpolation must be 'none', 'linear' or a tuple of three of them, got {interpolation!r}")
    for a, v in zip("xyz", interp):
        check_choice(f"interpolation ({a})", v, ("none", "linear"))
    aliases = check_int("aliases", aliases, lo=0)
    df = discrete_field("box", params, shape, spacing, correction=correction, hf_compensation=hf_compensation)
    q2 = 2.0 * math.pi * np.fft.fftfreq(shape[1], spacing[1])
    q3 = 2.0 * math.pi * np.fft.fftfreq(shape[2], spacing[2])
    g2, g3 = (a.ravel() for a in np.meshgrid(q2, q3, indexing="ij"))
    n_a = sum(f.n_outputs for f in fs)
    q_max = math.sqrt(sum((math.pi * (2 * aliases + 1 if v == "linear" else 1) / d) ** 2
                          for v, d in zip(interp, spacing)))
    probes = _fast_probes(fs, q_max)
    plan = _plan(fs, probes, _FUSED)

    def acc(q1, k2, k3, w, phi, out):
        _accumulate(fs, q1, k2, k3, w, phi, U, out, probes, plan)

    k_lines, out = lattice_lines(df, rows, g2, g3, spacing, interp, aliases, n_a, acc)
    return FunctionalSpectra(k_lines, names, out)


def _plane_lattice(params, fs, names, U, shape, spacing, rows, correction, hf_compensation, interpolation, aliases,
                   origin):
    """:func:`lattice_spectra` of a plane (``generate_plane``'s modes, k3 integrated; ``_linear_lattice`` notes)."""
    shape, spacing, rows, interp, aliases, origin = plane_arguments(fs, shape, spacing, rows, correction,
                                                                    hf_compensation, interpolation, aliases, origin)
    df = PlaneRows(params, shape, spacing)
    n_a = sum(f.n_outputs for f in fs)
    q_max = math.sqrt(sum((math.pi * (2 * aliases + 1 if v == "linear" else 1) / d) ** 2
                          for v, d in zip(interp, spacing)))
    probes = _fast_probes(fs, q_max)
    if origin is not None:
        read, zero = node_reader(spacing[1], origin[1]), np.zeros(shape[1])

        def transfer(q1, k2):
            return np.concatenate([f.transfer(q1, k2, zero, U, probes=pr, read_y=read) for f, pr in zip(fs, probes)])

        k_lines, out = plane_lines(df, rows, transfer, spacing, interp[0], aliases, n_a)
        return FunctionalSpectra(k_lines, names, out)
    plan = _plan(fs, probes, _FUSED)

    def acc(q1, k2, k3, w, phi, out):
        _accumulate(fs, q1, k2, k3, w, phi, U, out, probes, plan)

    q2 = 2.0 * math.pi * np.fft.fftfreq(shape[1], spacing[1])
    k_lines, out = lattice_lines(df, rows, q2, np.zeros_like(q2), tuple(spacing) + (1.0,), interp + ("none",),
                                 aliases, n_a, acc)
    return FunctionalSpectra(k_lines, names, out)


def per_hertz(spectrum_k, mean_speed: float):
    """A one-sided spectrum in k1 [m^3 s^-2] as one-sided per Hz [m^2 s^-2 / Hz]: ``(2 pi / U) F``."""
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    return (2.0 * math.pi / U) * np.asarray(spectrum_k)


@dataclasses.dataclass(frozen=True)
class AdaptiveSpectra:
    """The spectra of :func:`adaptive_spectra` on their refined k1 grid and the statistics' variances there.

    Attributes
    ----------
    spectra : FunctionalSpectra
        On the refined grid (every output and cross-spectrum).
    within : tuple of float
        Per statistic, ``within`` [m^2 s^-2] of :func:`period_variance` on
        that grid (no ``N / (N - 1)``).
    error : tuple of float
        Per statistic, the refinement's bound on the grid's relative error
        of ``within`` (``analysis/_linear_period.py``).
    converged : bool
        Whether every error is within the tolerance (False: ``max_k1`` reached).
    rounds : int
        Refinement rounds.
    """

    spectra: FunctionalSpectra
    within: tuple
    error: tuple
    converged: bool
    rounds: int


def adaptive_spectra(params, functionals, mean_speed: float, statistics, *, k1_range=(1e-4, 1.0), n_start: int = 9,
                     tol: float = 1e-3, max_k1: int = 400, quadrature: str = "plane",
                     resolution: float = 60.0) -> AdaptiveSpectra:
    """:func:`functional_spectra` on a k1 grid refined until each period statistic's variance is settled to ``tol``.

    The grid starts from ``n_start`` log-spaced k1 over ``k1_range`` and is
    bisected (in ln k1) where the spectra's log-log interpolation would move
    a statistic's ``within`` (its kernel: block, sampling and its aliasing,
    mean removal, the repetition's comb) by more than its share of ``tol``
    (``analysis/_linear_period.py``).

    Parameters
    ----------
    params : MannParameters
    functionals : LinearFunctional or sequence of them
    mean_speed : float
        U [m/s], > 0.
    statistics : sequence of PeriodStatistic
        The variances to converge; their outputs name the functionals' outputs.
    k1_range : (float, float)
        The grid's ends [rad/m] (below: flat; above: the last power law).
    n_start : int
        Starting k1 (>= 2): the coarsest interval the refinement tests.
    tol : float
        Relative tolerance of each ``within``, > 0.
    max_k1 : int
        Most k1 evaluated.
    quadrature, resolution
        :func:`functional_spectra`'s.

    Returns
    -------
    AdaptiveSpectra
    """
    fs, names = _check_functionals(functionals)
    stats = list(statistics)
    if not stats or not all(isinstance(st, PeriodStatistic) for st in stats):
        raise TypeError("statistics must be a non-empty sequence of PeriodStatistic")
    probe = FunctionalSpectra(np.ones(1), names, np.zeros((1, len(names), len(names)), dtype=complex))
    index = [probe._index(st.output) if st.weights is None
             else tuple((probe._index(o), w) for o, w in zip(st.output, st.weights)) for st in stats]

    def evaluate(k):
        return functional_spectra(k, params, fs, mean_speed, quadrature=quadrature, resolution=resolution).matrix_kab

    r = refine_k1(evaluate, index, stats, mean_speed, k1_range, n_start=n_start, tol=tol, max_k1=max_k1)
    s = FunctionalSpectra(r["k1"], names, r["matrix"])
    within = tuple(st.variance(s.k1_k, _auto(s.matrix_kab, a), mean_speed) for st, a in zip(stats, index))
    return AdaptiveSpectra(s, within, r["error"], r["converged"], r["rounds"])
