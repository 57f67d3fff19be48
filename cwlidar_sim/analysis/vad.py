"""Rectified-cosine (VAD) fit of a conical scan, the turbulence parameter and radial variances (CS section 2-3).

Model
-----
A homodyne conical lidar measures ``|v_r(theta)|`` with
``v_r = A cos(theta - theta_w) + B``, ``A = U sin Phi``, ``B = w cos Phi``
(:mod:`cwlidar_sim.sensors.conical`): ``theta_w`` is the azimuth *toward*
which the horizontal wind blows, in the field frame (from +x toward +y; 0 for
the simulator's mean wind), ``U`` the horizontal speed and ``w`` the
vertical speed.  :func:`fit_rectified_cosine` minimises
``sum_p (y_p - |a cos theta_p + b sin theta_p + c|)^2`` over the valid points
of each scan: for a fixed sign pattern ``s_p`` the problem is the linear
least squares ``s_p y_p ~ a cos theta_p + b sin theta_p + c``; starting from
12 trial directions (and the all-positive pattern), the signs are updated
from the fit until they no longer change (a local minimum of the piecewise
problem), and the best trial is kept.  A uniform flow is recovered exactly
(to rounding) whatever its direction.

Ambiguity
---------
``(a, b, c)`` and ``(-a, -b, -c)`` fit equally well: direction ``theta_w``
with ``w`` and ``theta_w + 180`` with ``-w``.  The fit picks the solution
whose direction lies within 90 deg of a reference -- a wind vane's direction
per scan, or, where none is given (NaN) and ``use_previous``, the previous
resolved scan's direction -- and flags a scan :attr:`VadFlag.UNRESOLVED`
where there is no reference or the direction is within ``ambiguity_margin_deg``
of perpendicular to it (then it keeps the solution with ``|direction| < 90``).

Turbulence parameter (CS Eq. 8)
-------------------------------
``TP = sqrt(<v_r'^2>) / U`` with ``v_r'`` the residual of the radial speeds
from the scan's fit, over one revolution (1 s scans) or three (3 s); the
radial variance is ``(TP U)^2 = <v_r'^2>``, here
``sum_p r_p^2 / (n_used - 3)`` (three fitted parameters), so that white
estimator noise of variance s^2 gives ``(TP U)^2 = s^2`` on average.

Sonic-equivalent radial variance (our definition; CS's appendix is not available)
----------------------------------------------------------------------------------
:func:`sonic_radial_variance`: the variance over the period of the point
sonic's fluctuation projected on the rotating beam,
``var_e( n(theta_e) . (u_s(t_e) - <u_s>) )`` at the lidar's estimate times
and azimuths; over whole revolutions it equals
``sin^2 Phi (sigma_u^2 + sigma_v^2) / 2 + cos^2 Phi sigma_w^2`` (plus a
vanishing ``sin 2 Phi <u'w'> <cos theta>``): the radial variance a
volume-free, instantaneous probe would see.  The ratio
``<(TP U)^2> / sonic_radial_variance`` is then the fraction of the radial
variance that lies between the probe length and the scan's length scale,
which is what :func:`cwlidar_sim.analysis.cs_model.radial_variance_ratio`
models.  ``scan=True`` instead fits the folded projected sonic series
scan by scan and returns its mean residual variance (what TP would be for
a point sensor: only the fluctuations within a scan's duration).
"""

from __future__ import annotations

import dataclasses
import enum
import math

import numpy as np

from .._repr import summary_repr
from .._validation import check_int, check_real

__all__ = [
    "VadFlag",
    "VadFit",
    "fit_rectified_cosine",
    "fit_record",
    "scan_arrays",
    "sonic_radial_variance",
    "period_statistics",
    "ambiguity_rate",
]


class VadFlag(enum.IntFlag):
    """Quality flags of a scan's fit (uint8 bits)."""

    #: Fewer valid points than ``min_points``: every output is NaN.
    FAILED = 1
    #: The 180 deg ambiguity could not be resolved (no reference, or the wind is
    #: perpendicular to it within the margin).
    UNRESOLVED = 2
    #: Resolved by the previous scan's direction (no reference of its own).
    FROM_PREVIOUS = 4


def _excluded_default():
    from ..signal.processing import Flag

    return int(Flag.NO_SIGNAL | Flag.NEAR_ZERO | Flag.NEAR_NYQUIST | Flag.SECOND_PEAK | Flag.FIT_FAILED |
               Flag.PAUSED)


