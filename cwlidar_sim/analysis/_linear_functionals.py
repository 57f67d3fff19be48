"""The description of a linear functional of the wind field: its looks and estimator weights.

The public names are re-exported by :mod:`cwlidar_sim.analysis.linear_theory`,
whose module notes define the functional, its transfer vector and the
conventions.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_real
from .rews_theory import _cis

# --------------------------------------------------------------------------
# description of a functional
# --------------------------------------------------------------------------
def _callables(name, value, n):
    seq = list(value) if isinstance(value, (list, tuple)) else [value] * n
    if len(seq) != n:
        raise ValueError(f"{name} holds {len(seq)} entries for {n} looks")
    for i, f in enumerate(seq):
        if f is not None and not callable(f):
            raise TypeError(f"{name}[{i}] must be a callable or None, got {type(f).__name__}")
    return tuple(seq)


@dataclasses.dataclass(frozen=True, eq=False)
class Looks:
    """Where, along which direction, with which weighting and when a functional samples the field.

    Parameters
    ----------
    point_lc : array_like, shape (n_l, 3)
        Look points p_l [m] (the focus of a beam, a point sensor's position),
        x along the mean wind; any common origin.
    direction_lc : array_like, shape (n_l, 3)
        Unit vectors n_l [-] along which the probe weighting runs (a beam's
        direction, signed as the line-of-sight speed is); for a point probe
        any unit vector.
    time_l : array_like, shape (n_l,), optional
        Time t_l [s] of each look relative to the statistic's time (default
        0): the look sees ``u_0(p_l - U (t + t_l) e1)``.
    probe_l : callable or None, or a sequence of them (n_l)
        ``q [rad/m] -> phi_hat(q)`` (complex, vectorised) of each look's
        weighting along ``n_l`` (``phi_hat(q) = integral phi(s) exp(-i q s)
        ds``, e.g. :func:`lorentzian_probe`,
        :func:`cwlidar_sim.analysis.rews_theory.beam_transfer` or a
        :class:`cwlidar_sim.beam.ProbeVolume`'s ``fourier``); None: a point.
    response_l : callable or None, or a sequence of them (n_l)
        ``omega [rad/s] -> H(omega)`` of a causal time filter applied to the
        look's sample (:func:`first_order_response`, :func:`block_response`);
        None: none.
    """

    point_lc: np.ndarray
    direction_lc: np.ndarray
    time_l: np.ndarray = None
    probe_l: tuple = None
    response_l: tuple = None

    def __post_init__(self):
        p = np.array(self.point_lc, dtype=float, ndmin=2)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1 or not np.all(np.isfinite(p)):
            raise ValueError(f"point_lc must be finite points of shape (n_looks >= 1, 3) [m], got {p.shape}")
        n_l = p.shape[0]
        n = np.array(self.direction_lc, dtype=float, ndmin=2)
        if n.shape != (n_l, 3) or not np.all(np.isfinite(n)):
            raise ValueError(f"direction_lc must be finite, of shape ({n_l}, 3), got {n.shape}")
        if np.any(np.abs(np.linalg.norm(n, axis=1) - 1.0) > 1e-6):
            raise ValueError("direction_lc must hold unit vectors (|n| = 1 within 1e-6)")
        t = np.zeros(n_l) if self.time_l is None else np.array(np.broadcast_to(
            np.asarray(self.time_l, dtype=float), (n_l,)))
        if not np.all(np.isfinite(t)):
            raise ValueError("time_l must be finite times [s]")
        for name, a in (("point_lc", p), ("direction_lc", n), ("time_l", t)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        object.__setattr__(self, "probe_l", _callables("probe_l", self.probe_l, n_l))
        object.__setattr__(self, "response_l", _callables("response_l", self.response_l, n_l))

    @property
    def n_looks(self) -> int:
        """Number of looks."""
        return self.point_lc.shape[0]

    def probe_scale(self) -> float:
        """Largest length scale of the looks' probe weightings [m]: ``ln 2 / q`` where ``|phi_hat(q)|`` falls to 1/2.

        z_R for a Lorentzian; 0 when every look is a point.  Sets the
        quadrature's resolution of the weightings' kinks and fall
        (:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`).
        """
        q = np.geomspace(1e-6, 1e6, 481)
        out = 0.0
        seen = set()
        for f in self.probe_l:
            if f is None or id(f) in seen:
                continue
            seen.add(id(f))
            a = np.abs(np.asarray(f(q), dtype=complex))
            i = int(np.argmax(a < 0.5 * a[0])) if np.any(a < 0.5 * a[0]) else q.size - 1
            out = max(out, math.log(2.0) / q[i])
        return out

    def lateral_span(self) -> float:
        """Largest distance between two looks' points in the (y, z) plane [m]."""
        yz = self.point_lc[:, 1:]
        if yz.shape[0] > 200:  # a bound is enough: twice the largest distance from the centroid
            return 2.0 * float(np.max(np.linalg.norm(yz - yz.mean(axis=0), axis=1)))
        d = yz[:, None, :] - yz[None, :, :]
        return float(np.max(np.linalg.norm(d, axis=-1)))


@dataclasses.dataclass(frozen=True, eq=False)
class LinearFunctional:
    """Outputs ``A_o = sum_l sum_c W_olc (look l's average of u_c)`` (module notes).

    Parameters
    ----------
    looks : Looks
    weight_olc : array_like, shape (n_o, n_l, 3)
        Estimator weight of each output, look and velocity component (u, v, w) [-].
    names : sequence of str, optional
        One name per output (default ``"0"``, ``"1"``, ...); unique.
    """

    looks: Looks
    weight_olc: np.ndarray
    names: tuple = None

    def __post_init__(self):
        if not isinstance(self.looks, Looks):
            raise TypeError(f"looks must be a Looks, got {type(self.looks).__name__}")
        w = np.array(self.weight_olc, dtype=float)
        if w.ndim == 2:
            w = w[None]
        if w.ndim != 3 or w.shape[1:] != (self.looks.n_looks, 3) or not np.all(np.isfinite(w)):
            raise ValueError(f"weight_olc must be finite, of shape (n_outputs, {self.looks.n_looks}, 3), "
                             f"got {np.shape(self.weight_olc)}")
        w.setflags(write=False)
        object.__setattr__(self, "weight_olc", w)
        names = tuple(str(i) for i in range(w.shape[0])) if self.names is None else tuple(
            str(s) for s in ([self.names] if isinstance(self.names, str) else self.names))
        if len(names) != w.shape[0] or len(set(names)) != len(names):
            raise ValueError(f"names must be {w.shape[0]} unique names, got {names!r}")
        object.__setattr__(self, "names", names)

    @property
    def n_outputs(self) -> int:
        """Number of outputs."""
        return self.weight_olc.shape[0]

    def transfer(self, k1: float, k2, k3, U: float, *, probes=None, read_y=None) -> np.ndarray:
        """Transfer vectors ``g_oc(k)`` at ``(k1, k2_n, k3_n)`` [-], complex, shape (n_o, n_nodes, 3).

        Parameters
        ----------
        k1 : float
            Along-wind wavenumber [rad/m].
        k2, k3 : ndarray, shape (n_nodes,)
            Lateral wavenumbers [rad/m].
        U : float
            Mean wind speed [m/s] along +x.
        probes : sequence of callables or None, optional
            Stand-ins for ``looks.probe_l`` (the same functions, e.g. tabulated).
        read_y : callable, optional
            ``read_y(y_l, k2) -> (n_l, n_nodes)`` complex: how each look reads
            a mode's ``exp(i k2 y)`` across y, in place of ``exp(i k2 y_l)``
            (a plane's nodes interpolated, :func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`).
        """
        k2 = np.asarray(k2, dtype=float)
        k3 = np.asarray(k3, dtype=float)
        lk = self.looks
        probes = lk.probe_l if probes is None else probes
        used = np.nonzero(np.any(self.weight_olc != 0.0, axis=(0, 2)))[0]
        p, n = lk.point_lc[used], lk.direction_lc[used]
        if read_y is None:
            e_ln = _cis(np.multiply.outer(k1 * (p[:, 0] - U * lk.time_l[used]), np.ones(k2.size))
                        + np.multiply.outer(p[:, 1], k2) + np.multiply.outer(p[:, 2], k3))
        else:
            e_ln = _cis(np.multiply.outer(k1 * (p[:, 0] - U * lk.time_l[used]), np.ones(k2.size))
                        + np.multiply.outer(p[:, 2], k3)) * read_y(p[:, 1], k2)
        for j, i in enumerate(used):
            if probes[i] is not None:
                e_ln[j] *= np.conj(np.asarray(probes[i](k1 * n[j, 0] + k2 * n[j, 1] + k3 * n[j, 2]), dtype=complex))
            if lk.response_l[i] is not None:
                e_ln[j] *= complex(np.asarray(lk.response_l[i](np.array([-k1 * U])), dtype=complex).ravel()[0])
        w = self.weight_olc[:, used, :]  # (o, l, c)
        g = np.transpose(w, (0, 2, 1)).reshape(-1, used.size).astype(complex) @ e_ln  # (o c, n)
        return np.transpose(g.reshape(self.n_outputs, 3, k2.size), (0, 2, 1))


def lidar_functional(looks: Looks, coef_ol, names=None) -> LinearFunctional:
    """Outputs ``A_o = sum_l c_ol v_l`` of the looks' line-of-sight speeds ``v_l = n_l.u`` (weighted).

    ``W_olc = c_ol n_lc``: a staring beam's average (``c = 1 / n_l``), a VAD
    or reconstruction fit (:func:`least_squares_functional`), a nacelle
    lidar's REWS estimate (``c_b = w_b / n_bx``).

    Parameters
    ----------
    looks : Looks
    coef_ol : array_like, shape (n_o, n_l) or (n_l,)
        Weight of each look's line-of-sight speed in each output [-].
    names : sequence of str, optional
    """
    if not isinstance(looks, Looks):
        raise TypeError(f"looks must be a Looks, got {type(looks).__name__}")
    c = np.array(coef_ol, dtype=float, ndmin=2)
    if c.ndim != 2 or c.shape[1] != looks.n_looks:
        raise ValueError(f"coef_ol must have shape (n_outputs, {looks.n_looks}), got {np.shape(coef_ol)}")
    return LinearFunctional(looks, c[:, :, None] * looks.direction_lc[None, :, :], names)


def least_squares_functional(looks: Looks, components=("u", "v", "w")) -> LinearFunctional:
    """The least-squares fit of a uniform wind to the looks' line-of-sight speeds (a VAD, a 3-beam reconstruction).

    Fits ``v_l = n_l . (u, v, w)`` over the looks (only the ``components``
    named; the others taken as 0): the weights are the rows of the design
    matrix's pseudo-inverse.  On a full conical circle this is the VAD's
    first harmonic (u, v) and its mean (w); with three looks, the
    reconstruction matrix ``N^-1``.

    Parameters
    ----------
    looks : Looks
    components : sequence of {"u", "v", "w"}
        The fitted components, in the outputs' order (their names).
    """
    if not isinstance(looks, Looks):
        raise TypeError(f"looks must be a Looks, got {type(looks).__name__}")
    comps = tuple(components)
    idx = [("u", "v", "w").index(check_choice("components", c, ("u", "v", "w"))) for c in comps]
    if not idx or len(set(idx)) != len(idx):
        raise ValueError(f"components must name distinct components of u, v, w; got {comps!r}")
    X = looks.direction_lc[:, idx]
    if np.linalg.matrix_rank(X) < len(idx):
        raise ValueError(f"the looks' directions cannot resolve components {comps!r} (rank-deficient design)")
    return lidar_functional(looks, np.linalg.pinv(X), comps)


def point_functional(point, components=("u", "v", "w"), *, response=None, time: float = 0.0) -> LinearFunctional:
    """A point sensor: a sonic (each component) or, with ``response``, a cup (``("u",)``, first order).

    Parameters
    ----------
    point : (x, y, z)
        Position [m].
    components : sequence of {"u", "v", "w"}
        The outputs, one velocity component each (their names).
    response : callable, optional
        ``omega -> H(omega)`` of the instrument's time response
        (:func:`first_order_response` for a cup of distance constant l:
        time constant ``l / U``).
    time : float
        Time offset of the reading [s].
    """
    comps = tuple(components)
    idx = [("u", "v", "w").index(check_choice("components", c, ("u", "v", "w"))) for c in comps]
    looks = Looks(np.asarray(point, dtype=float).reshape(1, 3), [[1.0, 0.0, 0.0]], [time], None, response)
    w = np.zeros((len(idx), 1, 3))
    for o, c in enumerate(idx):
        w[o, 0, c] = 1.0
    return LinearFunctional(looks, w, comps)


def conical_looks(height: float, half_angle_deg: float, azimuth_l, *, time_l=None, probe=None, origin=(0.0, 0.0, 0.0),
                  focus_distance: float | None = None) -> Looks:
    """Looks of an upward conical scan: beam ``n = (sin a cos theta, sin a sin theta, cos a)``.

    ``theta`` the azimuth from +x (the mean wind) toward +y, ``a`` the
    half-angle from the vertical; the focus at ``origin + r n`` with
    ``r = height / cos a`` unless ``focus_distance`` is given.

    Parameters
    ----------
    height : float
        Focus height above the lidar [m], > 0.
    half_angle_deg : float
        Cone half-angle [deg], in [0, 90).
    azimuth_l : array_like
        Azimuths [rad] of the looks.
    time_l : array_like, optional
        Their times [s] relative to the statistic's time.
    probe : callable or None, or a sequence of them
        ``phi_hat`` of the weighting along each beam (None: point).
    origin : (x, y, z)
        The lidar's position [m].
    focus_distance : float, optional
        r [m]; default ``height / cos a``.
    """
    z = check_real("height", height, lo=0.0, lo_open=True)
    a = math.radians(check_real("half_angle_deg", half_angle_deg, lo=0.0, hi=90.0, hi_open=True))
    th = np.asarray(azimuth_l, dtype=float).ravel()
    n = np.stack([math.sin(a) * np.cos(th), math.sin(a) * np.sin(th), np.full(th.size, math.cos(a))], axis=1)
    r = z / math.cos(a) if focus_distance is None else check_real("focus_distance", focus_distance, lo=0.0,
                                                                  lo_open=True)
    return Looks(np.asarray(origin, dtype=float)[None, :] + r * n, n, time_l, probe)


def lorentzian_probe(rayleigh_length: float):
    """``phi_hat(q) = exp(-z_R |q|)`` of the Lorentzian weighting (A2012 Eq. 4) [-]; z_R [m] >= 0."""
    zr = check_real("rayleigh_length", rayleigh_length, lo=0.0)

    def phi_hat(q):
        return np.exp(-zr * np.abs(np.asarray(q, dtype=float))).astype(complex)

    return phi_hat


def first_order_response(time_constant: float):
    """``H(omega) = 1 / (1 + i omega tau)`` of a first-order sensor (a cup: ``tau = l / U``); tau [s] >= 0."""
    tau = check_real("time_constant", time_constant, lo=0.0)

    def h(omega):
        return 1.0 / (1.0 + 1j * tau * np.asarray(omega, dtype=float))

    return h


def block_response(duration: float):
    """``H(omega) = sinc(omega T / 2)``: the average over ``[t - T/2, t + T/2]`` (a dwell); T [s] >= 0."""
    T = check_real("duration", duration, lo=0.0)

    def h(omega):
        return np.sinc(np.asarray(omega, dtype=float) * T / (2.0 * math.pi)).astype(complex)

    return h


