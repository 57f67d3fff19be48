"""A point sensor's variance below a generated field's grid: what a box, plane or line holds against the continuum.

A sonic or a cup samples a generated field (:mod:`cwlidar_sim.turbulence`)
at its position as the field is advected past it (Taylor, mean wind U along
+x).  The field is a sum over its grid's modes, so the sensor misses

* the wave vectors the grid does not hold: ``|k1| > pi / dx`` along the
  wind, and ``|k2| > pi / dy``, ``|k3| > pi / dz`` across it, at every k1
  (at the grid's k1 Nyquist about half of the one-point spectrum F11);
* part of the held ones: between the x nodes the sensor reads the linear
  interpolation of the nodes (:func:`cwlidar_sim.beam.sample_los`), whose
  mean square, for a line of wavenumber k, is ``sum_m sinc^4(k dx / 2 + pi m)
  = (2 + cos(k dx)) / 3`` of the line's variance (the images at ``k + 2 pi
  m / dx`` included; 1/3 at the Nyquist), and across the wind, a sensor off
  the nodes by the fractions (a_y, a_z) of a cell reads their bilinear
  average: ``1 - 2 a (1 - a) (1 - cos(k2 dy))`` per axis.

:func:`point_subgrid_variance` gives the expected within-period variance of
the sensor's series in the field (a sum over the field's own modes, the
discrete spectra the generator draws, with the interpolation above, the
sensor's first-order response and the period's mean removal and sampling),
the same on the continuum (the tensor's one-point spectra,
:func:`cwlidar_sim.turbulence.one_point_spectra`, through
:func:`cwlidar_sim.analysis.linear_theory.period_variance`), and their
difference, the *sub-grid variance*.  The field's missing modes are
independent of the ones it holds (a Gaussian field's disjoint wave vectors),
so a point sensor's continuum variance is, in expectation, its simulated
variance plus the sub-grid variance, whatever the seed; the missing scales
(metres and less) are far below a lidar's probe and scan filters, so they
add nothing to its covariance with a lidar.  docs/convergence.md, *Point
sensors below the grid*, gives the numbers of the CS scene.

Not included: the cup's own interpolation of its 10 Hz input (piecewise
linear, far above its response's corner), the nonlinearity of a horizontal
speed (taken as U + u), a sensor's noise.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .._validation import check_choice, check_real, check_tuple

__all__ = ["point_subgrid_variance", "interpolation_images"]

#: Images ``k + 2 pi m / dx``, |m| <= this, of the x interpolation (the rest weighs below 1e-7).
_IMAGES = 24
#: Rows of the field's discrete spectra per chunk (memory: rows x lateral modes x 6 doubles).
_ROWS_PER_CHUNK = 16
#: The field's rows evaluated: all up to this one, then this many log-spaced ones (the rest interpolated).
_ALL_ROWS, _LOG_ROWS = 64, 192


def interpolation_images(k1, dx: float, n_images: int = _IMAGES):
    """The lines a linear interpolation along x makes of lines of wavenumbers ``k1`` (module notes).

    Parameters
    ----------
    k1 : array_like
        Wavenumbers of the field's lines [rad/m].
    dx : float
        The grid spacing along x [m], > 0.
    n_images : int
        Images ``m = -n_images .. n_images``.

    Returns
    -------
    q_mk, weight_mk : ndarray, shape (2 n_images + 1, n_k)
        ``|k1 + 2 pi m / dx|`` [rad/m] and the share of each line's variance
        there, ``sinc^4(k1 dx / 2 + pi m)`` [-] (summing to
        ``(2 + cos(k1 dx)) / 3`` over m).
    """
    d = check_real("dx", dx, lo=0.0, lo_open=True)
    k = np.asarray(k1, dtype=float)
    m = np.arange(-int(n_images), int(n_images) + 1).reshape((-1,) + (1,) * k.ndim)
    q = k[None] + 2.0 * math.pi * m / d
    return np.abs(q), np.sinc(q * d / (2.0 * math.pi)) ** 4


def _response2(time_constant, U):
    """``|H|^2`` of a first-order response (``None``: 1) as a function of k1 [rad/m]."""
    if time_constant is None:
        return lambda k: np.ones(np.shape(k))
    tau = float(time_constant)
    return lambda k: 1.0 / (1.0 + (U * np.asarray(k) * tau) ** 2)


def _within_kernel(k, U, T, dt):
    """``1 - D_N``: the share of a line's variance that stays in a period's samples about their mean."""
    from .linear_theory import _dirichlet2

    om = U * np.asarray(k)
    if dt is None:
        return 1.0 - np.sinc(om * T / (2.0 * math.pi)) ** 2
    n = max(1, int(round(T / dt)))
    return 1.0 - _dirichlet2(om * dt, n)


def _lateral_weight(q, d, a):
    """``|(1 - a) + a exp(i q d)|^2``: a sensor a fraction a of a cell off the node."""
    return 1.0 - 2.0 * a * (1.0 - a) * (1.0 - np.cos(q * d))


def _field_lines(df, direction, offset):
    """Each positive-k1 row's variance at the sensor (lateral interpolation included) [m^2 s^-2] and its k1."""
    d1, d2, d3 = direction
    quad = np.array([d1 * d1, d2 * d2, d3 * d3, 2 * d1 * d3, 2 * d1 * d2, 2 * d2 * d3])
    n1 = df.shape[0]
    rows = np.arange(1, n1 // 2 + 1)
    lat = 1.0
    if df.kind != "line":
        n2 = df.lat[0] if df.kind == "box" else df.lat[1]
        dy = df.spacing[1]
        q2 = 2.0 * math.pi * np.fft.fftfreq(n2, dy)
        wy = _lateral_weight(q2, dy, offset[0])
        if df.kind == "box":
            dz = df.spacing[2]
            q3 = 2.0 * math.pi * np.fft.fftfreq(df.lat[1], dz)
            lat = wy[:, None] * _lateral_weight(q3, dz, offset[1])[None, :]
        else:
            lat = wy[None, :]
    # every row up to _ALL_ROWS (the cell-corrected ones among them), log-spaced ones above: the lateral sums are
    # smooth in k1 there, interpolated in log-log (within 1e-4 of the variance, tested)
    if rows.size > _ALL_ROWS + _LOG_ROWS:
        some = np.unique(np.concatenate([rows[:_ALL_ROWS], np.geomspace(_ALL_ROWS + 1, rows[-1], _LOG_ROWS).round()
                                         .astype(np.int64), rows[-2:]]))
    else:
        some = rows
    v_some = np.empty(some.size)
    for lo in range(0, some.size, _ROWS_PER_CHUNK):
        r = some[lo:lo + _ROWS_PER_CHUNK]
        phi = df.phi_rows(r) @ quad  # (R, N2, N3)
        v_some[lo:lo + r.size] = np.sum(phi * lat, axis=(1, 2))
    var = v_some if some.size == rows.size else np.exp(np.interp(np.log(rows), np.log(some),
                                                                 np.log(np.maximum(v_some, 1e-300))))
    # a row n stands for +-k1 (twice) but the Nyquist row of an even N1 (once)
    var *= 2.0
    if n1 % 2 == 0:
        var[-1] *= 0.5
    return df.k1_of_rows(rows).astype(float), var


@functools.lru_cache(maxsize=16)
def _continuum_spectrum(params, direction, k_lo, k_hi):
    """One-sided spectrum of ``direction . u`` on a log grid (50 per decade; 'coarse' rule, 2.5e-4) [m^3 s^-2]."""
    from ..turbulence.spectra import one_point_spectra

    k = np.geomspace(k_lo, k_hi, int(math.ceil(50 * math.log10(k_hi / k_lo))) + 1)
    F11, F22, F33, F13 = one_point_spectra(k, params, rule="coarse")
    d = direction
    F = d[0] ** 2 * F11 + d[1] ** 2 * F22 + d[2] ** 2 * F33 + 2.0 * d[0] * d[2] * F13
    k.setflags(write=False)
    F.setflags(write=False)
    return k, F


def point_subgrid_variance(params, mean_speed: float, duration: float, kind: str, shape, spacing, *,
                           direction=(1.0, 0.0, 0.0), offset=(0.0, 0.0), time_constant: float | None = None,
                           sample_interval: float | None = None, correction: str = "cell",
                           hf_compensation: bool = False) -> dict:
    """Expected variance of a point sensor's series within a period, in a generated field and on the continuum.

    Parameters
    ----------
    params : MannParameters
        The field's tensor.
    mean_speed : float
        U [m/s], > 0: the advection along +x.
    duration : float
        The period T [s], > 0; its mean is removed from the series.
    kind : {"box", "plane", "line"}
        The field (:func:`cwlidar_sim.turbulence.generate_box`, ``generate_plane``, ``generate_line``).
    shape, spacing : tuple
        The field's *generated* shape (a laterally doubled box's full width)
        and spacing [m], one entry per axis of ``kind``.
    direction : (3,) float
        The sensor reads ``direction . u`` (a unit vector; ``(1, 0, 0)``:
        u, a cup's or a sonic's horizontal speed to first order; a beam's
        direction: a sonic projected on it).
    offset : (float, float)
        The sensor's position off the nodes across the wind, fractions of a
        cell in [0, 1) along y and z (0: on a node; z is ignored by a plane,
        both by a line).
    time_constant : float, optional
        A first-order response's time constant [s] (a cup: distance
        constant / U); None: none.
    sample_interval : float, optional
        The series' sampling interval [s]; None: continuous.
    correction, hf_compensation
        The field's (:func:`cwlidar_sim.turbulence.generate_box`; a box only).

    Returns
    -------
    dict
        ``field``, ``continuum`` [m^2 s^-2]: the expected (1/N) sample
        variance about the period's mean in the field and on the continuum;
        ``subgrid = continuum - field``; ``n_samples`` (``T / dt``, or None).
        The expected ``ddof=1`` variance is ``N / (N - 1)`` times each.
    """
    from ..turbulence._discrete import discrete_field
    from .._validation import check_int
    from ..turbulence.tensor import _check_params
    from .linear_theory import period_variance

    _check_params(params)
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    T = check_real("duration", duration, lo=0.0, lo_open=True)
    check_choice("kind", kind, ("box", "plane", "line"))
    n_axes = {"box": 3, "plane": 2, "line": 1}[kind]
    shape = check_tuple("shape", shape, n_axes, lambda n, v: check_int(n, v, lo=2))
    spacing = check_tuple("spacing", spacing, n_axes, lambda n, v: check_real(n, v, lo=0.0, lo_open=True))
    dvec = np.array(check_tuple("direction", direction, 3, check_real), dtype=float)
    if abs(np.linalg.norm(dvec) - 1.0) > 1e-6:
        raise ValueError(f"direction must be a unit vector (|n| = 1 within 1e-6), got {tuple(dvec)}")
    off = check_tuple("offset", offset, 2, lambda n, v: check_real(n, v, lo=0.0, hi=1.0, hi_open=True))
    tau = None if time_constant is None else check_real("time_constant", time_constant, lo=0.0)
    dt = None if sample_interval is None else check_real("sample_interval", sample_interval, lo=0.0, lo_open=True)
    h2 = _response2(tau, U)

    kw = {"correction": correction, "hf_compensation": hf_compensation} if kind == "box" else {}
    df = discrete_field(kind, params, shape, spacing, **kw)
    k_n, var_n = _field_lines(df, dvec, off if kind == "box" else (off[0], 0.0) if kind == "plane" else (0.0, 0.0))
    q_mn, w_mn = interpolation_images(k_n, spacing[0])
    field = float(np.sum(var_n[None] * w_mn * h2(q_mn) * _within_kernel(q_mn, U, T, dt)))

    k, F = _continuum_spectrum(params, tuple(dvec), min(1e-3 / params.length_scale, 0.2 * math.pi / (U * T)),
                               1e3 * max(1.0 / params.length_scale, math.pi / spacing[0]))
    cont = period_variance(k, F * h2(k), U, T, sample_interval=dt)["within"]
    return {"field": field, "continuum": float(cont), "subgrid": float(cont) - field,
            "n_samples": None if dt is None else max(1, int(round(T / dt)))}
