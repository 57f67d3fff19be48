"""The adaptive k1 grid of the linear theory's period statistics (analysis/_linear_period.py, adaptive_spectra)."""

import functools
import math

import numpy as np
import pytest

from cwlidar_sim.analysis import _linear_period as lp
from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.turbulence import MannParameters

P = MannParameters(alpha_eps=0.1, length_scale=30.0, gamma=3.0)
U, T, D = 8.0, 600.0, 20.0 * math.pi  # a peak of the pair at k1 = 1 rad/m (the grids' end, its last power law)


def _pair():
    """u weighted 0.6 and 0.4 at two points D apart along the wind: ``|0.6 + 0.4 exp(i k1 D)|^2`` times u's
    spectrum, dips to 1/25 at ``k1 = pi (2 m + 1) / D`` (sharp in log-log), each look a Lorentzian along x
    (``exp(-2 zR k1)``: a steep last power law at 1 rad/m, the grids' end); and a cup (first-order response)."""
    looks = lt.Looks([[0.0, 0.0, 50.0], [D, 0.0, 50.0]], [[1.0, 0.0, 0.0]] * 2, probe_l=lt.lorentzian_probe(10.0))
    w = np.zeros((1, 2, 3))
    w[0, :, 0] = (0.6, 0.4)
    pair = lt.LinearFunctional(looks, w, ("u",))
    cup = lt.point_functional((0.0, 0.0, 50.0), ("u",), response=lt.first_order_response(2.3 / U))
    return [pair, cup]


STATS = [lt.PeriodStatistic("0.u", T, 1.0), lt.PeriodStatistic("0.u", 600.0, 3.0, repeat=(3, 1.0)),
         lt.PeriodStatistic("1.u", T, 0.1), lt.PeriodStatistic("1.u", T)]


@functools.lru_cache(maxsize=1)
def _dense_spectra():
    k = np.geomspace(1e-4, 1.0, 1001)
    return k, lt.functional_spectra(k, P, _pair(), U, quadrature="x_only")


def _dense(stat):
    k, s = _dense_spectra()
    return stat.variance(k, s.spectrum(stat.output), U)


def test_adaptive_grid_converges_to_a_dense_grid():
    """Each statistic (sampled, mean removed, the 3-copy comb, continuous) within tol of a 1001-point grid, with
    far fewer wavenumbers, and the refinement's own error estimate within tol."""
    tol = 1e-3
    r = lt.adaptive_spectra(P, _pair(), U, STATS, tol=tol, quadrature="x_only")
    assert r.converged and r.spectra.k1_k.size < 150
    for st, v, e in zip(STATS, r.within, r.error):
        assert abs(v / _dense(st) - 1.0) < tol, st
        assert e < tol
    # the spectra on the refined grid are functional_spectra's there
    s = lt.functional_spectra(r.spectra.k1_k, P, _pair(), U, quadrature="x_only")
    np.testing.assert_allclose(r.spectra.matrix_kab, s.matrix_kab, rtol=1e-12)


def test_adaptive_grid_refines_at_the_sharp_dips():
    """The pair's dips (k1 = pi / D, 3 pi / D, ...) draw the points: in ln k1 the refined grid is over eight
    times denser over [0.5, 4] pi / D than the starting grid and twice the smooth decades below 1e-2 rad/m; the
    statistic needs them (the starting grid misses its variance by more than twice tol)."""
    r = lt.adaptive_spectra(P, _pair(), U, STATS[:1], tol=1e-3, quadrature="x_only")
    k = r.spectra.k1_k
    start = 8 / math.log(1e4)  # the starting grid's k1 per unit of ln k1
    near = np.sum((k > 0.5 * math.pi / D) & (k < 4.0 * math.pi / D)) / math.log(8.0)
    smooth = np.sum(k < 1e-2) / math.log(100.0)
    assert near > 8.0 * start and near > 2.0 * smooth, np.round(np.log10(k), 2)
    coarse = np.geomspace(1e-4, 1.0, 9)
    s = lt.functional_spectra(coarse, P, _pair(), U, quadrature="x_only")
    assert abs(STATS[0].variance(coarse, s.spectrum(0), U) / _dense(STATS[0]) - 1.0) > 2e-3


def test_repeat_is_the_comb_of_the_copies():
    """period_variance's repeat = (n, tau): the mean of n copies tau apart, i.e. the spectrum times
    |sum_m exp(i m k1 U tau)|^2 / n^2 on a dense grid (independent route, linear interpolation)."""
    k = np.geomspace(1e-4, 1.0, 40)
    F = lt.functional_spectra(k, P, _pair(), U, quadrature="x_only").spectrum("1.u")
    kd = np.geomspace(1e-4, 100.0, 64001)
    comb = np.abs(np.exp(1j * np.outer(kd * U * 1.0, np.arange(3))).sum(axis=1)) ** 2 / 9.0
    comb[-2:] = 1.0 / 3.0
    ref = lt.period_variance(kd, lp._loglog(k, F, kd) * comb, U, 600.0, sample_interval=3.0)["within"]
    got = lt.period_variance(k, F, U, 600.0, sample_interval=3.0, repeat=(3, 1.0))["within"]
    assert got == pytest.approx(ref, rel=1e-5)
    one = lt.period_variance(k, F, U, 600.0, sample_interval=3.0)["within"]
    assert got < 0.95 * one  # averaging three copies removes the cup's high-frequency variance


