"""The conical lidar's focus and probe length per height, its speckle looks, and the cup's response, pinned by
physics: a range-varying field averaged by the Lorentzian of zR = lambda r^2 / (pi a0^2) at r = z / cos Phi,
the scan's speckle time in closed form, and the cup's filtered variance against the spectrum it filters."""

import math

import numpy as np
import pytest
import xarray as xr
from scipy.integrate import quad

from cwlidar_sim.sensors.conical import ConicalLidar, measure_conical
from cwlidar_sim.sensors.cup import Cup, cup_response, cup_transfer, sample_cup
from cwlidar_sim.signal.instrument import CS_SERIES

PHI = math.radians(30.0)


def _range_wave_box(lid, kz, amp, z_focus, dz=0.2, d=4.0, nx=16):
    """w = amp cos(kz (z - z_focus)), constant in x and y, fine in z (trilinear error (kz dz)^2 / 8)."""
    ext = lid.beam_extent(lid.heights[0])
    R = ext["radius"] + 2 * d
    y = np.arange(-R, R + d, d)
    z = np.arange(ext["z_lo"] - 1.0, ext["z_hi"] + 1.0, dz)
    w = amp * np.cos(kz * (z - z_focus))
    shape = (nx, y.size, z.size)
    data = {"u": (("x", "y", "z"), np.zeros(shape)), "v": (("x", "y", "z"), np.zeros(shape)),
            "w": (("x", "y", "z"), np.broadcast_to(w, shape).copy())}
    return xr.Dataset(data, coords={"x": d * np.arange(nx), "y": y, "z": z})


@pytest.mark.parametrize("z", [40.0, 100.0])
def test_focus_and_probe_length_per_height_seen_through_a_range_varying_wind(z):
    # The beam at r = z / cos Phi along n = (sin Phi cos theta, sin Phi sin theta, cos Phi) sees w(s) =
    # a cos(kz cos Phi s) at distance s from its focus; the Lorentzian of half-width zR = lambda r^2 / (pi a0^2)
    # over +-span zR (the tail sees the mean wind: 0 here) averages it to a cos Phi int L(s) cos(kz cos Phi s) ds,
    # L cut at the telescope and renormalised: over its weight in front of it, 1/2 + arctan(r / zR) / pi.
    # A focus at z instead of z / cos Phi shifts the wave's phase, a zR at the wrong range its attenuation.
    r = z / math.cos(PHI)
    inst = CS_SERIES.replace(focus=r)
    zR = CS_SERIES.wavelength * r * r / (math.pi * CS_SERIES.telescope_radius**2)
    assert zR == pytest.approx(0.0013 * r * r, rel=1e-12)  # CS's series ZephIR
    lid = ConicalLidar(heights=(z,), weighting="lorentzian", cell_length=0.25, sub_dwells=1)
    assert lid.focus(z) == pytest.approx(r, rel=1e-15)
    assert lid.instrument_at(z).rayleigh_length == pytest.approx(inst.rayleigh_length, rel=1e-12)
    kz = 0.25 / zR  # attenuation exp(-kz cos Phi zR) = 0.80 of a full Lorentzian
    amp, U = 1.0, 1.0
    rec = measure_conical(_range_wave_box(lid, kz, amp, z), lid, 1.0, U)
    half = lid.span * zR
    kappa = kz * math.cos(PHI)
    front = 0.5 + math.atan(r / zR) / math.pi
    gain = 2 * quad(lambda s: zR / math.pi / (zR**2 + s**2), 0.0, half, weight="cos", wvar=kappa)[0] / front
    want = U * math.sin(PHI) * np.cos(np.radians(rec.azimuth_e)) + amp * math.cos(PHI) * gain
    # cells of 0.25 m sampled at their centres: relative (kappa cl)^2 / 24 = 1e-5; the grid's 0.2 m: 3e-5
    np.testing.assert_allclose(rec.vlos_e, want, rtol=0, atol=2e-4)
    info = rec.info["heights"][z]
    assert info["focus"] == pytest.approx(r, rel=1e-12)
    assert info["rayleigh_length"] == pytest.approx(zR, rel=1e-12)


