"""The WindScanner's and the SpinnerLidar's linear functionals (campaign/periods/scanner_theory.py): their limits, and
the WindScanner's transfer functions against the simulated tier-los ones."""

import math

import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.periods import scanner_theory as st
from cwlidar_sim.campaign.periods import theory as th
from cwlidar_sim.sensors.spinner import SpinnerLidar
from cwlidar_sim.sensors.windscanner import WindScanner
from kind_scenes import WINDSCANNER

RNG = np.random.default_rng(31)
WS_SCENE = WINDSCANNER
K_RANDOM = RNG.normal(scale=0.05, size=(3, 16))  # (k1, k2, k3) [rad/m]


def _axes_scanner():
    """Three units looking along +x, +y and +z at one point 40 m away."""
    t = (0.0, 0.0, 50.0)
    return WindScanner(positions=((-40.0, 0.0, 50.0), (0.0, -40.0, 50.0), (0.0, 0.0, 10.0)), target=t)


def _g(functional, k, U=8.0, probes=None):
    return np.stack([functional.transfer(k[0, j], k[1, j:j + 1], k[2, j:j + 1], U, probes=probes)
                     for j in range(k.shape[1])])


def test_beams_along_the_axes_with_point_probes_are_the_sonic():
    """zR -> 0 and beams along x, y, z: N is the identity, the reconstruction is the sonic at the target, exactly
    (every wavevector's transfer vector); with the beams' weighting it differs at nonzero k."""
    ws = _axes_scanner()
    assert np.linalg.cond(ws.directions()[0]) == pytest.approx(1.0)
    recon, sonic = st.windscanner_functionals(ws, probe=False)
    assert recon.names == sonic.names == ("u", "v", "w")
    np.testing.assert_allclose(_g(recon, K_RANDOM), _g(sonic, K_RANDOM), atol=1e-12)
    weighted, _ = st.windscanner_functionals(ws)
    assert np.abs(_g(weighted, K_RANDOM) - _g(sonic, K_RANDOM)).max() > 1e-2


def test_a_uniform_field_is_reconstructed_by_every_layout():
    """k -> 0 (a uniform field): every component's transfer vector is the sonic's unit vector, for the published
    layout (three unequal ranges, clock offsets) held or averaged over a Lissajous pattern; so both transfer
    functions tend to 1 as the field's scales outgrow the layout.  A wrong reconstruction row or one beam's sign flipped breaks it."""
    k0 = np.array([[1e-9], [0.0], [0.0]])
    for ws in (WindScanner(time_offsets=(0.0, 0.01, -0.02)),
               WindScanner(pattern="lissajous", points_per_pattern=32, amplitude=5.0)):
        recon, sonic = st.windscanner_functionals(ws)
        np.testing.assert_allclose(_g(recon, k0), _g(sonic, k0), atol=1e-6)


def test_the_limits_fail_on_a_broken_reconstruction(monkeypatch):
    """The checks above see a beam's sign flipped and a wrong reconstruction row."""
    ws = _axes_scanner()
    k0 = np.array([[1e-9], [0.0], [0.0]])
    real = np.linalg.inv
    for broken in (lambda n: real(n * np.array([1.0, -1.0, 1.0])[..., :, None]),  # unit 1's speed sign
                   lambda n: real(n)[..., [0, 2, 1], :]):  # rows v and w swapped
        monkeypatch.setattr(st.np.linalg, "inv", broken)
        recon, sonic = st.windscanner_functionals(ws, probe=False)
        assert np.abs(_g(recon, K_RANDOM) - _g(sonic, K_RANDOM)).max() > 1e-3
        recon, sonic = st.windscanner_functionals(WindScanner())
        assert np.abs(_g(recon, k0) - _g(sonic, k0)).max() > 0.5
        monkeypatch.setattr(st.np.linalg, "inv", real)


def _params():
    from cwlidar_sim.turbulence import MannParameters

    return MannParameters(alpha_eps=0.05, length_scale=33.6, gamma=3.9)


