"""Probe-volume weighted line-of-sight speed (A2012 Eq. 2): uniform fields and spectral transfer."""

import math

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import quad

from cwlidar_sim.beam import BeamOptics, fourier_exact, los_average, sample_los, weight_lorentzian

# Line field for the spectral tests: N nodes at dx, period N dx = 512 m.
N, DX, U = 2048, 0.25, 10.0
FOCUS = 67.5  # 270 dx: the focus is a grid node
N_CELLS = 539  # cell length 2 span zR / N_CELLS = DX: every cell centre falls on a node
HALF = N_CELLS * DX / 2  # 67.375 m < FOCUS: the span does not reach the telescope


def line_field(seed):
    rng = np.random.default_rng(seed)
    u, v, w = rng.standard_normal((3, N))
    return xr.Dataset({"u": ("x", u), "v": ("x", v), "w": ("x", w)}, coords={"x": DX * np.arange(N)})


def spectral_setup(weighting, renormalise):
    """Averaged and point series over one full period of the line, and their DFTs."""
    opt = BeamOptics(focus=FOCUS)
    span = HALF / opt.rayleigh_length
    field = line_field(21)
    time_t = DX / U * np.arange(N)  # U dt = dx: each sample moves the field by one node
    res = los_average(field, opt, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], time_t, U, weighting, span=span,
                      n_cells=N_CELLS, renormalise=renormalise)
    _, point = sample_los(field, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [FOCUS], time_t, U)
    k = 2 * np.pi * np.fft.fftfreq(N, d=DX)  # Taylor: k = 2 pi f / U [rad/m]
    return opt, res, np.fft.fft(res.vlos_t), np.fft.fft(point[:, 0]), k


def discretisation_bound(k, zR, ds):
    """|sum_s w_s exp(-iks_s) - int_span phi exp(-iks) ds| for cell integrals w_s sampled at cell centres.

    First-order term: sum over cells of max|phi'| ds^3/12 <= (ds^2/12) * total variation of phi
    = ds^2/12 * 2 phi(0) = ds^2 / (6 pi zR), times |k|.  Second-order term: |e^{-ie}-1+ie| <= e^2/2 with
    |e| <= |k| ds/2, times the kept weight (<= 1).  A factor 1.5 covers max-over-cell vs the variation.
    """
    return 1.5 * (np.abs(k) * ds**2 / (6 * np.pi * zR) + k**2 * ds**2 / 8) + 1e-12  # + round-off


def front(zR):
    """The line Lorentzian's weight in front of the telescope (s > -FOCUS): the weighting is it cut there, over this."""
    return 0.5 + math.atan(FOCUS / zR) / math.pi


def lorentzian_truncated_transform(k, zR, half):
    """int_{-half}^{half} phi(s) exp(-iks) ds = (exp(-|k| zR) - 2 int_half^inf phi_L cos(ks) ds) / front (QAWF)."""
    out = np.empty(k.size)
    for i, kk in enumerate(np.abs(k)):
        if kk == 0:
            out[i] = (1 - (2 / np.pi) * math.atan2(zR, half)) / front(zR)
            continue
        tail, _ = quad(weight_lorentzian, half, np.inf, args=(zR,), weight="cos", wvar=kk)
        out[i] = (math.exp(-kk * zR) - 2 * tail) / front(zR)
    return out


def test_lorentzian_power_transfer_along_the_wind():
    opt, res, avg_f, point_f, k = spectral_setup("lorentzian", renormalise=False)
    zR = opt.rayleigh_length
    cells = res.cells
    assert np.allclose(np.diff(cells.s_s), DX) and np.allclose(cells.s_s / DX, np.round(cells.s_s / DX))
    # 1) staring along x under Taylor, the average is a circular convolution of the point series:
    #    its DFT is exactly H(k) = sum_s w_s exp(-i k s_s) times the point series' DFT (round-off only)
    H = cells.transfer(k)
    np.testing.assert_allclose(avg_f, H * point_f, rtol=0, atol=1e-10 * np.abs(point_f).max())
    good = np.abs(point_f) > 1e-3 * np.abs(point_f).max()
    np.testing.assert_allclose(np.abs(avg_f[good]) ** 2 / np.abs(point_f[good]) ** 2, np.abs(H[good]) ** 2,
                               rtol=1e-8)
    # 2) H against the continuous truncated Lorentzian transform, truncation accounted for analytically
    sel = (np.abs(k) <= 0.6) & (k >= 0)  # exp(-2 k zR) >= 1e-3 there
    theory = lorentzian_truncated_transform(k[sel], zR, HALF)
    bound = discretisation_bound(k[sel], zR, DX)
    assert np.all(np.abs(H[sel] - theory) <= bound)
    # 3) the power transfer function against A2012 Eq. 9: off by at most twice the line Lorentzian's missing
    #    tail weight and its share behind the telescope eps (cut off), over the front weight 1 - eps, plus the
    #    discretisation (|a^2 - b^2| <= 2|a - b| for a, b <= 1)
    line_trunc, eps = 1 - (2 / np.pi) * math.atan(HALF / zR), 1 - front(zR)
    assert res.truncated_fraction == pytest.approx(1 - (1 - line_trunc) / front(zR), rel=1e-12)
    power_dev = np.abs(np.abs(H[sel]) ** 2 - np.exp(-2 * np.abs(k[sel]) * zR))
    assert np.all(power_dev <= 2 * ((line_trunc + eps) / front(zR) + bound))
    # with the tail restored (the truncated transform) the agreement is at the discretisation level
    assert np.all(np.abs(np.abs(H[sel]) ** 2 - theory**2) <= 2 * bound)


