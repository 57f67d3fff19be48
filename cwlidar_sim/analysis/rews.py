"""Rotor-effective wind speed, its lidar estimate, preview and their coherence (pure functions).

What a lidar-assisted turbine controller needs from a nacelle lidar (Schlipf
et al. 2013, J. Atmos. Oceanic Technol. 30; Simley et al. 2014, Wind Energy
17; Held & Mann 2019, Wind Energ. Sci. 4): the rotor-effective wind speed
(REWS) the rotor will feel, the lidar's estimate of it shifted by the preview
time, how coherent the two are, and the optimal (Wiener) preview filter.
The analytic coherence from the Mann tensor is in :mod:`.rews_theory`.

Frame and conventions
---------------------
x along the mean wind (downwind), y to the left looking downwind, z up; the
rotor plane is ``x = 0`` with the hub at ``(hub_y, hub_z)``; a sensor at
rest sees the frozen field at ``x - U t`` (Taylor).  Beam directions are
unit vectors from the lidar, line-of-sight speeds ``v_los = n . u`` are
positive away from the lidar, so a beam looking upwind has ``n_x < 0``.

* **REWS.**  ``u_R(t) = integral w(r) u(0, y, z, t) dA / integral w(r) dA``
  over the disc of radius R about the hub, with the per-area weight
  ``w(r) = (r / R)^p`` (:class:`RotorDisc`; ``p = 0``, the default, is the
  plain area average; ``p = 1`` weights like the aerodynamic torque of a
  rotor with uniform loading per unit span).  Only u enters: the REWS is
  the speed along the rotor axis.  On a grid the integral is the sum over
  the grid nodes inside the disc with those weights.
* **Lidar estimate.**  Each beam's ``v_los`` is turned into u assuming
  ``v = w = 0``: ``u_b = v_los / n_x`` (exact for a uniform wind along x);
  the estimate is the average of ``u_b`` over one scan (the N beams of a
  multi-beam lidar at one time, or the last N samples of a circular scan),
  each beam shifted by its preview time.
* **Preview.**  The air a beam measures ``d = |x_focus|`` upwind reaches the
  rotor ``T = d / U`` later (:func:`preview_time`): the estimate at time t
  is compared with the REWS at ``t + T`` (:func:`align_preview`).
* **Spectra.**  Estimated spectra are *one-sided* in f [Hz] (or k = 2 pi f / U
  [rad/m]), cross-spectra ``C_RL = E[X_R X_L^*]`` (rotor first), as in
  :func:`cwlidar_sim.analysis.segment_spectra`.  The magnitude-squared
  coherence ``gamma^2 = |C_RL|^2 / (C_RR C_LL)`` and the Wiener filter's gain
  ``|G| = |C_RL| / C_LL`` (the optimal linear estimate of the REWS from the
  lidar is ``G L`` with ``G = C_RL / C_LL``) do not depend on the
  one-/two-sided convention.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_keys, check_real

__all__ = [
    "RotorDisc",
    "rotor_node_weights",
    "rews_from_box",
    "los_to_u",
    "fit_uvw",
    "scan_average",
    "preview_time",
    "align_preview",
    "CoherenceEstimate",
    "coherence_estimate",
    "coherence_interval",
    "effective_averages",
    "coherence_bandwidth",
    "wiener_gain",
]


# --------------------------------------------------------------------------
# the rotor
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class RotorDisc:
    """Rotor disc and the weighting of its REWS.

    Parameters
    ----------
    radius : float
        Rotor radius R [m]; > 0.
    exponent : float
        p of the per-area weight ``(r / R)^p``; in [0, 10].  0 (default):
        uniform over the disc.
    """

    radius: float
    exponent: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "radius", check_real("radius", self.radius, lo=0.0, lo_open=True))
        object.__setattr__(self, "exponent", check_real("exponent", self.exponent, lo=0.0, hi=10.0))

    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "RotorDisc":
        """Build from a mapping; unknown keys are rejected by name, defaults fill the rest."""
        check_keys(cls, d, required=["radius"])
        return cls(**d)

    def transfer(self, kperp):
        """Transfer function of the disc average, ``D(kappa)`` [-], for ``kappa = |(k2, k3)|`` [rad/m].

        ``D = integral_0^R w(r) J0(kappa r) r dr / integral_0^R w(r) r dr``:
        ``2 J1(kappa R) / (kappa R)`` for p = 0 (closed form), Gauss-Legendre
        in r otherwise (4 nodes per half-period of J0 plus 32).  Real, even,
        ``D(0) = 1``; the REWS of a mode ``exp(i (k2 y + k3 z))`` centred on
        the hub is D times the mode at the hub.
        """
        from scipy.special import j0, j1

        kap = np.abs(np.asarray(kperp, dtype=float))
        x = kap * self.radius
        if self.exponent == 0.0:
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.where(x > 1e-8, 2.0 * j1(x) / np.where(x > 1e-8, x, 1.0), 1.0 - x * x / 8.0)
            return out
        n = int(32 + 4 * math.ceil(float(x.max(initial=0.0)) / math.pi))
        g, w = np.polynomial.legendre.leggauss(n)
        r = 0.5 * (g + 1.0)  # in units of R
        wr = 0.5 * w * r ** (self.exponent + 1.0)
        # einsum, not BLAS: small products, and a threaded BLAS on a busy machine is slow
        return np.einsum("...r,r->...", j0(np.multiply.outer(x, r)), wr) / wr.sum()


def rotor_node_weights(rotor: RotorDisc, y_y, z_z, hub_y: float, hub_z: float):
    """Weights of the grid nodes inside the disc, summing to 1 [-].

    Parameters
    ----------
    rotor : RotorDisc
    y_y, z_z : array_like
        Node coordinates [m] of the grid's y and z axes (uniform).
    hub_y, hub_z : float
        Hub position [m].

    Returns
    -------
    w_yz : ndarray, shape (len(y_y), len(z_z))
        ``(r / R)^p`` for nodes with ``r <= R`` (r from the hub), 0 outside,
        normalised to sum 1 (each node stands for an equal cell of area).

    Raises
    ------
    ValueError
        No node of the grid lies in the disc.
    """
    if not isinstance(rotor, RotorDisc):
        raise TypeError(f"rotor must be a RotorDisc, got {type(rotor).__name__}")
    y = np.asarray(y_y, dtype=float)
    z = np.asarray(z_z, dtype=float)
    hy, hz = check_real("hub_y", hub_y), check_real("hub_z", hub_z)
    r = np.hypot(y[:, None] - hy, z[None, :] - hz)
    inside = r <= rotor.radius * (1.0 + 1e-12)
    if not inside.any():
        raise ValueError(f"no grid node lies in the rotor disc of radius {rotor.radius} m about "
                         f"({hy}, {hz}); allowed: a disc that covers at least one node")
    w = np.where(inside, (r / rotor.radius) ** rotor.exponent if rotor.exponent else 1.0, 0.0)
    return w / w.sum()


def rews_from_box(box, rotor: RotorDisc, hub_y: float, hub_z: float, *, x: float, times, U: float):
    """REWS time series of a frozen box field at the rotor plane ``x`` [m/s].

    The box (dims x, y, z; periodic in x) is advected at U along +x; at
    time t the rotor plane sees the box at ``x - U t``, linearly interpolated
    between its x planes, and the REWS is the :func:`rotor_node_weights`
    sum of u over the nodes in the disc.

    Parameters
    ----------
    box : xarray.Dataset
        u [m/s] on dims ("x", "y", "z") with uniform coordinates [m].
    rotor : RotorDisc
    hub_y, hub_z : float
        Hub position in the box's coordinates [m].
    x : float
        Position of the rotor plane in the box's coordinates [m].
    times : array_like
        Times [s].
    U : float
        Mean speed [m/s], > 0.

    Returns
    -------
    rews_t : ndarray
        u_R(t) [m/s] (fluctuation; add U for the total).
    """
    U = check_real("U", U, lo=0.0, lo_open=True)
    x0 = check_real("x", x)
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or not np.all(np.isfinite(t)):
        raise ValueError("times must be a 1-D array of finite times [s]")
    u = box["u"].transpose("x", "y", "z")
    xc = np.asarray(box["x"].values, dtype=float)
    dx = float(xc[1] - xc[0])
    w = rotor_node_weights(rotor, box["y"].values, box["z"].values, hub_y, hub_z)
    # The REWS of every x plane first (one pass over the box), then interpolation in time.
    plane_x = np.tensordot(np.asarray(u.values, dtype=np.float64), w, axes=([1, 2], [0, 1]))
    pos = ((x0 - U * t) - xc[0]) / dx
    i0 = np.floor(pos).astype(np.int64)
    f = pos - i0
    n = plane_x.size
    return (1.0 - f) * plane_x[i0 % n] + f * plane_x[(i0 + 1) % n]


# --------------------------------------------------------------------------
# the lidar estimate and the preview
# --------------------------------------------------------------------------
def los_to_u(vlos, direction):
    """u from line-of-sight speeds assuming ``v = w = 0``: ``v_los / n_x`` [m/s].

    Parameters
    ----------
    vlos : array_like, shape (..., n_b) or (n_t,)
        Line-of-sight speeds [m/s], positive away from the lidar.
    direction : array_like, shape (n_b, 3) or (3,)
        Unit beam directions [-], broadcast against ``vlos``'s last axis.

    Returns
    -------
    u : ndarray
        [m/s]; exact for a uniform wind along x (any sign of n_x).
    """
    n = np.asarray(direction, dtype=float)
    nx = n[..., 0]
    if np.any(np.abs(nx) < 1e-6):
        raise ValueError("a beam with n_x = 0 (perpendicular to the mean wind) cannot estimate u; "
                         "allowed: |n_x| >= 1e-6")
    return np.asarray(vlos, dtype=float) / nx


def fit_uvw(los_e, direction_ec, group_e=None, *, valid_e=None):
    """Least-squares wind ``(u, v, w)`` from line-of-sight speeds, per group of estimates (e.g. revolutions).

    Solves ``los_e = direction_ec . (u, v, w)`` over each group's valid estimates
    (the homogeneous-flow reconstruction of a scan; exact for a uniform wind
    with directions the dwell-averaged ones the speeds were projected on).

    Parameters
    ----------
    los_e : array_like, shape (n_e,)
        Line-of-sight speeds [m/s], positive away from the lidar.
    direction_ec : array_like, shape (n_e, 3)
        Directions they refer to [-].
    group_e : array_like of int, shape (n_e,), optional
        Group of each estimate; default one group.
    valid_e : array_like of bool, optional
        Estimates to use; default the finite ones.

    Returns
    -------
    groups : ndarray of int, shape (n_g,)
    uvw_gc : ndarray, shape (n_g, 3)
        [m/s]; NaN for a group with fewer than 3 valid estimates or a
        singular geometry (condition number above 1e8).
    """
    los = np.asarray(los_e, dtype=float)
    n = np.asarray(direction_ec, dtype=float)
    if los.ndim != 1 or n.shape != (los.size, 3):
        raise ValueError(f"los_e must be 1-D and direction_ec of shape (n_e, 3), got {los.shape}, {n.shape}")
    g = np.zeros(los.size, dtype=np.int64) if group_e is None else np.asarray(group_e)
    if g.shape != los.shape:
        raise ValueError(f"group_e must have the shape of los_e, got {g.shape}")
    ok = np.isfinite(los) & np.all(np.isfinite(n), axis=1)
    if valid_e is not None:
        ok &= np.asarray(valid_e, dtype=bool)
    groups = np.unique(g)
    out = np.full((groups.size, 3), np.nan)
    for i, k in enumerate(groups):
        m = ok & (g == k)
        if m.sum() < 3:
            continue
        A = n[m]
        if np.linalg.cond(A) > 1e8:
            continue
        out[i] = np.linalg.lstsq(A, los[m], rcond=None)[0]
    return groups, out


def scan_average(u_t, n: int):
    """Trailing average over the last ``n`` samples (one scan) [same unit as ``u_t``].

    ``out[j] = mean(u_t[j - n + 1 .. j])``; the first ``n - 1`` values are
    NaN (no complete scan yet).
    """
    n = check_int("n", n, lo=1)
    u = np.asarray(u_t, dtype=float)
    if u.ndim != 1:
        raise ValueError(f"u_t must be 1-D, got shape {u.shape}")
    out = np.full(u.size, np.nan)
    if u.size >= n:
        c = np.concatenate([[0.0], np.cumsum(u)])
        out[n - 1:] = (c[n:] - c[:-n]) / n
    return out


def preview_time(distance, U: float):
    """Preview time ``T = d / U`` [s] of air ``distance`` d [m] upwind of the rotor (Taylor)."""
    U = check_real("U", U, lo=0.0, lo_open=True)
    d = np.asarray(distance, dtype=float)
    if np.any(d < 0) or not np.all(np.isfinite(d)):
        raise ValueError("distance must be finite and >= 0 m (upwind of the rotor)")
    return d / U if d.ndim else float(d) / U


def align_preview(rotor_t, lidar_t, dt: float, preview: float):
    """Pair the lidar estimate with the REWS it previews.

    Parameters
    ----------
    rotor_t, lidar_t : array_like, shape (n,)
        REWS and lidar estimate sampled together at step dt.
    dt : float
        Sample step [s], > 0.
    preview : float
        Preview time T [s], >= 0 (:func:`preview_time`).

    Returns
    -------
    rotor_seg, lidar_seg : ndarray
        ``rotor_t[j + m]`` and ``lidar_t[j]`` for the overlap, with
        ``m = round(T / dt)`` samples: the lidar's sample j previews the
        REWS m samples later.
    residual : float
        ``T - m dt`` [s], the part of the preview not applied (a phase
        ``exp(2 pi i f residual)`` in the cross-spectrum, no change to the
        coherence's magnitude).
    """
    dt = check_real("dt", dt, lo=0.0, lo_open=True)
    preview = check_real("preview", preview, lo=0.0)
    r = np.asarray(rotor_t, dtype=float)
    li = np.asarray(lidar_t, dtype=float)
    if r.shape != li.shape or r.ndim != 1:
        raise ValueError(f"rotor_t and lidar_t must be 1-D of one length, got {r.shape} and {li.shape}")
    m = int(round(preview / dt))
    if m >= r.size:
        raise ValueError(f"preview {preview} s is {m} samples, not shorter than the series ({r.size} samples)")
    return r[m:], li[: r.size - m], preview - m * dt


# --------------------------------------------------------------------------
# coherence
# --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class CoherenceEstimate:
    """Segment-averaged spectra of the REWS (R) and the lidar estimate (L) and their coherence.

    Attributes
    ----------
    f_f : ndarray
        Frequencies [Hz] (bin centres when binned).
    k_f : ndarray
        Wavenumbers ``2 pi f / U`` [rad/m].
    rotor_f, lidar_f : ndarray
        One-sided PSDs of R and L [m^2 s^-2 / Hz].
    cross_f : ndarray, complex
        One-sided cross-spectrum ``E[X_R X_L^*]`` [m^2 s^-2 / Hz].
    coherence_f : ndarray
        Magnitude-squared coherence ``|cross|^2 / (rotor lidar)`` [-].
    n_dof_f : ndarray
        Effective number of independent periodogram ordinates averaged per
        value (:func:`effective_averages`: segments times the bin's
        frequencies, less for a taper, whose neighbouring ordinates are
        correlated).
    lower_f, upper_f : ndarray
        Confidence interval of the coherence (:func:`coherence_interval`).
    confidence : float
        Its confidence level.
    """

    f_f: np.ndarray
    k_f: np.ndarray
    rotor_f: np.ndarray
    lidar_f: np.ndarray
    cross_f: np.ndarray
    coherence_f: np.ndarray
    n_dof_f: np.ndarray
    lower_f: np.ndarray
    upper_f: np.ndarray
    confidence: float

    @property
    def gain_f(self) -> np.ndarray:
        """Wiener preview filter's gain ``|cross| / lidar`` [-]."""
        return wiener_gain(self.cross_f, self.lidar_f)


def coherence_interval(coherence, n_dof, confidence: float = 0.95):
    """Confidence interval of a segment-averaged magnitude-squared coherence.

    Fisher's transformation of the coherence's modulus (Enochson & Goodman
    1965; Bendat & Piersol, Random Data, sec. 9.2.3): ``atanh(|gamma|)`` is
    nearly normal with mean ``atanh(|gamma|) + 1 / (2 (n - 1))`` and variance
    ``1 / (2 (n - 1))`` for ``n`` independent averages; the interval is
    transformed back and squared.  Good for n >= 8 or so and ``gamma^2``
    away from 0.

    Parameters
    ----------
    coherence : array_like
        Estimated ``gamma^2`` [-], in [0, 1].
    n_dof : array_like
        Independent averages n, > 1 (effective, :func:`effective_averages`).
    confidence : float
        Two-sided level, in (0, 1).

    Returns
    -------
    lower, upper : ndarray
        Bounds of ``gamma^2`` [-].
    """
    from scipy.special import ndtri  # the normal quantile; scipy.stats is slow to import

    confidence = check_real("confidence", confidence, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    g2 = np.clip(np.asarray(coherence, dtype=float), 0.0, 1.0)
    n = np.asarray(n_dof, dtype=float)
    if np.any(n <= 1):
        raise ValueError("n_dof must be > 1 independent average (effective averages may be fractional)")
    zq = float(ndtri(0.5 + 0.5 * confidence))
    s = 1.0 / np.sqrt(2.0 * (n - 1.0))
    with np.errstate(divide="ignore"):
        z = np.arctanh(np.sqrt(np.minimum(g2, 1.0 - 1e-15))) - s * s
    lo = np.tanh(np.maximum(z - zq * s, 0.0)) ** 2
    hi = np.tanh(np.maximum(z + zq * s, 0.0)) ** 2
    return lo, hi


def effective_averages(count, n_per: int, window: str = "none"):
    """Effective number of independent ordinates in the mean of ``count`` consecutive periodogram ordinates [-].

    A taper correlates neighbouring DFT ordinates: for a white (or locally
    smooth) spectrum the complex correlation at a lag of l ordinates is
    ``rho_l = sum_n w_n^2 exp(-2 pi i l n / N) / sum_n w_n^2`` (the
    periodic Hann window: ``rho_1 = -2/3``, ``rho_2 = 1/6``, 0 beyond), and
    the mean of m consecutive ordinates has the variance of
    ``m^2 / sum_(i, i') |rho_(i - i')|^2`` independent ones (about ``m / 1.94``
    for large m with Hann; m without a taper).  Fisher's interval of the
    coherence (:func:`coherence_interval`) takes this number, times the
    segments.

    Parameters
    ----------
    count : array_like of int
        Consecutive ordinates averaged per value, >= 1 (0 gives 0).
    n_per : int
        Samples per segment, >= 2.
    window : {"none", "hann"}

    Returns
    -------
    ndarray
        Effective averages [-] per value, ``<= count``.
    """
    n_per = check_int("n_per", n_per, lo=2)
    check_choice("window", window, ("none", "hann"))
    m = np.asarray(count, dtype=float)
    if np.any(m < 0) or not np.all(np.isfinite(m)):
        raise ValueError("count must be finite and >= 0")
    if window == "none":
        return m
    w2 = (0.5 - 0.5 * np.cos(2.0 * math.pi * np.arange(n_per) / n_per)) ** 2
    lags = np.arange(min(int(m.max(initial=1.0)), n_per // 2) + 1)
    rho2 = np.abs(np.exp(-2j * math.pi * np.outer(lags, np.arange(n_per)) / n_per) @ w2 / w2.sum()) ** 2
    out = np.zeros(m.shape)
    for v in np.unique(m[m > 0]):
        ll = lags[lags < v]
        out[m == v] = v * v / (v + 2.0 * np.sum((v - ll[1:]) * rho2[ll[1:]]))
    return out


def coherence_estimate(rotor_t, lidar_t, *, fs: float, U: float, segment_duration: float = 600.0,
                       f_edges=None, window: str = "none", confidence: float = 0.95) -> CoherenceEstimate:
    """Spectra and coherence of the REWS and its (preview-aligned) lidar estimate.

    Parameters
    ----------
    rotor_t, lidar_t : array_like, shape (n,)
        REWS and lidar estimate [m/s] at rate ``fs``, already aligned by the
        preview (:func:`align_preview`); NaN marks a gap (handled as in
        :func:`~cwlidar_sim.analysis.segment_spectra`).
    fs : float
        Sampling rate [Hz].
    U : float
        Mean speed [m/s] for ``k = 2 pi f / U``.
    segment_duration : float
        Segment length [s]; the frequency resolution is its inverse.
    f_edges : array_like, optional
        Frequency bin edges [Hz]: spectra are averaged in the bins before the
        coherence is formed (more averages per value, coarser resolution).
    window : {"none", "hann"}
    confidence : float
        Level of the interval (:func:`coherence_interval`).

    Returns
    -------
    CoherenceEstimate

    Notes
    -----
    Without gaps and ``f_edges``, ``coherence_f`` is
    ``scipy.signal.coherence`` (``nperseg`` the segment, ``noverlap = 0``,
    boxcar or Hann) to round-off, f = 0 left out; the interval and the gap
    handling are this function's own.
    """
    from .spectra import bin_average, segment_spectra

    U = check_real("U", U, lo=0.0, lo_open=True)
    ss = segment_spectra(rotor_t, lidar_t, fs=fs, segment_duration=segment_duration, window=window)
    f, srr, sll, srl = ss.f_f, ss.psd_xf, ss.psd_yf, ss.csd_f
    count = np.ones(f.size, dtype=int)
    if f_edges is not None:
        (srr, sll, srl), count = _bin_all(bin_average, f, (srr, sll, srl), f_edges)
        keep = count > 0
        lo, hi = np.asarray(f_edges, dtype=float)[:-1], np.asarray(f_edges, dtype=float)[1:]
        f = np.sqrt(lo * hi)[keep]
        srr, sll, srl, count = srr[keep], sll[keep], srl[keep], count[keep]
    g2 = np.abs(srl) ** 2 / (srr * sll)
    n = effective_averages(count, ss.n_per, window) * ss.n_segments
    if np.any(n <= 1):
        raise ValueError(f"only {ss.n_segments} segment(s): the coherence of one average is 1; allowed: "
                         "at least 2 segments, or frequency bins holding several frequencies")
    lo, hi = coherence_interval(g2, n, confidence)
    return CoherenceEstimate(f_f=f, k_f=2.0 * math.pi * f / U, rotor_f=srr, lidar_f=sll, cross_f=srl,
                             coherence_f=g2, n_dof_f=n, lower_f=lo, upper_f=hi, confidence=confidence)


def _bin_all(bin_average, f, arrays, edges):
    out = []
    count = None
    for a in arrays:
        m, count = bin_average(f, a, edges)
        out.append(m)
    return out, count


def coherence_bandwidth(k, coherence, level: float = 0.5) -> float:
    """The wavenumber where the coherence first falls to ``level`` [rad/m] (the usual figure of merit).

    Linear interpolation in ``log k`` between the last value above and the
    first below ``level``, scanning from low k.  NaN if the coherence starts
    below ``level`` or never falls to it.
    """
    level = check_real("level", level, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    k = np.asarray(k, dtype=float)
    g = np.asarray(coherence, dtype=float)
    if k.shape != g.shape or k.ndim != 1 or np.any(k <= 0) or np.any(np.diff(k) <= 0):
        raise ValueError("k must be increasing positive wavenumbers [rad/m], of the coherence's shape")
    below = np.nonzero(g < level)[0]
    if below.size == 0 or below[0] == 0:
        return math.nan
    j = below[0]
    a, b = g[j - 1], g[j]
    t = (a - level) / (a - b)
    return float(math.exp(math.log(k[j - 1]) + t * (math.log(k[j]) - math.log(k[j - 1]))))


def wiener_gain(cross, lidar_psd):
    """Gain of the optimal (Wiener) preview filter, ``|G| = |S_RL| / S_LL`` [-].

    The filter ``G = S_RL / S_LL`` applied to the lidar estimate gives the
    least-squares estimate of the REWS; ``|G|^2 = gamma^2 S_RR / S_LL``.
    """
    c = np.asarray(cross)
    s = np.asarray(lidar_psd, dtype=float)
    if np.any(s <= 0):
        raise ValueError("lidar_psd must be > 0")
    return np.abs(c) / s