def test_spinner_rews_of_a_uniform_wind_is_the_rotors():
    """k -> 0: the disc fit's u0 over a rosette (blocked estimates left out, yawed and tilted) is the rotor's
    REWS along its axis, u cos gamma + v sin gamma, exactly; without the yaw in the rotor's weights it is not."""
    lid = SpinnerLidar(focus_distance=60.0, yaw_misalignment_deg=10.0, tilt_deg=5.0, n_blades=3, rotor_rpm=16.0,
                       estimates_per_rosette=246, sub_dwells=2)
    rotor, est = st.spinner_functionals(lid, 10.0, 40.0, w_zero=False)
    assert est.looks.n_looks < 246 * 2  # the blades block some
    k0 = np.array([[1e-9], [0.0], [0.0]])
    np.testing.assert_allclose(_g(est, k0), _g(rotor, k0), atol=1e-6)
    # w = 0 assumed (the scene's default): a uniform w leaks into u0 through the tilted rosette, a little
    _, assumed = st.spinner_functionals(lid, 10.0, 40.0)
    leak = _g(assumed, k0)[0, 0, 0] - _g(rotor, k0)[0, 0, 0]
    np.testing.assert_allclose(leak[:2], 0.0, atol=1e-6)
    assert 1e-4 < abs(leak[2]) < 1e-2
    np.testing.assert_allclose(_g(rotor, k0)[0, 0, 0].real, [np.cos(np.radians(10.0)), np.sin(np.radians(10.0)), 0.0],
                               atol=1e-9)
    y, z, w = st.rotor_disc_nodes(40.0, 2.0)
    assert w.sum() == pytest.approx(1.0) and np.hypot(y, z).max() < 40.0
    # the disc's (r/R)^p weight: the mean of r^2 is R^2 (p + 2) / (p + 4)
    assert np.sum(w * (y * y + z * z)) == pytest.approx(1600.0 * 4.0 / 6.0, rel=1e-9)


def test_the_periods_theory_is_computed_once_per_scene_not_per_realisation(monkeypatch):
    """Two periods that differ only in their seed share one theory computation (it depends on the geometry, the
    tensor, U and T, not the realisation); another U computes again."""
    calls = []

    def fake(ws, params, U, k1, **kw):
        calls.append(np.asarray(k1).copy())
        k = np.asarray(k1)
        return {"k1": k, "ratio_ck": np.stack([np.log(k)] * 3), "cross_ck": np.stack([2.0 * np.log(k)] * 3),
                "w_variance_ratio": U}

    monkeypatch.setattr(st, "windscanner_theory", fake)
    monkeypatch.setattr(th, "_CACHE", {})
    extra = '[[period]]\nname = "b"\nmean_speed = 8.0\nseed = 7\n[[period]]\nname = "c"\nmean_speed = 9.0\n'
    scene = loads_scene(WS_SCENE + extra)
    edges = scene.scanner.k_edges()
    kc = np.sqrt(edges[1:] * edges[:-1])
    out = [st.windscanner_variables(scene, i, kc) for i in range(3)]
    assert len(calls) == 2
    np.testing.assert_allclose(out[0]["transfer_ratio_theory"][1][0], np.log(kc)[None].repeat(3, 0), rtol=1e-12)
    assert out[0]["transfer_ratio_theory"][1].tobytes() == out[1]["transfer_ratio_theory"][1].tobytes()
    assert out[2]["w_variance_ratio_theory"][1][0] == 9.0


def _ws_periods_text(n, box=4.0):
    """n seeded 160-s tier-los periods of the published layout at 8 m/s, A2012's functions in 4 bins of 0.03-0.12
    rad/m (40-s segments): the band the 4-m box resolves (finer bins see its smoothing, module notes)."""
    periods = "".join(f'[[period]]\nname = "p{i}"\nmean_speed = 8.0\nseed = {100 + i}\n' for i in range(n))
    head = WS_SCENE[:WS_SCENE.index("[[period]]")].replace("duration = 30.0", "duration = 160.0")
    head = head.replace("segment_duration = 10.0", "segment_duration = 40.0\nk_min = 0.03\nk_max = 0.12\nn_k = 4")
    return head.replace("spacing = 4.0", f"spacing = {box}") + periods


