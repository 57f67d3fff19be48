"""The general linear theory (analysis/linear_theory.py) against the package's other theories and closed forms."""

import math

import numpy as np
import pytest
import reference

from cwlidar_sim.analysis import cs_model, misaligned_spectra
from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.analysis import rews_theory as rt
from cwlidar_sim.turbulence import MannParameters, one_point_spectra

P = MannParameters(alpha_eps=0.1, length_scale=30.0, gamma=3.0)
U = 8.0
K = np.geomspace(1e-3, 1.0, 5)


def _beam(n, zr, name, point=(0.0, 0.0, 0.0), time=0.0):
    probe = lt.lorentzian_probe(zr) if zr > 0 else None
    return lt.lidar_functional(lt.Looks([point], [n], [time], probe), [1.0], [name])


def test_point_look_is_the_one_point_spectra():
    """A sonic (zR -> 0) sees the tensor's one-point spectra F11, F22, F33, F13, on the plane and x-only."""
    F = one_point_spectra(K, P)
    for quad, rtol in (("plane", 2e-5), ("x_only", 1e-12)):
        s = lt.functional_spectra(K, P, lt.point_functional((3.0, -2.0, 50.0)), U, quadrature=quad)
        np.testing.assert_allclose(s.spectrum("u"), F[0], rtol=rtol)
        np.testing.assert_allclose(s.spectrum("v"), F[1], rtol=rtol)
        np.testing.assert_allclose(s.spectrum("w"), F[2], rtol=rtol)
        np.testing.assert_allclose(s.cross("u", "w").real, F[3], rtol=rtol)
        np.testing.assert_allclose(s.cross("u", "v"), 0.0, atol=1e-6 * F[0].max())  # mirror symmetry in y


def test_aligned_staring_beam_is_eq9():
    """Along the wind the beam's probe is a pure filter in k1: F_lidar / F_sonic = exp(-2 k1 zR) (A2012 Eq. 9)."""
    zr = 10.0
    s = lt.functional_spectra(K, P, [_beam([1, 0, 0], zr, "lidar"), _beam([1, 0, 0], 0.0, "sonic")], U)
    # the probe's tabulated transform (linear_theory._Table) is within 1e-7 of exp(-zR |q|): 6e-6 of exp(-20)
    np.testing.assert_allclose(s.spectrum("0.lidar") / s.spectrum("1.sonic"), np.exp(-2.0 * K * zr), rtol=2e-5)
    np.testing.assert_allclose(s.cross(0, 1).real / s.spectrum(1), np.exp(-K * zr), rtol=2e-5)


@pytest.mark.parametrize("theta", [30.0, 90.0])
def test_misaligned_staring_beam_is_eqs_12_to_14(theta):
    """A horizontal beam at theta from the wind: F_vs, F_vr and chi of A2012 Eqs. 12-14 (theory.misaligned_spectra)."""
    zr = 10.0
    th = math.radians(theta)
    n = [math.cos(th), math.sin(th), 0.0]
    s = lt.functional_spectra(K, P, [_beam(n, zr, "lidar"), _beam(n, 0.0, "sonic")], U)
    f_vs, f_vr, chi = misaligned_spectra(K, P, theta, zr)
    np.testing.assert_allclose(s.spectrum("1.sonic"), f_vs, rtol=2e-5)
    # the weight's kink along k.n = 0 crosses the polar nodes: within 1e-3 for k1 zR <= 2, 3e-3 at k1 zR = 10
    rtol = np.where(K * zr <= 2.0, 1e-3, 3e-3)
    assert np.all(np.abs(s.spectrum("0.lidar") / f_vr - 1.0) < rtol)
    assert np.all(np.abs(s.cross(0, 1).real / chi - 1.0) < rtol)
    np.testing.assert_allclose(s.cross(0, 1).imag, 0.0, atol=1e-9 * f_vs.max())


