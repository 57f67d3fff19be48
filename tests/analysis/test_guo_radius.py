"""The scan radius where a single-beam circular scan's REWS coherence bandwidth peaks (issue 31).

Fu, Guo, Schlipf & Pena (2023, Wind Energ. Sci. 8, 1893) find the optimum of a spinner-mounted
single-beam lidar ahead of the IEA 15 MW rotor (R = 120 m) at a scan radius of 0.6 R.  Reduced
size of studies/guo_radius_sweep.py (docs/reproductions/guo2023.md): the analytic coherence of
rews_theory, one beam turning with the rotor at 7.56 rpm, 120 m upwind, U = 15 m/s, IEC Mann
parameters, eddy-lifetime evolution T = 15 s; 6 point beams and a coarse polar grid.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.rews import RotorDisc, coherence_bandwidth
from cwlidar_sim.analysis.rews_theory import circular_scan, rews_spectra
from cwlidar_sim.turbulence import MannParameters
from cwlidar_sim.turbulence.evolution import EddyLifetimeEvolution

R, X, U, T_REV = 120.0, 120.0, 15.0, 60.0 / 7.56
PARAMS = MannParameters(alpha_eps=0.1, length_scale=33.6, gamma=3.9)
K = np.geomspace(2e-3, 0.024, 7)  # rad/m: the crossings of 0.5 lie at 0.003-0.012


def _spectra(rr, *, evolving, resolution=15.0, k=K, revolution_time=T_REV):
    r = rr * R
    beams = circular_scan(6, math.degrees(math.atan2(r, X)), math.hypot(X, r), revolution_time=revolution_time)
    ev = EddyLifetimeEvolution(15.0, U) if evolving else None
    # paired like the campaign: the preview x / U less the revolution average's mean delay
    return rews_spectra(k, PARAMS, RotorDisc(R), beams, U, weighting="lorentzian", evolution=ev,
                        resolution=resolution, preview_shift=X / U - float(beams.delay_pb.mean()))


def _k_half(rr, **kw):
    return coherence_bandwidth(K, _spectra(rr, **kw).coherence_k)


@pytest.fixture(scope="module")
def evolving_sweep():
    return {rr: _k_half(rr, evolving=True) for rr in (0.2, 0.4, 0.6, 0.8, 1.0)}


def test_bandwidth_peaks_between_0_4_and_0_8_R(evolving_sweep):
    k = evolving_sweep
    # the quadrature's own error at the optimum: the polar grid doubled
    quad = abs(_k_half(0.6, evolving=True, resolution=30.0) - k[0.6])
    assert k[0.6] > k[0.4] and k[0.6] > k[0.8], k  # a maximum inside (0.4 R, 0.8 R)
    assert k[0.6] - max(k[0.2], k[1.0]) > 10.0 * quad + 2e-4, (k, quad)  # well above both ends


def test_evolution_lowers_the_bandwidth_at_every_radius(evolving_sweep):
    # eddies decorrelating over the 8 s from the lidar's plane to the rotor's only remove coherence
    for rr in (0.6, 1.0):
        assert _k_half(rr, evolving=False) > 1.15 * evolving_sweep[rr], rr


def test_revolution_delays_are_paired_out():
    # Frozen: the revolution average delays beam b's sample by tau_b, and the pairing takes their mean off
    # the preview; averaged over the scan's phases every beam sees every delay, so the cross-spectrum is the
    # simultaneous lidar's (revolution_time = 0) times a real factor: the same phase.  (Its phase is not 0:
    # the beams' v and w contamination, correlated with u, adds one.)  A delay counted the wrong way round
    # would add k U 2 tau_mean (0.6 rad at 0.005 rad/m).
    k = np.array([0.002, 0.005])
    scan = _spectra(0.6, evolving=False, k=k)
    still = _spectra(0.6, evolving=False, k=k, revolution_time=0.0)
    assert np.all(np.abs(np.angle(scan.cross_k / still.cross_k)) < 0.02), np.angle(scan.cross_k / still.cross_k)
    assert np.all(np.abs(scan.cross_k) < np.abs(still.cross_k))  # the revolution's smear only loses coherence
