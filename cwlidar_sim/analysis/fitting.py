"""Least-squares fit of the Mann (1994) tensor parameters to measured one-point spectra.

As in Mann (1994, section 5), the three parameters (alpha_eps, L, Gamma) are
chosen so that the model's one-point spectra F11, F22, F33 and F13
(:func:`cwlidar_sim.turbulence.one_point_spectra`) match the measured,
log-smoothed ones in the least-squares sense, the residuals being taken on
the premultiplied spectra ``k1 F_ij(k1)``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._repr import summary_repr
from .._validation import check_int, check_real
from ..turbulence.parameters import GAMMA_MAX, LENGTH_SCALE_MAX

__all__ = ["MannFit", "fit_mann", "fit_quality"]

_PARAM_NAMES = ("alpha_eps", "length_scale", "gamma")
_DEFAULT_BOUNDS = {"length_scale": (0.5, LENGTH_SCALE_MAX), "gamma": (0.0, GAMMA_MAX)}
# Every component's k1 F_33 peaks at k1 L = 1.8-2.2 for Gamma in 0..5
# (checked on one_point_spectra), which gives the initial L.
_KL_PEAK_33 = 2.0
_DEFAULT_GAMMA = 3.0
#: A parameter within this fraction of its bound's span (L on a log scale) is "at the bound": the optimiser
#: stopped there, the fit is not a minimum and its linearised uncertainties do not hold.
_AT_BOUND = 1e-3
#: Largest RMS relative residual of a fit the tensor describes.  A record of the tensor leaves 0.1-0.2 (the
#: spectra's sampling scatter, tests/analysis/test_records.py); white noise or a spike train leaves more.
MAX_RESIDUAL_RMS = 0.5


@dataclasses.dataclass(frozen=True)
class MannFit:
    """Result of :func:`fit_mann`.

    Attributes
    ----------
    params : MannParameters
        Fitted alpha_eps [m^(4/3) s^-2], length_scale L [m] and gamma [-].
    std : dict
        1-sigma uncertainties ``{"alpha_eps": ..., "length_scale": ...,
        "gamma": ...}`` (square roots of the diagonal of ``covariance``).
    covariance : ndarray, shape (3, 3)
        Covariance of (alpha_eps, length_scale, gamma), linearised at the
        optimum (see :func:`fit_mann`).
    residual_rms : float
        RMS of the weighted residuals of the premultiplied spectra, relative
        to each component's scale [-].
    n_points : int
        Number of residuals (component x bin values that were finite).
    success : bool
        The optimiser converged, alpha_eps > 0 and the covariance is finite.
    message : str
        The optimiser's message (and the reason for a failure).
    nfev : int
        Model evaluations on the fine quadrature (calls of
        ``one_point_spectra`` on all bins): the Gauss-Newton finish, its
        Jacobian and the final model (6).
    nfev_coarse : int
        Evaluations of the search on the coarse quadrature.
    covariance_method : str
        "residual" (``(J^T J)^-1`` times the residual variance) or
        "chi-square" (sandwich with the sampling covariance implied by
        ``n_k``).
    """

    __repr__ = summary_repr

    params: object
    std: dict
    covariance: np.ndarray
    residual_rms: float
    n_points: int
    success: bool
    message: str
    nfev: int = 0
    covariance_method: str = "residual"
    nfev_coarse: int = 0


def _model_spectra(k_k, L, gamma, rule="fine"):
    """One-sided (F11, F22, F33, F13) for alpha_eps = 1, shape (4, n) (the bins shared among the threads)."""
    from ..turbulence import MannParameters, one_point_spectra

    return np.array(one_point_spectra(k_k, MannParameters(1.0, L, gamma), rule=rule))


def _check_pair(name, value, lo, hi):
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ValueError(f"bounds[{name!r}] must be a (low, high) pair, got {value!r}")
    a = check_real(f"bounds[{name!r}][0]", value[0], lo=lo, hi=hi)
    b = check_real(f"bounds[{name!r}][1]", value[1], lo=a, lo_open=True, hi=hi)
    return a, b


def _parse_bounds(bounds):
    out = dict(_DEFAULT_BOUNDS)
    if bounds is None:
        return out
    if not isinstance(bounds, dict):
        raise TypeError(f"bounds must be a dict with keys 'length_scale' and/or 'gamma', got {type(bounds).__name__}")
    unknown = sorted(set(bounds) - set(out))
    if unknown:
        raise ValueError(f"unknown key(s) in bounds: {unknown}; allowed: ['gamma', 'length_scale'] "
                         f"(alpha_eps is solved in closed form and needs no bounds)")
    if "length_scale" in bounds:
        # the tensor's own range (MannParameters refuses a fit outside it only after the fit has run)
        out["length_scale"] = _check_pair("length_scale", bounds["length_scale"], 1e-6, LENGTH_SCALE_MAX)
        if out["length_scale"][0] <= 0:
            raise ValueError(f"bounds['length_scale'] = {bounds['length_scale']!r}; allowed: 0 < low < high")
    if "gamma" in bounds:
        out["gamma"] = _check_pair("gamma", bounds["gamma"], 0.0, GAMMA_MAX)
    return out


def _parse_initial(initial):
    from ..turbulence import MannParameters

    if initial is None:
        return None, None
    if isinstance(initial, MannParameters):
        return initial.length_scale, initial.gamma
    if isinstance(initial, dict):
        unknown = sorted(set(initial) - set(_PARAM_NAMES))
        if unknown:
            raise ValueError(f"unknown key(s) in initial: {unknown}; allowed: {list(_PARAM_NAMES)}")
        L = initial.get("length_scale")
        g = initial.get("gamma")
        L = None if L is None else check_real("initial['length_scale']", L, lo=0.0, lo_open=True)
        g = None if g is None else check_real("initial['gamma']", g, lo=0.0)
        return L, g
    raise TypeError(f"initial must be a MannParameters or a dict, got {type(initial).__name__}")


def _sampling_cov(G, n_k):
    """Per-bin 4x4 covariance of the bin means (F11, F22, F33, Re F13) from chi-square statistics.

    For circular complex Gaussian Fourier coefficients (U, V, W) with
    one-point cross-spectra G (V uncorrelated with U and W, F12 = F23 = 0
    for the Mann tensor), Isserlis' theorem gives per raw value
    var|U|^2 = G11^2, cov(|U|^2, |W|^2) = G13^2,
    cov(|U|^2, Re U W^*) = G11 G13, cov(|W|^2, Re U W^*) = G33 G13,
    var Re(U W^*) = (G11 G33 + G13^2) / 2; a bin mean of n values divides
    these by n.
    """
    g11, g22, g33, g13 = G
    C = np.zeros((G.shape[1], 4, 4))
    C[:, 0, 0] = g11**2
    C[:, 1, 1] = g22**2
    C[:, 2, 2] = g33**2
    C[:, 3, 3] = 0.5 * (g11 * g33 + g13**2)
    C[:, 0, 2] = C[:, 2, 0] = g13**2
    C[:, 0, 3] = C[:, 3, 0] = g11 * g13
    C[:, 2, 3] = C[:, 3, 2] = g33 * g13
    return C / n_k[:, None, None]


def _finish(model_q, alpha_of, bq_ck, ok_ck, L, g):
    """The fine model at (L, g), the Jacobian of the residuals in (alpha_eps, L, Gamma) there, and the
    Gauss-Newton step in (ln L, Gamma) it gives (alpha_eps in closed form).

    The Jacobian: alpha_eps analytically, L and Gamma by central differences
    of 1e-3 (one-sided where Gamma - 1e-3 would be negative); 5 fine evaluations.
    """
    aq_ck = model_q(L, g)
    alpha = max(alpha_of(aq_ck), 1e-300)
    hL = 1e-3 * L
    hg = 1e-3 * max(1.0, g)
    dL_ck = (model_q(L + hL, g) - model_q(L - hL, g)) / (2.0 * hL)
    if g - hg >= 0.0:
        dg_ck = (model_q(L, g + hg) - model_q(L, g - hg)) / (2.0 * hg)
    else:
        dg_ck = (model_q(L, g + hg) - aq_ck) / hg
    J_m3 = np.stack([aq_ck[ok_ck], alpha * dL_ck[ok_ck], alpha * dg_ck[ok_ck]], axis=1)
    r_m = (alpha * aq_ck - bq_ck)[ok_ck]
    try:
        step = np.linalg.lstsq(J_m3, -r_m, rcond=None)[0]
    except np.linalg.LinAlgError:
        step = np.zeros(3)
    if not np.all(np.isfinite(step)):
        step = np.zeros(3)
    dx = (math.log1p(max(step[1] / L, -0.5)), float(step[2]))
    return aq_ck, J_m3, dx


def fit_mann(k1_k, F11_k, F22_k, F33_k, F13_k, *, one_sided=True, initial=None, bounds=None, weights=None,
             n_k=None, max_nfev=60):
    """Fit (alpha_eps, L, Gamma) of the Mann tensor to measured one-point spectra.

    Parameters
    ----------
    k1_k : array_like, shape (n,)
        Wavenumbers k1 of the (log-smoothed) spectra [rad/m], > 0.
    F11_k, F22_k, F33_k, F13_k : array_like, shape (n,)
        Measured spectra of u, v, w and Re of the u-w cross-spectrum
        [m^3 s^-2 = (m/s)^2 / (rad/m)]; NaN values (e.g. empty bins) are
        skipped.
    one_sided : bool
        True (the default) if the measured spectra are one-sided in k1, the
        package's convention (:func:`component_spectra`): the model is
        :func:`~cwlidar_sim.turbulence.one_point_spectra`'s ``F_ij`` as it
        is.  False for two-sided spectra (``integral over -inf..inf``, Mann's
        convention): the model is then ``F_ij / 2``.
    initial : MannParameters or dict, optional
        Starting ``length_scale`` and ``gamma`` (alpha_eps, solved in closed
        form, is ignored).  Default: ``L = 2 / k_peak`` with k_peak the
        bin where the measured k1 F33 is largest (k1 F33 peaks at
        k1 L = 1.8-2.2 whatever Gamma), and Gamma = 3.
    bounds : dict, optional
        ``{"length_scale": (lo, hi), "gamma": (lo, hi)}`` [m], [-]; default
        L in [0.5, 5000] m, Gamma in [0, 8].
    weights : array_like, optional
        Non-negative factors on the residuals, broadcastable to (4, n)
        (rows in the order 11, 22, 33, 13), e.g. ``sqrt(n_k)``.  Default 1.
    n_k : array_like of int, shape (n,), optional
        Raw periodogram values averaged into each bin (from
        :func:`component_spectra`).  When given, the covariance is the
        "sandwich" with the chi-square sampling covariance of the bin means
        instead of the residual-variance estimate (see Notes).
    max_nfev : int
        Maximum evaluations of the search (>= 5).

    Returns
    -------
    MannFit

    Notes
    -----
    Residuals: ``r_c(k_in) = w_c(k_in) (alpha_eps k_in G_c(k_in; L, Gamma) - k_in F_c(k_in)) / s_c``
    with G_ck the model for alpha_eps = 1, F_ck_in the measurement, and the scale
    s_c the RMS of the measured ``k_in F_c`` over the finite bins for c = 11,
    22, 33 and ``sqrt(s_11 s_33)`` for the cross-spectrum (which crosses
    zero; its own RMS would over-weight it).  alpha_eps enters linearly and
    is solved in closed form inside the loop (variable projection);
    ``scipy.optimize.least_squares`` (trust-region reflective) varies
    (ln L, Gamma) within the bounds with a forward-difference Jacobian, on
    the coarse one-point quadrature (``rule='coarse'``, within 2.5e-4 of the
    fine one, 0.3 of its nodes).  One Gauss-Newton step on the fine quadrature
    (in alpha_eps, L, Gamma; L and Gamma kept within the bounds) then moves
    the result to the fine model's optimum: on A2012's four periods (36 bins)
    it agrees with a search run on the fine quadrature throughout to 8e-6
    in L and 3e-7 in Gamma, 1e-4 of their standard errors, which is that
    search's own tolerance (``tests/analysis/test_analysis_fitting.py``).

    Uncertainty: the Jacobian J_m3 of the residuals with respect to
    (alpha_eps, L, Gamma) of that step (alpha_eps analytically, L and Gamma
    by central differences on the fine quadrature, at the search's optimum,
    within ~1e-5 of the final one).  Without ``n_k``, ``covariance =
    (J_m3^T J_m3)^-1 * sum(r_m^2) / (m - 3)`` (m residuals), which assumes
    independent residuals of equal variance.  With ``n_k``,
    ``covariance = (J_m3^T J_m3)^-1 J_m3^T S_mm J_m3 (J_m3^T J_m3)^-1`` where S_mm is the covariance
    of the weighted residuals implied by chi-square statistics of averaged
    periodograms (each bin mean of n raw values has ``var F_ii = F_ii^2 / n``
    etc., evaluated with the fitted model; see ``_sampling_cov``); this is
    the right linearised covariance when the model holds and the bins are
    independent, as for a stationary Gaussian record.  Measured on five
    realisations of a 2**17-point line (15 bins, 5 per decade, 2e-3..2
    rad/m): the seed-to-seed scatter of (L, Gamma) was (0.85 m, 0.157); the
    chi-square estimate reported (1.31 m, 0.142), the residual estimate
    (0.97 m, 0.064).  The residual estimate understates Gamma's uncertainty
    about 2.5-fold, because the low-k_in bins that fix Gamma scatter more than
    the average residual and the components of a bin are correlated: pass
    ``n_k`` whenever it is known.

    Cost: each evaluation integrates the tensor at every bin
    (``one_point_spectra``, about 5 ms per k1 value on one core with the fine
    rule, 1.5 ms with the coarse one; the bins are shared among the
    configured threads).  A fit takes typically 10-25 coarse evaluations and
    6 fine ones: one A2012 period's fit (36 bins) takes 0.85 s on 2 cores.
    """
    from scipy.optimize import least_squares

    from ..turbulence import MannParameters

    k_in = np.asarray(k1_k, dtype=float)
    if k_in.ndim != 1 or k_in.size < 2:
        raise ValueError(f"k1_k must be a 1-D array of at least 2 wavenumbers, got shape {k_in.shape}")
    F_ck_in = []
    for name, a in zip(("F11_k", "F22_k", "F33_k", "F13_k"), (F11_k, F22_k, F33_k, F13_k)):
        a = np.asarray(a, dtype=float)
        if a.shape != k_in.shape:
            raise ValueError(f"{name} has shape {a.shape}, k1_k has {k_in.shape}; allowed: equal shapes")
        F_ck_in.append(a)
    F_ck_in = np.array(F_ck_in)
    if not isinstance(one_sided, (bool, np.bool_)):
        raise TypeError(f"one_sided must be a bool, got {type(one_sided).__name__}")
    max_nfev = check_int("max_nfev", max_nfev, lo=5, hi=10_000)
    kfin = np.isfinite(k_in)
    if np.any(k_in[kfin] <= 0):
        raise ValueError(f"k1_k must be > 0 rad/m, got min {k_in[kfin].min()!r}")
    W_ck_in = np.ones((4, k_in.size))
    if weights is not None:
        try:
            W_ck_in = np.broadcast_to(np.asarray(weights, dtype=float), (4, k_in.size)).copy()
        except ValueError:
            raise ValueError(f"weights of shape {np.shape(weights)} do not broadcast to (4, {k_in.size})") from None
        if not np.all(np.isfinite(W_ck_in)) or np.any(W_ck_in < 0):
            raise ValueError("weights must be finite and >= 0")
    nk_k = None
    if n_k is not None:
        nk_k = np.asarray(n_k, dtype=float)
        if nk_k.shape != k_in.shape:
            raise ValueError(f"n_k has shape {nk_k.shape}, k1_k has {k_in.shape}; allowed: equal shapes")
    valid = np.isfinite(F_ck_in) & kfin[None, :] & (W_ck_in > 0)
    if nk_k is not None:
        valid &= (nk_k > 0)[None, :]
    bins = valid.any(axis=0)
    if np.count_nonzero(valid) < 4 or np.count_nonzero(bins) < 2:
        raise ValueError(f"only {np.count_nonzero(valid)} finite spectral values in {np.count_nonzero(bins)} "
                         f"bins; allowed: at least 4 values in 2 bins")
    bnd = _parse_bounds(bounds)
    L0, g0 = _parse_initial(initial)

    k_k = k_in[bins]
    F_ck = F_ck_in[:, bins]
    ok_ck = valid[:, bins]
    W_ck = W_ck_in[:, bins]
    b_ck = k_k[None, :] * F_ck
    scale = np.full(4, np.nan)
    for c in range(4):
        if ok_ck[c].any():
            scale[c] = math.sqrt(np.mean(b_ck[c, ok_ck[c]] ** 2))
    if np.isfinite(scale[0]) and np.isfinite(scale[2]):
        scale[3] = math.sqrt(scale[0] * scale[2])
    if np.any(~np.isfinite(scale[ok_ck.any(axis=1)])) or np.any(scale[ok_ck.any(axis=1)] <= 0):
        raise ValueError(f"a measured spectrum is identically zero (scales {scale.tolist()}); "
                         f"allowed: spectra with non-zero values")
    Q_ck = np.where(ok_ck, W_ck / np.where(np.isfinite(scale), scale, 1.0)[:, None], 0.0)
    bq_ck = np.where(ok_ck, b_ck, 0.0) * Q_ck
    sided = 1.0 if one_sided else 0.5  # one_point_spectra is one-sided

    if L0 is None:
        if ok_ck[2].any():
            i_pk = np.argmax(np.where(ok_ck[2], b_ck[2], -np.inf))
            L0 = _KL_PEAK_33 / k_k[i_pk]
        else:
            L0 = 30.0
    if g0 is None:
        g0 = _DEFAULT_GAMMA
    L0 = min(max(L0, bnd["length_scale"][0]), bnd["length_scale"][1])
    g0 = min(max(g0, bnd["gamma"][0]), bnd["gamma"][1])

    nfev = [0, 0]

    def model_q(L, g, rule="fine"):
        nfev[rule == "coarse"] += 1
        return sided * k_k[None, :] * _model_spectra(k_k, L, g, rule) * Q_ck

    def alpha_of(aq_ck):
        den = np.sum(aq_ck * aq_ck)
        return np.sum(aq_ck * bq_ck) / den if den > 0 else 0.0

    def resid(x):
        aq_ck = model_q(math.exp(x[0]), x[1], "coarse")
        al = max(alpha_of(aq_ck), 1e-300)
        return (al * aq_ck - bq_ck)[ok_ck]

    lb = [math.log(bnd["length_scale"][0]), bnd["gamma"][0]]
    ub = [math.log(bnd["length_scale"][1]), bnd["gamma"][1]]
    x0 = np.clip([math.log(L0), g0], lb, ub)
    # The search runs on the coarse quadrature (within 2.5e-4); the fine one finishes it below.
    res = least_squares(resid, x0, bounds=(lb, ub), method="trf", jac="2-point", diff_step=1e-4,
                        x_scale=np.array([1.0, 1.0]), xtol=1e-6, ftol=1e-8, gtol=1e-8, max_nfev=max_nfev)
    message = str(res.message)
    success = bool(res.status > 0)
    L, g = math.exp(res.x[0]), float(res.x[1])
    aq_ck, J_m3, dx = _finish(model_q, alpha_of, bq_ck, ok_ck, L, g)
    # One Gauss-Newton step on the fine model, bounded, from the coarse optimum (a 2.5e-4 model
    # difference moves the optimum by about as much, so one step lands within ~1e-7 of it).
    L, g = math.exp(min(max(math.log(L) + dx[0], lb[0]), ub[0])), min(max(g + dx[1], lb[1]), ub[1])
    aq_ck = model_q(L, g)
    alpha = alpha_of(aq_ck)
    if not alpha > 0:
        success = False
        message += f"; closed-form alpha_eps = {alpha:.3g} is not positive"
        alpha = max(alpha, 1e-300)
    r_m = (alpha * aq_ck - bq_ck)[ok_ck]
    m = r_m.size
    cov = np.full((3, 3), np.nan)
    method = "residual" if nk_k is None else "chi-square"
    try:
        A = np.linalg.inv(J_m3.T @ J_m3)
        if nk_k is None:
            if m > 3:
                cov = A * (r_m @ r_m) / (m - 3)
        else:
            G_ck = sided * _model_spectra(k_k, L, g) * alpha  # measured-convention model spectra
            C_k44 = _sampling_cov(G_ck, nk_k[bins])  # (nbins, 4, 4)
            # Residual covariance: r_m = Q_ck k_in (model - F_hat), entries (c, bin) kept by ok_ck.
            idx = np.full((4, k_k.size), -1)
            idx[ok_ck] = np.arange(m)
            S_mm = np.zeros((m, m))
            for j in range(k_k.size):
                comp = np.nonzero(ok_ck[:, j])[0]
                e = idx[comp, j]
                fac = Q_ck[comp, j] * k_k[j]
                S_mm[np.ix_(e, e)] = C_k44[j][np.ix_(comp, comp)] * np.outer(fac, fac)
            JS_33 = J_m3.T @ S_mm @ J_m3
            cov = A @ JS_33 @ A
    except np.linalg.LinAlgError:
        message += "; singular Jacobian, no covariance"
    if not np.all(np.isfinite(cov)):
        success = False
    std = {n: float(math.sqrt(cov[i, i])) if np.isfinite(cov[i, i]) and cov[i, i] >= 0 else math.nan
           for i, n in enumerate(_PARAM_NAMES)}
    params = MannParameters(alpha_eps=float(alpha), length_scale=L, gamma=g)
    return MannFit(params=params, std=std, covariance=cov, residual_rms=float(math.sqrt(np.mean(r_m * r_m))),
                   n_points=int(m), success=success, message=message, nfev=int(nfev[0]),
                   nfev_coarse=int(nfev[1]),
                   covariance_method=method)


def fit_quality(fit: MannFit, bounds=None) -> dict:
    """Whether a fit can be trusted: the parameters at a bound, a failed optimiser, a large residual.

    Parameters
    ----------
    fit : MannFit
        From :func:`fit_mann`.
    bounds : dict, optional
        The bounds the fit was given (default: :func:`fit_mann`'s).

    Returns
    -------
    dict
        ``{"quality": "ok" or "suspect", "at_bound": [names of the parameters
        at a bound, e.g. "length_scale=0.5 (lower bound)"], "reasons": [...]}``.
        A record the tensor cannot describe (white noise, a record in wrong
        units) drives L or Gamma to a bound: its "fit" is the bound, not a
        measurement.
    """
    if not isinstance(fit, MannFit):
        raise TypeError(f"fit must be a MannFit, got {type(fit).__name__}")
    bnd = _parse_bounds(bounds)
    p = fit.params
    at = []
    for name, value, log in (("length_scale", p.length_scale, True), ("gamma", p.gamma, False)):
        lo, hi = bnd[name]
        f = (lambda x: math.log(x)) if log else (lambda x: x)
        span = f(hi) - f(lo)
        for edge, which in ((lo, "lower"), (hi, "upper")):
            if abs(f(value) - f(edge)) <= _AT_BOUND * span:
                at.append(f"{name}={value:.4g} ({which} bound)")
    reasons = [f"{a}: the optimiser stopped at the bound" for a in at]
    if not fit.success:
        reasons.append(f"the optimiser failed ({fit.message})")
    if not fit.residual_rms <= MAX_RESIDUAL_RMS:
        reasons.append(f"residual_rms = {fit.residual_rms:.3g} > {MAX_RESIDUAL_RMS} (the tensor does not describe "
                       f"the spectra)")
    return {"quality": "suspect" if reasons else "ok", "at_bound": at, "reasons": reasons}
