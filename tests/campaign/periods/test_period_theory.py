"""The scenes' instruments as linear functionals (campaign/periods/theory.py) against the special-case theories."""

import dataclasses
import math

import numpy as np
import pytest

from cwlidar_sim.analysis import cs_model, misaligned_spectra
from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.campaign.execution.reproduce import bundled_scene
from cwlidar_sim.campaign.periods import staring as ps
from cwlidar_sim.campaign.periods import theory as th
from cwlidar_sim.campaign.periods.staring_field import period_params, plan_field
from cwlidar_sim.sensors import ConicalLidar, Cup


@pytest.fixture
def whole_line_lorentzian(monkeypatch):
    """The probe of A2012 Eq. 4 over the whole line, exp(-z_R |q|): what Eqs. 12-14 and CS's filter assume.  The
    package's ``lorentzian`` weighting is cut at the telescope and renormalised (no air behind it), which moves
    these spectra by a few per cent at 60-100 m; the models' own probe isolates the geometry under test."""
    monkeypatch.setattr(th, "_probe", lambda lidar, instrument: lt.lorentzian_probe(instrument.rayleigh_length))


def test_a2012_staring_lidar_and_sonic_are_eqs_12_to_14(whole_line_lorentzian):
    """The A2012 scene's lidar (built as the period builds it, Lorentzian weighting) and its sonic: the beam average
    and the sonic's wind along the beam give theory.misaligned_spectra's F_vr, F_vs and chi (Eqs. 12-14)."""
    scene = bundled_scene("a2012")
    period = scene.periods[0]
    params = period_params(scene, 0)
    plan = plan_field(scene, 0, params)
    lidar = dataclasses.replace(ps._lidar(scene, plan, params, period), weighting="lorentzian")
    beam, sonic = th.staring_functionals(lidar, plan.sonic_position)
    k1 = np.geomspace(1e-3, 1.0, 4)
    s = lt.functional_spectra(k1, params, [beam, sonic], period.mean_speed)
    f_vs, f_vr, chi = misaligned_spectra(k1, params, period.misalignment_deg, lidar.instrument.rayleigh_length)
    np.testing.assert_allclose(s.spectrum("1.sonic"), f_vs, rtol=1e-4)
    np.testing.assert_allclose(s.spectrum("0.lidar"), f_vr, rtol=1e-3)  # measured 7e-5
    np.testing.assert_allclose(s.cross(0, 1), chi, rtol=1e-3)  # the sonic at the focus: no phase


def _cs_lidar(heights=None, **over):
    """The CS scene's lidar; a period of the scene runs one height at a time (``heights=(z,)``)."""
    cs = bundled_scene("cs")
    kw = cs.lidar_fields(1.0)
    kw.update(over)
    return cs, ConicalLidar(heights=cs.scan.heights if heights is None else heights, **kw)


def test_conical_fit_returns_a_uniform_wind():
    """The VAD functional of the CS scene's scan (8 sub-dwell looks per estimate, 50 estimates a revolution):
    a uniform wind comes out as w and as (u, v) times the dwells' smearing, the mean of cos(azimuth offset) over
    each estimate's looks (the fit uses the estimates' mid-azimuths); every look sits on the cone at its height."""
    _, lidar = _cs_lidar((60.0,))
    vad, cup = th.conical_functionals(lidar, 60.0, 8.0, revolutions=3, cup=Cup(position=(0.0, 0.0, 60.0)))
    tau = cup.looks.response_l[0](np.array([8.0 / Cup(position=(0.0, 0.0, 60.0)).distance_constant]))
    assert cup.names == ("u",) and complex(tau[0]) == pytest.approx(1.0 / (1.0 + 1j))  # omega tau = 1: tau = l / U
    assert vad.looks.n_looks == 3 * 50 * 8
    smear = np.mean(np.cos(np.radians(((np.arange(8) + 0.5) / 8 - 0.5) * 360.0 / 50)))  # 0.99935
    np.testing.assert_allclose(vad.weight_olc.sum(axis=1), np.diag([smear, smear, 1.0]), atol=1e-12)
    np.testing.assert_allclose(vad.looks.point_lc[:, 2], 60.0, rtol=1e-12)
    radius = np.hypot(vad.looks.point_lc[:, 0], vad.looks.point_lc[:, 1])
    np.testing.assert_allclose(radius, 60.0 * math.tan(math.radians(30.0)), rtol=1e-12)
    assert np.ptp(vad.looks.time_l) == pytest.approx(3.0 - 1.0 / 400.0)