@dataclasses.dataclass(frozen=True)
class VadFit:
    """Fits of a set of scans (one entry per scan).

    Attributes
    ----------
    speed_p : ndarray
        Horizontal speed U = A / sin Phi [m/s].
    direction_p : ndarray
        Azimuth toward which the wind blows [deg], in (-180, 180], from +x toward +y.
    w_p : ndarray
        Vertical speed B / cos Phi [m/s].
    amplitude_p, offset_p : ndarray
        A [m/s] (>= 0) and B [m/s] of the fitted rectified cosine.
    residual_var_p : ndarray
        ``sum r^2 / (n_used - 3)`` [m^2/s^2]: the radial variance (TP U)^2.
    tp_p : ndarray
        Turbulence parameter sqrt(residual_var) / U [-] (CS Eq. 8).
    n_used_p : ndarray of int
        Points used.
    n_points : int
        Points per scan (the maximum possible).
    flags_p : ndarray of uint8
        :class:`VadFlag` bits.
    """

    __repr__ = summary_repr

    speed_p: np.ndarray
    direction_p: np.ndarray
    w_p: np.ndarray
    amplitude_p: np.ndarray
    offset_p: np.ndarray
    residual_var_p: np.ndarray
    tp_p: np.ndarray
    n_used_p: np.ndarray
    n_points: int
    flags_p: np.ndarray

    @property
    def n(self) -> int:
        """Number of scans."""
        return int(self.speed_p.size)

    @property
    def availability(self) -> float:
        """Fraction of scans with a fit [-]."""
        return float(np.mean(np.isfinite(self.speed_p))) if self.n else float("nan")

    @property
    def unresolved_rate(self) -> float:
        """Fraction of fitted scans whose 180 deg ambiguity stayed unresolved [-]."""
        ok = np.isfinite(self.speed_p)
        if not ok.any():
            return float("nan")
        return float(np.mean((self.flags_p[ok] & VadFlag.UNRESOLVED) != 0))


def _as_2d(name, a):
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] < 1:
        raise ValueError(f"{name} must have shape (n_scans, n_points) or (n_points,), got {np.shape(a)}")
    return arr


def _normal_matrix(cos_p, sin_p, m_p):
    """The weighted design (cos, sin, 1) m and its normal matrix, batched over scans: (Xw, G, singular mask).

    They do not depend on the signs, so a fit's sign iterations share them.
    """
    X = np.stack([cos_p, sin_p, np.ones_like(cos_p)], axis=-1)  # (n, p, 3)
    Xw = X * m_p[..., None]
    G = np.einsum("npi,npj->nij", Xw, X)
    det = np.linalg.det(G)
    scale = np.einsum("nii->n", G) ** 3 + 1e-300
    bad = ~(np.abs(det) > 1e-12 * scale)
    G[bad] = np.eye(3)
    return Xw, G, bad


def _solve(normal, y_p, s_p, rows=None):
    """Weighted linear least squares of s y on (cos, sin, 1) (``normal``: :func:`_normal_matrix`): (n, 3).

    ``rows``: only those scans (each scan's fit is its own; the batch does not change its bits).
    """
    Xw, G, _ = normal
    if rows is not None:
        Xw, G, y_p, s_p = Xw[rows], G[rows], y_p[rows], s_p[rows]
    r = np.einsum("npi,np->ni", Xw, s_p * y_p)
    return np.linalg.solve(G, r[..., None])[..., 0]