def _z(sim_pk, theory_k):
    """(mean over periods - theory) / its standard error."""
    n = sim_pk.shape[0]
    return (sim_pk.mean(axis=0) - theory_k) / (sim_pk.std(axis=0, ddof=1) / np.sqrt(n))


@pytest.mark.slow
def test_windscanner_transfer_functions_agree_with_eight_simulated_periods(monkeypatch):
    """Eight seeded tier-los periods (160 s, the 4-m box): each component's A2012 methods 1 and 2 (tier 1) over
    0.03-0.12 rad/m agree with the linear theory (the reconstruction matrix over the beams' weightings) within 3
    standard errors of the periods' mean.  Two broken theories are rejected by the same statistic: point probes
    (the reconstruction at one point is the sonic, ratio 1) and rows v and w of N^-1 swapped."""
    from cwlidar_sim.campaign.periods import windscanner as pw

    scene = loads_scene(_ws_periods_text(8))
    runs = [pw.run_unit(scene, i) for i in range(8)]
    j = list(runs[0].estimate.values).index("tier1")
    assert all(np.all(r.transfer_ratio_theory.values == runs[0].transfer_ratio_theory.values) for r in runs)
    k = runs[0].k.values
    z = {}
    for var in ("transfer_ratio", "transfer_cross"):
        sim = np.stack([r[var].values[0, j] for r in runs])  # (period, component, k)
        assert np.isfinite(sim).all()
        z[var] = _z(sim, runs[0][f"{var}_theory"].values[0])
        print(var, "k", np.round(k, 3), "z (u, v, w by k)", np.round(z[var], 2))
    assert max(np.abs(v).max() for v in z.values()) < 3.0, z
    # the same statistic rejects a theory without the beams' weighting and one with a wrong reconstruction
    p = scene.periods[0]
    ws, params = scene.sensor(), scene.period_params(p)
    sim = np.stack([r.transfer_ratio.values[0, j] for r in runs])
    point = st.windscanner_theory(ws, params, 8.0, k, probe=False, resolution=20.0)
    assert np.abs(_z(sim, point["ratio_ck"])).max() > 10.0
    real = np.linalg.inv
    monkeypatch.setattr(st.np.linalg, "inv", lambda n: real(n)[..., [0, 2, 1], :])
    swapped = st.windscanner_theory(ws, params, 8.0, k, resolution=20.0)
    monkeypatch.setattr(st.np.linalg, "inv", real)
    assert np.abs(_z(sim, swapped["ratio_ck"])).max() > 3.0