@pytest.mark.parametrize("revolutions", [1, 3])
def test_conical_x_only_is_cs_model(revolutions, whole_line_lorentzian):
    """The CS scene's VAD u (its response to u alone, Lorentzian weighting) over a field varying along x only,
    against a point: CS's 1-D filter model (cs_model.model_ratios) of the lidar/cup std ratio, within 3 % (the
    scan's true layout along x against CS's rectified sine; measured 2.4 % and 1.6 %)."""
    z, U = 100.0, 8.0
    cs, lidar = _cs_lidar((z,), weighting="lorentzian")
    params = cs.turbulence.params(z, U)
    vad = th.conical_functionals(lidar, z, U, revolutions=revolutions)
    u_only = lt.LinearFunctional(vad.looks, vad.weight_olc[:1] * np.array([1.0, 0.0, 0.0]), ["u"])
    point = lt.point_functional((0.0, 0.0, z), ("u",))
    k1 = np.geomspace(1e-6, 1e3, 900)
    s = lt.functional_spectra(k1, params, [u_only, point], U, quadrature="x_only")
    ratio = math.sqrt(np.trapezoid(s.spectrum(0) * k1, np.log(k1)) / np.trapezoid(s.spectrum(1) * k1, np.log(k1)))
    base = cs_model.model_ratios(z, U, revolutions, spectrum="mann", params=params,
                                 rayleigh_length=lidar.instrument_at(z).rayleigh_length)["std_ratio"]
    assert ratio == pytest.approx(base, rel=0.03)


def test_conical_bad_input_names_the_field():
    _, lidar = _cs_lidar()
    with pytest.raises(ValueError, match="height"):
        th.conical_functionals(lidar, 50.0, 8.0)
    with pytest.raises(ValueError, match="revolutions"):
        th.conical_functionals(lidar, 60.0, 8.0, revolutions=2)


def test_nacelle_scan_is_rews_theory():
    """The nacelle scene's lidar (its cone, 1-s revolution, exact weighting) as a REWS functional with a rotor of
    grid nodes: rews_theory.rews_spectra's spectra, cross-spectrum (phase: delays and preview) and coherence."""
    from cwlidar_sim.analysis import rews_theory as rt

    scene = bundled_scene("nacelle")
    p = scene.periods[0]
    r, U = 100.0, p.mean_speed
    lidar = scene.sensor(p, (r,))
    params = scene.period_params(p)
    yy, zz = np.meshgrid(np.linspace(-60, 60, 5), np.linspace(-60, 60, 5))
    inside = np.hypot(yy, zz) <= 65.0
    nodes = (yy[inside], zz[inside], np.full(int(inside.sum()), 1.0 / inside.sum()))
    rotor, est = th.nacelle_functionals(lidar, r, U, nodes, n_beams=6, preview_shift=9.0)
    k1 = np.geomspace(3e-3, 0.1, 3)
    beams = rt.scan_beams(lidar.geometry, 6, r, all_phases=False, origin=lidar.position)
    opt = lidar.instrument_at(r).optics()
    ref = rt.rews_spectra(k1, params, nodes, beams, U, weighting=lidar.weighting, preview_shift=9.0,
                          resolution=240, wavelength=opt.wavelength, radius=opt.radius)
    s = lt.functional_spectra(k1, params, [rotor, est], U, resolution=240)
    np.testing.assert_allclose(s.spectrum(0), 2.0 * ref.rotor_k, rtol=1e-3)  # one-sided: twice rews' two-sided
    np.testing.assert_allclose(s.spectrum(1), 2.0 * ref.lidar_k, rtol=1e-3)
    # the cross-spectrum to 1e-3 of sqrt(F_rotor F_lidar) (at k1 = 0.1 the coherence is 1e-3: 2e-3 of itself)
    scale = np.sqrt(s.spectrum(0) * s.spectrum(1))
    assert np.all(np.abs(s.cross(0, 1) - 2.0 * ref.cross_k) < 1e-3 * scale)
    assert lidar.revolution_time > 0 and np.ptp(est.looks.time_l) > 0.5  # the delays matter here


def _staring(theta_deg):
    """A staring lidar at the origin looking upwind, misaligned by ``theta_deg``, the sonic at its focus."""
    from cwlidar_sim.sensors import StaringLidar

    lidar = StaringLidar(azimuth_deg=180.0 + theta_deg, weighting="lorentzian", cell_length=0.5)
    return lidar, lidar.instrument.focus * np.asarray(lidar.direction)


A2012_PARAMS = bundled_scene("a2012").turbulence.params()


