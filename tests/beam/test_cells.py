"""Probe cells for every lidar: equal and grown cells, sub-points, the tail rule, the cloud's interval weight."""

import math

import numpy as np
import pytest
from scipy import integrate

from cwlidar_sim.beam import BeamOptics, fourier_exact, weight_exact, weight_truncated
from cwlidar_sim.beam.cells import interval_weight, probe_cells

OPT = BeamOptics(focus=67.5)  # A2012: z_R = 5.61 m
ZR = OPT.rayleigh_length
#: The line Lorentzian's weight in front of the telescope (s > -r): the cut one is it over this.
FRONT_LOR = 0.5 + math.atan(OPT.focus / ZR) / math.pi


def test_equal_cells_are_the_truncated_weighting_and_the_tail_sees_the_mean():
    for span, cl in ((20.0, 0.5), (5.0, 2.0), (300.0, 7.0)):
        c = probe_cells(OPT, "exact", span, cl)
        n = math.ceil((span * ZR + min(span * ZR, OPT.focus)) / cl - 1e-9)
        ref = weight_truncated(OPT, "exact", span=span, n_cells=n, renormalise=False)
        assert c.n_cells == n
        np.testing.assert_array_equal(c.weight_s, ref.weight_s)
        np.testing.assert_array_equal(c.s_s, ref.s_s)
        # one sub-point per cell, at its centre, the whole weight
        np.testing.assert_array_equal(c.sub_j, c.s_s)
        np.testing.assert_array_equal(c.fraction_j, 1.0)
        # the weight beyond the span is the tail cell's: a uniform wind is returned exactly
        assert c.weight_s.sum() + c.tail_weight == pytest.approx(1.0, abs=1e-14)
        assert c.tail_weight == pytest.approx(ref.truncated_fraction, rel=1e-12)
        r = probe_cells(OPT, "exact", span, cl, tail="renormalise")
        assert r.tail_weight == 0.0 and r.weight_s.sum() == pytest.approx(1.0, abs=1e-14)
        assert r.weight_tail_s.size == r.n_cells and c.weight_tail_s.size == c.n_cells + 1


def test_lorentzian_tail_weight_is_two_over_pi_span():
    # A2012 Eq. 4 beyond +-S z_R on both sides (the focus far from the telescope), of the weight in front of
    # the telescope, 1/2 + arctan(r / z_R) / pi (nothing behind it): 1 - (2/pi) arctan(S) / front
    far = BeamOptics(focus=100.0, radius=0.2)  # z_R = 0.12 m: +-100 z_R stays in front of the telescope
    front = 0.5 + math.atan(far.focus / far.rayleigh_length) / math.pi
    for span in (5.0, 20.0, 100.0):
        c = probe_cells(far, "lorentzian", span, far.rayleigh_length / 4)
        assert c.tail_weight == pytest.approx(1.0 - 2.0 / math.pi * math.atan(span) / front, rel=1e-9)