def test_speckle_time_and_looks_of_the_scan_in_closed_form():
    # tau_c = w0 / v_spot with w0 = lambda r / (pi a0) and v_spot = 2 pi r sin Phi / T_rev: lambda T_rev /
    # (2 pi^2 a0 sin Phi), the same at every height (8 us for the CS optics)
    lid = ConicalLidar(heights=(40.0, 100.0))
    lam, a0 = CS_SERIES.wavelength, CS_SERIES.telescope_radius
    tau = lam * 1.0 / (2 * math.pi**2 * a0 * math.sin(PHI))
    for z in (40.0, 100.0):
        assert lid.speckle_time(z) == pytest.approx(tau, rel=1e-12)
    assert 7e-6 < tau < 9e-6
    # M blocks of T_b, AR(1) speckle of correlation exp(-T_b / tau) in amplitude, exp(-2 T_b / tau) in power:
    # M_eff = M^2 / sum_ij rho^|i-j| summed directly (not the package's closed form)
    M, Tb = CS_SERIES.blocks_per_estimate, CS_SERIES.block_duration
    rho = math.exp(-2 * Tb / tau)
    lag = np.arange(1, M)
    m_eff = M * M / (M + 2 * np.sum((M - lag) * rho**lag))
    assert lid.speckle_looks(40.0) == pytest.approx(m_eff, rel=1e-6)
    # a spot sweeping slower (a 10 s revolution) keeps the speckle 10 times longer: fewer looks
    slow = ConicalLidar(heights=(40.0,), revolution_time=10.0)
    assert slow.speckle_time(40.0) == pytest.approx(10 * tau, rel=1e-12)
    assert slow.speckle_looks(40.0) < 0.2 * lid.speckle_looks(40.0)


