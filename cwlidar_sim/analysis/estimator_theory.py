"""The Doppler estimator as part of the filter: each estimator's expected transfer function (aligned beam).

A lidar's speed is not the weighted line-of-sight average of A2012 Eq. 2 but
an *estimator* (median, centroid, peak, ml: :data:`cwlidar_sim.signal.ESTIMATORS`)
applied to a speckled Doppler spectrum; a nonlinear estimator responds to the
velocity distribution in the probe volume, not to its mean, so its transfer
function depends on the turbulence, the spectral resolution and window, the
line broadening and the threshold, not only on zR.

Model (a documented fast numerical one)
---------------------------------------
For the staring beam along the mean wind (A2012's geometry, misalignment 0):

1. ``n_lines`` independent periodic lines of u along x
   (:func:`cwlidar_sim.turbulence.generate_line`, the scene's Mann
   parameters and spacing ``dx``), seeded from ``seed`` alone: nothing is
   shared with a campaign's realisation.
2. One estimate per grid point ``x_i`` (the focus there): the range cells of
   the staring beam (:func:`cwlidar_sim.beam.cells.probe_cells`, the cells
   every lidar uses: its weighting, span, cell length, growth and tail rule)
   at ``x_i - s`` (the beam looks upwind), their speeds ``U + u`` linearly
   interpolated on the periodic line at the cells' sub-points, exactly as the
   sensor samples a line field (the mean-wind tail stays out of the
   spectrum, as in :mod:`cwlidar_sim.signal.chain`).
3. The tier-2 continuum-speckle spectra of those cells
   (:func:`cwlidar_sim.signal.spectral.continuum_moments` and
   :func:`~cwlidar_sim.signal.spectral.sample_moments`: the instrument's
   resolution, window, noise, threshold, the sub-cell spread from the
   tensor, the transit time and any instrument line broadening) and every
   requested estimator on the *same* spectra
   (:func:`cwlidar_sim.signal.estimate`, exact noise floor).
4. The point speed ``u(x_i)`` (a noise-free sonic at the focus) and the
   estimates along each line are Fourier transformed (periodic: no window,
   no leakage) and, per log bin of k, the regression of the estimates on the
   point speed ``H = sum Re(V_r U^*) / sum |U|^2`` over the lines' modes
   gives method 2, ``T2 = H^2`` (A2012 Eq. 11: ``Re(chi)^2 / F_vs^2``).
   Its 1-sigma uncertainty is ``2 |H| sigma_H`` with
   ``sigma_H^2 = sum |R|^2 |U|^2 / 2 / (sum |U|^2)^2``, ``R = V_r - H U``
   the part of the estimates uncorrelated with the point speed (speckle
   noise and the estimator's nonlinearity).  Method 1 is not given: its
   high-k floor is the estimator noise per unit wavenumber, which depends on
   the estimate rate and block averaging, not on the filter.

Every estimate of a campaign sees the same per-estimate physics, so the
campaign's method 2 scatters about this ``T2`` (validated in
``studies/validate_estimator_theory.py``).  Failed estimates (NaN) are
replaced by their line's mean and counted (``availability_e``).

Effective probe length
----------------------
``zR_eff`` is the weighted least-squares fit of ``log T2 = -2 k zR_eff``
over the bins of ``band`` (default 0.02-0.6 rad/m, the band of the
campaign's ``t2_log_error``), weights ``(T2 / sigma_T2)^2``.  A single
exponential does not describe the median well (its attenuation grows like
``(k zR)^2`` at low k), so the band is part of the answer.

Spectrum convention: transfer functions are ratios and need none; k1 in rad/m.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from .._seeding import seed_int
from .._repr import summary_repr
from .._validation import check_choice, check_int, check_real, check_seed

__all__ = ["EstimatorTransfer", "THEORY_ESTIMATORS", "estimator_transfer", "fit_zr_eff", "DEFAULT_BAND", "THEORY_SEED",
           "ProbeLengthFit", "ProbeLengthError", "fit_probe_length", "radius_of_rayleigh_length", "ZR_FACTORS"]

#: Band of k [rad/m] over which zR_eff is fitted by default.
DEFAULT_BAND = (0.02, 0.6)
#: The estimators the campaign's theory covers.
THEORY_ESTIMATORS = ("median", "centroid", "peak", "ml")
#: Default seed of the theory's own line fields (independent of every campaign seed by construction).
THEORY_SEED = 20130013


@dataclasses.dataclass(frozen=True)
class EstimatorTransfer:
    """Expected method-2 transfer function of each estimator (:func:`estimator_transfer`).

    Attributes
    ----------
    estimators : tuple of str
    k_k : ndarray, shape (n_k,)
        Bin centres (geometric mean of the edges) [rad/m].
    k_edges : ndarray, shape (n_k + 1,)
    transfer_cross_ek : ndarray, shape (n_estimators, n_k)
        ``Re(chi)^2 / F_vs^2`` [-]; NaN in bins without a line mode.
    transfer_cross_sigma_ek : ndarray
        Its 1-sigma ensemble uncertainty [-].
    n_modes_k : ndarray of int
        Fourier modes (over all lines) in each bin.
    zR_eff_e, zR_eff_sigma_e : ndarray, shape (n_estimators,)
        Effective probe length [m] and its 1-sigma uncertainty.
    band : (float, float)
        k band of the zR_eff fit [rad/m].
    rayleigh_length : float
        zR of the instrument (A2012 Eq. 1) [m].
    availability_e : ndarray
        Fraction of valid estimates per estimator [-].
    info : dict
        Settings (U, dx, cells, sub-cell spread, correlation time, lines,
        points, seed) and the wall time [s].
    """

    __repr__ = summary_repr

    estimators: tuple
    k_k: np.ndarray
    k_edges: np.ndarray
    transfer_cross_ek: np.ndarray
    transfer_cross_sigma_ek: np.ndarray
    n_modes_k: np.ndarray
    zR_eff_e: np.ndarray
    zR_eff_sigma_e: np.ndarray
    band: tuple
    rayleigh_length: float
    availability_e: np.ndarray
    info: dict


def _check_band(band):
    if not isinstance(band, (tuple, list)) or len(band) != 2:
        raise ValueError(f"band must be (k_lo, k_hi) in rad/m, got {band!r}")
    lo = check_real("band[0]", band[0], lo=0.0, lo_open=True)
    hi = check_real("band[1]", band[1], lo=lo, lo_open=True)
    return lo, hi


def fit_zr_eff(k_k, transfer_cross_k, transfer_cross_sigma_k=None, band=DEFAULT_BAND):
    """Best ``zR_eff`` of ``T2 = exp(-2 k zR_eff)`` over ``band``: ``(zR_eff, sigma, n_bins_used)``.

    Weighted least squares on ``log T2`` (weights ``(T2 / sigma_T2)^2``, or
    1 without sigma): ``zR_eff = -sum w k log T2 / (2 sum w k^2)``,
    ``sigma = 1 / (2 sqrt(sum w k^2))`` (with unit weights, scaled by the
    residual rms).  Bins outside the band, non-finite or <= 0 are skipped;
    NaN when none is left.
    """
    lo, hi = _check_band(band)
    k = np.asarray(k_k, dtype=np.float64)
    T = np.asarray(transfer_cross_k, dtype=np.float64)
    s = None if transfer_cross_sigma_k is None else np.asarray(transfer_cross_sigma_k, dtype=np.float64)
    ok = (k >= lo) & (k <= hi) & np.isfinite(T) & (T > 0)
    if s is not None:
        ok &= np.isfinite(s) & (s > 0)
    n = int(np.count_nonzero(ok))
    if n == 0:
        return math.nan, math.nan, 0
    kk, y = k[ok], np.log(T[ok])
    w = np.ones(n) if s is None else (T[ok] / s[ok]) ** 2
    z = -float(np.sum(w * kk * y) / (2.0 * np.sum(w * kk * kk)))
    sig = 1.0 / (2.0 * math.sqrt(float(np.sum(w * kk * kk))))
    if s is None:
        res = y + 2.0 * kk * z
        sig *= math.sqrt(float(np.sum(res * res)) / max(n - 1, 1))
    return z, sig, n


def _line_cells(instrument, weighting: str = "exact", span: float = 20.0, cell_length: float = 0.5, *,
                growth: float = 0.0, tail: str = "mean_wind"):
    """Range cells of the staring beam: the probe cells every lidar uses (:func:`cwlidar_sim.beam.cells.probe_cells`).

    The span ``[-span z_R, span z_R]`` around the focus, clipped at the
    telescope, cut into cells of about ``cell_length`` (growing in the tails
    with ``growth``), each sampled at its sub-points; the spectrum's cells
    are these (the mean-wind tail cell is a sub-threshold pedestal, left out
    of the spectrum as :mod:`cwlidar_sim.signal.chain` does).

    Returns
    -------
    cwlidar_sim.beam.cells.ProbeCells
    """
    from ..beam.cells import probe_cells
    from ..beam.probe import get_weighting

    get_weighting(weighting)  # a registered name, checked first
    span = check_real("span", span, lo=0.0, hi=1000.0, lo_open=True)
    cell_length = check_real("cell_length", cell_length, lo=0.0, hi=1000.0, lo_open=True)
    return probe_cells(instrument.optics(), weighting, span, cell_length, growth=growth, tail=tail)


def estimator_transfer(instrument, params, U, *, estimators=THEORY_ESTIMATORS, k_edges=None,
                       cnr_db=-10.0, weighting="exact", span=20.0, dx=0.5, cell_length=None, cell_growth=0.0,
                       tail="mean_wind", subcell_spread=None, transverse_speed=None, n_lines=8, n_points=4096,
                       seed=THEORY_SEED, band=DEFAULT_BAND, modulation=None, gain=1.0,
                       chunk=1024) -> EstimatorTransfer:
    """Expected method-2 transfer function of each estimator for the beam along the wind (module notes).

    Parameters
    ----------
    instrument : Instrument
        Resolution, window, threshold, noise, line broadening; its own
        ``estimator`` is ignored (see ``estimators``).
    params : MannParameters
        Turbulence.
    U : float
        Mean wind along the beam [m/s]; in [1, 30] (sets the Doppler bin of
        the line; the estimates must stay clear of the blind zone).
    estimators : sequence of str
        Names from :data:`cwlidar_sim.signal.ESTIMATORS`, evaluated on the
        same spectra.
    k_edges : array_like, optional
        Bin edges [rad/m]; default 10 per decade over 1e-3 .. pi/dx.
    cnr_db : float
        Wideband CNR [dB]; in [-40, 60].
    weighting, span : as :class:`cwlidar_sim.sensors.StaringLidar`.
    dx : float
        Line spacing [m]; in [0.05, 10] (the campaign's ``field.dx``).
    cell_length : float, optional
        Range-cell length [m]; default ``dx``.
    cell_growth, tail
        The probe cells' growth and tail rule (:func:`cwlidar_sim.beam.cells.probe_cells`), as the lidar's.
    subcell_spread : float, optional
        Sub-cell speed spread [m/s]; default ``sqrt(subcell_variance(params, dx))``.
    transverse_speed : float, optional
        Aerosol speed across the beam [m/s] (speckle transit time); default
        ``sqrt(sigma_v^2 + sigma_w^2)`` of the tensor (the campaign's default).
    n_lines, n_points : int
        Ensemble size: lines of ``n_points`` points (power of two advised);
        cost is proportional to ``n_lines * n_points``.
    seed : int
        Seed of the theory's own lines and speckle.
    band : (float, float)
        k band of the zR_eff fit [rad/m].
    modulation : callable, optional
        ``modulation(rng, n_points, dx) -> ndarray (n_points,)`` of positive
        backscatter factors frozen in the flow (see
        :mod:`cwlidar_sim.signal.aerosol`); each estimate's cell weights are
        multiplied by it at the cells' positions and renormalised.
    gain : float
        Receiver gain relative to the background calibration [-]; in
        [0.5, 2] (``1 + instrument.background_mismatch`` of a campaign at the
        calibration's end; :func:`cwlidar_sim.signal.processing.background_gain`):
        every spectrum is multiplied by it before the estimator.
    chunk : int
        Estimates per batch (memory only).

    Returns
    -------
    EstimatorTransfer
    """
    from ..signal.instrument import Instrument
    from ..signal.processing import ESTIMATORS, estimate_variants
    from ..signal.spectral import continuum_moments, sample_moments
    from ..turbulence import MannParameters, covariances, generate_line, subcell_variance

    t0 = time.perf_counter()
    if not isinstance(instrument, Instrument):
        raise TypeError(f"instrument must be an Instrument, got {type(instrument).__name__}")
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be MannParameters, got {type(params).__name__}")
    U = check_real("U", U, lo=1.0, hi=30.0)
    est = tuple(estimators)
    if not est:
        raise ValueError("estimators must name at least one estimator")
    for e in est:
        check_choice("estimators", e, tuple(ESTIMATORS))
    cnr_db = check_real("cnr_db", cnr_db, lo=-40.0, hi=60.0)
    dx = check_real("dx", dx, lo=0.05, hi=10.0)
    cell_length = dx if cell_length is None else check_real("cell_length", cell_length, lo=0.01, hi=100.0)
    n_lines = check_int("n_lines", n_lines, lo=1, hi=10_000)
    n_points = check_int("n_points", n_points, lo=64, hi=2**22)
    seed = check_seed("seed", seed)
    band = _check_band(band)
    chunk = check_int("chunk", chunk, lo=1, hi=10**6)
    gain = check_real("gain", gain, lo=0.5, hi=2.0)
    if k_edges is None:
        from .spectra import log_bins

        k_edges = log_bins(1e-3, math.pi / dx, 10)
    e_k = np.asarray(k_edges, dtype=np.float64)
    if e_k.ndim != 1 or e_k.size < 2 or not np.all(np.isfinite(e_k)) or np.any(np.diff(e_k) <= 0) or e_k[0] <= 0:
        raise ValueError("k_edges must be a finite increasing 1-D array of > 0 rad/m with at least 2 edges")
    if subcell_spread is None:
        subcell_spread = math.sqrt(subcell_variance(params, dx))
    spread = check_real("subcell_spread", subcell_spread, lo=0.0, hi=100.0)
    if transverse_speed is None:
        c = covariances(params)
        transverse_speed = math.sqrt(c.vv + c.ww)
    vt = check_real("transverse_speed", transverse_speed, lo=0.0, hi=1000.0)
    tau = instrument.speckle_time(vt)

    cells = _line_cells(instrument, weighting, span, cell_length, growth=cell_growth, tail=tail)
    w_s = np.ascontiguousarray(cells.weight_s, dtype=np.float64)
    pos = -cells.sub_j / dx                   # sub-point offsets in grid steps (the beam looks upwind, -x)
    m_s = np.floor(pos).astype(np.int64)
    f_s = pos - m_s
    frac_j, ptr_s = cells.fraction_j, cells.ptr_s
    grown = cells.sub_j.size > cells.n_cells
    insts = [instrument.replace(estimator=e) for e in est]

    nf = n_points // 2 + 1
    k_m = 2.0 * math.pi * np.arange(nf) / (n_points * dx)
    bin_m = np.searchsorted(e_k, k_m, side="right") - 1
    use = (bin_m >= 0) & (bin_m < e_k.size - 1) & (np.arange(nf) > 0)
    nk = e_k.size - 1
    s_uu = np.zeros(nk)
    s_ru = np.zeros((len(est), nk))
    s_rr = np.zeros((len(est), nk))
    per_line = []                            # (R_m, U_m) to get the residual after H is known
    line_ru, line_uu = [], []
    n_bad = np.zeros(len(est), dtype=np.int64)
    streams = np.random.SeedSequence(seed).spawn(n_lines)
    for j, ssj in enumerate(streams):
        s_line, s_speckle, s_mod = ssj.spawn(3)
        line_seed = seed_int(s_line)
        u_x = np.asarray(generate_line(params, n_points, dx, line_seed).u.values, dtype=np.float64)
        key = np.uint64(seed_int(s_speckle))
        mod_x = None
        if modulation is not None:
            mod_x = np.asarray(modulation(np.random.default_rng(s_mod), n_points, dx), dtype=np.float64)
            if mod_x.shape != (n_points,) or not np.all(np.isfinite(mod_x)) or np.any(mod_x < 0):
                raise ValueError("modulation must return n_points finite factors >= 0")
        v_ex = np.empty((len(est), n_points))
        for c0 in range(0, n_points, chunk):
            c1 = min(n_points, c0 + chunk)
            i_e = np.arange(c0, c1)[:, None]
            i0 = (i_e + m_s[None, :]) % n_points
            i1 = (i0 + 1) % n_points
            vlos_es = U + (1.0 - f_s) * u_x[i0] + f_s * u_x[i1]
            if grown:  # a grown cell's speed is its sub-points' weighted mean, as the sensor samples it
                vlos_es = U + np.add.reduceat((vlos_es - U) * frac_j, ptr_s[:-1], axis=1)
            if mod_x is None:
                mean, var, _ = continuum_moments(instrument, vlos_es, w_s, cnr_db, spread, correlation_time=tau)
            else:
                mod_es = (1.0 - f_s) * mod_x[i0] + f_s * mod_x[i1]
                if grown:
                    mod_es = np.add.reduceat(mod_es * frac_j, ptr_s[:-1], axis=1)
                mean, var = _modulated_moments(instrument, vlos_es, w_s, mod_es, cnr_db, spread, tau)
            spec = sample_moments(mean, var, key, e0=c0)
            if gain != 1.0:
                spec *= gain
            for a, e in enumerate(estimate_variants(spec, insts)):
                v_ex[a, c0:c1] = e.speed_e
        u_f = np.fft.rfft(u_x - u_x.mean())
        R = []
        for a in range(len(est)):
            bad = ~np.isfinite(v_ex[a])
            n_bad[a] += int(np.count_nonzero(bad))
            v = v_ex[a]
            if bad.all():
                v = np.zeros(n_points)
            elif bad.any():
                v = v.copy()
                v[bad] = np.mean(v[~bad])
            r_f = np.fft.rfft(v - v.mean())
            s_ru[a] += np.bincount(bin_m[use], (r_f[use] * np.conj(u_f[use])).real, minlength=nk)[:nk]
            s_rr[a] += np.bincount(bin_m[use], np.abs(r_f[use]) ** 2, minlength=nk)[:nk]
            R.append(r_f)
        uu_j = np.bincount(bin_m[use], np.abs(u_f[use]) ** 2, minlength=nk)[:nk]
        s_uu += uu_j
        line_uu.append(uu_j)
        line_ru.append(np.array([np.bincount(bin_m[use], (R[a][use] * np.conj(u_f[use])).real, minlength=nk)[:nk]
                                 for a in range(len(est))]))
        per_line.append((np.array(R), u_f))
    n_modes = np.bincount(bin_m[use], minlength=nk)[:nk] * n_lines
    with np.errstate(invalid="ignore", divide="ignore"):
        H_ek = s_ru / s_uu
        res = np.zeros((len(est), nk))
        for R, u_f in per_line:
            for a in range(len(est)):
                r = R[a][use] - H_ek[a][bin_m[use]] * u_f[use]
                res[a] += np.bincount(bin_m[use], 0.5 * np.abs(r) ** 2 * np.abs(u_f[use]) ** 2, minlength=nk)[:nk]
        sigma_H = np.sqrt(res) / s_uu
        T2 = H_ek**2
        sT2 = 2.0 * np.abs(H_ek) * sigma_H
    empty = n_modes == 0
    T2[:, empty] = np.nan
    sT2[:, empty] = np.nan
    k_k = np.sqrt(e_k[:-1] * e_k[1:])
    z = np.array([fit_zr_eff(k_k, T2[a], sT2[a], band)[:2] for a in range(len(est))]).reshape(len(est), 2)
    # realisation scatter: band mean of log T2 line by line, against what the per-bin sigmas predict for one line
    inb = (k_k >= band[0]) & (k_k <= band[1]) & np.all(np.isfinite(T2) & (T2 > 0), axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        lm = np.array([[np.mean(np.log((line_ru[j][a][inb] / line_uu[j][inb]) ** 2)) for j in range(n_lines)]
                       for a in range(len(est))])
        pred = np.sqrt(np.sum((sT2[:, inb] / T2[:, inb]) ** 2, axis=1)) / max(int(inb.sum()), 1) * math.sqrt(n_lines)
    info = {"U": U, "dx": dx, "cell_length": cell_length, "n_cells": int(w_s.size), "weighting": weighting,
            "span": span, "cnr_db": cnr_db, "subcell_spread": spread, "transverse_speed": vt,
            "correlation_time": tau, "n_lines": n_lines, "n_points": n_points, "seed": seed,
            "modulated": modulation is not None, "gain": gain, "line_mean_log_T2": lm, "band_bins": int(inb.sum()),
            "line_sd_predicted": pred, "wall_time": time.perf_counter() - t0}
    return EstimatorTransfer(estimators=est, k_k=k_k, k_edges=e_k, transfer_cross_ek=T2, transfer_cross_sigma_ek=sT2,
                             n_modes_k=n_modes,
                             zR_eff_e=z[:, 0], zR_eff_sigma_e=z[:, 1], band=band,
                             rayleigh_length=float(instrument.rayleigh_length),
                             availability_e=1.0 - n_bad / float(n_lines * n_points), info=info)


def _modulated_moments(instrument, vlos_es, w_s, mod_es, cnr_db, spread, tau):
    """continuum_moments with per-estimate weights ``w_s mod_es`` (renormalised), grouped row by row."""
    from ..signal.spectral import continuum_moments

    w_es = w_s[None, :] * mod_es
    w_es = w_es / np.sum(w_es, axis=1, keepdims=True)
    mean = np.empty((vlos_es.shape[0], instrument.n_bins))
    var = np.empty_like(mean)
    for e in range(vlos_es.shape[0]):
        m, v, _ = continuum_moments(instrument, vlos_es[e:e + 1], w_es[e], cnr_db, spread, correlation_time=tau)
        mean[e], var[e] = m[0], v[0]
    return mean, var


# ---------------------------------------------------------------------------
# probe length from measured method-2 values
# ---------------------------------------------------------------------------
class ProbeLengthError(ValueError):
    """Method-2 values that cannot give a probe length (no overlap with the band, all NaN, negative)."""


@dataclasses.dataclass(frozen=True)
class ProbeLengthFit:
    """Result of :func:`fit_probe_length`.

    Attributes
    ----------
    estimator : str
    zR, zR_sigma : float
        Rayleigh length [m] whose estimator theory fits the values best, and its 1-sigma uncertainty.
    a0, a0_sigma : float
        Telescope radius [m] that gives ``zR`` through A2012 Eq. 1, ``a0 = sqrt(lambda r^2 / (pi zR))``.
    zR_eff, zR_eff_sigma : float
        The values' own ``exp(-2 k zR_eff)`` fit over the band [m] (no estimator model).
    band : (float, float)
    n_bins : int
        Bins used.
    chi2 : float
        Minimum chi-square (with the given sigmas; else the log residuals' sum of squares).
    zR_grid, chi2_grid : ndarray
        The profile.
    nominal_zR, nominal_a0 : float
        Of the instrument given.
    """

    __repr__ = summary_repr

    estimator: str
    zR: float
    zR_sigma: float
    a0: float
    a0_sigma: float
    zR_eff: float
    zR_eff_sigma: float
    band: tuple
    n_bins: int
    chi2: float
    zR_grid: np.ndarray
    chi2_grid: np.ndarray
    nominal_zR: float
    nominal_a0: float

    def summary(self) -> dict:
        return {k: (list(map(float, v)) if isinstance(v, np.ndarray) else v)
                for k, v in dataclasses.asdict(self).items()}


#: Default factors on the nominal zR of the theory grid of :func:`fit_probe_length`.
ZR_FACTORS = (0.5, 0.71, 1.0, 1.41, 2.0, 2.83)


def _check_measured(k_k, transfer_cross_k, sigma_k, band):
    k = np.asarray(k_k, dtype=np.float64).ravel()
    T = np.asarray(transfer_cross_k, dtype=np.float64).ravel()
    if k.shape != T.shape or k.size == 0:
        raise ProbeLengthError(f"k_k and transfer_cross_k must be 1-D arrays of one length, got {np.shape(k_k)} and "
                               f"{np.shape(transfer_cross_k)}")
    s = None
    if sigma_k is not None:
        s = np.asarray(sigma_k, dtype=np.float64).ravel()
        if s.shape != T.shape:
            raise ProbeLengthError(f"sigma_T2 must have the shape of T2 {T.shape}, got {s.shape}")
    fin = np.isfinite(T) & np.isfinite(k)
    if not fin.any():
        raise ProbeLengthError("T2 is NaN (or k non-finite) in every bin: no method-2 value to fit")
    if np.any(T[fin] < 0):
        i = int(np.flatnonzero(fin & (T < 0))[0])
        raise ProbeLengthError(f"T2 must be >= 0 (Re(chi)^2 / F_vs^2); got T2={T[i]!r} at k={k[i]!r} rad/m")
    if np.any(k[fin] <= 0):
        raise ProbeLengthError("k must be > 0 rad/m")
    if s is not None and np.any(s[fin & np.isfinite(s)] < 0):
        raise ProbeLengthError("sigma_T2 must be >= 0")
    lo, hi = band
    inb = fin & (k >= lo) & (k <= hi) & (T > 0)
    if s is not None:
        inb &= np.isfinite(s) & (s > 0)
    if not inb.any():
        raise ProbeLengthError(f"no finite, positive T2 at k in the theory's band {lo:g}-{hi:g} rad/m "
                               f"(given k {np.nanmin(k):.3g}-{np.nanmax(k):.3g} rad/m)")
    return k, T, s, inb


def radius_of_rayleigh_length(zR: float, zR_sigma: float, *, wavelength: float, focus: float):
    """Telescope radius a0 [m] giving the Rayleigh length zR (A2012 Eq. 1 inverted) and its 1-sigma [m].

    ``a0 = sqrt(lambda r^2 / (pi zR))``, so ``a0 ~ zR^(-1/2)`` and, to first
    order, ``sigma_a0 = a0 sigma_zR / (2 zR)``.
    """
    zR = check_real("zR", zR, lo=0.0, lo_open=True)
    zR_sigma = check_real("zR_sigma", zR_sigma, lo=0.0)
    a0 = math.sqrt(wavelength * focus**2 / (math.pi * zR))
    return a0, 0.5 * a0 * zR_sigma / zR


def fit_probe_length(k_k, transfer_cross_k, transfer_cross_sigma_k=None, *, instrument, params, U, estimator="median",
                     band=DEFAULT_BAND, zR_factors=ZR_FACTORS, n_lines=4, n_points=4096, seed=THEORY_SEED,
                     **theory_kw) -> ProbeLengthFit:
    """The probe length (zR and the telescope radius a0 it implies) of measured method-2 values.

    The estimator theory (:func:`estimator_transfer`, seeded on its own) is
    computed on the measured bins for telescope radii giving
    ``zR_factors * zR_nominal``; ``log T2`` of the theory is interpolated
    linearly in ``log zR`` onto a fine grid and the chi-square
    ``sum ((T2 - T2_theory(zR)) / sigma)^2`` over the bins in ``band``
    (``sigma^2`` = the measurement's plus the theory's; without measured
    sigmas, the sum of squared log residuals) is minimised.  The 1-sigma
    uncertainty is where the chi-square rises by 1 (by ``chi2_min / (n - 1)``
    without sigmas), scaled by the Birge ratio ``sqrt(chi2_min / (n - 1))``
    when that exceeds 1 (the bins of one record are not independent: the
    realisation's velocity spread in the probe volume moves them together).

    Parameters
    ----------
    k_k, transfer_cross_k : array_like
        Bin centres [rad/m] and method-2 values ``Re(chi)^2 / F_vs^2`` [-]
        (NaN bins are skipped; negative values are an error).
    transfer_cross_sigma_k : array_like, optional
        1-sigma uncertainties of T2.
    instrument : Instrument
        The lidar (focus, wavelength, nominal a0, resolution, threshold).
    params : MannParameters
        Turbulence (e.g. fitted to the sonic).
    U : float
        Mean wind speed [m/s].
    estimator : str
        The lidar's Doppler estimator.
    band : (float, float)
        Bins used [rad/m].
    zR_factors : sequence of float
        Theory grid, factors on the nominal zR (> 0, at least 3); the
        result must lie inside it (else ProbeLengthError).
    n_lines, n_points, seed, **theory_kw
        Passed to :func:`estimator_transfer` (cnr_db, weighting, span, dx, ...).

    Returns
    -------
    ProbeLengthFit

    Raises
    ------
    ProbeLengthError
        No finite positive value in the band, all NaN, negative values, or a
        best fit at the edge of the grid.
    """
    from ..signal.instrument import Instrument

    if not isinstance(instrument, Instrument):
        raise TypeError(f"instrument must be an Instrument, got {type(instrument).__name__}")
    band = _check_band(band)
    k, T, s, inb = _check_measured(k_k, transfer_cross_k, transfer_cross_sigma_k, band)
    fac = np.asarray(sorted(float(check_real("zR_factors", f, lo=0.0, lo_open=True)) for f in zR_factors))
    if fac.size < 3:
        raise ValueError(f"zR_factors needs at least 3 values, got {list(zR_factors)}")
    zR0, a00 = instrument.rayleigh_length, instrument.telescope_radius
    kb = k[inb]
    # bin edges around the measured centres (geometric midpoints)
    order = np.argsort(kb)
    kb = kb[order]
    mid = np.sqrt(kb[1:] * kb[:-1]) if kb.size > 1 else np.array([])
    r = kb[1] / kb[0] if kb.size > 1 else 1.25
    edges = np.concatenate([[kb[0] / math.sqrt(r)], mid, [kb[-1] * math.sqrt(kb[-1] / kb[-2]) if kb.size > 1
                                                          else kb[0] * math.sqrt(r)]])
    Tb = T[inb][order]
    sb = None if s is None else s[inb][order]
    zg = zR0 * fac
    th, sth, infos = [], [], []
    for z in zg:
        inst = instrument.replace(telescope_radius=math.sqrt(instrument.wavelength * instrument.focus**2 / (math.pi * z)))
        t = estimator_transfer(inst, params, U, estimators=(estimator,), k_edges=edges, n_lines=n_lines,
                               n_points=n_points, seed=seed, band=band, **theory_kw)
        th.append(t.transfer_cross_ek[0])
        sth.append(t.transfer_cross_sigma_ek[0])
        infos.append(t.info)
    th, sth = np.array(th), np.array(sth)
    use = np.all(np.isfinite(th) & (th > 0), axis=0)
    if not use.any():
        raise ProbeLengthError(f"the theory has no mode in the measured bins of {band[0]:g}-{band[1]:g} rad/m "
                               "(lines too short: raise n_points)")
    lz = np.log(zg)
    fine = np.linspace(lz[0], lz[-1], 400)
    lt = np.log(th[:, use])
    rel = (sth[:, use] / th[:, use])
    chi = np.empty(fine.size)
    for i, f in enumerate(fine):
        j = min(max(int(np.searchsorted(lz, f)) - 1, 0), lz.size - 2)
        w = (f - lz[j]) / (lz[j + 1] - lz[j])
        t_k = np.exp((1 - w) * lt[j] + w * lt[j + 1])
        if sb is None:
            chi[i] = np.sum((np.log(Tb[use]) - np.log(t_k)) ** 2)
        else:
            st = ((1 - w) * rel[j] + w * rel[j + 1]) * t_k
            chi[i] = np.sum((Tb[use] - t_k) ** 2 / (sb[use] ** 2 + st**2))
    i0 = int(np.argmin(chi))

    def zR_here(f):
        return math.exp(f)

    if i0 == 0 or i0 == fine.size - 1:
        raise ProbeLengthError(f"best zR at the edge of the theory grid ({zg[0]:.3g}-{zg[-1]:.3g} m): widen zR_factors")
    n = int(use.sum())
    rise = 1.0 if sb is not None else max(chi[i0] / max(n - 1, 1), 1e-300)
    lo_i = i0
    while lo_i > 0 and chi[lo_i] - chi[i0] < rise:
        lo_i -= 1
    hi_i = i0
    while hi_i < fine.size - 1 and chi[hi_i] - chi[i0] < rise:
        hi_i += 1
    zR = float(math.exp(fine[i0]))
    zsig = float(0.5 * (math.exp(fine[hi_i]) - math.exp(fine[lo_i])))
    # The velocity distribution in the probe volume changes from one realisation to the next and moves
    # every bin of a record together, which per-bin sigmas miss: q = the theory's line-to-line scatter of
    # the band mean of log T2 over what its per-bin sigmas predict (a property of the model, not of the
    # record length) inflates the fit's sigma (at least the Birge ratio), and the theory's own realisation
    # error (line scatter / sqrt(lines), through the slope of the band mean with zR) is added.
    jn = int(np.argmin(np.abs(lz - fine[i0])))
    lm, pred = infos[jn]["line_mean_log_T2"][0], infos[jn]["line_sd_predicted"][0]
    q, th_sd = 1.0, 0.0
    if lm.size > 1 and np.all(np.isfinite(lm)) and pred > 0:
        sd_line = float(np.std(lm, ddof=1))
        q = max(1.0, sd_line / pred)
        th_sd = sd_line / math.sqrt(lm.size)
    if sb is not None and n > 1:
        q = max(q, math.sqrt(chi[i0] / (n - 1)))
    bm = np.mean(lt, axis=1)                                       # band mean of log T2 at each grid zR
    slope = abs(float(np.interp(fine[i0], 0.5 * (lz[1:] + lz[:-1]), np.diff(bm) / np.diff(lz)))) / zR_here(fine[i0])
    zsig = math.sqrt((q * zsig) ** 2 + (th_sd / slope) ** 2) if slope > 0 else math.inf
    a0, a0_sigma = radius_of_rayleigh_length(zR, zsig, wavelength=instrument.wavelength, focus=instrument.focus)
    ze, zes, _ = fit_zr_eff(k, T, s, band)
    return ProbeLengthFit(estimator=estimator, zR=zR, zR_sigma=zsig, a0=a0, a0_sigma=a0_sigma,
                          zR_eff=ze, zR_eff_sigma=zes, band=band, n_bins=n, chi2=float(chi[i0]),
                          zR_grid=np.exp(fine), chi2_grid=chi, nominal_zR=zR0, nominal_a0=a00)