def test_cubic_interpolation_converges_faster_than_linear():
    """On the cup's spectrum (a knee in log-log), 17 k1 with the cubic spline are within 2e-4 of 1001 k1,
    ten times closer than with straight lines."""
    k = np.geomspace(1e-4, 1.0, 17)
    F = lt.functional_spectra(k, P, _pair(), U, quadrature="x_only").spectrum("1.u")
    ref = _dense(STATS[2])
    cub = lt.period_variance(k, F, U, T, sample_interval=0.1, interpolation="cubic")["within"] / ref - 1.0
    lin = lt.period_variance(k, F, U, T, sample_interval=0.1)["within"] / ref - 1.0
    assert abs(cub) < 2e-4 and abs(cub) < 0.1 * abs(lin), (cub, lin)


def test_a_weighted_sum_of_outputs_gives_the_covariance():
    """``weights``: the statistic of ``x_pair - x_cup`` (its spectrum ``F_00 + F_11 - 2 Re F_01``, the pair's dips
    filled by the cup) converges to the dense grid's within tol; the covariance from the difference and from the sum
    agree to the tolerance, and is far from zero (the pair and the cup share u at the same point)."""
    tol = 1e-3
    pair_cup = [lt.PeriodStatistic("0.u", T, 1.0), lt.PeriodStatistic("1.u", T, 1.0)]
    diff = lt.PeriodStatistic(("0.u", "1.u"), T, 1.0, weights=(1.0, -1.0))
    both = lt.PeriodStatistic(("0.u", "1.u"), T, 1.0, weights=(1.0, 1.0))
    r = lt.adaptive_spectra(P, _pair(), U, pair_cup + [diff, both], tol=tol, quadrature="x_only")
    k, s = _dense_spectra()
    F_x = 2.0 * s.cross("0.u", "1.u").real
    dense_d = diff.variance(k, s.spectrum(0) + s.spectrum(1) - F_x, U)
    assert r.converged and abs(r.within[2] / dense_d - 1.0) < tol
    v0, v1 = r.within[:2]
    cov_d, cov_s = 0.5 * (v0 + v1 - r.within[2]), 0.5 * (r.within[3] - v0 - v1)
    assert abs(cov_d - cov_s) < tol * (v0 + v1) and cov_d / math.sqrt(v0 * v1) > 0.5
    # the weighted statistic is the sum's own: weights (2, 0) are four times the pair's variance
    two = lt.adaptive_spectra(P, _pair(), U, [lt.PeriodStatistic(("0.u", "1.u"), T, 1.0, weights=(2.0, 0.0))],
                              tol=tol, quadrature="x_only")
    assert two.within[0] == pytest.approx(4.0 * _dense(pair_cup[0]), rel=tol)
    with pytest.raises(ValueError, match="one weight per output"):
        lt.PeriodStatistic(("0.u", "1.u"), T, weights=(1.0,))
    with pytest.raises(TypeError, match="tuple of output"):
        lt.PeriodStatistic("0.u", T, weights=(1.0,))


def test_bad_statistics_are_refused_by_name():
    with pytest.raises(ValueError, match="period"):
        lt.PeriodStatistic("0.u", -1.0)
    with pytest.raises(ValueError, match="sample_interval"):
        lt.PeriodStatistic("0.u", 600.0, 0.0)
    with pytest.raises(ValueError, match=r"repeat\[0\]"):
        lt.PeriodStatistic("0.u", 600.0, 1.0, repeat=(0, 1.0))
    with pytest.raises(TypeError, match="repeat"):
        lt.PeriodStatistic("0.u", 600.0, 1.0, repeat=3)
    with pytest.raises(TypeError, match="PeriodStatistic"):
        lt.adaptive_spectra(P, _pair(), U, [600.0], quadrature="x_only")
    with pytest.raises(ValueError, match="no output 'x'"):
        lt.adaptive_spectra(P, _pair(), U, [lt.PeriodStatistic("x", 600.0)], quadrature="x_only")
    with pytest.raises(ValueError, match="n_start"):
        lt.adaptive_spectra(P, _pair(), U, STATS, n_start=3, quadrature="x_only")
    with pytest.raises(ValueError, match="interpolation"):
        lt.period_variance([1e-3, 1e-2], [1.0, 0.5], U, T, interpolation="spline")