def fit_rectified_cosine(azimuth_deg, speed, half_angle_deg: float = 30.0, *, valid=None, reference_deg=None,
                         use_previous: bool = True, min_points: int = 6, ambiguity_margin_deg: float = 5.0,
                         max_iter: int = 30) -> VadFit:
    """Fit ``|A cos(theta - theta_w) + B|`` to the folded radial speeds of each scan (module notes).

    Parameters
    ----------
    azimuth_deg : array_like, shape (n_scans, n_points) or (n_points,)
        Beam azimuths [deg] (e.g. each dwell's mid-azimuth).
    speed : array_like, same shape
        Measured |v_r| [m/s]; NaN points are left out.
    half_angle_deg : float
        Cone half-angle Phi [deg]; in (0, 90).
    valid : array_like of bool, same shape, optional
        False leaves a point out (e.g. flagged estimates, :func:`fit_record`).
    reference_deg : float or array_like (n_scans,), optional
        Reference direction toward which the wind blows [deg] (a vane), per
        scan or one for all; NaN entries have none.
    use_previous : bool
        Resolve a scan without a reference by the previous resolved scan.
    min_points : int
        Fewest valid points for a fit; in [3, n_points].
    ambiguity_margin_deg : float
        A direction within this of perpendicular to its reference is left
        unresolved [deg]; in [0, 90).
    max_iter : int
        Sign-update iterations per trial; in [1, 1000].

    Returns
    -------
    VadFit
    """
    az = _as_2d("azimuth_deg", azimuth_deg)
    y = _as_2d("speed", speed)
    if y.shape != az.shape:
        raise ValueError(f"speed has shape {y.shape}, azimuth_deg {az.shape}; they must match")
    if not np.all(np.isfinite(az)):
        raise ValueError("azimuth_deg must be finite")
    phi = math.radians(check_real("half_angle_deg", half_angle_deg, lo=0.0, hi=90.0, lo_open=True, hi_open=True))
    n_s, n_p = y.shape
    min_points = check_int("min_points", min_points, lo=3, hi=max(3, n_p))
    margin = check_real("ambiguity_margin_deg", ambiguity_margin_deg, lo=0.0, hi=90.0, hi_open=True)
    max_iter = check_int("max_iter", max_iter, lo=1, hi=1000)
    m = np.isfinite(y)
    if valid is not None:
        v = np.asarray(valid)
        if v.dtype != bool:
            raise TypeError(f"valid must be a bool array, got dtype {v.dtype}")
        v = v.reshape(1, -1) if v.ndim == 1 else v
        if v.shape != y.shape:
            raise ValueError(f"valid has shape {v.shape}; it must match speed {y.shape}")
        m &= v
    if np.any(y[m] < 0):
        raise ValueError("speed must be >= 0 (folded radial speeds) where valid")
    if reference_deg is None:
        ref = np.full(n_s, np.nan)
    else:
        ref = np.broadcast_to(np.asarray(reference_deg, dtype=np.float64), (n_s,)).copy()
    yz = np.where(m, y, 0.0)
    mw = m.astype(np.float64)
    th = np.radians(az)
    c_p, s_p = np.cos(th), np.sin(th)
    n_used = m.sum(axis=1)
    best_sse = np.full(n_s, np.inf)
    best = np.full((n_s, 3), np.nan)
    trials = [None] + list(np.radians(np.arange(12) * 15.0))
    normal = _normal_matrix(c_p, s_p, mw)
    bad = normal[2]
    for t0 in trials:
        sign = np.ones_like(yz) if t0 is None else np.where(np.cos(th - t0) >= 0.0, 1.0, -1.0)
        act = np.arange(n_s)  # the scans whose signs still change (the others' fits would repeat)
        for _ in range(max_iter):
            q = _solve(normal, yz, sign, act)
            ca, sa = c_p[act], s_p[act]
            lin = q[:, 0:1] * ca + q[:, 1:2] * sa + q[:, 2:3]
            new = np.where(lin >= 0.0, 1.0, -1.0)
            changed = np.any((new != sign[act]) & m[act], axis=1)
            sign[act] = new
            act = act[changed]
            if not act.size:
                break
        p = _solve(normal, yz, sign)
        lin = p[:, 0:1] * c_p + p[:, 1:2] * s_p + p[:, 2:3]
        sse = np.sum(mw * (yz - np.abs(lin)) ** 2, axis=1)
        sse[bad] = np.inf
        take = sse < best_sse * (1 - 1e-12) - 1e-300
        best_sse = np.where(take, sse, best_sse)
        best[take] = p[take]
    failed = (n_used < min_points) | ~np.isfinite(best_sse)
    a, b, c = best[:, 0], best[:, 1], best[:, 2]
    A = np.hypot(a, b)
    dirn = np.degrees(np.arctan2(b, a))
    flags = np.zeros(n_s, dtype=np.uint8)
    prev = np.nan
    for i in range(n_s):
        if failed[i]:
            continue
        r = ref[i]
        from_prev = False
        if not np.isfinite(r) and use_previous and np.isfinite(prev):
            r, from_prev = prev, True
        if np.isfinite(r):
            d = math.degrees(math.acos(max(-1.0, min(1.0, math.cos(math.radians(dirn[i] - r))))))
            if abs(d - 90.0) <= margin:
                flags[i] |= VadFlag.UNRESOLVED
                flip = abs(_wrap180(dirn[i])) > 90.0
            else:
                flip = d > 90.0
                if from_prev:
                    flags[i] |= VadFlag.FROM_PREVIOUS
        else:
            flags[i] |= VadFlag.UNRESOLVED
            flip = abs(_wrap180(dirn[i])) > 90.0
        if flip:
            dirn[i] += 180.0
            c[i] = -c[i]
        dirn[i] = _wrap180(dirn[i])
        if not flags[i] & VadFlag.UNRESOLVED:
            prev = dirn[i]
    dof = np.maximum(n_used - 3, 1)
    resid = best_sse / dof
    nanf = np.where(failed, np.nan, 1.0)
    flags[failed] = VadFlag.FAILED
    U = A / math.sin(phi) * nanf
    with np.errstate(divide="ignore", invalid="ignore"):
        tp = np.sqrt(resid) / U
    return VadFit(speed_p=U, direction_p=dirn * nanf, w_p=c / math.cos(phi) * nanf, amplitude_p=A * nanf,
                  offset_p=c * nanf, residual_var_p=resid * nanf, tp_p=tp * nanf, n_used_p=n_used.astype(np.int64),
                  n_points=n_p, flags_p=flags)


