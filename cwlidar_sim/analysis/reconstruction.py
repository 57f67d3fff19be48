"""The wind vector from three line-of-sight speeds at one point (a WindScanner's three beams meeting there).

Per time step k the three units' unit look directions are the rows of
``N_k`` (shape 3 x 3; row i the direction of unit i, from the unit toward
the focus) and their line-of-sight speeds ``v_k`` (positive away from the
unit, the chain's convention: ``v_i = n_i . (U + u, v, w)``).  The wind is
the solution of ``N_k u_k = v_k`` (``numpy.linalg.solve``, per k).

Conditioning
------------
``cond(N_k)``, the ratio of N's largest to smallest singular value (the
2-norm condition number, ``numpy.linalg.cond``), bounds how much a relative
error of the speeds grows in the wind: ``|du| / |u| <= cond(N) |dv| / |v|``.
Beams nearly in one plane (e.g. three low-elevation beams for w, or two
nearly parallel ones) make it large.  A step with ``cond(N_k) >
max_condition`` is *flagged* :attr:`ReconstructionFlag.ILL_CONDITIONED` and
its wind is NaN; it is counted and kept in the arrays, never dropped.

The homodyne sign
-----------------
A homodyne instrument reports ``|v_los|`` (the chain's ``speed_e``).  The
sign of each unit's speed is taken as that of the mean wind's projection on
its beam, ``sign(n_i . W)`` (:func:`homodyne_signs`, ``W`` the mean wind,
e.g. ``(U, 0, 0)``): right while the turbulence does not reverse the
line-of-sight speed, which the chain flags near 0
(:attr:`cwlidar_sim.signal.Flag.NEAR_ZERO`).  The three units' chain flags
are OR-ed into the step's flags (the low seven bits, as
:class:`cwlidar_sim.signal.Flag`), and a step with a unit's speed NaN has a
NaN wind.
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from .._repr import summary_repr
from .._validation import check_real

__all__ = ["ReconstructionFlag", "Reconstruction", "reconstruct_uvw", "homodyne_signs", "DEFAULT_MAX_CONDITION"]

#: Condition number of N above which a step is flagged ill-conditioned (the published layout's is 2.65).
DEFAULT_MAX_CONDITION = 10.0


class ReconstructionFlag(enum.IntFlag):
    """The reconstruction's own flag, above the chain's seven bits (:class:`cwlidar_sim.signal.Flag`)."""

    #: ``cond(N) > max_condition``: the wind is NaN.
    ILL_CONDITIONED = 128


@dataclasses.dataclass(frozen=True)
class Reconstruction:
    """The wind vector per step (:func:`reconstruct_uvw`).

    Attributes
    ----------
    uvw_kc : ndarray, shape (n_k, 3)
        (u, v, w) [m/s] in the frame of the directions; NaN where ill-conditioned or a speed is NaN.
    condition_k : ndarray, shape (n_k,)
        ``cond(N_k)`` [-] (2-norm).
    flags_k : ndarray of uint8, shape (n_k,)
        The units' chain flags OR-ed, and :attr:`ReconstructionFlag.ILL_CONDITIONED`.
    n_ill_conditioned : int
        Steps flagged ill-conditioned.
    n_missing : int
        Steps with a unit's speed NaN (not ill-conditioned).
    max_condition : float
        The threshold used.
    """

    __repr__ = summary_repr

    uvw_kc: np.ndarray
    condition_k: np.ndarray
    flags_k: np.ndarray
    n_ill_conditioned: int
    n_missing: int
    max_condition: float


def _directions(direction_kic):
    n = np.asarray(direction_kic, dtype=np.float64)
    if n.ndim == 2:
        n = n[None]
    if n.ndim != 3 or n.shape[1:] != (3, 3):
        raise ValueError(f"direction_kic must have shape (n_k, 3, 3) (steps, units, x/y/z) [-], got "
                         f"{np.shape(direction_kic)}")
    if not np.all(np.isfinite(n)):
        raise ValueError("direction_kic must be finite")
    norm = np.sqrt(np.sum(n * n, axis=2))
    if np.any(np.abs(norm - 1.0) > 1e-9):
        raise ValueError(f"direction_kic must hold unit vectors; |n| = {norm.ravel()[np.argmax(np.abs(norm - 1.0))]!r}; "
                         f"allowed: |n| within 1e-9 of 1")
    return n


def homodyne_signs(direction_kic, wind_c) -> np.ndarray:
    """The sign each unit's speed is given: ``sign(n_i @ W)``, shape (n_k, 3), +1 where the projection is 0 (module notes).

    Parameters
    ----------
    direction_kic : array_like, shape (n_k, 3, 3) or (3, 3)
        Unit look directions per step and unit [-].
    wind_c : array_like, shape (3,)
        The mean wind ``W`` [m/s].
    """
    n = _directions(direction_kic)
    w = np.asarray(wind_c, dtype=np.float64)
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ValueError(f"wind_c must be 3 finite numbers [m/s], got {wind_c!r}")
    return np.where(np.einsum("kic,c->ki", n, w) < 0.0, -1.0, 1.0)


def reconstruct_uvw(direction_kic, vlos_ki, *, flags_ki=None, max_condition: float = DEFAULT_MAX_CONDITION
                    ) -> Reconstruction:
    """Solve ``N_k u_k = v_k`` per step: the wind from three line-of-sight speeds (module notes).

    Parameters
    ----------
    direction_kic : array_like, shape (n_k, 3, 3)
        Unit look directions [-]: step k, unit i, component (x, y, z); from the unit toward the focus
        (shape (3, 3) with ``vlos_ki`` of shape (3,): one step).
    vlos_ki : array_like, shape (n_k, 3)
        Signed line-of-sight speeds [m/s], positive away from the unit (a
        homodyne speed times :func:`homodyne_signs`); NaN: missing.
    flags_ki : array_like of uint8, shape (n_k, 3), optional
        The units' chain flags (:class:`cwlidar_sim.signal.Flag`), OR-ed per step.
    max_condition : float
        Steps with ``cond(N_k)`` above it are flagged and NaN; in [1, 1e12].

    Returns
    -------
    Reconstruction
    """
    n = _directions(direction_kic)
    v = np.asarray(vlos_ki, dtype=np.float64)
    if np.ndim(direction_kic) == 2 and v.shape == (3,):
        v = v[None]  # one step
    if v.shape != n.shape[:2]:
        raise ValueError(f"vlos_ki must have shape {n.shape[:2]} (steps, units) [m/s], got {v.shape}")
    max_condition = check_real("max_condition", max_condition, lo=1.0, hi=1e12)
    flags = np.zeros(n.shape[0], dtype=np.uint8)
    if flags_ki is not None:
        f = np.asarray(flags_ki)
        if f.shape != v.shape:
            raise ValueError(f"flags_ki must have shape {v.shape}, got {f.shape}")
        flags = np.bitwise_or.reduce(f.astype(np.uint8), axis=1)
    cond = np.linalg.cond(n) if n.shape[0] else np.zeros(0)
    bad = ~(cond <= max_condition)
    flags[bad] |= np.uint8(ReconstructionFlag.ILL_CONDITIONED)
    missing = ~np.all(np.isfinite(v), axis=1)
    uvw = np.full((n.shape[0], 3), np.nan)
    ok = ~bad & ~missing
    if np.any(ok):
        uvw[ok] = np.linalg.solve(n[ok], v[ok][:, :, None])[:, :, 0]
    return Reconstruction(uvw_kc=uvw, condition_k=cond, flags_k=flags, n_ill_conditioned=int(bad.sum()),
                          n_missing=int((missing & ~bad).sum()), max_condition=max_condition)