def test_isotropy_at_gamma_zero():
    """Gamma = 0: von Karman's closed forms, and any beam across the wind sees F22 = F33 (and not at Gamma = 3)."""
    iso = MannParameters(alpha_eps=0.1, length_scale=30.0, gamma=0.0)
    kl = K * iso.length_scale
    a = iso.alpha_eps * iso.length_scale ** (5.0 / 3.0)
    f11 = 2.0 * (9.0 / 55.0) * a / (1.0 + kl**2) ** (5.0 / 6.0)  # one-sided: twice Mann's two-sided forms
    f22 = 2.0 * (3.0 / 110.0) * a * (3.0 + 8.0 * kl**2) / (1.0 + kl**2) ** (11.0 / 6.0)
    psi = math.radians(35.0)
    tilted = _beam([0.0, math.cos(psi), math.sin(psi)], 0.0, "tilted")
    s = lt.functional_spectra(K, iso, [lt.point_functional((0.0, 0.0, 0.0)), tilted], U)
    np.testing.assert_allclose(s.spectrum("0.u"), f11, rtol=2e-5)
    np.testing.assert_allclose(s.spectrum("0.v"), f22, rtol=2e-5)
    np.testing.assert_allclose(s.spectrum("0.w"), f22, rtol=2e-5)
    np.testing.assert_allclose(s.spectrum("1.tilted"), f22, rtol=2e-5)
    np.testing.assert_allclose(s.cross("0.u", "0.w").real, 0.0, atol=1e-6 * f11.max())
    sheared = lt.functional_spectra(K, P, tilted, U).spectrum(0)
    F = one_point_spectra(K, P)
    expect = math.cos(psi) ** 2 * F[1] + math.sin(psi) ** 2 * F[2]
    np.testing.assert_allclose(sheared, expect, rtol=2e-5)  # F23 = 0: the two components add
    assert np.max(np.abs(sheared / F[1] - 1.0)) > 0.05


def _cs_weighting(length, n=2001):
    x = np.linspace(-0.5 * length, 0.5 * length, n)
    w = np.abs(np.sin(math.pi * x / length))
    w[[0, -1]] *= 0.5
    return x, w / w.sum()


def test_x_only_field_is_cs_filter_model():
    """A field varying along x only: a rectified-sine weighting along x and a Lorentzian probe along x give CS's
    1-D model F_u L_lor L_u (cs_model), laid out in space or, by Taylor's hypothesis, in time."""
    zr, length = 8.3, 110.0
    x, w = _cs_weighting(length)
    k = np.geomspace(1e-4, 0.2, 40)
    expect = (cs_model.mann_spectra_one_sided(k, P)[0] * cs_model.probe_transfer(k, zr)
              * cs_model.scan_transfer(k, length, "rectified_sine"))
    along_x = np.tile([1.0, 0.0, 0.0], (x.size, 1))
    in_space = lt.Looks(np.stack([x, 0 * x, 0 * x], axis=1), along_x, None, lt.lorentzian_probe(zr))
    in_time = lt.Looks(np.zeros((x.size, 3)), along_x, -x / U, lt.lorentzian_probe(zr))
    for looks in (in_space, in_time):
        s = lt.functional_spectra(k, P, lt.lidar_functional(looks, w, ["u"]), U, quadrature="x_only")
        np.testing.assert_allclose(s.spectrum("u"), expect, rtol=1e-4)