def test_renormalised_transfer_is_scaled_by_kept_weight():
    _, res_keep, avg_keep, _, _ = spectral_setup("lorentzian", renormalise=False)
    _, res_ren, avg_ren, _, _ = spectral_setup("lorentzian", renormalise=True)
    assert res_ren.renormalised and not res_keep.renormalised
    np.testing.assert_allclose(avg_ren * res_keep.kept_fraction, avg_keep, rtol=0,
                               atol=1e-12 * np.abs(avg_keep).max())


def test_exact_weighting_transfer_along_the_wind():
    opt, res, avg_f, point_f, k = spectral_setup("exact", renormalise=True)
    H = res.cells.transfer(k)
    np.testing.assert_allclose(avg_f, H * point_f, rtol=0, atol=1e-10 * np.abs(point_f).max())
    # against the untruncated exact transform: the truncated weight (renormalised) and the
    # discretisation bound the difference: |H - phi_hat| <= 2 * trunc / kept + bound
    sel = (k >= 0) & (k <= 0.6)
    zR = opt.rayleigh_length
    bound = discretisation_bound(k[sel], zR, DX) + 2 * res.truncated_fraction / res.kept_fraction
    assert np.all(np.abs(H[sel] - fourier_exact(k[sel], FOCUS)) <= bound)


@pytest.mark.parametrize("weighting", ["exact", "lorentzian"])
def test_uniform_field_gives_back_the_value(weighting):
    shape, h = (16, 10, 10), (4.0, 4.0, 4.0)
    c = np.array([7.0, -1.5, 0.375])  # exact in float32
    field = xr.Dataset(
        {name: (("x", "y", "z"), np.full(shape, val, dtype=np.float32)) for name, val in zip("uvw", c)},
        coords={d: h[i] * np.arange(shape[i]) for i, d in enumerate("xyz")},
    )
    opt = BeamOptics(focus=20.0)  # zR = 0.49 m: span 20 zR stays inside the 36 m box
    n = np.array([0.8, 0.36, 0.48])
    t = np.linspace(0, 10, 25)
    ren = los_average(field, opt, [2.0, 10.0, 6.0], n, t, 5.0, weighting, span=20.0, n_cells=101)
    np.testing.assert_allclose(ren.vlos_t, n @ c, rtol=1e-12)
    keep = los_average(field, opt, [2.0, 10.0, 6.0], n, t, 5.0, weighting, span=20.0, n_cells=101,
                       renormalise=False)
    np.testing.assert_allclose(keep.vlos_t, (n @ c) * keep.kept_fraction, rtol=1e-12)
    assert keep.truncated_fraction == pytest.approx(1 - keep.kept_fraction, abs=1e-15)
    if weighting == "lorentzian":  # of the weight in front of the telescope (nothing behind it)
        front = 0.5 + math.atan(opt.focus / opt.rayleigh_length) / math.pi
        assert keep.truncated_fraction == pytest.approx(1 - (2 / np.pi) * math.atan(20.0) / front, rel=1e-12)
    # add_mean: the total wind (U + u, v, w)
    tot = los_average(field, opt, [2.0, 10.0, 6.0], n, t, 5.0, weighting, span=20.0, n_cells=101, add_mean=True)
    np.testing.assert_allclose(tot.vlos_t, n @ (c + [5.0, 0, 0]), rtol=1e-12)


def test_los_average_validation():
    field = line_field(1)
    opt = BeamOptics(focus=FOCUS)
    with pytest.raises(TypeError, match="optics"):
        los_average(field, 67.5, [0, 0, 0], [1.0, 0, 0], [0.0], U)
    with pytest.raises(ValueError, match="weighting"):
        los_average(field, opt, [0, 0, 0], [1.0, 0, 0], [0.0], U, "gauss")
    with pytest.raises(ValueError, match="line field in y"):
        los_average(field, opt, [0, 0, 0], [0.8, 0.6, 0], [0.0], U)
