"""Virtual cup anemometer: horizontal speed through a first-order response (CS's reference instrument).

Response
--------
A cup's rotor follows the horizontal speed ``V_h = sqrt((U + u)^2 + v^2)``
with a first-order lag whose time constant is the *distance constant* over
the speed, ``tau = l_0 / V`` (the rotor turns through the same air length
whatever the speed): ``dS/dt = (V_h(t) - S) / tau``.  With ``tau = l_0 / U``
fixed (``speed_dependent=False``, the linear response) the transfer function
is ``H(f) = 1 / (1 + i 2 pi f tau)``, ``|H|^2 = 1 / (1 + (2 pi f tau)^2)``;
``speed_dependent=True`` uses ``tau = l_0 / S`` at every step (the rotor's
own speed), a mild nonlinearity (overspeeding is not modelled).

Discretisation (exact for a piecewise-linear input): with ``a = exp(-h/tau)``
and the input linear between samples,
``S_{n+1} = a S_n + b0 V_n + b1 V_{n+1}`` with
``b1 = 1 - (tau/h)(1 - a)``, ``b0 = (tau/h)(1 - a) - a`` -- so a sinusoid
sampled well above its frequency is filtered as by ``H`` to second order in
``2 pi f h``.  The output starts at ``S_0 = V_0`` (no spin-up transient).

Default distance constant 2.3 m: a common value for the cups on met masts
(e.g. the Vector Instruments A100 series' specification; first-class cups
of IEC 61400-12-1 lie between about 1.5 and 3 m).  At 10 m/s, tau = 0.23 s:
the cup attenuates little below 0.3 Hz, so its 10-minute standard deviation
is nearly the point value.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._validation import check_bool, check_keys, check_real, check_tuple

__all__ = ["Cup", "sample_cup", "cup_response", "cup_transfer"]

#: Default distance constant [m] (module notes).
DISTANCE_CONSTANT = 2.3


@dataclasses.dataclass(frozen=True)
class Cup:
    """A virtual cup anemometer at a point.

    Parameters
    ----------
    position : tuple of 3 floats
        (x, y, z) [m] in the field's frame.
    distance_constant : float
        l_0 [m]; in (0, 100].  Default 2.3 m (module notes).
    rate : float
        Sampling rate of the input wind [Hz]; in (0, 1e4].
    speed_dependent : bool
        ``tau = l_0 / S`` (True) or ``l_0 / U`` (False, linear).
    """

    position: tuple
    distance_constant: float = DISTANCE_CONSTANT
    rate: float = 10.0
    speed_dependent: bool = False

    def __post_init__(self):
        object.__setattr__(self, "position", check_tuple("position", self.position, 3, check_real))
        object.__setattr__(self, "distance_constant",
                           check_real("distance_constant", self.distance_constant, lo=0.0, hi=100.0, lo_open=True))
        object.__setattr__(self, "rate", check_real("rate", self.rate, lo=0.0, hi=1e4, lo_open=True))
        object.__setattr__(self, "speed_dependent", check_bool("speed_dependent", self.speed_dependent))

    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return {"position": tuple(self.position), "distance_constant": self.distance_constant, "rate": self.rate,
                "speed_dependent": self.speed_dependent}

    @classmethod
    def from_dict(cls, d: dict) -> "Cup":
        """Build from a mapping; unknown keys are rejected by name, ``position`` is required."""
        check_keys(cls, d, required=["position"])
        return cls(**d)

    def times(self, duration: float, start: float = 0.0) -> np.ndarray:
        """Sample times ``start + j / rate`` over ``[start, start + duration)`` [s]."""
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        n = int(np.floor(duration * self.rate + 1e-9))
        if n < 2:
            raise ValueError(f"duration={duration} s holds fewer than 2 samples at rate={self.rate} Hz")
        return start + np.arange(n) / self.rate


def cup_transfer(f, tau: float):
    """First-order transfer function H(f) = 1 / (1 + i 2 pi f tau) [-] (f in Hz, tau in s)."""
    tau = check_real("tau", tau, lo=0.0)
    f = np.asarray(f, dtype=np.float64)
    return 1.0 / (1.0 + 2j * np.pi * f * tau)


def cup_response(speed_t, dt: float, distance_constant: float = DISTANCE_CONSTANT, *, mean_speed=None,
                 speed_dependent: bool = False) -> np.ndarray:
    """Cup output for an input horizontal-speed series (module notes).

    Parameters
    ----------
    speed_t : array_like, shape (n_t,)
        Horizontal speed [m/s] at a uniform step; finite, > 0 somewhere.
    dt : float
        Sample step h [s]; > 0.
    distance_constant : float
        l_0 [m]; > 0.
    mean_speed : float, optional
        Speed for the linear time constant ``l_0 / mean_speed`` [m/s]; default
        the series mean.
    speed_dependent : bool
        Use ``tau = l_0 / S_n`` at every step instead.

    Returns
    -------
    ndarray, shape (n_t,)
        Rotor speed S [m/s].
    """
    V = np.asarray(speed_t, dtype=np.float64)
    if V.ndim != 1 or V.size < 1 or not np.all(np.isfinite(V)):
        raise ValueError(f"speed_t must be a finite 1-D series, got shape {V.shape}")
    h = check_real("dt", dt, lo=0.0, lo_open=True)
    l0 = check_real("distance_constant", distance_constant, lo=0.0, lo_open=True)
    speed_dependent = check_bool("speed_dependent", speed_dependent)
    if mean_speed is None:
        mean_speed = float(np.mean(V))
    Um = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    from . import _cup_kernels as K

    out = np.empty_like(V)
    K.first_order_kernel(V, h, l0, Um, speed_dependent, out)
    return out


def sample_cup(field, cup: Cup, times_t, U: float, *, wrap: bool = False) -> np.ndarray:
    """Cup output at its position and the given (uniform) times [m/s].

    The horizontal speed ``sqrt((U + u)^2 + v^2)`` is sampled from the field
    (advected at U along +x, trilinear) and passed through :func:`cup_response`.
    """
    from .sonic import Sonic, sample_sonic

    if not isinstance(cup, Cup):
        raise TypeError(f"cup must be a Cup, got {type(cup).__name__}")
    t = np.asarray(times_t, dtype=np.float64)
    if t.ndim != 1 or t.size < 2:
        raise ValueError("times_t must be a 1-D array of >= 2 times [s]")
    d = np.diff(t)
    if not (d[0] > 0 and np.allclose(d, d[0], rtol=1e-9, atol=0.0)):
        raise ValueError("times_t must be uniformly spaced and increasing")
    vel = sample_sonic(field, Sonic(position=cup.position), t, U, wrap=wrap)
    vh = np.hypot(vel[:, 0], vel[:, 1])
    return cup_response(vh, float(d[0]), cup.distance_constant, speed_dependent=cup.speed_dependent)