def test_nacelle_rews_agrees_with_rews_theory():
    """A 4-beam nacelle lidar's REWS estimate against a rotor of grid nodes: rews_theory's spectra and coherence."""
    lid = rt.circular_scan(4, 15.0, 80.0, revolution_time=0.0)  # the exact weighting: phi_hat complex
    yy, zz = np.meshgrid(np.linspace(-40, 40, 5), np.linspace(-40, 40, 5))
    inside = np.hypot(yy, zz) <= 45.0
    yn, zn = yy[inside], zz[inside]
    wn = np.full(yn.size, 1.0 / yn.size)
    k1 = np.geomspace(3e-3, 0.1, 3)
    ref = rt.rews_spectra(k1, P, (yn, zn, wn), lid, U, weighting="exact", resolution=240)
    pts = lid.focus_points_bc
    # each beam's preview shift T_b = -p_bx / U is the look's time t_l = -T_b
    looks = lt.Looks(pts, lid.direction_bc, pts[:, 0] / U, rt.beam_transfer(80.0, "exact"))
    lidar = lt.lidar_functional(looks, lid.weight_b / lid.direction_bc[:, 0], ["lidar"])
    rotor_looks = lt.Looks(np.stack([0 * yn, yn, zn], axis=1), np.tile([1.0, 0.0, 0.0], (yn.size, 1)))
    rotor = lt.LinearFunctional(rotor_looks, wn[None, :, None] * np.array([1.0, 0.0, 0.0]), ["rotor"])
    s = lt.functional_spectra(k1, P, [rotor, lidar], U, resolution=240)
    np.testing.assert_allclose(s.spectrum(0), 2.0 * ref.rotor_k, rtol=1e-3)  # one-sided: twice rews' two-sided
    np.testing.assert_allclose(s.spectrum(1), 2.0 * ref.lidar_k, rtol=1e-3)
    np.testing.assert_allclose(s.cross(0, 1), 2.0 * ref.cross_k, rtol=1e-3)
    np.testing.assert_allclose(s.coherence(0, 1), ref.coherence_k, rtol=1e-3)


def _two_horizontal_functionals():
    la = [(1.0, (1.0, 0.0), (0.0, 0.0, 0.0), 0.0)]
    lb = [(0.6, (0.8, 0.6), (5.0, 10.0, 5.0), 0.5), (0.4, (0.0, 1.0), (0.0, -4.0, 2.0), -0.3)]

    def func(looks, name):
        n = [[c[1][0], c[1][1], 0.0] for c in looks]
        return lt.lidar_functional(lt.Looks([c[2] for c in looks], n, [c[3] for c in looks]),
                                   [c[0] for c in looks], [name])

    return la, lb, [func(la, "a"), func(lb, "b")]


def test_brute_force_reference_sum():
    """Separated, delayed, oblique point looks: the cross-spectrum (phase included) against a plain double sum."""
    la, lb, fs = _two_horizontal_functionals()
    k1 = 0.1
    ref = reference.linear_functional_cross_spectrum(k1, P.alpha_eps, P.length_scale, P.gamma, U, la, lb, h=0.02)
    ref_bb = reference.linear_functional_cross_spectrum(k1, P.alpha_eps, P.length_scale, P.gamma, U, lb, lb, h=0.02)
    s = lt.functional_spectra([k1], P, fs, U, resolution=120)
    assert abs(s.cross(0, 1)[0] / 2.0 - ref) < 1e-4 * abs(ref)  # measured 3e-6 (1.2e-4 at resolution 60)
    assert s.spectrum(1)[0] / 2.0 == pytest.approx(ref_bb.real, rel=1e-5)


def test_quadrature_converges():
    """Doubling the resolution moves the spectra and the coherence of separated looks by less than 1e-3."""
    _, _, fs = _two_horizontal_functionals()
    k1 = np.geomspace(3e-3, 0.3, 4)
    a = lt.functional_spectra(k1, P, fs, U, resolution=60.0)
    b = lt.functional_spectra(k1, P, fs, U, resolution=120.0)
    np.testing.assert_allclose(a.spectrum(1), b.spectrum(1), rtol=1e-3)
    np.testing.assert_allclose(a.coherence(0, 1), b.coherence(0, 1), rtol=1e-3)
    np.testing.assert_allclose(a.cross(0, 1), b.cross(0, 1), rtol=1e-3)