@pytest.mark.slow
def test_spinner_rews_coherence_agrees_with_eight_simulated_periods():
    """Eight seeded frozen tier-los 300-s periods of the bundled SpinnerLidar (aligned, 4-m box): the tier-1 REWS per
    rosette against the rotor's, Hann-windowed 150-s segments pooled over the periods (shorter ones smooth the red spectra
    across the bins), in three bins over 0.01-0.1
    rad/m (below the rosettes' Nyquist, whose aliasing the theory leaves out), agree with the theory's coherence
    for the estimator tier 1 is (the blocked estimates kept) within 3 jackknife standard errors; the theory with
    the blocked estimates left out (the main estimate's) is rejected by the same statistic."""
    import math

    from cwlidar_sim.analysis.spectra import bin_average, segment_spectra
    from cwlidar_sim.campaign.execution.reproduce import bundled_text
    from cwlidar_sim.campaign.periods import spinner as ps

    text = bundled_text("spinner").replace("duration = 600.0", "duration = 300.0").replace('tier = "spectral"',
                                                                                          'tier = "los"')
    text = text[:text.index("[[period]]")] + "".join(
        f'[[period]]\nname = "p{i}"\nmean_speed = 10.0\nrotor_rpm = 16.0\nseed = {200 + i}\n' for i in range(8))
    scene = loads_scene(text)
    edges = np.geomspace(0.01, 0.1, 4)
    k = np.sqrt(edges[1:] * edges[:-1])
    lid = scene.sensor(scene.periods[0])
    S = []
    for i in range(8):
        ds = ps.run_unit(scene, i)
        j = list(ds.estimate.values).index("tier1")
        s = segment_spectra(ds.rews.values[0, j], ds.rews_rotor.values[0], fs=1.0 / lid.rosette_time,
                            segment_duration=150.0, window="hann")
        S.append(bin_average(s.f_f * 2.0 * math.pi / 10.0, np.stack([s.psd_xf, s.psd_yf, s.csd_f]), edges)[0])
    S = np.array(S)

    def coherence(m):
        return np.abs(m[2]) ** 2 / (m[0].real * m[1].real)

    sim = coherence(S.mean(axis=0))
    jk = np.array([coherence(np.delete(S, i, axis=0).mean(axis=0)) for i in range(8)])
    se = np.sqrt(7.0 / 8.0 * ((jk - jk.mean(axis=0)) ** 2).sum(axis=0))
    params, nodes = scene.period_params(scene.periods[0]), st.rotor_disc_nodes(40.0, 0.0, n_radial=12, n_azimuth=32)
    z = {}
    for blocked in (False, True):
        th = st.spinner_theory(lid, params, 10.0, k, 40.0, sub_dwells=1, stride=4, rotor_nodes=nodes,
                               resolution=20.0, exclude_blocked=blocked)["coherence_k"]
        z[blocked] = (sim - th) / se
        print("k", np.round(k, 4), "simulated", np.round(sim, 3), "se", np.round(se, 3), "theory", np.round(th, 3),
              "blocked left out" if blocked else "blocked kept", "z", np.round(z[blocked], 2))
    assert np.abs(z[False]).max() < 3.0, z
    assert np.abs(z[True]).max() > 3.0, z


def test_node_sonic_reads_the_box_as_the_sampler():
    """A sonic off the box's nodes across the wind, in a field of one mode u = cos(k . x) with transverse k: the
    simulation's reading (sample_sonic, a node along x) is node_sonic's bilinear mix of the four (y, z) nodes, not
    the mode at the sonic itself (which differs by > 5 %); on a node the two agree."""
    import xarray as xr

    from cwlidar_sim.sensors.sonic import Sonic, sample_sonic

    d, shape, origin = 4.0, (8, 8, 8), (-16.0, -13.3, 90.6)
    axes = [origin[i] + d * np.arange(shape[i]) for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    for k in ((0.3, 0.5, 0.0), (0.1, 0.7, 0.45)):
        u = np.cos(k[0] * X + k[1] * Y + k[2] * Z)
        zero = np.zeros_like(u)
        box = xr.Dataset({"u": (("x", "y", "z"), u), "v": (("x", "y", "z"), zero), "w": (("x", "y", "z"), zero)},
                         coords={"x": axes[0], "y": axes[1], "z": axes[2]})
        for pos in ((0.0, 0.95, 101.3), (0.0, -1.3 + 4.0, 90.6 + 12.0)):
            sim = sample_sonic(box, Sonic(position=pos), [0.0], 8.0)[0, 0] - 8.0
            f = st.node_sonic(pos, origin, (d, d, d))
            reading = float(np.sum(f.weight_olc[0, :, 0] * np.cos(f.looks.point_lc @ np.array(k))))
            assert reading == pytest.approx(sim, abs=1e-9)
            at_point = math.cos(float(np.dot(k, pos)))
            on_node = pos[1] == -1.3 + 4.0
            assert (abs(at_point - sim) < 1e-9) if on_node else (abs(at_point - sim) > 0.05)
    with pytest.raises(ValueError, match="spacing"):
        st.node_sonic((0.0, 0.0, 0.0), origin, (d, 0.0, d))