def _wrap180(d):
    return (d + 180.0) % 360.0 - 180.0 if ((d + 180.0) % 360.0) != 0.0 else 180.0


def scan_arrays(x_e, revolution_e, n_rev: int):
    """Group per-estimate values into scans of ``n_rev`` consecutive revolutions, shape (n_scans, n_points).

    Parameters
    ----------
    x_e : array_like, shape (n_e,)
    revolution_e : array_like of int, shape (n_e,)
        Revolution number of each estimate (:class:`cwlidar_sim.sensors.conical.ScanSchedule`);
        every revolution must hold the same number of estimates.
    n_rev : int
        Revolutions per scan (1: 1 s scans, 3: 3 s scans); >= 1.  Incomplete
        trailing scans are dropped.
    """
    n_rev = check_int("n_rev", n_rev, lo=1)
    x = np.asarray(x_e)
    rev = np.asarray(revolution_e)
    if x.shape != rev.shape or x.ndim != 1:
        raise ValueError(f"x_e {x.shape} and revolution_e {rev.shape} must be 1-D of one length")
    u, cnt = np.unique(rev, return_counts=True)
    if cnt.size and np.any(cnt != cnt[0]):
        raise ValueError("every revolution must hold the same number of estimates")
    if cnt.size == 0:
        return x.reshape(0, 0)
    per = int(cnt[0])
    n_scans = u.size // n_rev
    order = np.argsort(rev, kind="stable")
    return x[order][: n_scans * n_rev * per].reshape(n_scans, n_rev * per)


def fit_record(record, height: float, n_rev: int, *, half_angle_deg: float = 30.0, reference_deg=None,
               excluded_flags: int | None = None, **kw) -> VadFit:
    """VAD fits of a conical lidar's :class:`~cwlidar_sim.sensors.LidarRecord` at one height, ``n_rev`` revolutions per scan.

    Points with NaN speed or any of ``excluded_flags`` (default: NO_SIGNAL,
    NEAR_ZERO, NEAR_NYQUIST, SECOND_PEAK, FIT_FAILED, PAUSED) are left out.
    ``reference_deg`` per scan or scalar; ``kw`` go to :func:`fit_rectified_cosine`.
    """
    sel = record.select(height)
    excl = _excluded_default() if excluded_flags is None else check_int("excluded_flags", excluded_flags, lo=0,
                                                                       hi=255)
    az = scan_arrays(sel["azimuth_e"], sel["revolution_e"], n_rev)
    sp = scan_arrays(sel["speed_e"], sel["revolution_e"], n_rev)
    fl = scan_arrays(sel["flags_e"], sel["revolution_e"], n_rev)
    return fit_rectified_cosine(az, sp, half_angle_deg, valid=(fl & excl) == 0, reference_deg=reference_deg, **kw)