def test_least_squares_fit_is_the_reconstruction():
    """Three beams' least-squares weights are N^-1, and a full VAD circle's fit of u is its first harmonic."""
    dirs = np.array([[0.8, 0.6, 0.0], [0.8, -0.6, 0.0], [0.6, 0.0, 0.8]])
    f = lt.least_squares_functional(lt.Looks(np.zeros((3, 3)), dirs))
    np.testing.assert_allclose(np.einsum("olc,lc->ol", f.weight_olc, dirs), np.linalg.inv(dirs), atol=1e-12)
    th = 2.0 * math.pi * np.arange(50) / 50
    looks = lt.conical_looks(100.0, 30.0, th)
    vad = lt.least_squares_functional(looks, ("u", "v", "w"))
    coef_l = np.einsum("lc,lc->l", vad.weight_olc[0], looks.direction_lc)  # the weight of each v_l in u
    np.testing.assert_allclose(coef_l, 2.0 * np.cos(th) / (th.size * math.sin(math.radians(30.0))), atol=1e-12)


def test_lattice_is_periodic_and_close_to_the_continuum():
    """On a box's modes two points one box width apart are the same point (coherence 1); a point's lattice
    spectrum is near the continuum cut at the grid's lateral Nyquist (one_point_spectra with k2, k3 cut)."""
    shape, spacing = (64, 16, 16), (4.0, 4.0, 4.0)
    a = lt.point_functional((0.0, 0.0, 0.0), ("u",))
    b = lt.point_functional((0.0, shape[1] * spacing[1], 0.0), ("u",))
    c = lt.point_functional((0.0, 0.5 * shape[1] * spacing[1], 0.0), ("u",))
    s = lt.lattice_spectra(P, [a, b, c], U, shape, spacing, rows=[2, 5, 9])
    np.testing.assert_allclose(s.coherence(0, 1), 1.0, rtol=1e-12)
    assert np.all(s.coherence(0, 2) < 0.9)
    cut = math.pi / spacing[1]
    F11 = one_point_spectra(s.k1_k, P, k2_max=cut, k3_max=cut)[0]
    np.testing.assert_allclose(s.spectrum(0), F11, rtol=0.1)  # the lattice's cell sums and corrections


