"""Every speckle model gives the documented mean Doppler line power and noise floor (issue 33).

Convention (:mod:`cwlidar_sim.signal.spectral`): CNR is the total signal power
over the noise power in 0 .. f_s/2 on the real detector signal; a cell of
weight ``w_s`` adds ``(CNR w_s / 2) [G(k - x_s) + G(k + x_s)]`` to the expected
one-sided spectrum (shot noise 1 per bin) and ``sum_k G(k - x) = N``, so a
line well inside (0, f_s/2) carries ``CNR N / 2`` summed over the bins, above
the noise floor :func:`cwlidar_sim.signal.noise.noise_floor`.  The speckle
models ('continuum', 'independent', 'coherent' in tier 2; tier 3's
synthesised signal with and without the sub-cell spread) change how the
power fluctuates and how the line is shaped, never its mean.

The spectra are taken exactly as :func:`cwlidar_sim.signal.chain.run_chain`
hands them to the estimators (a spy on ``chain.estimate_variants``), so the
chain's own CNR bookkeeping (its ``0.5 * CNR`` per cell, the models'
dispatch) is inside what is checked.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cwlidar_sim.signal.chain as chain_mod
from cwlidar_sim.signal.chain import ChainSettings, FocusGroup, run_chain
from cwlidar_sim.signal.instrument import CS_SERIES
from cwlidar_sim.signal.noise import noise_floor

# 400 blocks of 5 us per estimate (2 ms) keep tier 3 cheap; the CS optics, RIN and 0 Hz reflection
INST = CS_SERIES.replace(blocks_per_estimate=400)
V = 15.0  # m/s: about bin 97 of 257, far from 0 Hz and Nyquist
W_S = np.array([0.2, 0.3, 0.3, 0.2])
V_S = V + np.array([-0.3, -0.1, 0.1, 0.3])
MODELS = [("spectral", "continuum", 2000), ("spectral", "independent", 2000), ("spectral", "coherent", 2000),
          ("signal", "continuum", 200), ("signal", "coherent", 200)]


def _spectra(monkeypatch, tier, speckle, n, cnr_db):
    """The chain's averaged periodograms [shot-noise units per bin] of n estimates of the four-cell target."""
    seen = []
    real = chain_mod.estimate_variants

    def spy(spec, *args, **kw):
        seen.append(np.array(spec, dtype=np.float64))
        return real(spec, *args, **kw)

    monkeypatch.setattr(chain_mod, "estimate_variants", spy)

    def sample(lo, hi):
        return np.broadcast_to(V_S, (hi - lo, 1, V_S.size)).copy(), np.full(hi - lo, float(W_S @ V_S)), None

    group = FocusGroup(instrument=INST, index_e=np.arange(n), time_e=np.arange(n) / INST.estimate_rate,
                       weight_s=W_S, n_looks=1, sample=sample, seed=np.random.SeedSequence(7),
                       transverse_speed=10.0, subcell_spread=0.15)
    rec = run_chain(ChainSettings(tier=tier, cnr_db=cnr_db, speckle=speckle, exact_background=True), [group], n)
    monkeypatch.undo()
    spec = np.concatenate(seen)
    assert spec.shape == (n, INST.n_bins)
    return spec, rec.groups[0]


@pytest.mark.parametrize("tier,speckle,n", MODELS, ids=[f"{t}-{s}" for t, s, _ in MODELS])
def test_every_speckle_model_has_the_documented_line_power_and_noise_floor(monkeypatch, tier, speckle, n):
    r"""Mean line power ``CNR N / 2`` at CNR = -5 dB and mean floor ``noise_floor`` at -60 dB, per model.

    Line power of an estimate: ``L_e = sum_k (S_ek - floor_k)`` over all 257
    one-sided bins (leakage and line shape drop out of the sum); its
    expectation is ``CNR N / 2 (1 + (G(x) + G(N/2 - x)) / N)``, the bracket
    within 1e-4 of 1 at bin 97.  The estimates are independent (the speckle
    time, 0.25 ms at 10 m/s across the waist, is far below the 20 ms between
    estimates; tier 2 draws each estimate's gains and noise apart), so the
    mean of n has the standard error ``sd(L_e) / sqrt(n)`` by the central
    limit theorem: with about 8 speckle looks ``sd(L_e) / L`` is 0.35-0.5,
    i.e. 0.8-1.1 % of L for tier 2's 2000 estimates and 3 % for tier 3's
    200.  Noise floor: the per-estimate bin mean ``r_e = mean_k S_ek /
    floor_k`` at CNR = -60 dB (line power 2.6e-4 against 257 for the noise,
    below 1e-6 of it), expected 1, standard error ``sd(r_e) / sqrt(n)``
    (about 7e-5 and 2e-4).  Each within 4.5 standard errors (10 checks:
    a false alarm below 1e-4).  A factor 2 in one model's line power misses
    by 30-100 standard errors, a noise floor 1 % off by 40-140.
    """
    floor = noise_floor(INST)
    cnr = 10.0 ** (-5.0 / 10.0)
    expected = cnr * INST.n_fft / 2.0
    spec, info = _spectra(monkeypatch, tier, speckle, n, -5.0)
    used = info["speckle"]
    assert used == speckle if tier == "spectral" else used in ("continuum", "tier 3 (AR(1) per cell)"), info
    line_e = spec.sum(axis=1) - floor.sum()
    se = float(line_e.std(ddof=1)) / math.sqrt(n)
    assert se < 0.04 * expected  # informative: a factor 2 is >= 25 standard errors
    assert abs(line_e.mean() - expected) < 4.5 * se, (line_e.mean(), expected, se)
    quiet, _ = _spectra(monkeypatch, tier, speckle, n, -60.0)
    r_e = (quiet / floor).mean(axis=1)
    se_r = float(r_e.std(ddof=1)) / math.sqrt(n)
    assert abs(r_e.mean() - 1.0) < 4.5 * se_r, (r_e.mean(), se_r)
