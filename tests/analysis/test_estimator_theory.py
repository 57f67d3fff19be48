"""The estimator-aware theory: the zR_eff fit, the probe-length fit and its named errors.

The theory's agreement with simulated method 2 is tested on a campaign run in
tests/campaign/periods/test_campaign_physics.py (long validation: studies/validate_estimator_theory.py).
"""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis import ProbeLengthError, estimator_transfer, fit_probe_length, fit_zr_eff
from cwlidar_sim.signal import PROTOTYPE_2003
from cwlidar_sim.turbulence import MannParameters

P = MannParameters(0.06224407174474577, 18.76, 3.9)
K = np.geomspace(0.01, 1.0, 21)


def test_fit_zr_eff_recovers_an_exponential_and_its_band():
    z, s, n = fit_zr_eff(K, np.exp(-2 * K * 3.3), band=(0.02, 0.6))
    assert z == pytest.approx(3.3, rel=1e-12) and n == int(np.sum((K >= 0.02) & (K <= 0.6)))
    # weighted: sigma from the weights, 1 / (2 sqrt(sum w k^2)) with w = (T / sigma)^2 = 1 / 0.1^2
    T = np.exp(-2 * K * 3.3)
    Tn = T * np.exp(0.1 * np.sin(7 * K))
    z, s, n = fit_zr_eff(K, Tn, 0.1 * Tn, band=(0.02, 0.6))
    b = (K >= 0.02) & (K <= 0.6)
    assert s == pytest.approx(0.1 / (2 * math.sqrt(np.sum(K[b] ** 2))), rel=1e-12)
    assert abs(z - 3.3) < 3 * s
    assert math.isnan(fit_zr_eff(K, T, band=(2.0, 3.0))[0])


@pytest.mark.parametrize("T2, sigma, band, match", [
    (np.full(K.size, np.nan), None, (0.02, 0.6), r"NaN \(or k non-finite\) in every bin"),
    (np.where(K > 0.3, -1e-3, 0.5), None, (0.02, 0.6), "must be >= 0"),
    (np.exp(-2 * K * 5.61), None, (2.0, 4.0), r"no finite, positive T2 at k in the theory's band 2-4 rad/m"),
    (np.exp(-2 * K * 5.61), np.full(K.size, np.nan), (0.02, 0.6), "no finite, positive T2"),
])
def test_probe_length_bad_input_is_a_named_error(T2, sigma, band, match):
    with pytest.raises(ProbeLengthError, match=match):
        fit_probe_length(K, T2, sigma, instrument=PROTOTYPE_2003, params=P, U=8.0, band=band)


SMALL = dict(n_lines=4, n_points=1024, cnr_db=-10.0, span=10.0)
INST = PROTOTYPE_2003.replace(focus=40.0)          # zR = 1.97 m: few cells, cheap


def test_probe_length_recovers_zR_and_a0_of_an_unseen_realisation():
    """A median lidar with a0 = 24 mm (not the nominal 20 mm), simulated on lines of another seed."""
    a0 = 0.024
    truth = INST.replace(telescope_radius=a0)
    sim = estimator_transfer(truth, P, 8.0, estimators=("median",), seed=99, **{**SMALL, "n_lines": 4})
    fit = fit_probe_length(sim.k_k, sim.transfer_cross_ek[0], sim.transfer_cross_sigma_ek[0], instrument=INST, params=P, U=8.0,
                           estimator="median", band=(0.05, 1.5), zR_factors=(0.5, 0.71, 1.0), **SMALL)
    assert fit.nominal_a0 == 0.020 and fit.nominal_zR == pytest.approx(INST.rayleigh_length)
    assert abs(fit.zR - truth.rayleigh_length) < 2.5 * fit.zR_sigma, (fit.zR, fit.zR_sigma, truth.rayleigh_length)
    assert abs(fit.a0 - a0) < 2.5 * fit.a0_sigma
    # a real constraint: the uncertainty is well below the distance to the nominal radius
    assert fit.a0_sigma < 0.25 * abs(a0 - 0.020)
    # and a median's zR_eff is shorter than its zR (its filter is not exp(-2 k zR))
    assert fit.zR_eff < 0.8 * fit.zR


@pytest.mark.parametrize("weighting, span, cell, focus, growth", [("exact", 20.0, 0.5, 67.5, 0.0),
                                                                  ("lorentzian", 8.0, 1.3, 40.0, 0.0),
                                                                  ("exact", 200.0, 2.0, 10.0, 0.0),
                                                                  ("exact", 200.0, 0.5, 67.5, 0.1)])
def test_the_theory_cells_are_the_staring_lidars(weighting, span, cell, focus, growth):
    """The theory builds its cells itself (the analysis does not import the sensors): the lidar's own cells.

    The last case is clipped at the telescope (span 200 z_R reaches behind a 10 m focus).
    """
    from cwlidar_sim.analysis.estimator_theory import _line_cells
    from cwlidar_sim.sensors import StaringLidar

    inst = PROTOTYPE_2003.replace(focus=focus)
    ours = _line_cells(inst, weighting, span, cell, growth=growth)
    theirs = StaringLidar(instrument=inst, weighting=weighting, span=span, cell_length=cell,
                          cell_growth=growth).cells()
    for a in ("s_s", "weight_s", "sub_j", "fraction_j", "ptr_s"):
        np.testing.assert_array_equal(getattr(ours, a), getattr(theirs, a))
    assert ours.truncated_fraction == theirs.truncated_fraction and ours.tail_weight == theirs.tail_weight
    with pytest.raises(ValueError, match="weighting"):
        _line_cells(inst, "gaussian", span, cell)