def test_period_variance_of_an_exponential_covariance():
    """R(tau) = s2 exp(-|tau| / theta), F(k1) = (2 s2 theta U / pi) / (1 + (theta U k1)^2): the variance of a
    period mean, continuous and sampled, and of samples about it, against their closed forms."""
    s2, theta, T = 1.3, 20.0, 600.0
    k = np.geomspace(1e-7, 1e3, 2000)
    F = (2.0 * s2 * theta * U / math.pi) / (1.0 + (theta * U * k) ** 2)
    cont = lt.period_variance(k, F, U, T)
    x = T / theta
    of_mean = 2.0 * s2 / x * (1.0 - (1.0 - math.exp(-x)) / x)
    assert cont["total"] == pytest.approx(s2, rel=1e-4)
    assert cont["of_mean"] == pytest.approx(of_mean, rel=1e-3)
    assert cont["within"] == pytest.approx(s2 - of_mean, rel=1e-3)
    dt = 5.0
    n = int(T / dt)
    rho = math.exp(-dt / theta)
    m = np.arange(1, n)
    of_mean_n = s2 / n**2 * (n + 2.0 * np.sum((n - m) * rho**m))
    smp = lt.period_variance(k, F, U, T, sample_interval=dt)
    assert smp["of_mean"] == pytest.approx(of_mean_n, rel=1e-3)
    assert smp["within"] == pytest.approx(s2 - of_mean_n, rel=1e-3)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="direction_lc"):
        lt.Looks([[0, 0, 0]], [[1.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="weight_olc"):
        lt.LinearFunctional(lt.Looks([[0, 0, 0]], [[1.0, 0, 0]]), np.ones((1, 2, 3)))
    with pytest.raises(ValueError, match="k1"):
        lt.functional_spectra([0.0], P, lt.point_functional((0, 0, 0)), U)
    with pytest.raises(ValueError, match="quadrature"):
        lt.functional_spectra([0.1], P, lt.point_functional((0, 0, 0)), U, quadrature="cube")
    with pytest.raises(ValueError, match="cannot resolve"):
        lt.least_squares_functional(lt.Looks([[0, 0, 0]], [[1.0, 0, 0]]))
    with pytest.raises(TypeError, match="probe_l"):
        lt.Looks([[0, 0, 0]], [[1.0, 0, 0]], None, 3.0)


def _small_cs(n_looks=12, probe=True):
    """A short conical scan (the exact weighting, or point looks), each look at its own time, and a cup."""
    th = 2.0 * math.pi * (np.arange(n_looks) + 0.5) / n_looks
    looks = lt.conical_looks(100.0, 30.0, th, time_l=th / (2.0 * math.pi) - 0.5,
                             probe=rt.beam_transfer(100.0 / math.cos(math.radians(30.0)), "exact") if probe else None)
    vad = lt.least_squares_functional(looks, ("u", "v", "w"))
    cup = lt.point_functional((3.0, 0.0, 100.0), ("u",), response=lt.first_order_response(2.3 / U), time=0.4)
    return [vad, cup]


def test_fused_kernel_is_the_numpy_path(monkeypatch):
    """The fused numba kernel (analysis/_linear_kernels.py) gives the plain numpy path's sums to round-off:
    plane, x-only and lattice, complex probes, time filters and delays, two functionals; for any thread count."""
    from cwlidar_sim import _config

    fs = _small_cs()
    k1 = np.array([2e-3, 0.04])
    fused = [lt.functional_spectra(k1, P, fs, U), lt.functional_spectra(k1, P, fs, U, quadrature="x_only"),
             lt.lattice_spectra(P, fs, U, (32, 16, 16), (8.0, 8.0, 8.0), rows=[1, 3])]
    monkeypatch.setattr(_config, "_num_threads", 1)
    one = lt.functional_spectra(k1, P, fs, U)
    np.testing.assert_array_equal(one.matrix_kab, fused[0].matrix_kab)  # the blocks' fixed order
    monkeypatch.setattr(lt, "_FUSED", False)
    plain = [lt.functional_spectra(k1, P, fs, U), lt.functional_spectra(k1, P, fs, U, quadrature="x_only"),
             lt.lattice_spectra(P, fs, U, (32, 16, 16), (8.0, 8.0, 8.0), rows=[1, 3])]
    for a, b in zip(fused, plain):
        scale = np.sqrt(np.abs(np.einsum("kaa,kbb->kab", b.matrix_kab, b.matrix_kab)))
        assert np.max(np.abs(a.matrix_kab - b.matrix_kab) / scale) < 1e-12


def test_wider_panels_converge_for_a_conical_scan(monkeypatch):
    """The conical scan's panels (3 / (span / 2), module constant _PANEL; point looks, so that the lateral phases
    set them) against panels three times narrower: spectra and coherence of the VAD's u and the cup move < 1e-3."""
    fs = _small_cs(probe=False)
    k1 = np.array([3e-3, 0.05, 0.3])
    a = lt.functional_spectra(k1, P, fs, U)
    monkeypatch.setattr(lt, "_PANEL", 1.0)
    b = lt.functional_spectra(k1, P, fs, U)
    np.testing.assert_allclose(a.spectrum("0.u"), b.spectrum("0.u"), rtol=1e-3)
    np.testing.assert_allclose(a.spectrum("1.u"), b.spectrum("1.u"), rtol=1e-3)
    np.testing.assert_allclose(a.coherence("0.u", "1.u"), b.coherence("0.u", "1.u"), rtol=1e-3)
