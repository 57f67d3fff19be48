"""numba kernel of the cup anemometer's first-order response (imported lazily; compiles on first use).

Plain-Python reference: ``tests/reference.py::cup_first_order``.
"""

from __future__ import annotations

import math

import numba

from .._config import NJIT


@numba.njit(**NJIT)
def first_order_kernel(V, h, l0, mean_speed, speed_dependent, out):
    """``S_{n+1} = a S_n + b0 V_n + b1 V_{n+1}``, exact for an input linear between samples.

    ``a = exp(-h / tau)``, ``b1 = 1 - (tau/h)(1 - a)``, ``b0 = (tau/h)(1 - a) - a``;
    ``tau = l0 / mean_speed``, or ``l0 / max(S_n, 1e-3)`` when ``speed_dependent``.
    ``S_0 = V_0``.
    """
    n = V.shape[0]
    out[0] = V[0]
    tau = l0 / mean_speed
    a = math.exp(-h / tau)
    q = tau / h * (1.0 - a)
    for i in range(n - 1):
        if speed_dependent:
            tau = l0 / max(out[i], 1e-3)
            a = math.exp(-h / tau)
            q = tau / h * (1.0 - a)
        out[i + 1] = a * out[i] + (q - a) * V[i] + (1.0 - q) * V[i + 1]
