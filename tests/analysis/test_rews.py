"""REWS, its lidar estimate and their coherence: analysis/rews.py and analysis/rews_theory.py.

Deterministic checks: closed forms and limiting cases of the analytic spectra (a point
lidar on the rotor axis gives the point-to-REWS coherence, an axial Lorentzian beam
A2012 Eq. 9, a point lidar focused on the hub the REWS point itself, a point rotor and an
evolving field the model's longitudinal coherence), the beam transfers against
cwlidar_sim.beam, and the quadrature's convergence.

Monte Carlo: boxes (``correction="none"``, so that every mode's variance is the tensor
at the mode) sampled by ``los_average`` (tier 1) and the REWS of the disc's grid nodes,
against an explicit sum over the box's modes that includes the sampler's trilinear
interpolation, itself checked against the package's box-discrete analytic without it.
Each k1 row of each seed is one complex Gaussian pair (REWS, lidar); the pooled
co-coherence's standard error comes from the pairs' expected moments (delta method),
and a band passes within 4 of them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.rews import (
    RotorDisc,
    align_preview,
    coherence_bandwidth,
    coherence_estimate,
    coherence_interval,
    effective_averages,
    los_to_u,
    preview_time,
    rews_from_box,
    rotor_node_weights,
    scan_average,
    wiener_gain,
)
from cwlidar_sim.analysis.rews_theory import (
    LidarBeams,
    RewsSpectra,
    beam_transfer,
    circular_scan,
    estimated_spectra,
    rews_spectra,
    rotor_spectrum,
)
from cwlidar_sim.beam import BeamOptics, fourier_exact, los_average, weight_truncated
from cwlidar_sim.turbulence import MannParameters, one_point_spectra
from cwlidar_sim.turbulence.evolution import EddyLifetimeEvolution, generate_evolving_boxes, longitudinal_coherence
from cwlidar_sim.turbulence.tensor import spectral_tensor

P = MannParameters(alpha_eps=0.05, length_scale=20.0, gamma=3.9)
U = 10.0


# ---------------------------------------------------------------------------
# the rotor, the estimator, the preview
# ---------------------------------------------------------------------------
def test_rotor_disc_transfer_and_weights():
    rotor = RotorDisc(16.0)
    kap = np.array([0.0, 1e-9, 0.05, 0.3, 2.0])
    D = rotor.transfer(kap)
    assert D[0] == 1.0 and D[1] == pytest.approx(1.0)
    # the numeric path (p > 0) at p -> 0 is the closed form 2 J1(x) / x
    np.testing.assert_allclose(RotorDisc(16.0, exponent=1e-12).transfer(kap), D, atol=1e-12)
    # a fine grid of nodes, equal weights: sum w exp(i k.p) -> D (uniform), -> the p = 1 transfer
    h = 0.05
    c = np.arange(-16.0, 16.0 + h / 2, h)
    for p in (0.0, 1.0):
        r = RotorDisc(16.0, exponent=p)
        w = rotor_node_weights(r, c, c, 0.0, 0.0)
        assert w.sum() == pytest.approx(1.0)
        for k2, k3 in ((0.05, 0.0), (0.2, 0.1)):
            s = np.sum(w * np.cos(k2 * c[:, None] + k3 * c[None, :]))
            assert s == pytest.approx(float(r.transfer(math.hypot(k2, k3))), abs=2e-3)
    assert RotorDisc.from_dict({"radius": 5.0}) == RotorDisc(5.0)
    with pytest.raises(ValueError, match="unknown key.*'radios'"):
        RotorDisc.from_dict({"radios": 5.0})
    with pytest.raises(ValueError, match="radius"):
        RotorDisc(0.0)
    with pytest.raises(ValueError, match="no grid node"):
        rotor_node_weights(RotorDisc(0.1), [0.0, 1.0], [0.0, 1.0], 0.5, 0.5)


def test_uniform_wind_is_returned_exactly():
    # u from v_los under v = w = 0, any beam looking up- or downwind
    lid = circular_scan(7, 15.0, 80.0)
    vlos = lid.direction_bc @ np.array([9.3, 0.0, 0.0])
    np.testing.assert_allclose(los_to_u(vlos, lid.direction_bc), 9.3, rtol=1e-14)
    with pytest.raises(ValueError, match="n_x"):
        los_to_u([1.0], [0.0, 1.0, 0.0])
    # REWS of a uniform field is its value; of a field linear in y about the hub, the hub's value
    x = np.arange(8) * 2.0
    y = np.arange(20) * 2.0
    import xarray as xr

    uu = np.broadcast_to(0.7 + 0.1 * (y[None, :, None] - 19.0), (8, 20, 20)).astype(np.float64)
    box = xr.Dataset({"u": (("x", "y", "z"), uu)}, coords={"x": x, "y": y, "z": y})
    rews = rews_from_box(box, RotorDisc(12.0), 19.0, 19.0, x=3.0, times=np.arange(5) * 0.1, U=8.0)
    np.testing.assert_allclose(rews, 0.7, atol=1e-12)


def test_scan_average_and_preview():
    u = np.arange(10.0)
    s = scan_average(u, 4)
    assert np.all(np.isnan(s[:3]))
    np.testing.assert_allclose(s[3:], np.arange(1.5, 8.0))
    assert preview_time(100.0, 8.0) == 12.5
    r = np.arange(20.0)
    lidar = np.roll(r, -5)  # the lidar sees now what the rotor sees 5 samples later
    rs, ls, resid = align_preview(r, lidar, 1.0, 5.0)
    assert rs.size == ls.size == 15 and resid == 0.0
    np.testing.assert_array_equal(rs, ls)
    rs, ls, resid = align_preview(r, lidar, 0.5, 2.6)
    assert rs.size == 15 and resid == pytest.approx(0.1)
    with pytest.raises(ValueError, match="preview"):
        align_preview(r, r, 1.0, 30.0)


def test_coherence_estimate_of_a_known_coherence_and_its_interval():
    # y = a x + b n with x, n white: gamma^2 = a^2 / (a^2 + b^2) at every frequency
    rng = np.random.default_rng(5)
    a, b = 1.0, 0.8
    g2 = a * a / (a * a + b * b)
    inside = 0
    trials = 40
    for _ in range(trials):
        x = rng.standard_normal(1024)
        y = a * x + b * rng.standard_normal(1024)
        est = coherence_estimate(x, y, fs=1.0, U=1.0, segment_duration=32.0)
        # an interval (32 averages) covers the truth with the stated confidence; the
        # frequencies of white series are independent
        inside += np.count_nonzero((est.lower_f <= g2) & (g2 <= est.upper_f))
    n = trials * est.f_f.size
    # binomial: 95 % of 640 with sd 0.86 % -> within 4 sd
    assert abs(inside / n - 0.95) < 4 * math.sqrt(0.95 * 0.05 / n)
    # pooled over all frequencies the estimate is unbiased to its bias (1 - g2)^2 / n
    assert np.mean(est.coherence_f) == pytest.approx(g2 + (1 - g2) ** 2 / est.n_dof_f[0], abs=0.02)
    np.testing.assert_allclose(est.gain_f, np.abs(est.cross_f) / est.lidar_f)
    edges = np.geomspace(0.05, 0.5, 4)
    binned = coherence_estimate(x, y, fs=1.0, U=1.0, segment_duration=32.0, f_edges=edges)
    assert np.all(binned.n_dof_f >= 2 * est.n_dof_f[0])
    lo, hi = coherence_interval([0.5], [30])
    assert lo[0] < 0.5 < hi[0]


def test_hann_bins_count_their_correlated_ordinates():
    # the periodic Hann window's ordinates correlate as rho_1 = -2/3, rho_2 = 1/6 (w^2 = 3/8 - cos/2 + cos2/8)
    m = np.array([1, 2, 4, 1000])
    expected = m**2 / (m + 2 * ((m - 1) * (2 / 3) ** 2 + np.maximum(m - 2, 0) * (1 / 6) ** 2))
    np.testing.assert_allclose(effective_averages(m, 4096, "hann"), expected, rtol=1e-9)
    np.testing.assert_array_equal(effective_averages(m, 4096, "none"), m)
    # coverage of Fisher's interval with bins of 4 Hann ordinates: 95 % with the effective number
    # (2.38 per segment), about 87 % with the 4 nominal ones
    rng = np.random.default_rng(11)
    a, b = 1.0, 0.8
    g2 = a * a / (a * a + b * b)
    edges = (np.arange(1, 34, 4) - 0.5) / 64.0  # 8 bins of 4 ordinates j / 64
    inside = n = 0
    for _ in range(150):
        x = rng.standard_normal(2048)
        y = a * x + b * rng.standard_normal(2048)
        est = coherence_estimate(x, y, fs=1.0, U=1.0, segment_duration=64.0, f_edges=edges, window="hann")
        inside += np.count_nonzero((est.lower_f <= g2) & (g2 <= est.upper_f))
        n += est.f_f.size
    np.testing.assert_allclose(est.n_dof_f, 32 * expected[2])
    assert abs(inside / n - 0.95) < 4 * math.sqrt(0.95 * 0.05 / n), inside / n


def _ar1_pair_spectra(a, sigma_n, k):
    """Two-sided spectra in k (U = 1, fs = 1) of x (AR(1), unit innovations) and y = x + white noise."""
    s_x = 1.0 / np.abs(1.0 - a * np.exp(-1j * k)) ** 2 / (2 * math.pi)
    return RewsSpectra(k1_k=k, rotor_k=s_x, lidar_k=s_x + sigma_n**2 / (2 * math.pi), cross_k=s_x.astype(complex))


def test_estimated_spectra_are_what_segment_averages_converge_to():
    # a red pair (AR(1) with a = 0.97 and the same plus white noise): the coherence falls from
    # 0.97 to 0.1 over the bins; 32-sample Hann segments leak the coherent low frequencies upward
    from scipy.signal import lfilter

    a, sig = 0.97, 2.0
    rng = np.random.default_rng(3)
    n_seg, n_per = 4000, 32
    x = lfilter([1.0], [1.0, -a], rng.standard_normal(n_seg * n_per + 500))[500:]
    y = x + sig * rng.standard_normal(x.size)
    edges = np.array([0.5, 1.5, 2.5, 4.5, 8.5, 12.5]) / n_per  # clear of the Nyquist ordinate
    est = coherence_estimate(x, y, fs=1.0, U=1.0, segment_duration=float(n_per), f_edges=edges, window="hann")
    th = _ar1_pair_spectra(a, sig, np.geomspace(1e-4, math.pi, 400))
    exp = estimated_spectra(th, 1.0, fs=1.0, segment_duration=float(n_per), window="hann", f_edges=edges)
    np.testing.assert_allclose(exp.k1_k, est.k_f)
    n = est.n_dof_f
    # levels: a mean of n effective periodograms has relative sd 1 / sqrt(n)
    for got, want in ((est.rotor_f, exp.rotor_k), (est.lidar_f, exp.lidar_k)):
        assert np.all(np.abs(got / want - 1) < 4 / np.sqrt(n)), got / want
    # coherence: Fisher's z with its bias
    s = 1 / np.sqrt(2 * (n - 1))

    def z(c):
        return (np.arctanh(np.sqrt(est.coherence_f)) - s * s - np.arctanh(np.sqrt(c))) / s

    assert np.all(np.abs(z(exp.coherence_k)) < 4), z(exp.coherence_k)
    # informative: the coherence of the spectra at the bin centres (no leakage, no bin average) is off
    kc = 2 * math.pi * np.sqrt(edges[:-1] * edges[1:])
    naive = _ar1_pair_spectra(a, sig, kc).coherence_k
    assert exp.coherence_k[0] > 0.85 and exp.coherence_k[-1] < 0.3
    assert np.max(np.abs(z(naive))) > 8, z(naive)


def test_coherence_bandwidth_and_wiener_gain():
    k = np.geomspace(1e-3, 1.0, 200)
    g2 = np.exp(-k / 0.05)
    assert coherence_bandwidth(k, g2) == pytest.approx(0.05 * math.log(2), rel=2e-3)
    assert math.isnan(coherence_bandwidth(k, 0.4 * g2))
    assert math.isnan(coherence_bandwidth(k, np.ones_like(k)))
    np.testing.assert_allclose(wiener_gain(np.array([1 + 1j]), np.array([2.0])), math.sqrt(2) / 2)


# ---------------------------------------------------------------------------
# beam transfers
# ---------------------------------------------------------------------------
def test_exact_transfer_is_fourier_exact():
    # fourier_exact's QAWF integral goes wrong below |q| ~ 1e-6 rad/m (0.02 off at 1e-7,
    # against a smooth limit); compared from 1e-5 on
    q = np.array([-0.4, 1e-5, 1e-3, 0.02, 0.3, 1.0, 4.0])
    for r in (40.0, 120.0, 300.0):
        np.testing.assert_allclose(beam_transfer(r, "exact")(q), fourier_exact(q, r), rtol=0, atol=5e-9)
    assert beam_transfer(40.0, "exact")(np.array([0.0]))[0] == pytest.approx(1.0, abs=1e-12)


def test_cells_transfer_is_the_sum_over_cells():
    cells = weight_truncated(BeamOptics(40.0), "exact", span=20.0, n_cells=201)
    q = np.array([-1.3, 0.0, 0.011, 0.2, 0.77, 2.4])
    np.testing.assert_allclose(beam_transfer(40.0, cells)(q), cells.transfer(q), rtol=0, atol=3e-5)


# ---------------------------------------------------------------------------
# analytic spectra: limits
# ---------------------------------------------------------------------------
K1 = np.array([0.003, 0.03, 0.3])


def _point_to_disc(k1, R):
    """Independent polar quadrature of the point-on-axis against a disc (trapezoid, dense)."""
    rotor = RotorDisc(R)
    out = []
    for kk in k1:
        # geometric up to 0.2 rad/m (the sheared tensor has structure on the scale k1 there)
        kap = np.concatenate([np.geomspace(1e-7, 0.2, 400), np.linspace(0.2, 6.0, 1200)[1:],
                              np.geomspace(6.0, 3e3, 200)[1:]])
        psi = (np.arange(128) + 0.5) * 2 * math.pi / 128  # the sheared tensor at k1 L = 0.06 needs them
        K2, K3 = np.cos(psi)[None, :] * kap[:, None], np.sin(psi)[None, :] * kap[:, None]
        f = spectral_tensor(kk, K2, K3, P)[..., 0, 0].mean(axis=1) * 2 * math.pi * kap
        D = rotor.transfer(kap)
        out.append([np.trapezoid(f * D, kap), np.trapezoid(f * D * D, kap), np.trapezoid(f, kap)])
    return np.array(out).T


def test_axial_point_lidar_gives_the_point_to_rews_coherence():
    F = one_point_spectra(K1, P)[0] / 2.0  # rews_theory's spectra are two-sided (its module notes)
    lid = circular_scan(1, 0.0, 50.0)
    s = rews_spectra(K1, P, RotorDisc(16.0), lid, U, weighting="point")
    # the independent reference at the two lower k1; at 0.3 rad/m (k1 R = 4.8) the
    # cross-spectrum is 2e-3 of F11, a near cancellation of the disc's oscillating transfer
    # (0.5 % apart there, 4e-6 in a coherence of 4e-4, where the reference is not converged)
    cross, rr, point = _point_to_disc(K1[:2], 16.0)
    np.testing.assert_allclose(point, F[:2], rtol=5e-4)  # the reference's own accuracy (measured 2e-4)
    np.testing.assert_allclose(s.lidar_k, F, rtol=2e-6)
    np.testing.assert_allclose(s.rotor_k[:2], rr, rtol=1e-3)
    np.testing.assert_allclose(rotor_spectrum(K1, P, RotorDisc(16.0)), s.rotor_k, rtol=1e-12)
    np.testing.assert_allclose(s.cross_k.imag, 0.0, atol=1e-12 * F.max())
    np.testing.assert_allclose(s.cross_k.real[:2], cross, rtol=1e-3)
    np.testing.assert_allclose(s.coherence_k[:2], cross**2 / (point * rr), rtol=2e-3)
    assert np.all(np.diff(s.coherence_k) < 0) and s.coherence_k[-1] < 0.05
    # a point rotor: everything is F11 and the coherence 1
    p = rews_spectra(K1, P, RotorDisc(1e-4), lid, U, weighting="point")
    for a in (p.rotor_k, p.lidar_k, p.cross_k.real):
        np.testing.assert_allclose(a, F, rtol=3e-6)
    np.testing.assert_allclose(p.coherence_k, 1.0, atol=1e-9)


def test_axial_lorentzian_beam_is_a2012_eq9():
    """Eq. 9's exp(-2 zR k) for the Lorentzian on the whole line; the weighting is it cut at the telescope.

    phi_hat(k) = (exp(-k zR) - int_{s < -r} L(s) exp(-i k s) ds) / (1/2 + arctan(r / zR) / pi), the part behind
    the telescope by QUADPACK's Fourier integral (QAWF).
    """
    from scipy.integrate import quad

    F = one_point_spectra(K1, P)[0] / 2.0  # two-sided, as rews_spectra
    r = 50.0
    zR = BeamOptics(r).rayleigh_length
    s = rews_spectra(K1, P, RotorDisc(16.0), circular_scan(1, 0.0, r), U, weighting="lorentzian")

    def behind(k):  # s = -r - v: exp(-i k s) = exp(i k r) exp(i k v)
        c, sn = (quad(lambda v: zR / math.pi / (zR**2 + (r + v) ** 2), 0.0, np.inf, weight=w, wvar=k)[0]
                 for w in ("cos", "sin"))
        return np.exp(1j * k * r) * (c + 1j * sn)

    ph = np.array([np.exp(-k * zR) - behind(k) for k in K1]) / (0.5 + math.atan(r / zR) / math.pi)
    np.testing.assert_allclose(s.lidar_k, F * np.abs(ph) ** 2, rtol=3e-6)
    # Eq. 9 within the cut's share 2 arctan(zR / r) / pi (and its slow transform)
    np.testing.assert_allclose(s.lidar_k, F * np.exp(-2 * zR * K1), rtol=4 * math.atan(zR / r) / math.pi)


def test_lidar_focused_on_the_hub_is_the_rews_of_a_point():
    # a point beam from 60 m downwind of the rotor plane looking upwind, focused on the hub,
    # estimates u at the hub: L = R for a one-node rotor, on a box's grid of modes
    lid = LidarBeams(direction_bc=[[-1.0, 0.0, 0.0]], focus_b=[60.0], weight_b=[1.0], delay_pb=[[0.0]],
                     origin=(60.0, 0.0, 0.0))
    k1 = 2 * math.pi * np.arange(1, 6) / 512.0
    s = rews_spectra(k1, P, ([0.0], [0.0], [1.0]), lid, U, weighting="point", box_grid=((256, 16, 16), (2, 4, 4)))
    np.testing.assert_allclose(s.cross_k, s.rotor_k, rtol=1e-12)
    np.testing.assert_allclose(s.lidar_k, s.rotor_k, rtol=1e-12)
    np.testing.assert_allclose(s.coherence_k, 1.0, rtol=1e-12)


def test_evolving_point_limit_is_the_model_longitudinal_coherence():
    ev = EddyLifetimeEvolution(40.0, U)
    lid = circular_scan(1, 0.0, 80.0)
    s = rews_spectra(K1, P, RotorDisc(1e-4), lid, U, weighting="point", evolution=ev)
    np.testing.assert_allclose(s.coherence_k, longitudinal_coherence(K1, P, ev, 80.0) ** 2, rtol=2e-5)
    frozen = rews_spectra(K1, P, RotorDisc(1e-4), lid, U, weighting="point",
                          evolution=EddyLifetimeEvolution(math.inf, U))
    np.testing.assert_allclose(frozen.coherence_k, 1.0, atol=1e-9)


def test_realistic_scan_quadrature_converges_and_obeys_cauchy_schwarz():
    # a 4-beam scan at 60 m before a 30 m rotor: the inner polar disc doubled changes the
    # coherence by less than 1e-3 (measured 1e-6)
    lid = circular_scan(4, 15.0, 60.0, revolution_time=0.8, all_phases=False)
    k1 = np.array([0.04])
    a = rews_spectra(k1, P, RotorDisc(30.0), lid, U)
    b = rews_spectra(k1, P, RotorDisc(30.0), lid, U, resolution=120.0)
    np.testing.assert_allclose(a.coherence_k, b.coherence_k, atol=1e-3)
    assert 0.0 < a.coherence_k[0] <= 1.0
    # the scan's timing lowers the coherence against simultaneous beams
    c = rews_spectra(k1, P, RotorDisc(30.0), circular_scan(4, 15.0, 60.0), U)
    assert c.coherence_k[0] > a.coherence_k[0]


def test_bad_arguments():
    with pytest.raises(ValueError, match="n_x"):
        LidarBeams(direction_bc=[[0.0, 1.0, 0.0]], focus_b=[50.0], weight_b=[1.0], delay_pb=[[0.0]])
    with pytest.raises(ValueError, match="sum to 1"):
        LidarBeams(direction_bc=[[-1.0, 0.0, 0.0]], focus_b=[50.0], weight_b=[0.5], delay_pb=[[0.0]])
    with pytest.raises(ValueError, match="k1"):
        rews_spectra([0.0], P, RotorDisc(10.0), circular_scan(1, 0.0, 50.0), U)
    with pytest.raises(ValueError, match="weighting"):
        rews_spectra([0.1], P, RotorDisc(10.0), circular_scan(1, 0.0, 50.0), U, weighting="gauss")
    with pytest.raises(TypeError, match="lidar"):
        rews_spectra([0.1], P, RotorDisc(10.0), {"beams": 1}, U)


# ---------------------------------------------------------------------------
# Monte Carlo against the box-discrete theory
# ---------------------------------------------------------------------------
SHAPE, SPACING = (512, 32, 32), (2.0, 2.0, 2.0)
HUB = (31.0, 31.0)
NB, HALF_ANGLE, FOCUS = 4, 15.0, 40.0
X_ROTOR = 0.5 * SHAPE[0] * SPACING[0] + 0.7  # off the grid in x, like the beams' cells
ROWS = np.arange(1, 38)  # k1 up to 0.23 rad/m
EV = EddyLifetimeEvolution(30.0, U)
SEEDS = range(6)
N_CELLS = 101  # 0.78 m cells on the 2 m grid


def _setup():
    rotor = RotorDisc(16.0)
    yc = np.arange(SHAPE[1]) * SPACING[1]
    w = rotor_node_weights(rotor, yc, yc, *HUB)
    iy, iz = np.nonzero(w)
    nodes = (yc[iy] - HUB[0], yc[iz] - HUB[1], w[iy, iz])
    cells = weight_truncated(BeamOptics(FOCUS), "exact", span=20.0, n_cells=N_CELLS)
    return rotor, nodes, cells


def _explicit_spectra(lid, nodes, cells, *, interp, rho=None, rows=ROWS):
    """Expected spectra of the sampled series: an explicit sum over the box's modes.

    The lidar's transfer is summed over the beams' cell points (weights, n / n_x), each
    point's mode value exp(i k.p) or, with ``interp``, the trilinear interpolate of the
    mode from the grid's nodes (what los_average computes), separably in x, y, z; the
    scan's delays and phases are applied per beam; ``rho`` multiplies the cross term.
    """
    k1 = 2 * math.pi * rows / (SHAPE[0] * SPACING[0])
    k2 = 2 * math.pi * np.fft.fftfreq(SHAPE[1], SPACING[1])
    origin = np.array([X_ROTOR, *HUB])
    r_s = np.maximum(FOCUS + cells.s_s, 0.0)
    pts = np.concatenate([origin + r_s[:, None] * n for n in lid.direction_bc])
    coef = np.concatenate([(w * cells.weight_s / n[0])[:, None] * n for n, w in zip(lid.direction_bc, lid.weight_b)])
    beam = np.repeat(np.arange(NB), r_s.size)

    def factor(k, x, h, x0):
        if not interp:
            return np.exp(1j * np.multiply.outer(x - x0, k))
        lo = np.floor(x / h) * h
        f = ((x - lo) / h)[:, None]
        return (1 - f) * np.exp(1j * np.multiply.outer(lo - x0, k)) + f * np.exp(1j * np.multiply.outer(lo + h - x0, k))

    # each point's lateral factor on the (k2, k3) grid of modes, once (no BLAS: plain einsum
    # sums, which a loaded machine's threaded BLAS would slow a hundredfold)
    M = np.einsum("pa,pb->pab", factor(k2, pts[:, 1], SPACING[1], HUB[0]),
                  factor(k2, pts[:, 2], SPACING[2], HUB[1])).reshape(pts.shape[0], -1)
    K2, K3 = np.meshgrid(k2, k2, indexing="ij")
    gr = np.einsum("n,an,bn->ab", nodes[2], np.exp(1j * np.multiply.outer(k2, nodes[0])),
                   np.exp(1j * np.multiply.outer(k2, nodes[1])))
    out = np.zeros((3, k1.size), dtype=complex)
    for j, kk in enumerate(k1):
        phi = spectral_tensor(kk, K2, K3, P)
        rj = 1.0 if rho is None else rho(np.sqrt(kk**2 + K2**2 + K3**2))
        Xf = factor(np.array([kk]), pts[:, 0], SPACING[0], X_ROTOR)[:, 0]
        acc = np.zeros(3, dtype=complex)
        for d_b in lid.delay_pb:
            lag = np.exp(1j * kk * U * d_b[beam])
            a = coef * (Xf * lag)[:, None]
            G = np.stack([(a[:, c, None] * M).sum(axis=0) for c in range(3)], axis=-1).reshape(K2.shape + (3,))
            pg = np.einsum("abij,abj->abi", phi, G)
            acc += [np.sum(np.abs(gr) ** 2 * phi[..., 0, 0]), np.sum(np.conj(G) * pg),
                    np.sum(np.conj(gr) * pg[..., 0] * rj)]
        out[:, j] = acc / len(lid.delay_pb)
    dk = (k2[1] - k2[0]) ** 2
    return out[0].real * dk, out[1].real * dk, out[2] * dk


@pytest.fixture(scope="module")
def mc_rows():
    """Per seed, the FFT rows of the REWS and of three lidar estimates (simultaneous, scanning, evolving)."""
    rotor, nodes, cells = _setup()
    optics = BeamOptics(FOCUS)
    t = np.arange(SHAPE[0]) * SPACING[0] / U
    lid = circular_scan(NB, HALF_ANGLE, FOCUS, azimuth0_deg=20.0)
    focus_x = float(lid.focus_points_bc[0, 0])
    out = {"rotor": [], "simultaneous": [], "scanning": [], "evolving": []}
    for s in SEEDS:
        box0, box1 = generate_evolving_boxes(P, SHAPE, SPACING, 500 + s, EV, [0.0, focus_x], correction="none")
        out["rotor"].append(np.fft.fft(rews_from_box(box0, rotor, *HUB, x=X_ROTOR, times=t, U=U)))
        u_b = {}
        for name, box in (("frozen", box0), ("evolving", box1)):
            u_b[name] = np.array([los_average(box, optics, (X_ROTOR, *HUB), n, t, U, "exact", span=20.0,
                                              n_cells=N_CELLS, wrap=True).vlos_t / n[0] for n in lid.direction_bc])
        out["simultaneous"].append(np.fft.fft(u_b["frozen"].mean(axis=0)))
        out["evolving"].append(np.fft.fft(u_b["evolving"].mean(axis=0)))
        # a circular scan, one beam per sample (beam j mod N at t_j), averaged over the last N
        seq = u_b["frozen"][np.arange(SHAPE[0]) % NB, np.arange(SHAPE[0])]
        out["scanning"].append(np.fft.fft(np.convolve(np.concatenate([seq[-(NB - 1):], seq]), np.ones(NB) / NB,
                                                      "valid")))
    return {k: np.array(v)[:, ROWS] for k, v in out.items()}


def _bands_z(X, Y, srr, sll, srl, n_bands=4):
    """z-scores of the pooled co-coherence (phase of the theory removed) per band of rows."""
    n = X.shape[0]
    ph = np.exp(-1j * np.angle(srl))
    z = []
    for b in np.array_split(np.arange(X.shape[1]), n_bands):
        C = np.sum((X[:, b] * np.conj(Y[:, b]) * ph[b]).real)
        A, B = np.sum(np.abs(X[:, b]) ** 2), np.sum(np.abs(Y[:, b]) ** 2)
        a, bb, c = srr[b], sll[b], np.abs(srl[b])
        Ea, Eb, Ec = n * a.sum(), n * bb.sum(), n * c.sum()
        theory = Ec / math.sqrt(Ea * Eb)
        S = n * np.array([[np.sum(a * bb + c * c) / 2, np.sum(a * c), np.sum(bb * c)],
                          [np.sum(a * c), np.sum(a * a), np.sum(c * c)],
                          [np.sum(bb * c), np.sum(c * c), np.sum(bb * bb)]])
        g = np.array([1 / math.sqrt(Ea * Eb), -theory / (2 * Ea), -theory / (2 * Eb)])
        z.append((C / math.sqrt(A * B) - theory) / math.sqrt(g @ S @ g))
    return np.array(z)


def test_box_discrete_theory_is_the_explicit_sum():
    rotor, nodes, cells = _setup()
    k1 = 2 * math.pi * ROWS / (SHAPE[0] * SPACING[0])
    for lid, ev in ((circular_scan(NB, HALF_ANGLE, FOCUS, azimuth0_deg=20.0), None),
                    (circular_scan(NB, HALF_ANGLE, FOCUS, azimuth0_deg=20.0, revolution_time=NB * 0.2), EV)):
        th = rews_spectra(k1[::6], P, nodes, lid, U, weighting=cells, preview_shift=0.0, evolution=ev,
                          box_grid=(SHAPE, SPACING))
        focus_x = abs(float(lid.focus_points_bc[0, 0]))
        rho = None if ev is None else (lambda k: ev.mode_correlation(k, focus_x, P))
        ref = _explicit_spectra(lid, nodes, cells, interp=False, rho=rho, rows=ROWS[::6])
        np.testing.assert_allclose(th.rotor_k, ref[0], rtol=1e-12)
        np.testing.assert_allclose(th.lidar_k, ref[1], rtol=5e-5)
        np.testing.assert_allclose(th.cross_k, ref[2], rtol=5e-5, atol=1e-5 * np.abs(ref[2]).max())


@pytest.mark.slow
@pytest.mark.parametrize("case", ["simultaneous", "scanning", "evolving"])
def test_simulated_coherence_is_the_theory_within_sampling_error(mc_rows, case):
    rotor, nodes, cells = _setup()
    lid = circular_scan(NB, HALF_ANGLE, FOCUS, azimuth0_deg=20.0,
                        revolution_time=NB * SPACING[0] / U if case == "scanning" else 0.0)
    focus_x = abs(float(lid.focus_points_bc[0, 0]))
    rho = (lambda k: EV.mode_correlation(k, focus_x, P)) if case == "evolving" else None
    srr, sll, srl = _explicit_spectra(lid, nodes, cells, interp=True, rho=rho)
    z = _bands_z(mc_rows["rotor"], mc_rows[case], srr, sll, srl)
    assert np.all(np.abs(z) < 4.0), z
    # the theory is informative here: the coherence spans high to low over the bands
    # (the evolving field starts lower: 3.9 s of age at 38.6 m)
    g2 = np.abs(srl) ** 2 / (srr * sll)
    assert g2[0] > (0.6 if case == "evolving" else 0.9) and g2[-1] < 0.4