def sonic_radial_variance(vel_ec, azimuth_e, half_angle_deg: float = 30.0, *, scan: bool = False,
                          revolution_e=None, n_rev: int = 1) -> float:
    """Sonic-equivalent radial variance [m^2/s^2] (module notes).

    Parameters
    ----------
    vel_ec : array_like, shape (n_e, 3)
        Total wind (U + u, v, w) at the sonic, sampled at the lidar's estimate times [m/s].
    azimuth_e : array_like, shape (n_e,)
        The lidar's azimuth at those times [deg].
    half_angle_deg : float
    scan : bool
        False: the period variance of the projected fluctuation.  True: the
        mean residual variance of the VAD fits of the folded projected series
        (needs ``revolution_e`` and ``n_rev``).
    """
    vel = np.asarray(vel_ec, dtype=np.float64)
    az = np.radians(np.asarray(azimuth_e, dtype=np.float64))
    if vel.ndim != 2 or vel.shape[1] != 3 or vel.shape[0] != az.size:
        raise ValueError(f"vel_ec must have shape (n_e, 3) with n_e = len(azimuth_e) = {az.size}, got {vel.shape}")
    phi = math.radians(check_real("half_angle_deg", half_angle_deg, lo=0.0, hi=90.0, lo_open=True, hi_open=True))
    n = np.stack([math.sin(phi) * np.cos(az), math.sin(phi) * np.sin(az), np.full(az.shape, math.cos(phi))], 1)
    if not scan:
        fl = vel - vel.mean(axis=0)
        return float(np.var(np.sum(n * fl, axis=1)))
    if revolution_e is None:
        raise ValueError("scan=True needs revolution_e")
    vr = np.abs(np.sum(n * vel, axis=1))
    fit = fit_rectified_cosine(scan_arrays(np.degrees(az), revolution_e, n_rev), scan_arrays(vr, revolution_e, n_rev),
                               half_angle_deg)
    return float(np.nanmean(fit.residual_var_p))


def period_statistics(fit: VadFit, *, min_used_fraction: float = 0.65) -> dict:
    """Statistics of a period's scans (CS: 10 minutes), and CS's selection.

    Returns
    -------
    dict
        ``mean_speed``, ``std_speed`` (ddof=1 over fitted scans) [m/s],
        ``mean_direction`` [deg], ``mean_w`` [m/s], ``mean_tp``,
        ``radial_variance`` (mean of (TP U)^2) [m^2/s^2], ``n_scans``,
        ``n_fitted``, ``availability``, ``mean_points_used_fraction``
        (mean n_used / n_points over all scans), ``selected`` (CS: that
        fraction >= ``min_used_fraction``), ``unresolved_rate``.
    """
    f = check_real("min_used_fraction", min_used_fraction, lo=0.0, hi=1.0)
    ok = np.isfinite(fit.speed_p)
    used = float(np.mean(fit.n_used_p / fit.n_points)) if fit.n else float("nan")
    sp = fit.speed_p[ok]
    d = np.radians(fit.direction_p[ok])
    return {
        "mean_speed": float(sp.mean()) if sp.size else float("nan"),
        "std_speed": float(sp.std(ddof=1)) if sp.size > 1 else float("nan"),
        "mean_direction": float(np.degrees(np.arctan2(np.sin(d).mean(), np.cos(d).mean()))) if sp.size else
        float("nan"),
        "mean_w": float(fit.w_p[ok].mean()) if sp.size else float("nan"),
        "mean_tp": float(fit.tp_p[ok].mean()) if sp.size else float("nan"),
        "radial_variance": float(fit.residual_var_p[ok].mean()) if sp.size else float("nan"),
        "n_scans": fit.n,
        "n_fitted": int(ok.sum()),
        "availability": fit.availability,
        "mean_points_used_fraction": used,
        "selected": bool(used >= f),
        "unresolved_rate": fit.unresolved_rate,
    }


def ambiguity_rate(direction_p, true_direction_p) -> float:
    """Fraction of scans whose resolved direction lies more than 90 deg from the true one [-].

    Parameters
    ----------
    direction_p : array_like, shape (n_scans,)
        The fits' directions [deg] (NaN: not fitted, left out).
    true_direction_p : array_like, shape (n_scans,)
        The true (e.g. the sonic's) direction over each scan [deg].

    Returns
    -------
    float
        NaN where no scan was fitted.  Angles are compared on the circle
        (179 deg and -179 deg are 2 deg apart).
    """
    d = np.asarray(direction_p, dtype=np.float64)
    t = np.asarray(true_direction_p, dtype=np.float64)
    if d.shape != t.shape or d.ndim != 1:
        raise ValueError(f"direction_p {d.shape} and true_direction_p {t.shape} must be 1-D of one length")
    ok = np.isfinite(d) & np.isfinite(t)
    if not ok.any():
        return float("nan")
    dd = np.abs((d[ok] - t[ok] + 180.0) % 360.0 - 180.0)
    return float(np.mean(dd > 90.0))
