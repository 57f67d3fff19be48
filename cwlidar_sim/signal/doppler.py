"""Speed estimates of a uniform target through any tier: what ``cwlidar-sim doppler`` runs.

The target is a uniform flow of radial speed V along the beam: every range
cell moves at V, so

* tier ``los`` (A2012 Eq. 2, the ideal limit) returns V exactly, with its
  sign: the weights integrate to 1 and no noise, speckle, binning or
  homodyne folding is modelled;
* tiers ``spectral`` and ``signal`` return ``|V|`` as the lidar would, with
  the instrument's binning, noise, speckle, threshold and estimator.

The speckle correlation time is the transit time across the beam waist,
``tau_c = w0 / v_perp`` (:meth:`Instrument.speckle_time`), ``v_perp`` the
transverse speed of the aerosols (turbulence across the beam; 0 freezes the
speckle over each estimate).
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_choice, check_int, check_real, check_seed
from .instrument import PROTOTYPE_2003, Instrument
from .processing import DopplerEstimates, background_spectrum, estimate

__all__ = ["TIERS", "simulate_uniform", "uniform_report"]

TIERS = ("los", "spectral", "signal")


def _cells(instrument, n_cells):
    from ..beam.optics import weight_truncated

    rc = weight_truncated(instrument.optics(), "exact", span=20.0, n_cells=n_cells, renormalise=True)
    return rc.weight_s


def simulate_uniform(speed: float, cnr_db: float, *, instrument: Instrument = PROTOTYPE_2003, tier: str = "spectral",
                     n: int = 100, seed: int = 0, transverse_speed: float = 1.0, n_cells: int = 8,
                     speckle: str = "coherent", estimator: str | None = None,
                     exact_background: bool = False, cloud_range: float | None = None,
                     cloud_weight: float = 0.0, cloud_speed: float = 0.0) -> tuple[DopplerEstimates, dict]:
    """Simulate ``n`` consecutive estimates of a uniform target moving at ``speed`` along the beam.

    Parameters
    ----------
    speed : float
        Radial speed V [m/s] (positive away from the lidar); |V| <= 1000.
    cnr_db : float
        Carrier-to-noise ratio [dB]: total signal power over noise power in
        the detection bandwidth 0..f_s/2 (see :mod:`cwlidar_sim.signal.spectral`).
    instrument : Instrument
        Preset (possibly overridden).
    tier : {'los', 'spectral', 'signal'}
    n : int
        Number of estimates; in [1, 10**7] (tier 'signal': at most 10**4).
    seed : int
        Seed of the background measurement and of the estimates.
    transverse_speed : float
        Aerosol speed across the beam [m/s]; >= 0.
    n_cells : int
        Range cells of the probe volume (exact weighting over +/-20 z_R,
        renormalised); in [1, 256].
    speckle : {'coherent', 'independent'}
        Tier 2's speckle gain per estimate or per bin.
    estimator : str, optional
        Overrides the instrument's estimator.
    exact_background : bool
        Use the exact noise floor instead of a measured one (M_bg blocks).
    cloud_range : float, optional
        Distance of a cloud layer from the lidar along the beam [m]; > 0.
        The focused beam's weighting has heavy tails (~ z_R / (pi s^2)), so
        a cloud far beyond the focus, whose backscatter is orders of
        magnitude above the aerosol's, adds a second Doppler peak (CS
        discards periods with cloud base below 1600 m for this reason).
    cloud_weight : float
        The cloud's integrated backscatter relative to the aerosol
        backscatter per metre [m] (``beta_cloud * depth / beta_aerosol``;
        e.g. 1e3-1e4 per metre over 10-50 m: 1e4-5e5 m); >= 0.  The cloud
        then carries ``w_c = phi(cloud_range - focus) * cloud_weight`` of the
        aerosol probe volume's weight (phi: the exact weighting,
        :func:`cwlidar_sim.beam.optics.weight_exact`), reported in the info
        as ``cloud_fraction = w_c / (1 + w_c)``.
    cloud_speed : float
        The cloud's radial speed [m/s]; |v| <= 1000.

    Returns
    -------
    (DopplerEstimates, dict)
        The estimates and run information (correlation time [s], M_eff [-],
        cloud fraction, ...).  ``cnr_db`` is the aerosol's CNR; the cloud
        adds its own power on top.  Tier 'los' returns the weighted mean of
        target and cloud.
    """
    if not isinstance(instrument, Instrument):
        raise TypeError(f"instrument must be an Instrument, got {type(instrument).__name__}")
    v = check_real("speed", speed, lo=-1000.0, hi=1000.0)
    cnr_db = check_real("cnr_db", cnr_db, lo=-200.0, hi=200.0)
    check_choice("tier", tier, TIERS)
    n = check_int("n", n, lo=1, hi=10**4 if tier == "signal" else 10**7)
    seed = check_seed("seed", seed)
    n_cells = check_int("n_cells", n_cells, lo=1, hi=256)
    name = instrument.estimator if estimator is None else estimator
    from .processing import check_estimator

    check_estimator(name)
    tau = instrument.speckle_time(transverse_speed)
    from .spectral import speckle_looks

    m_eff = speckle_looks(instrument.blocks_per_estimate, instrument.block_duration, tau)
    info = {"correlation_time": tau, "m_eff": m_eff, "n_cells": n_cells}
    w_c, v_c = _cloud(instrument, cloud_range, cloud_weight, cloud_speed)
    info["cloud_fraction"] = w_c / (1.0 + w_c)
    if tier == "los":
        sp = np.full(n, (v + w_c * v_c) / (1.0 + w_c))
        est = DopplerEstimates(speed_e=sp, frequency_e=sp / instrument.speed_per_hz,
                               flags_e=np.zeros(n, dtype=np.uint8), estimator="los")
        info["note"] = "tier 'los' is the ideal weighted line-of-sight average: V exactly, signed"
        return est, info
    ss = np.random.SeedSequence(seed)
    s_bg, s_sim = ss.spawn(2)
    bg = None if exact_background else background_spectrum(instrument, np.random.default_rng(s_bg))
    w = _cells(instrument, n_cells)
    vl = np.full(n_cells, v)
    if w_c > 0.0:
        # the cloud is one more cell; weights renormalised to 1, its power added to the CNR
        w = np.append(w, w_c) / (1.0 + w_c)
        vl = np.append(vl, v_c)
        cnr_db = cnr_db + 10.0 * math.log10(1.0 + w_c)
        n_cells += 1
    if tier == "spectral":
        return _spectral_chunked(instrument, vl, w, cnr_db, tau, m_eff, n, np.random.default_rng(s_sim), speckle,
                                 bg, name), info
    else:
        from .heterodyne import simulate_signal_spectra

        spectra = simulate_signal_spectra(instrument, np.broadcast_to(vl, (n, n_cells)), w, cnr_db,
                                          np.random.default_rng(s_sim), correlation_time=tau)
    return estimate(spectra, instrument, bg, estimator=name), info


def _cloud(instrument, cloud_range, cloud_weight, cloud_speed):
    """Weight (relative to the aerosol probe volume) and radial speed of a cloud return."""
    cloud_weight = check_real("cloud_weight", cloud_weight, lo=0.0, hi=1e12)
    cloud_speed = check_real("cloud_speed", cloud_speed, lo=-1000.0, hi=1000.0)
    if cloud_range is None:
        if cloud_weight > 0.0:
            raise ValueError("cloud_weight > 0 needs cloud_range [m]")
        return 0.0, 0.0
    cloud_range = check_real("cloud_range", cloud_range, lo=0.0, hi=1e6, lo_open=True)
    from ..beam.optics import weight_exact

    phi = float(weight_exact(cloud_range - instrument.focus, instrument.focus, instrument.wavelength,
                             instrument.telescope_radius))
    return phi * cloud_weight, cloud_speed


def _spectral_chunked(instrument, vl, w, cnr_db, tau, m_eff, n, rng, speckle, bg, name, chunk=4096):
    """Tier 2 drawn and processed in chunks of estimates, so the spectra stay in cache.

    Identical to ``estimate(sample_spectra(...))`` with the same generator.
    """
    from .spectral import _draw_rows, _speckle_draws, expected_spectrum, line_shape_table

    check_choice("speckle", speckle, ("coherent", "independent"))
    sig, noise = expected_spectrum(instrument, vl, w, cnr_db, correlation_time=tau)
    key, gain = _speckle_draws(rng, n, instrument.n_bins, m_eff, speckle)
    table = line_shape_table(instrument.n_fft, instrument.window)
    speed = np.empty(n)
    freq = np.empty(n)
    flags = np.empty(n, dtype=np.uint8)
    buf = np.empty((min(n, chunk), instrument.n_bins))
    for e0 in range(0, n, chunk):
        e1 = min(n, e0 + chunk)
        out = buf[: e1 - e0]
        _draw_rows(sig, noise, instrument.blocks_per_estimate, gain[e0:e1], key, e0, out)
        est = estimate(out, instrument, bg, estimator=name, line_table=table)
        speed[e0:e1], freq[e0:e1], flags[e0:e1] = est.speed_e, est.frequency_e, est.flags_e
    return DopplerEstimates(speed_e=speed, frequency_e=freq, flags_e=flags, estimator=name)


def uniform_report(est: DopplerEstimates, info: dict, *, speed, cnr_db, tier, instrument) -> dict:
    """JSON-ready summary of :func:`simulate_uniform`'s output."""
    s = est.summary()
    ok = est.speed_e[np.isfinite(est.speed_e)]
    truth = float(speed) if tier == "los" else abs(float(speed))
    rep = {
        "tier": tier,
        "speed": float(speed),
        "expected": truth,
        "cnr_db": float(cnr_db),
        "estimator": est.estimator,
        **s,
        "bias": float(ok.mean() - truth) if ok.size else None,
        "rms_error": float(math.sqrt(np.mean((ok - truth) ** 2))) if ok.size else None,
        "bin_speed": instrument.bin_speed,
        "nyquist_speed": instrument.nyquist_speed,
        "correlation_time": None if math.isinf(info["correlation_time"]) else info["correlation_time"],
        "m_eff": info["m_eff"],
        "cloud_fraction": info.get("cloud_fraction", 0.0),
        "instrument": instrument.as_dict(),
    }
    if "note" in info:
        rep["note"] = info["note"]
    if tier != "los" and abs(float(speed)) > instrument.nyquist_speed:
        # the instrument cannot see it (no flag can be set from the spectrum): the simulation says so
        rep["warning"] = (f"|speed| {abs(float(speed)):g} m/s is beyond Nyquist ({instrument.nyquist_speed:.4g} m/s): "
                          f"the estimates are the alias, not the speed")
    return rep
