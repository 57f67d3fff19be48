"""The period statistics of the linear theory and the adaptive k1 grid they are computed on.

:func:`period_variance` turns a spectrum on a k1 grid into the expected
variance of a statistic's samples within a period (its mean removed) and of
the period's mean; :class:`PeriodStatistic` names one such variance (an
output, its period, sampling, block and repetition); :func:`refine_k1` grows
a log k1 grid where the spectra's log-log interpolation would move these
variances.  :func:`cwlidar_sim.analysis.linear_theory.adaptive_spectra` is
the public entry (the functionals' spectra on the refined grid); all three
are re-exported by :mod:`cwlidar_sim.analysis.linear_theory`.

The refinement
--------------
Start from ``n_start`` log-spaced k1 over ``k1_range``.  Each round
evaluates the spectra at the log-midpoints of the open intervals and, for
every statistic s with kernel ``K_s(k1)`` (:meth:`PeriodStatistic.kernel`:
block average, sampling with its aliasing, mean removal, the repetition's
comb), estimates what the midpoint changes in the interval ::

    e_si = integral_i |F_new - F_old| K_s dk1

(``F_old`` the log-log line through the interval's ends, ``F_new`` the two
lines through the midpoint; 32 log-spaced nodes per interval).  An interval
is settled when ``e_si <= tol V_s w_i`` for every s (``V_s`` the statistic's
variance on the current grid, ``w_i`` the interval's share of ``ln k1``),
else both halves stay open.  The midpoints of settled intervals stay in the
grid, so ``sum_i e_si / V_s`` (reported as ``error``) bounds the grid's
error of each variance from above as far as the midpoint test sees it (a
feature narrower than a settled interval and symmetric about its midpoint
goes unseen: ``n_start`` sets the coarsest interval).  Outside ``k1_range``
the spectra are extrapolated as :func:`period_variance` does (flat below,
the last power law above), not refined.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.interpolate import CubicSpline

from .._validation import check_choice, check_int, check_real

__all__ = ["PeriodStatistic", "period_variance", "refine_k1"]

#: Log-spaced nodes per interval of the refinement's error integral.
_SUB = 32
#: The change a bisection makes over what it leaves, once the changes of successive bisections fall as the
#: spline's error should (as the width to the fourth: 15 for a smooth spectrum; 8 leaves a margin).
_RICHARDSON = 8.0


def _check_k1(k1):
    k = np.array(k1, dtype=float, ndmin=1)
    if k.ndim != 1 or not np.all(np.isfinite(k) & (k > 0)):
        raise ValueError("k1 must be a 1-D array of wavenumbers > 0 rad/m")
    return k


def _loglog(k_src, F_src, k):
    """Log-log interpolation of a positive spectrum, flat below its grid, its last power law above."""
    lk = np.log(k_src)
    lf = np.log(np.maximum(F_src, 1e-300))
    x = np.log(np.maximum(k, k_src[0]))
    slope = (lf[-1] - lf[-2]) / (lk[-1] - lk[-2])
    return np.exp(np.where(x > lk[-1], lf[-1] + slope * (x - lk[-1]), np.interp(x, lk, lf)))


def _logcubic(k_src, F_src, k=None):
    """:func:`_loglog` with a not-a-knot cubic spline in (ln k1, ln F) inside the grid (>= 4 wavenumbers).

    With ``k`` None, the interpolating function itself (the spline built once).
    """
    lk = np.log(k_src)
    lf = np.log(np.maximum(F_src, 1e-300))
    slope = (lf[-1] - lf[-2]) / (lk[-1] - lk[-2])
    spline = CubicSpline(lk, lf)

    def f(k):
        x = np.log(np.maximum(k, k_src[0]))
        inside = x <= lk[-1]
        out = lf[-1] + slope * (x - lk[-1])
        out[inside] = spline(x[inside])
        return np.exp(out)

    return f if k is None else f(k)


def _dirichlet2(x, n):
    """``|sum_{m<n} exp(i m x)|^2 / n^2`` [-]."""
    s = np.sin(0.5 * x)
    small = np.abs(s) < 1e-12
    return np.where(small, 1.0, (np.sin(0.5 * n * x) / (n * np.where(small, 1.0, s))) ** 2)


def period_variance(k1, spectrum_k, mean_speed: float, period: float, *, sample_interval: float | None = None,
                    block: float | None = None, lines: bool = False, repeat: tuple | None = None,
                    interpolation: str = "linear") -> dict:
    """Expected variance of a statistic's samples within a period (mean removed) and of the period's mean.

    For a statistic with one-sided spectrum ``F(k1)``, seen at rest
    (``omega = U k1``), sampled every ``sample_interval`` over ``period``
    (``N = period / sample_interval`` samples) or continuously, each sample
    optionally a block average over ``block`` [s]:

    * ``within = integral F B (1 - D_N)`` -- the expected (1/N) sample
      variance about the period's own mean;
    * ``of_mean = integral F B D_N`` -- the variance of the period mean,

    with ``B = sinc^2(omega block / 2)`` and ``D_N = |sum_m exp(i m omega
    dt)|^2 / N^2`` (``sinc^2(omega T / 2)`` when continuous).  Sampling's
    aliasing is included (``D_N`` is periodic in omega); ``within + of_mean``
    is the variance.  With ``repeat = (n, tau)`` each sample is the mean of n
    copies of the statistic ``tau`` apart (a scan of n revolutions as the
    mean of n one-revolution fits): B gains the comb ``D_n(omega tau)``, taken
    as its mean 1/n where it oscillates faster than an eighth of the
    quadrature's geometric step.

    Parameters
    ----------
    k1, spectrum_k : array_like
        A spectrum [m^3 s^-2] on an increasing grid of k1 [rad/m], log-log
        interpolated (200 per decade give 1e-4 about a knee), held flat below the
        grid and extended by its last power law above; with ``lines=True``
        the lines of :func:`lattice_spectra` (density times ``dk1`` is each
        line's variance; nothing outside them).
    mean_speed : float
        U [m/s].
    period : float
        T [s], > 0.
    sample_interval : float, optional
        dt [s]; None: continuous.
    block : float, optional
        Block-average duration [s]; None: none.
    lines : bool
    repeat : (int, float), optional
        ``(n, tau)``: n >= 1 copies, tau [s] > 0 apart; None: one.
    interpolation : {"linear", "cubic"}
        Of the spectrum between its k1, in (ln k1, ln F): straight lines, or
        a not-a-knot cubic spline (at least 4 k1; the error falls as the
        fourth power of the spacing, not the second).

    Returns
    -------
    dict
        ``within``, ``of_mean``, ``total`` [m^2 s^-2].
    """
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    T = check_real("period", period, lo=0.0, lo_open=True)
    k_src = _check_k1(k1)
    F_src = np.asarray(spectrum_k, dtype=float).ravel()
    if F_src.shape != k_src.shape or not np.all(np.isfinite(F_src)):
        raise ValueError("spectrum_k must be finite, one value per k1")
    n = None
    if sample_interval is not None:
        dt = check_real("sample_interval", sample_interval, lo=0.0, lo_open=True)
        n = check_int("period / sample_interval", int(round(T / dt)), lo=1)
    b = 0.0 if block is None else check_real("block", block, lo=0.0)
    n_rep, tau = (1, 0.0) if repeat is None else _check_repeat(repeat)
    k_avg = math.inf  # above it the comb is taken as its mean (set with the geometric nodes below)

    def comb(k):
        if n_rep == 1:
            return 1.0
        return np.where(k > k_avg, 1.0 / n_rep, _dirichlet2(U * k * tau, n_rep))

    def kernels(k):
        om = U * k
        B = np.sinc(om * b / (2.0 * math.pi)) ** 2 * comb(k)
        D = np.sinc(om * T / (2.0 * math.pi)) ** 2 if n is None else _dirichlet2(om * dt, n)
        return B * (1.0 - D), B * D

    if lines:
        if np.any(np.diff(k_src) <= 0):
            raise ValueError("k1 must increase")
        dk = 2.0 * math.pi / U / T if k_src.size == 1 else float(np.min(np.diff(k_src)))
        kw, km = kernels(k_src)
        var = F_src * dk
        w_, m_ = float(np.sum(var * kw)), float(np.sum(var * km))
        return {"within": w_, "of_mean": m_, "total": w_ + m_}
    if k_src.size < 2 or np.any(np.diff(k_src) <= 0):
        raise ValueError("k1 must hold at least 2 increasing wavenumbers")

    check_choice("interpolation", interpolation, ("linear", "cubic"))
    if interpolation == "cubic" and k_src.size < 4:
        raise ValueError("interpolation = 'cubic' needs at least 4 wavenumbers")
    F_of = (lambda k: _loglog(k_src, F_src, k)) if interpolation == "linear" else _logcubic(k_src, F_src)

    def FB(k):
        return F_of(k) * np.sinc(U * k * b / (2.0 * math.pi)) ** 2 * comb(k)

    dk_t = 2.0 * math.pi / (U * T)  # the spacing of the period's own harmonics in k1
    h = dk_t / 16.0
    # total: uniform nodes over the low band, geometric above, the last power law's tail in closed form
    k_band = 200.0 * dk_t
    ku = (np.arange(int(math.ceil(k_band / h))) + 0.5) * h
    k_end = max(k_src[-1], k_band) * 1e4
    kg = np.geomspace(ku[-1] + 0.5 * h, k_end, 8001)
    lg = np.log(kg)
    kc = np.exp(0.5 * (lg[1:] + lg[:-1]))
    if n_rep > 1:
        k_avg = 2.0 * math.pi / (U * tau) / (8.0 * (lg[1] - lg[0]))
    total = float(np.sum(FB(ku)) * h + np.sum(FB(kc) * np.diff(kg)))
    slope = math.log(F_src[-1] / F_src[-2]) / math.log(k_src[-1] / k_src[-2]) if F_src[-2] > 0 else -math.inf
    if slope < -1.0 and b == 0.0:
        total += float(F_of(np.array([k_end]))[0]) * k_end / (-slope - 1.0) / n_rep
    if n is None:
        # of the mean: sinc^2(U k T / 2) resolved over the low band; above it its average 1 / (2 x^2)
        x = 0.5 * U * T * kc
        of_mean = float(np.sum(FB(ku) * np.sinc(U * ku * T / (2.0 * math.pi)) ** 2) * h
                        + np.sum(FB(kc) * np.diff(kg) / (2.0 * x * x)))
    else:
        # sampled: fold onto the base band [0, k_s / 2] over 64 aliases, D_N's average 1 / N beyond
        k_s = 2.0 * math.pi / (U * dt)
        kb = (np.arange(int(math.ceil(0.5 * k_s / h))) + 0.5) * (0.5 * k_s / int(math.ceil(0.5 * k_s / h)))
        hb = 0.5 * k_s / kb.size
        acc = FB(kb)
        for m in range(1, 65):
            acc = acc + FB(m * k_s - kb) + FB(m * k_s + kb)
        of_mean = float(np.sum(acc * _dirichlet2(U * kb * dt, n)) * hb)
        beyond = kc > 64.5 * k_s
        of_mean += float(np.sum(FB(kc[beyond]) * np.diff(kg)[beyond])) / n
    return {"within": total - of_mean, "of_mean": of_mean, "total": total}


def _check_repeat(repeat, name="repeat"):
    if isinstance(repeat, (str, bytes)) or not hasattr(repeat, "__len__") or len(repeat) != 2:
        raise TypeError(f"{name} must be (n, interval): n >= 1 copies, interval [s] > 0 apart; got {repeat!r}")
    return (check_int(f"{name}[0] (copies)", repeat[0], lo=1),
            check_real(f"{name}[1] (interval)", repeat[1], lo=0.0, lo_open=True))


def _is_output(o) -> bool:
    return isinstance(o, (str, int, np.integer)) and not isinstance(o, bool)


def _auto(M, a):
    """The real spectrum [m^3 s^-2] of output index ``a``, or of ``sum_i w_i x_{a_i}`` for ``a`` a tuple of pairs."""
    if isinstance(a, (int, np.integer)):
        return M[:, a, a].real
    idx = [i for i, _ in a]
    w = np.array([x for _, x in a], dtype=float)
    return np.einsum("a,kab,b->k", w, M[:, idx][:, :, idx].real, w)


@dataclasses.dataclass(frozen=True)
class PeriodStatistic:
    """One output's expected variance within a period, its mean removed: :func:`period_variance`'s ``within``.

    Attributes
    ----------
    output : str or int
        The output: one of the spectra's names (``"<functional index>.<output name>"``
        with more than one functional) or its index.
    period : float
        T [s], > 0.
    sample_interval : float or None
        dt [s], > 0; None: continuous.
    block : float or None
        Each sample's block average [s], >= 0; None: none.
    repeat : (int, float) or None
        ``(n, tau)``: each sample the mean of n copies of the output tau [s]
        apart; None: one.
    weights : tuple of float or None
        With a tuple of outputs in ``output``: the statistic is of their sum
        weighted so, ``sum_a w_a x_a`` (its spectrum ``sum_ab w_a w_b Re F_ab``:
        a covariance from the variances of a sum and its parts); None: one output.
    """

    output: object
    period: float
    sample_interval: float | None = None
    block: float | None = None
    repeat: tuple | None = None
    weights: tuple | None = None

    def __post_init__(self):
        if self.weights is not None:
            outs = self.output if isinstance(self.output, tuple) else None
            if outs is None or not outs or not all(_is_output(o) for o in outs):
                raise TypeError(f"output must be a tuple of output names or indices with weights, got {self.output!r}")
            w = tuple(check_real(f"weights[{i}]", x) for i, x in enumerate(np.ravel(self.weights)))
            if len(w) != len(outs):
                raise ValueError(f"weights must hold one weight per output ({len(outs)}), got {self.weights!r}")
            object.__setattr__(self, "weights", w)
        elif not _is_output(self.output):
            raise TypeError(f"output must be an output's name or index, got {self.output!r}")
        object.__setattr__(self, "period", check_real("period", self.period, lo=0.0, lo_open=True))
        if self.sample_interval is not None:
            dt = check_real("sample_interval", self.sample_interval, lo=0.0, lo_open=True)
            check_int("period / sample_interval", int(round(self.period / dt)), lo=1)
            object.__setattr__(self, "sample_interval", dt)
        if self.block is not None:
            object.__setattr__(self, "block", check_real("block", self.block, lo=0.0))
        if self.repeat is not None:
            object.__setattr__(self, "repeat", _check_repeat(self.repeat))

    def kernel(self, k1, mean_speed: float) -> np.ndarray:
        """``B (1 - D_N) D_n`` [-] at k1 [rad/m]: what ``within`` weights the spectrum by (:func:`period_variance`)."""
        om = float(mean_speed) * np.asarray(k1, dtype=float)
        b = 0.0 if self.block is None else self.block
        K = np.sinc(om * b / (2.0 * math.pi)) ** 2
        if self.sample_interval is None:
            K = K * (1.0 - np.sinc(om * self.period / (2.0 * math.pi)) ** 2)
        else:
            K = K * (1.0 - _dirichlet2(om * self.sample_interval, int(round(self.period / self.sample_interval))))
        if self.repeat is not None:
            K = K * _dirichlet2(om * self.repeat[1], self.repeat[0])
        return K

    def variance(self, k1, spectrum_k, mean_speed: float) -> float:
        """``within`` [m^2 s^-2] of a spectrum on a k1 grid (:func:`period_variance`, cubic interpolation)."""
        return period_variance(k1, spectrum_k, mean_speed, self.period, sample_interval=self.sample_interval,
                               block=self.block, repeat=self.repeat, interpolation="cubic")["within"]


def _interval_errors(k_old, F_old, k_new, F_new, ka, kb, kern, U):
    """Per interval (ka, kb), ``integral |F_new - F_old| K dk1``: the splines of the old and new grids (module notes)."""
    u = (np.arange(_SUB) + 0.5) / _SUB
    la, lb = np.log(ka)[:, None], np.log(kb)[:, None]
    kk = np.exp(la + u * (lb - la))
    dx = (lb - la)[:, 0] / _SUB
    diff = np.abs(_logcubic(k_new, F_new, kk.ravel()) - _logcubic(k_old, F_old, kk.ravel())).reshape(kk.shape)
    return np.sum(diff * kern(kk, U) * kk, axis=1) * dx


def _scale(k, F_k, kern, U):
    """``integral F K dk1`` over the grid's span, spline-interpolated (the refinement's variance scale)."""
    kk = np.geomspace(k[0], k[-1], 20001)
    f = _logcubic(k, F_k, kk) * kern(kk, U) * kk
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(np.log(kk))))


def refine_k1(evaluate, index_s, statistics, mean_speed: float, k1_range=(1e-4, 1.0), *, n_start: int = 9,
              tol: float = 1e-3, max_k1: int = 400) -> dict:
    """Grow a log k1 grid until every statistic's variance is settled to ``tol`` (module notes).

    Parameters
    ----------
    evaluate : callable
        ``evaluate(k1)`` -> the spectral matrices ``F_ab`` [m^3 s^-2], shape (n_k, n_a, n_a), at the k1 [rad/m].
    index_s : sequence of int or of tuples
        Per statistic, its output's index a, or ``((a, w_a), ...)``: the
        weighted sum of outputs (:class:`PeriodStatistic`'s ``weights``).
    statistics : sequence of PeriodStatistic
    mean_speed : float
        U [m/s].
    k1_range : (float, float)
        The grid's ends [rad/m], 0 < lo < hi.
    n_start : int
        Log-spaced k1 to start from (>= 4, the spline's least).
    tol : float
        Relative tolerance of each variance, > 0.
    max_k1 : int
        Most k1 evaluated (>= n_start): the refinement stops there, unconverged.

    Returns
    -------
    dict
        ``k1`` [rad/m] and ``matrix`` on the refined grid; ``error`` (per statistic, relative), ``converged``,
        ``rounds``.
    """
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    if len(k1_range) != 2:
        raise ValueError(f"k1_range must be (lo, hi) [rad/m], got {k1_range!r}")
    lo = check_real("k1_range[0]", k1_range[0], lo=0.0, lo_open=True)
    hi = check_real("k1_range[1]", k1_range[1], lo=lo, lo_open=True)
    n_start = check_int("n_start", n_start, lo=4)
    tol = check_real("tol", tol, lo=0.0, lo_open=True)
    max_k1 = check_int("max_k1", max_k1, lo=n_start)
    kernels = [st.kernel for st in statistics]
    k = np.geomspace(lo, hi, n_start)
    M = np.asarray(evaluate(k))
    open_i = np.ones(k.size - 1, dtype=bool)
    est = np.zeros((len(kernels), k.size - 1))  # per statistic and interval, the estimated error left in it
    made = np.zeros((len(kernels), k.size - 1))  # the change of the bisection that made it (0: none yet)
    rounds = 0
    while open_i.any() and k.size + int(open_i.sum()) <= max_k1:
        ia = np.nonzero(open_i)[0]
        km = np.sqrt(k[ia] * k[ia + 1])
        Mm = np.asarray(evaluate(km))
        k_new = np.concatenate([k, km])
        order = np.argsort(k_new)
        M_new = np.concatenate([M, Mm])[order]
        err = np.array([_interval_errors(k, _auto(M, a), k_new[order], _auto(M_new, a), k[ia], k[ia + 1],
                                         kern, U) for a, kern in zip(index_s, kernels)])
        M = M_new
        # a bisected interval's halves share what its change leaves: 1 / _RICHARDSON of it where the change fell
        # at least fourfold from the bisection before (the spline's order seen), all of it else
        seen = np.all(err <= 0.25 * made[:, ia], axis=0)
        left = err / np.where(seen, _RICHARDSON, 1.0)
        e_new, m_new, pos = [], [], dict(zip(ia.tolist(), range(ia.size)))
        for i in range(k.size - 1):
            j = pos.get(i)
            e_new += [est[:, i]] if j is None else [0.5 * left[:, j]] * 2
            m_new += [made[:, i]] if j is None else [err[:, j]] * 2
        k, est, made = k_new[order], np.stack(e_new, axis=1), np.stack(m_new, axis=1)
        rounds += 1
        # open the intervals of largest estimate until what stays shut holds at most half the tolerance
        budget = tol * np.array([_scale(k, _auto(M, a), kern, U) for a, kern in zip(index_s, kernels)])
        if np.all(est.sum(axis=1) <= budget):
            open_i = np.zeros(k.size - 1, dtype=bool)
            break
        rel = est / np.maximum(budget, 1e-300)[:, None]
        worst = np.argsort(-rel.max(axis=0), kind="stable")
        shut = rel.sum(axis=1) - np.cumsum(rel[:, worst], axis=1).T  # per opened count, what stays shut
        n_open = int(np.argmax(np.all(shut <= 0.5, axis=1))) + 1
        open_i = np.zeros(k.size - 1, dtype=bool)
        open_i[worst[:n_open]] = True
    scale = np.array([_scale(k, _auto(M, a), kern, U) for a, kern in zip(index_s, kernels)])
    error = est.sum(axis=1) / np.maximum(scale, 1e-300)
    return {"k1": k, "matrix": M, "error": tuple(float(e) for e in error), "converged": not bool(open_i.any()),
            "rounds": rounds}
