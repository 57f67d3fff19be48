"""Virtual sonic anemometer and the resampling used to compare it with the lidar (A2012 section III).

Sonic
-----
A point sensor (A2012: a Metek USA-1 at 32 Hz) that returns the three
components of the *total* wind ``(U + u, v, w)`` at its position, with the
field advected at ``U`` along +x (Taylor's hypothesis) and interpolated as
:func:`cwlidar_sim.beam.sample_los` does (it is that function with one range
cell at range 0).  Optional white measurement noise, independent per
component and per sample.  The path average of a real sonic (about 0.15 m)
is not modelled: it is far below the lidar's probe length.

Resampling to 10 Hz
-------------------
A2012 compares 10 Hz series: the lidar's 50 Hz estimates are block-averaged
by 5 (:func:`block_average`), the sonic's 32 Hz samples resampled by A2012
Eqs. 5-7 (:func:`resample_a2012`): partitions of 16 samples (0.5 s), and in
each partition output ``i = 1..5`` is

``y_i = (w_1 x_{3(i-1)+1} + w_2 x_{3(i-1)+2} + w_3 x_{3(i-1)+3} + w_4 x_{3(i-1)+4}) / 3.2``,
``w = {0.2 (6 - i), 1, 1, 0.2 i}`` (1-based sample indices within the partition).

Every sample carries total weight 1 over the outputs (sample 4 gives 0.2 to
output 1 and 0.8 to output 2, sample 7 gives 0.4 and 0.6, ...), so this is
the exact block average over 3.2 samples of the sample-and-hold signal in
which sample j holds over ``[j, j+1)`` (sample units, 0-based): output i
covers ``[3.2 (i-1), 3.2 i)``.

Time stamps (derived).  With samples at ``t_j = t_0 + j / 32`` (j 0-based),
the weight centroid of output i of partition p is

``t_{p,i} = t_0 + (16 p + 1.125 + 3.1875 (i - 1)) / 32``  [s],  i = 1..5,

i.e. 1.125, 4.3125, 7.5, 10.6875, 13.875 samples into the partition:
symmetric about the partition centre (7.5), 3.1875 samples apart inside a
partition and 3.25 across its boundary.  A linear ramp is reproduced exactly
at these times (the weights are non-negative and the output is the weighted
mean of the sample times), which :func:`resample_a2012_times` returns (it
applies the same weights to the sample times).  They differ from the uniform
10 Hz grid ``t_0 + 0.034375 + 0.1 q`` by at most 0.025 samples (0.78 ms).
The sample-and-hold interval centres are later by half a sample
(``t_0 + 0.05 + 0.1 q``): that is the convention if a sonic sample is the
average over the following 1/32 s.

Block-average time stamps: the 50 Hz estimates at ``t_0 + j / 50`` give 10 Hz
means centred at ``t_0 + 0.04 + 0.1 q`` (``block_average(time_e, 5)``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._validation import check_int, check_keys, check_real, check_tuple

__all__ = [
    "Sonic",
    "sample_sonic",
    "nearest_node",
    "project",
    "resample_a2012",
    "resample_a2012_times",
    "block_average",
    "A2012_PARTITION",
    "A2012_OUTPUTS",
]

#: Samples per A2012 partition (0.5 s at 32 Hz).
A2012_PARTITION = 16
#: Outputs per A2012 partition (0.5 s at 10 Hz).
A2012_OUTPUTS = 5
# Eq. 5, un-normalised: row i - 1 holds {0.2 (6 - i), 1, 1, 0.2 i}; every row sums to 3.2 (Eq. 6).
_A2012_W = tuple((float(6 - i) / 5.0, 1.0, 1.0, float(i) / 5.0) for i in range(1, 6))
_A2012_SUM = 3.2


@dataclasses.dataclass(frozen=True)
class Sonic:
    """A virtual sonic anemometer at a point.

    Parameters
    ----------
    position : tuple of 3 floats
        (x, y, z) [m] in the field's frame (x along the mean wind, z up).
    rate : float
        Sampling rate [Hz]; in (0, 1e4].  A2012's Metek USA-1: 32 Hz.
        Used by :meth:`times`; :func:`sample_sonic` samples at the times given.
    noise_std : float
        Standard deviation of white measurement noise, per component and per
        sample [m/s]; in [0, 100].  0: noise-free.
    """

    position: tuple
    rate: float = 32.0
    noise_std: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "position", check_tuple("position", self.position, 3, check_real))
        object.__setattr__(self, "rate", check_real("rate", self.rate, lo=0.0, hi=1e4, lo_open=True))
        object.__setattr__(self, "noise_std", check_real("noise_std", self.noise_std, lo=0.0, hi=100.0))

    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return {"position": tuple(self.position), "rate": self.rate, "noise_std": self.noise_std}

    @classmethod
    def from_dict(cls, d: dict) -> "Sonic":
        """Build from a mapping; unknown keys are rejected by name, ``position`` is required."""
        check_keys(cls, d, required=["position"])
        return cls(**d)

    def times(self, duration: float, start: float = 0.0) -> np.ndarray:
        """Sample times ``start + j / rate`` [s] covering ``[start, start + duration)``.

        Parameters
        ----------
        duration : float
            Length of the record [s]; > 0.
        start : float
            Time of the first sample [s].
        """
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        n = int(np.floor(duration * self.rate + 1e-9))
        if n < 1:
            raise ValueError(f"duration={duration} s holds no sample at rate={self.rate} Hz; allowed: >= 1/rate")
        return start + np.arange(n) / self.rate


def sample_sonic(field, sonic: Sonic, times_t, U: float, seed=None, *, wrap: bool = False) -> np.ndarray:
    """Three-component total wind at the sonic's position.

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line field (see :func:`cwlidar_sim.beam.sample_los`);
        u, v, w are the fluctuations [m/s].
    sonic : Sonic
    times_t : array_like, shape (n_t,)
        Sample times [s] (e.g. :meth:`Sonic.times`).
    U : float
        Mean wind along +x [m/s]: the advection speed (Taylor) and the mean
        added to u.
    seed : int or numpy.random.Generator, optional
        Randomness of the measurement noise; required when ``noise_std > 0``.
    wrap : bool
        Treat y and z as periodic (see :func:`cwlidar_sim.beam.sample_los`).

    Returns
    -------
    vel_tc : ndarray, shape (n_t, 3), float64
        ``(U + u, v, w)`` [m/s] at ``position`` and ``times_t`` (the stored
        field at ``x - U t``, interpolated), plus ``noise_std`` times
        independent standard normals.
    """
    from ..beam.sampling import sample_los

    if not isinstance(sonic, Sonic):
        raise TypeError(f"sonic must be a Sonic, got {type(sonic).__name__}")
    vel_tsc, _ = sample_los(field, sonic.position, (1.0, 0.0, 0.0), [0.0], times_t, U, wrap=wrap, add_mean=True)
    vel_tc = np.ascontiguousarray(vel_tsc[:, 0, :])
    if sonic.noise_std > 0.0:
        if seed is None:
            raise ValueError(f"seed is required when noise_std={sonic.noise_std} > 0; allowed: an int or a Generator")
        from ..signal.processing import _rng

        vel_tc += sonic.noise_std * _rng(seed).standard_normal(vel_tc.shape)
    return vel_tc


def nearest_node(field, position, axes=("y", "z")) -> tuple:
    """``position`` with its coordinates along ``axes`` moved to the field's nearest grid node [m].

    A point sensor between grid nodes across the wind reads a linear
    interpolation of the nodes around it, i.e. their average: it loses the
    part of the variance that is not common to them.  At the conical scenes'
    spacing (z / 20) a cup midway between the nodes of both lateral axes
    reads a sigma 1.6-2 % low (paired, 40 boxes at 40 and 100 m:
    docs/convergence.md), so the lidar/cup ratio comes out 0.013-0.016 high,
    a bias that varied with the box's parity and the height.  On a node the
    sensor reads the field the grid holds; along the wind (x) the advected
    field passes through every position anyway.

    Parameters
    ----------
    field : xarray.Dataset or mapping
        A line, plane or box with coordinates named ``x``, ``y``, ``z`` [m],
        or a mapping of those names to 1-D node coordinates [m] (only the
        axes present, with more than one node, are moved).
    position : sequence of 3 float
        (x, y, z) [m] in the field's frame.
    axes : sequence of {'x', 'y', 'z'}
        The coordinates to move.

    Returns
    -------
    tuple of 3 float
        The moved position [m].
    """
    pos = [float(v) for v in check_tuple("position", position, 3, lambda n, v: check_real(n, v))]
    coords = getattr(field, "coords", field)
    for a in axes:
        if a not in ("x", "y", "z"):
            raise ValueError(f"axes must name 'x', 'y' or 'z', got {a!r}")
        if a in coords:
            c = np.asarray(coords[a], dtype=np.float64).ravel()
            if c.size > 1:
                i = "xyz".index(a)
                pos[i] = float(c[int(np.argmin(np.abs(c - pos[i])))])
    return tuple(pos)


def project(vel_tc, direction) -> np.ndarray:
    """Projection ``dot(n, vel)`` of velocity samples on a unit direction [m/s] (A2012: sonic on the beam).

    Parameters
    ----------
    vel_tc : array_like, shape (n_t, 3)
        Velocity samples [m/s].
    direction : array_like, shape (3,)
        Unit vector [-] (e.g. :attr:`cwlidar_sim.sensors.StaringLidar.direction`).

    Returns
    -------
    ndarray, shape (n_t,)
        Signed speed along ``direction`` [m/s].
    """
    vel = np.asarray(vel_tc, dtype=np.float64)
    if vel.ndim != 2 or vel.shape[1] != 3:
        raise ValueError(f"vel_tc must have shape (n_t, 3), got {vel.shape}")
    n = np.asarray(direction, dtype=np.float64)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or abs(np.linalg.norm(n) - 1.0) > 1e-6:
        raise ValueError(f"direction must be a finite unit vector of shape (3,), got {direction!r}")
    return vel[:, 0] * n[0] + vel[:, 1] * n[1] + vel[:, 2] * n[2]


def resample_a2012(x_t, axis: int = 0) -> np.ndarray:
    """A2012's 32 Hz -> 10 Hz resampling (Eqs. 5-7), see the module notes.

    Parameters
    ----------
    x_t : array_like
        Samples at 32 Hz along ``axis`` (any units; float).  NaN marks a
        missing sample: every output that gives it a weight is NaN.
    axis : int
        Time axis.

    Returns
    -------
    ndarray, float64
        ``5 * (n // 16)`` outputs along ``axis``; a trailing partial partition
        (fewer than 16 samples) is dropped.  Output ``5 p + i - 1`` is centred
        at the time given by :func:`resample_a2012_times`.
    """
    x = np.asarray(x_t, dtype=np.float64)
    if x.ndim == 0:
        raise ValueError("x_t must have at least one dimension (time)")
    axis = check_int("axis", axis, lo=-x.ndim, hi=x.ndim - 1)
    x = np.moveaxis(x, axis, 0)
    n_p = x.shape[0] // A2012_PARTITION
    xp = x[: n_p * A2012_PARTITION].reshape((n_p, A2012_PARTITION) + x.shape[1:])
    out = np.empty((n_p, A2012_OUTPUTS) + x.shape[1:])
    for i, (w1, w2, w3, w4) in enumerate(_A2012_W):
        j = 3 * i
        # explicit terms (not a matrix product): a NaN must reach only the outputs that weight it
        out[:, i] = (w1 * xp[:, j] + w2 * xp[:, j + 1] + w3 * xp[:, j + 2] + w4 * xp[:, j + 3]) / _A2012_SUM
    out = out.reshape((n_p * A2012_OUTPUTS,) + x.shape[1:])
    return np.moveaxis(out, 0, axis)


def resample_a2012_times(t_t) -> np.ndarray:
    """Time stamps of :func:`resample_a2012`'s outputs: the weighted mean of the sample times [s].

    Parameters
    ----------
    t_t : array_like, shape (n_t,)
        Sample times [s], finite.

    Returns
    -------
    ndarray, shape (5 * (n_t // 16),)
        For uniform 32 Hz samples from ``t_0``:
        ``t_0 + (16 p + 1.125 + 3.1875 (i - 1)) / 32`` (module notes); a
        signal linear in time is reproduced exactly at these times.
    """
    t = np.asarray(t_t, dtype=np.float64)
    if t.ndim != 1:
        raise ValueError(f"t_t must be 1-D, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("t_t must be finite")
    return resample_a2012(t)


def block_average(x_t, m: int, flags_t=None):
    """Mean of consecutive blocks of ``m`` samples over their valid samples (the lidar's 50 Hz -> 10 Hz, m = 5).

    Parameters
    ----------
    x_t : array_like, shape (n_t,) or (n_t, ...)
        Samples along axis 0 (e.g. speed estimates [m/s]); non-finite values
        are invalid (failed estimates are NaN).
    m : int
        Block length; in [1, 10**9].
    flags_t : array_like of int, shape (n_t,), optional
        Quality-flag bit fields (uint8-compatible, e.g.
        :class:`cwlidar_sim.signal.Flag`) of the samples.

    Returns
    -------
    mean_e : ndarray, float64, shape (n_t // m,) + x_t.shape[1:]
        Mean of the valid samples of each block; NaN where none is valid.
    n_valid_e : ndarray, int64, same shape
        Number of valid samples in each block (0..m).
    flags_e : ndarray, uint8, shape (n_t // m,)
        Bitwise OR of the block's flags (zeros when ``flags_t`` is None).

    Notes
    -----
    A trailing partial block (fewer than ``m`` samples) is dropped.  The block
    mean is over whichever samples are valid: a block with failed estimates
    is the mean of the rest, and ``n_valid_e`` tells how many those were.
    """
    x = np.asarray(x_t, dtype=np.float64)
    if x.ndim == 0:
        raise ValueError("x_t must have at least one dimension (time)")
    m = check_int("m", m, lo=1, hi=10**9)
    n_e = x.shape[0] // m
    xb = x[: n_e * m].reshape((n_e, m) + x.shape[1:])
    valid = np.isfinite(xb)
    n_valid = valid.sum(axis=1)
    total = np.where(valid, xb, 0.0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(n_valid > 0, total / np.maximum(n_valid, 1), np.nan)
    if flags_t is None:
        flags_e = np.zeros(n_e, dtype=np.uint8)
    else:
        f = np.asarray(flags_t)
        if f.shape != (x.shape[0],):
            raise ValueError(f"flags_t must have shape ({x.shape[0]},) to match x_t, got {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            raise TypeError(f"flags_t must be integers (uint8 bit fields), got {f.dtype}")
        if f.size and (f.min() < 0 or f.max() > 255):
            raise ValueError(f"flags_t must lie in [0, 255] (uint8 bit fields), got [{f.min()}, {f.max()}]")
        fb = f[: n_e * m].astype(np.uint8).reshape(n_e, m)
        flags_e = np.bitwise_or.reduce(fb, axis=1).astype(np.uint8)
    return mean, n_valid.astype(np.int64), flags_e