@pytest.mark.parametrize("growth", [0.05, 0.2, 1.0])
def test_grown_cells_keep_the_weighting_and_cost_fewer_cells(growth):
    span, cl = 200.0, 0.5
    eq = probe_cells(OPT, "exact", span, cl)
    gr = probe_cells(OPT, "exact", span, cl, growth=growth)
    assert gr.n_cells < eq.n_cells / 5
    # same span, same kept weight, and the cells tile it
    assert gr.edges[0] == pytest.approx(eq.edges[0]) and gr.edges[-1] == pytest.approx(eq.edges[-1])
    assert gr.weight_s.sum() == pytest.approx(eq.weight_s.sum(), rel=1e-12)
    assert gr.tail_weight == pytest.approx(eq.tail_weight, rel=1e-9)
    length = np.diff(gr.edges)
    centre = 0.5 * (gr.edges[:-1] + gr.edges[1:])
    # each cell about max(cl, growth |s|) long (measured from its inner edge), none a sliver
    inner = np.minimum(np.abs(gr.edges[:-1]), np.abs(gr.edges[1:]))
    # (the last cell may absorb a sliver shorter than half the next: at most (1.5 + growth / 2) times)
    assert np.all(length <= np.maximum(cl, growth * inner) * (1.5 + 0.5 * growth) + 1e-9)
    assert np.all(length >= 0.5 * cl - 1e-9)
    # sub-points every <= cl, each cell's fractions sum to 1, and their weights are the exact integrals
    n_sub = np.diff(gr.ptr_s)
    assert np.all(length / n_sub <= cl + 1e-9)
    sums = np.add.reduceat(gr.fraction_j, gr.ptr_s[:-1])
    np.testing.assert_allclose(sums, 1.0, rtol=1e-12)
    w_p = gr.fraction_j * np.repeat(gr.weight_s, n_sub)
    c = int(np.argmax(n_sub))
    e = np.linspace(gr.edges[c], gr.edges[c + 1], n_sub[c] + 1)
    exact = [integrate.quad(lambda s: weight_exact(s, OPT.focus), a, b)[0] for a, b in zip(e[:-1], e[1:])]
    np.testing.assert_allclose(w_p[gr.ptr_s[c]:gr.ptr_s[c + 1]], exact, rtol=1e-7)
    # tier 1's sum is the weighting's: equal and grown cells give the weighting's Fourier transform to
    # within the midpoint rule's error of <= 0.5 m sub-intervals, |d phi_hat| < 1e-3 at any k (equal cells:
    # the boxcar factor sinc(k h / 2), 1.3 % of phi_hat at 0.8 rad/m; unequal sub-intervals: O(h^2) steps),
    # far below a transfer function's noise floor (A2012's method 1 bottoms out near 2e-3), up to
    # 1 rad/m (|phi_hat|^2 = 1.4e-5); the tail cell adds its weight at k = 0 only (it sees the mean)
    k = np.linspace(0.0, 1.0, 41)
    exact = fourier_exact(k, OPT.focus) - np.where(k == 0.0, gr.tail_weight, 0.0)
    assert np.max(np.abs(gr.transfer(k) - exact)) < 1e-3
    assert np.max(np.abs(eq.transfer(k) - exact)) < 1e-3
    assert centre[0] < 0 < centre[-1]


def test_interval_weight_is_the_integral_of_the_weighting():
    for a, b in ((-3.0, 4.0), (100.0, 130.0), (1532.5, 1562.5), (-67.5, -10.0)):
        ref = integrate.quad(lambda s: weight_exact(s, OPT.focus), a, b, limit=200)[0]
        assert interval_weight(OPT, "exact", a, b) == pytest.approx(ref, rel=1e-8)
        lor = integrate.quad(lambda s: ZR / math.pi / (ZR**2 + s**2), a, b, limit=200)[0]
        assert interval_weight(OPT, "lorentzian", a, b) == pytest.approx(lor / FRONT_LOR, rel=1e-8)
    # a far cloud: the tail density z_R / (pi s^2) times its depth, of the weight in front of the telescope
    s0 = 1600.0 - OPT.focus
    assert interval_weight(OPT, "lorentzian", s0, s0 + 10.0) == pytest.approx(
        ZR / math.pi * 10.0 / s0**2 / FRONT_LOR, rel=0.01)


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="tail"):
        probe_cells(OPT, "exact", 20.0, 0.5, tail="edge")
    with pytest.raises(ValueError, match="growth"):
        probe_cells(OPT, "exact", 20.0, 0.5, growth=2.0)
    with pytest.raises(ValueError, match="number of range cells"):
        probe_cells(OPT, "exact", 1000.0, 0.001)
    with pytest.raises(ValueError, match="cell_length"):
        probe_cells(OPT, "exact", 20.0, 0.0)
    with pytest.raises(TypeError, match="BeamOptics"):
        probe_cells("prototype", "exact", 20.0, 0.5)
