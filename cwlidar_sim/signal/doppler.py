"""Speed estimates of a uniform target through any tier: what ``cwlidar-sim doppler`` runs.

The target is a uniform flow of radial speed V along the beam: every range
cell moves at V, so

* tier ``los`` (A2012 Eq. 2, the ideal limit) returns V exactly, with its
  sign: the weights integrate to 1 and no noise, speckle, binning or
  homodyne folding is modelled;
* tiers ``spectral`` and ``signal`` return ``|V|`` as the lidar would, with
  the instrument's binning, noise, speckle, threshold and estimator.

Sign: ``speed`` is the line-of-sight speed ``n . u`` of the package, ``n``
the beam's unit vector pointing away from the lidar, so V > 0 moves *away*
from the lidar (the convention of :mod:`cwlidar_sim.beam` and
:mod:`cwlidar_sim.sensors`).  Tiers ``spectral`` and ``signal`` have no sign
to give; the report's ``sign_convention`` says which reading a run returns.
(A staring campaign's results report the speed *toward* the lidar instead,
positive for a lidar looking into the wind: their ``sign_convention``
attributes say so.)

The speckle correlation time is the transit time across the beam waist,
``tau_c = w0 / v_perp`` (:meth:`Instrument.speckle_time`), ``v_perp`` the
transverse speed of the aerosols (turbulence across the beam; 0 freezes the
speckle over each estimate).
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_choice, check_int, check_real, check_seed
from ..beam.cells import weight_truncated
from ..beam.optics import weight_exact
from .chain import TIERS, ChainSettings, FocusGroup, run_chain
from .instrument import PROTOTYPE_2003, Instrument
from .processing import DopplerEstimates, check_estimator
from .spectral import speckle_looks

__all__ = ["simulate_uniform", "uniform_report"]


def simulate_uniform(speed: float, cnr_db: float, *, instrument: Instrument = PROTOTYPE_2003, tier: str = "spectral",
                     n: int = 100, seed: int = 0, transverse_speed: float = 1.0, n_cells: int = 8,
                     speckle: str = "coherent", estimator: str | None = None,
                     exact_background: bool = False, cloud_range: float | None = None,
                     cloud_weight: float = 0.0, cloud_speed: float = 0.0) -> tuple[DopplerEstimates, dict]:
    """Simulate ``n`` consecutive estimates of a uniform target moving at ``speed`` along the beam.

    The target is a sensor like any other: one focus, ``n_cells`` range cells
    over +/- 20 z_R (exact weighting, renormalised), every cell at ``speed``,
    one look per estimate, handed to :func:`cwlidar_sim.signal.chain.run_chain`.

    Parameters
    ----------
    speed : float
        Radial speed V [m/s] (positive away from the lidar); |V| <= 1000.
    cnr_db : float
        Carrier-to-noise ratio [dB]: total signal power over noise power in
        the detection bandwidth 0..f_s/2 (see :mod:`cwlidar_sim.signal.spectral`);
        in :data:`cwlidar_sim.signal.chain.CNR_DB_RANGE`.
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
        adds its own power on top.  Tier 'los' returns the ideal: the signed
        weighted mean of target and cloud, no instrument.
    """
    if not isinstance(instrument, Instrument):
        raise TypeError(f"instrument must be an Instrument, got {type(instrument).__name__}")
    v = check_real("speed", speed, lo=-1000.0, hi=1000.0)
    check_choice("tier", tier, TIERS)
    n = check_int("n", n, lo=1, hi=10**4 if tier == "signal" else 10**7)
    seed = check_seed("seed", seed)
    n_cells = check_int("n_cells", n_cells, lo=1, hi=256)
    check_choice("speckle", speckle, ("coherent", "independent"))
    name = instrument.estimator if estimator is None else estimator
    check_estimator(name)
    inst = instrument if name == instrument.estimator else instrument.replace(estimator=name)
    settings = ChainSettings(tier=tier, cnr_db=cnr_db, speckle=speckle, exact_background=exact_background)
    tau = inst.speckle_time(transverse_speed)
    m_eff = speckle_looks(inst.blocks_per_estimate, inst.block_duration, tau)
    info = {"correlation_time": tau, "m_eff": m_eff, "n_cells": n_cells}
    w_c, v_c = _cloud(inst, cloud_range, cloud_weight, cloud_speed)
    info["cloud_fraction"] = w_c / (1.0 + w_c)
    w = weight_truncated(inst.optics(), "exact", span=20.0, n_cells=n_cells, renormalise=True).weight_s

    def sample(lo, hi):
        return np.full((hi - lo, 1, n_cells), v), np.full(hi - lo, v), np.full((hi - lo, 1), v_c)

    group = FocusGroup(instrument=inst, index_e=np.arange(n), time_e=np.arange(n) / inst.estimate_rate, weight_s=w,
                       n_looks=1, sample=sample, seed=np.random.SeedSequence(seed), transverse_speed=transverse_speed,
                       cloud_weight=w_c)
    rec = run_chain(settings, [group], n)
    if tier == "los":
        sp = np.full(n, (v + w_c * v_c) / (1.0 + w_c))
        est = DopplerEstimates(speed_e=sp, frequency_e=sp / inst.speed_per_hz, flags_e=np.zeros(n, dtype=np.uint8),
                               estimator="los")
        info["note"] = "tier 'los' is the ideal weighted line-of-sight average: V exactly, signed"
        return est, info
    est = DopplerEstimates(speed_e=rec.speed_e, frequency_e=rec.speed_e / inst.speed_per_hz, flags_e=rec.flags_e,
                           estimator=name)
    return est, info


def _cloud(instrument, cloud_range, cloud_weight, cloud_speed):
    """Weight (relative to the aerosol probe volume) and radial speed of a cloud return."""
    cloud_weight = check_real("cloud_weight", cloud_weight, lo=0.0, hi=1e12)
    cloud_speed = check_real("cloud_speed", cloud_speed, lo=-1000.0, hi=1000.0)
    if cloud_range is None:
        if cloud_weight > 0.0:
            raise ValueError("cloud_weight > 0 needs cloud_range [m]")
        return 0.0, 0.0
    cloud_range = check_real("cloud_range", cloud_range, lo=0.0, hi=1e6, lo_open=True)
    phi = float(weight_exact(cloud_range - instrument.focus, instrument.focus, instrument.wavelength,
                             instrument.telescope_radius))
    return phi * cloud_weight, cloud_speed


def uniform_report(est: DopplerEstimates, info: dict, *, speed, cnr_db, tier, instrument) -> dict:
    """JSON-ready summary of :func:`simulate_uniform`'s output."""
    s = est.summary()
    ok = est.speed_e[np.isfinite(est.speed_e)]
    truth = float(speed) if tier == "los" else abs(float(speed))
    rep = {
        "tier": tier,
        "speed": float(speed),
        "expected": truth,
        "sign_convention": ("speed: positive away from the lidar (n . u, n the beam's unit vector pointing away); "
                            + ("mean, expected: signed, as speed" if tier == "los" else
                               "mean, expected: |speed|, a homodyne lidar reads no sign")),
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
    if tier != "los" and float(speed) < 0:
        # a homodyne cw lidar sees |V|: the estimates cannot carry the sign the user gave
        rep["note"] = (f"speed {float(speed):g} m/s: a homodyne cw lidar measures |V| (positive away from the "
                       f"lidar here), so the estimates read {abs(float(speed)):g} m/s; the sign is lost")
    if tier != "los" and abs(float(speed)) > instrument.nyquist_speed:
        # the instrument cannot see it (no flag can be set from the spectrum): the simulation says so
        rep["warning"] = (f"|speed| {abs(float(speed)):g} m/s is beyond Nyquist ({instrument.nyquist_speed:.4g} m/s): "
                          f"the estimates are the alias, not the speed")
    return rep