def test_staring_aligned_is_eq_9(whole_line_lorentzian):
    """A beam along the wind with the Lorentzian over the whole line (A2012 Eq. 4) and the sonic at its focus:
    methods 1 and 2 of the general theory are exp(-2 k zR) (Eq. 9) exactly (the probe depends on k1 alone), here
    within 2e-4 of the spectra's quadrature; the same with zR doubled is rejected (off by > 10 %)."""
    lidar, sonic = _staring(0.0)
    zR = lidar.instrument.rayleigh_length
    beam, son = th.staring_functionals(lidar, sonic)
    k1 = np.geomspace(1e-3, 0.5, 6)
    s = lt.functional_spectra(k1, A2012_PARAMS, [beam, son], 8.0, resolution=30.0)
    t1 = s.spectrum("0.lidar") / s.spectrum("1.sonic")
    t2 = s.cross("0.lidar", "1.sonic").real ** 2 / s.spectrum("1.sonic") ** 2
    for t in (t1, t2):
        np.testing.assert_allclose(t, np.exp(-2.0 * k1 * zR), rtol=2e-4)
        assert np.max(np.abs(t / np.exp(-4.0 * k1 * zR) - 1.0)) > 0.1  # the broken zR x 2


def test_staring_misaligned_is_eqs_12_to_14_and_rejects_a_flipped_probe(whole_line_lorentzian):
    """At 30 deg of misalignment the general theory's F_vs, F_vr and chi are misaligned_spectra's (Eqs. 12-14),
    within 1e-3 (measured 1e-4); the probe laid along the beam mirrored in the wind (misalignment -30 deg, the
    projection kept at +30 deg) is rejected: Phi_12's sign makes Eqs. 13-14 depend on that sign (> 1 %).  The
    misalignment's sign as a whole is a symmetry (y -> -y): no test can reject it."""
    lidar, sonic = _staring(30.0)
    zR = lidar.instrument.rayleigh_length
    beam, son = th.staring_functionals(lidar, sonic)
    k1 = np.geomspace(3e-3, 0.3, 4)
    f_vs, f_vr, chi = misaligned_spectra(k1, A2012_PARAMS, 30.0, zR)
    mirrored = lt.lidar_functional(lt.Looks(beam.looks.point_lc, _staring(-30.0)[0].direction, None,
                                            beam.looks.probe_l), [1.0], ["lidar"])
    mirrored = lt.LinearFunctional(mirrored.looks, beam.weight_olc, ["lidar"])  # n . u along +30 deg
    s = lt.functional_spectra(k1, A2012_PARAMS, [beam, son, mirrored], 8.0, resolution=30.0)
    np.testing.assert_allclose(s.spectrum("1.sonic"), f_vs, rtol=1e-3)
    np.testing.assert_allclose(s.spectrum("0.lidar"), f_vr, rtol=1e-3)
    np.testing.assert_allclose(s.cross("0.lidar", "1.sonic").real, chi, rtol=1e-3)
    assert np.max(np.abs(s.spectrum("2.lidar") / f_vr - 1.0)) > 0.01
    assert np.max(np.abs(s.cross("2.lidar", "1.sonic").real / chi - 1.0)) > 0.01
    f_vs2, f_vr2, chi2 = misaligned_spectra(k1, A2012_PARAMS, -30.0, zR)
    np.testing.assert_allclose(f_vr2, f_vr, rtol=1e-6)  # the symmetry


def test_staring_results_carry_the_fields_lattice():
    """A staring period's results carry the theory on its own field's modes: on a line (beam along the wind, the
    sonic on it) the lattice is the continuum, bit for bit; on a plane (a misaligned beam) the plane's lattice,
    below the continuum where the plane's k2 cut-off (pi / dy) removes the modes across the wind that pass the beam
    (k2 ~ 19 k1 at 3 deg: above ~0.3 rad/m at dy = 0.5 m), with attributes naming the plane."""
    sc = bundled_scene("a2012").with_values({"lidar.tier": "los", "lidar.variants": [], "analysis.fit": False,
                                             "duration": 300.0, "analysis.segment_duration": 150.0})
    per = sc.periods[2]
    sc = sc.replace(periods=(dataclasses.replace(per, name="aligned", misalignment_deg=0.0),
                             dataclasses.replace(per, name="turned", misalignment_deg=3.0)))
    line, plane = (ps.run_unit(sc, i) for i in (0, 1))
    assert line.transfer_ratio_theory_lattice.attrs["box"].startswith("line")
    for v in ("ratio", "cross"):
        assert line[f"transfer_{v}_theory_lattice"].values.tobytes() == line[f"transfer_{v}_theory"].values.tobytes()
    box = plane.transfer_ratio_theory_lattice.attrs["box"]
    shape = plan_field(sc, 1, sc.turbulence.params()).shape
    assert box.startswith(f"plane {shape}") and "(0.5, 0.5)" in box
    k = plane.k.values
    cont, lat = plane.transfer_ratio_theory.values[0], plane.transfer_ratio_theory_lattice.values[0]
    low, high = (k > 0.01) & (k < 0.1) & np.isfinite(cont), (k > 0.5) & (k < 1.0) & np.isfinite(cont)
    np.testing.assert_allclose(lat[low], cont[low], rtol=5e-3)
    assert np.all(lat[high] < 0.9 * cont[high])