def _kaimal_u_series(U, z, u_star, h, n, seed):
    """A periodic series with Kaimal's u spectrum (frequency form, one-sided S(f) = F_u(k) 2 pi / U): amplitudes
    exact, phases random; returns the series and its Fourier frequencies and component variances."""
    f = np.fft.rfftfreq(n, h)[1:-1]
    k = 2 * math.pi * f / U
    S = u_star**2 * 102.0 * z / (2 * math.pi) / (1 + 33.0 * k * z / (2 * math.pi)) ** (5 / 3) * 2 * math.pi / U
    var_j = S * (f[1] - f[0])  # the variance of each cosine
    rng = np.random.default_rng(seed)
    c = np.zeros(n // 2 + 1, complex)
    c[1:-1] = np.sqrt(2 * var_j) * np.exp(2j * math.pi * rng.random(f.size)) * n / 2
    return np.fft.irfft(c, n), f, var_j


@pytest.mark.parametrize("U, z", [(10.0, 40.0), (5.0, 100.0)])
def test_cup_filters_the_spectrum_it_sees_by_its_first_order_response(U, z):
    # A cup of distance constant l0 passes each component of frequency f with |H|^2 = 1 / (1 + (2 pi f l0 / U)^2):
    # its output variance is sum_j var_j |H(f_j)|^2, here for a periodic Kaimal series run through twice
    # (the second pass is free of the start-up transient)
    h, n = 0.02, 2**15  # 50 Hz, 655 s
    x, f, var_j = _kaimal_u_series(U, z, 0.5, h, n, seed=4)
    out = cup_response(np.concatenate([U + x, U + x]), h, 2.3, mean_speed=U)[n:]
    tau = 2.3 / U
    want = np.sum(var_j * np.abs(cup_transfer(f, tau)) ** 2)
    # the input is linear between samples: the fundamental is attenuated by sinc^2(f h), a relative
    # (pi f h)^2 / 3 of the filtered variance's dominant frequencies below 1 / (2 pi tau) (< 3e-4)
    assert np.var(out) == pytest.approx(want, rel=1e-3)
    # the cup removes a few per cent of sigma_u (the 1.6-3 %): exactly the spectrum's share above ~U / l0
    removed = 1 - math.sqrt(want / np.sum(var_j))
    assert 1 - np.std(out) / np.std(x) == pytest.approx(removed, abs=5e-4)
    assert 0.005 < removed < 0.05


def test_the_campaign_cup_has_its_documented_distance_constant():
    # the default cup (the conical period's) follows a 2.3 m distance constant: a sinusoid of 0.5 Hz in u at
    # 10 m/s, sampled at 10 Hz, comes out with |H(0.5 Hz; tau = 0.23 s)| = 0.811 of its amplitude
    U, fq = 10.0, 0.5
    x = 0.25 * np.arange(4096)
    lam = U / fq
    fld = xr.Dataset({"u": ("x", 0.3 * np.cos(2 * math.pi * x / lam)), "v": ("x", np.zeros(x.size)),
                      "w": ("x", np.zeros(x.size))}, coords={"x": x})
    cup = Cup(position=(0.0, 0.0, 0.0))
    t = cup.times(60.0)
    S = sample_cup(fld, cup, t, U)
    m = t > 10.0
    X = np.stack([np.cos(2 * math.pi * fq * t[m]), np.sin(2 * math.pi * fq * t[m]), np.ones(m.sum())], 1)
    c = np.linalg.lstsq(X, S[m], rcond=None)[0]
    H = abs(cup_transfer(fq, 2.3 / U))
    # linear interpolation of the 0.25 m field and of the 10 Hz input: sinc^2 factors, 1 - 0.0041 at 10 Hz
    assert math.hypot(c[0], c[1]) / 0.3 == pytest.approx(H * np.sinc(fq * 0.1) ** 2, rel=2e-3)
    assert abs(cup_transfer(fq, 1.0 / U)) > H + 0.1  # a shorter constant would pass visibly more


def test_cross_wind_structure_lands_in_the_radial_variance_that_the_1d_model_leaves_out():
    # CS's model filters along the wind only: a field that does not vary along x has all its variance at
    # k1 = 0, where every scan filter is 1, so the model's radial variance from it is 0.  On the circle the
    # beam sees u = a cos(k y) at y = rho sin Phi sin(theta): a cos(theta) cos(k R sin theta) pattern that
    # no rectified cosine fits.  Reference: the Lorentzian-averaged speeds in closed form (the cosine's odd
    # part integrates to 0 over the symmetric span) and a plain least-squares fit over the points the lidar kept.
    from cwlidar_sim.analysis.cs_model import model_integrals
    from cwlidar_sim.analysis.vad import fit_record

    z, U, a = 40.0, 8.0, 1.0
    lid = ConicalLidar(heights=(z,), weighting="lorentzian", cell_length=0.25, sub_dwells=1)
    r, R = lid.focus(z), z * math.tan(PHI)
    zR = lid.instrument_at(z).rayleigh_length
    k = math.pi / R  # half a wave across the circle
    ext = lid.beam_extent(z)
    y = np.arange(-ext["radius"] - 2.0, ext["radius"] + 2.0, 0.2)
    zz = np.arange(ext["z_lo"] - 4.0, ext["z_hi"] + 4.0, 4.0)
    shape = (16, y.size, zz.size)
    u = np.broadcast_to((a * np.cos(k * y))[None, :, None], shape).copy()
    fld = xr.Dataset({"u": (("x", "y", "z"), u), "v": (("x", "y", "z"), np.zeros(shape)),
                      "w": (("x", "y", "z"), np.zeros(shape))},
                     coords={"x": 4.0 * np.arange(16), "y": y, "z": zz})
    rec = measure_conical(fld, lid, 2.0, U)
    fit = fit_record(rec, z, 1, reference_deg=0.0)
    th = np.radians(rec.azimuth_e)
    half = lid.span * zR
    g = np.array([2 * quad(lambda s: zR / math.pi / (zR**2 + s**2), 0.0, half, weight="cos",
                           wvar=abs(k * math.sin(PHI) * st))[0] if st != 0 else 1 - 2 * math.atan2(zR, half) / math.pi
                  for st in np.sin(th)])
    g /= 0.5 + math.atan(r / zR) / math.pi  # the Lorentzian cut at the telescope: over its weight in front
    vr = math.sin(PHI) * np.cos(th) * (U + a * np.cos(k * r * math.sin(PHI) * np.sin(th)) * g)
    np.testing.assert_allclose(rec.vlos_e, vr, rtol=0, atol=1e-4)  # 0.25 m cells, 0.2 m grid: 3e-5 seen
    sel = rec.select(z)
    keep = np.isfinite(sel["speed_e"]) & (sel["flags_e"] == 0)
    resid = []
    for rev in range(2):
        m = keep & (sel["revolution_e"] == rev)
        X = np.stack([np.cos(th[m]), np.sin(th[m]), np.ones(m.sum())], 1)
        c = np.linalg.lstsq(X, vr[m], rcond=None)[0]
        resid.append(np.sum((vr[m] - X @ c) ** 2) / (m.sum() - 3))
    np.testing.assert_allclose(fit.residual_var_p, resid, rtol=1e-3)
    # 84 % of the projected variance sin^2 Phi / 2 * a^2 / 2 is left in the residual; the model says 0
    assert fit.residual_var_p.mean() > 0.8 * 0.5 * math.sin(PHI) ** 2 * 0.5 * a * a
    m = model_integrals(z, U, 1, rayleigh_length=zR, n_k=400)
    assert m["l_az"] > 2 * R  # the model's filters act along x only, whatever the circle's cross-wind extent
