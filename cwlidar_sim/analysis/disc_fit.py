"""The inflow over a rotor disc from a scanning lidar's line-of-sight speeds: a linear wind field, fitted (pure functions).

A lidar on the rotor axis that sweeps the disc at one focus distance (DTU's
SpinnerLidar, :mod:`cwlidar_sim.sensors.spinner`; a nacelle lidar's circle)
measures each estimate at a point ``p = r n`` (its direction n in the
nacelle frame, relative to the lidar; ``y = r n_y``, ``z = r n_z``).  Over a
rosette the wind is taken as linear across the disc:

``u = u0 + (du/dy) y + (du/dz) z``,  ``v = v0 + (dv/dz) z``,  ``w = w0``

(u along the rotor axis downwind, v to the left, w up: the nacelle frame of
:mod:`cwlidar_sim.sensors.nacelle`), and ``v_los = n . (u, v, w)`` is linear
in the six parameters.  An estimate that averages looks over its dwell is
the average of the looks' rows (``direction_elc``), so a tier-1 record of a
linear field is fitted exactly with a point weighting (a probe volume
averages along the beam too: then the fit is exact to the weighting's first
moment along n, and the tail rule's mean wind, :mod:`cwlidar_sim.beam.cells`,
sees no shear).

Products of one fit (:class:`DiscFit`):

* REWS ``u0``: the disc average of u along the rotor axis, for any radially
  symmetric weight (:class:`cwlidar_sim.analysis.rews.RotorDisc`): the
  linear terms integrate to zero over a disc centred on the hub;
* horizontal speed ``S0 = |(u0, v0)|`` and yaw misalignment
  ``gamma = atan2(-v0, u0)`` (a wind along +x seen from a rotor yawed by
  gamma is ``(U cos gamma, -U sin gamma)``);
* vertical shear ``dS/dz = (u0 du/dz + v0 dv/dz) / S0`` [1/s], horizontal
  shear ``du/dy`` [1/s], veer ``d(direction)/dz = (u0 dv/dz - v0 du/dz) / S0^2``
  [deg/m] (the wind turning from +x toward +y with height: the field's
  direction atan2(v, u)); shear and veer do not depend on the yaw.

Conditioning: at one focus distance ``v0`` against ``du/dy`` (and ``w0``
against ``du/dz``) are told apart only through the spread of ``cos theta``
over the disc (the columns ``n_x y`` and ``n_y`` differ by the factor
``r cos theta``): the SpinnerLidar's rosette (0-30.4 deg) gives a condition
number of the scaled columns of 52-54 at any focus distance, with or
without ``w0`` (``DiscFit.condition_g``); without ``du/dy``
(``horizontal_shear = False``) and ``w0`` it is 1.4.  In turbulence the
lateral gradients of u then leak into ``v0``: in the bundled spinner scene
(tier 1, frozen, aligned) the yaw estimates of ten rosettes scattered over
-52..+21 deg with ``du/dy`` fitted and -3..+7 deg without.  So the yaw
misalignment is best taken from the fit without ``du/dy``
(:mod:`cwlidar_sim.campaign.periods.spinner` does).  ``w_zero = True`` drops
``w0`` (w = 0 assumed).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._repr import summary_repr
from .._validation import check_bool, check_int, check_real
from .rews import fit_uvw

__all__ = ["DISC_PARAMETERS", "disc_design", "DiscFit", "fit_disc"]

#: Names of the linear field's parameters, in the columns' order [m/s, 1/s, 1/s, m/s, 1/s, m/s].
DISC_PARAMETERS = ("u0", "dudy", "dudz", "v0", "dvdz", "w0")


def disc_design(direction_elc, focus: float) -> np.ndarray:
    """Rows of the linear field's least squares, one per estimate, averaged over its looks.

    Parameters
    ----------
    direction_elc : array_like, shape (n_e, n_l, 3) or (n_e, 3)
        Unit directions of each estimate's looks in the nacelle frame [-] (one look: (n_e, 3)).
    focus : float
        Focus distance [m], > 0.

    Returns
    -------
    design_ep : ndarray, shape (n_e, 6)
        ``mean_l [n_x, n_x y, n_x z, n_y, n_y z, n_z]`` with ``y = r n_y``,
        ``z = r n_z`` [-, m, m, -, m, -] (columns of :data:`DISC_PARAMETERS`).
    """
    n = np.asarray(direction_elc, dtype=np.float64)
    if n.ndim == 2:
        n = n[:, None, :]
    if n.ndim != 3 or n.shape[2] != 3:
        raise ValueError(f"direction_elc must have shape (n_e, n_l, 3) or (n_e, 3), got {np.shape(direction_elc)}")
    r = check_real("focus", focus, lo=0.0, lo_open=True)
    nx, ny, nz = n[..., 0], n[..., 1], n[..., 2]
    y, z = r * ny, r * nz
    return np.stack([nx, nx * y, nx * z, ny, ny * z, nz], axis=-1).mean(axis=1)


@dataclasses.dataclass(frozen=True)
class DiscFit:
    """The linear inflow fitted per group of estimates (module notes).

    Attributes
    ----------
    groups : ndarray of int, shape (n_g,)
    params_gp : ndarray, shape (n_g, 6)
        :data:`DISC_PARAMETERS` [m/s, 1/s, 1/s, m/s, 1/s, m/s]; NaN where the fit failed.
    uvw_gc : ndarray, shape (n_g, 3)
        The homogeneous fit's (u, v, w) of the same estimates
        (:func:`cwlidar_sim.analysis.rews.fit_uvw` on the looks' mean directions) [m/s].
    n_used_g : ndarray of int
        Estimates used.
    condition_g : ndarray
        Condition number of the columns scaled to unit norm [-].
    residual_rms_g : ndarray
        RMS of the line-of-sight residuals [m/s].
    """

    __repr__ = summary_repr

    groups: np.ndarray
    params_gp: np.ndarray
    uvw_gc: np.ndarray
    n_used_g: np.ndarray
    condition_g: np.ndarray
    residual_rms_g: np.ndarray

    def param(self, name: str) -> np.ndarray:
        """One parameter per group (a name of :data:`DISC_PARAMETERS`)."""
        if name not in DISC_PARAMETERS:
            raise ValueError(f"name={name!r} is not a parameter; allowed: {list(DISC_PARAMETERS)}")
        return self.params_gp[:, DISC_PARAMETERS.index(name)]

    @property
    def rews_g(self) -> np.ndarray:
        """Rotor-effective wind speed along the rotor axis, ``u0`` [m/s]."""
        return self.param("u0")

    @property
    def speed_g(self) -> np.ndarray:
        """Horizontal speed at the hub ``|(u0, v0)|`` [m/s]."""
        return np.hypot(self.param("u0"), self.param("v0"))

    @property
    def yaw_misalignment_g(self) -> np.ndarray:
        """Yaw of the rotor from the wind, ``atan2(-v0, u0)`` [deg]."""
        return np.degrees(np.arctan2(-self.param("v0"), self.param("u0")))

    @property
    def vertical_shear_g(self) -> np.ndarray:
        """``dS/dz`` of the horizontal speed at the hub [1/s]."""
        u0, v0 = self.param("u0"), self.param("v0")
        return (u0 * self.param("dudz") + v0 * self.param("dvdz")) / self.speed_g

    @property
    def horizontal_shear_g(self) -> np.ndarray:
        """``du/dy`` across the rotor [1/s]."""
        return self.param("dudy")

    @property
    def veer_g(self) -> np.ndarray:
        """Turning of the wind direction with height, from +x toward +y [deg/m]."""
        u0, v0 = self.param("u0"), self.param("v0")
        return np.degrees((u0 * self.param("dvdz") - v0 * self.param("dudz")) / self.speed_g**2)


def fit_disc(los_e, direction_elc, focus: float, group_e=None, *, valid_e=None, w_zero: bool = False,
             horizontal_shear: bool = True, min_estimates: int = 12, max_condition: float = 1e6) -> DiscFit:
    """Least-squares linear inflow over the disc per group of estimates (e.g. rosettes) (module notes).

    Parameters
    ----------
    los_e : array_like, shape (n_e,)
        Line-of-sight speeds [m/s], positive away from the lidar.
    direction_elc : array_like, shape (n_e, n_l, 3) or (n_e, 3)
        Each estimate's looks' known directions in the nacelle frame [-].
    focus : float
        Focus distance [m].
    group_e : array_like of int, optional
        Group of each estimate; default one group.
    valid_e : array_like of bool, optional
        Estimates to use; default the finite ones.
    w_zero : bool
        Assume w = 0 (``w0`` is then 0, not fitted).
    horizontal_shear : bool
        Fit ``du/dy``; False: leave it out of the model (``dudy`` NaN), which
        frees ``v0`` (and the yaw misalignment) from its near-degeneracy with
        it (module notes).
    min_estimates : int
        Fewest valid estimates for a fit; in [6, 10**7].
    max_condition : float
        A group whose scaled columns' condition number exceeds this is NaN; in [1, 1e12].

    Returns
    -------
    DiscFit
    """
    los = np.asarray(los_e, dtype=np.float64)
    A = disc_design(direction_elc, focus)
    if los.ndim != 1 or A.shape[0] != los.size:
        raise ValueError(f"los_e must be 1-D with one value per row of direction_elc, got {los.shape}, {A.shape}")
    g = np.zeros(los.size, dtype=np.int64) if group_e is None else np.asarray(group_e)
    if g.shape != los.shape:
        raise ValueError(f"group_e must have the shape of los_e, got {g.shape}")
    w_zero = check_bool("w_zero", w_zero)
    horizontal_shear = check_bool("horizontal_shear", horizontal_shear)
    min_estimates = check_int("min_estimates", min_estimates, lo=6, hi=10**7)
    max_condition = check_real("max_condition", max_condition, lo=1.0, hi=1e12)
    ok = np.isfinite(los) & np.all(np.isfinite(A), axis=1)
    if valid_e is not None:
        ok &= np.asarray(valid_e, dtype=bool)
    cols = np.array([c for c in range(6) if not (c == 5 and w_zero) and not (c == 1 and not horizontal_shear)])
    groups = np.unique(g)
    ng = groups.size
    params = np.full((ng, 6), np.nan)
    n_used = np.zeros(ng, dtype=np.int64)
    cond, rms = np.full(ng, np.nan), np.full(ng, np.nan)
    for i, k in enumerate(groups):
        m = ok & (g == k)
        n_used[i] = int(m.sum())
        if n_used[i] < min_estimates:
            continue
        a = A[m][:, cols]
        scale = np.linalg.norm(a, axis=0)
        if np.any(scale == 0.0):
            continue
        cond[i] = float(np.linalg.cond(a / scale))
        if cond[i] > max_condition:
            continue
        x = np.linalg.lstsq(a / scale, los[m], rcond=None)[0] / scale
        params[i, cols] = x
        if w_zero:
            params[i, 5] = 0.0
        rms[i] = float(np.sqrt(np.mean((a @ x - los[m]) ** 2)))
    mean_dir = np.asarray(direction_elc, dtype=np.float64)
    mean_dir = mean_dir.mean(axis=1) if mean_dir.ndim == 3 else mean_dir
    uvw = fit_uvw(los, mean_dir, g, valid_e=ok)[1]
    return DiscFit(groups=groups, params_gp=params, uvw_gc=uvw, n_used_g=n_used, condition_g=cond,
                   residual_rms_g=rms)
