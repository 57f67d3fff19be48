"""The scenes' functionals at tier ``los`` (campaign/periods/theory.py): range cells, yaw, a fixed platform attitude.

Each option against a plain reference: the cells' phi_hat against the cells' own sum and, for fine cells over a
long span, the continuous weighting; the nacelle functional (the simulation's looks, its cells, yaw and tilt)
against the simulation itself in a field of one Fourier mode, where the tier-1 record is exactly the functional's
transfer at that wavenumber (up to the box's trilinear interpolation, ~(k dx)^2 / 8).
"""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis.rews_theory import beam_transfer
from cwlidar_sim.beam.cells import probe_cells
from cwlidar_sim.campaign.periods import theory as th
from cwlidar_sim.sensors import NacelleLidar
from cwlidar_sim.sensors.nacelle import measure_nacelle
from cwlidar_sim.sensors.platform import PlatformMotion
from cwlidar_sim.signal.instrument import CS_SERIES


def test_cells_probe_is_the_cells_sum():
    """cells_probe reproduces ProbeCells.transfer (the sub-points' sum) at any q, inside its table and beyond,
    negative q its conjugate; phi_hat(0) is the kept weight (the mean-wind tail carries no fluctuation)."""
    cells = probe_cells(CS_SERIES.replace(focus=100.0).optics(), "exact", 5.0, 2.0)
    f = th.cells_probe(cells)
    q = np.concatenate([np.geomspace(1e-4, 40.0, 3001), [1e3, 5e3]])
    ref = cells.transfer(q)
    assert np.max(np.abs(f(q) - ref)) < 1e-4
    np.testing.assert_allclose(f(-q), np.conj(f(q)), atol=1e-15)
    assert f(np.zeros(1))[0].real == pytest.approx(cells.weight_s.sum(), rel=1e-12)
    assert cells.weight_s.sum() == pytest.approx(1.0 - cells.truncated_fraction, rel=1e-9)
    with pytest.raises(TypeError, match="cells"):
        th.cells_probe("cells")


def test_fine_cells_over_a_long_span_are_the_continuous_weighting():
    """Cells of z_R / 10 over +/-100 z_R: the cells' phi_hat within 1e-2 of the beam's continuous weighting (the
    0.6 % beyond the span sees the mean wind); the scene's 4-m cells over 5 z_R differ by the span's 8.6 %."""
    inst = CS_SERIES.replace(focus=100.0)
    zr = inst.rayleigh_length
    cont = beam_transfer(100.0, "exact", wavelength=inst.wavelength, radius=inst.telescope_radius)
    fine = th.cells_probe(probe_cells(inst.optics(), "exact", 100.0, zr / 10.0))
    q = np.geomspace(1e-3, 3.0, 400) / zr
    assert np.max(np.abs(fine(q) - cont(q))) < 1e-2
    coarse = th.cells_probe(probe_cells(inst.optics(), "exact", 5.0, 4.0))
    assert np.max(np.abs(coarse(q) - cont(q))) > 0.05  # 8.6 % of the weight beyond 5 z_R


def _mode_box(k_c, spacing, shape, origin):
    """u = cos(k . x) on a box's nodes (v = w = 0), float64."""
    axes = [origin[i] + spacing * np.arange(shape[i]) for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    u = np.cos(k_c[0] * X + k_c[1] * Y + k_c[2] * Z)
    zero = np.zeros_like(u)
    return xr.Dataset({c: (("x", "y", "z"), a) for c, a in (("u", u), ("v", zero), ("w", zero))},
                      coords={"x": axes[0], "y": axes[1], "z": axes[2]})


def _trailing(x, n):
    c = np.concatenate([[0.0], np.cumsum(x)])
    return (c[n:] - c[:-n]) / n


@pytest.mark.parametrize("case", ["plain", "yaw", "tilt"])
def test_nacelle_functional_is_the_simulation_in_one_mode(case):
    """The nacelle lidar's tier-1 revolution mean in a field of one Fourier mode u = cos(k.x): the simulation's own
    series against Re(exp(-i k1 U t) g_u(k)) of nacelle_functionals(n_beams=None, probe='cells'), yawed 20 deg and
    tilted 4 deg (a fixed pitch) too; the continuous probe or the yaw left out each miss by more than 5 x the
    tolerance.  Each record's uniform-wind part (the mean wind, the cells' mean-wind tail) is taken off by a run in
    a still field."""
    U, r, dx = 10.0, 100.0, 4.0
    motion = None
    yaw = 20.0 if case == "yaw" else 0.0
    if case == "tilt":
        motion = PlatformMotion(time=[-10.0, 100.0], pitch_deg=[4.0, 4.0], heave=[1.0, 1.0])
    lidar = NacelleLidar(focus_distances=(r,), half_angle_deg=15.0, estimates_per_rev=50, sub_dwells=2,
                         span=5.0, cell_length=dx, yaw_misalignment_deg=yaw, motion=motion)
    shape = (256, 48, 48)
    k_c = np.array([2.0 * math.pi / (shape[0] * dx), 2.0 * math.pi / 210.0, -2.0 * math.pi / 170.0])
    origin = (-shape[0] * dx / 2, -94.0, -94.0)
    box = _mode_box(k_c, dx, shape, origin)
    still = box.copy(data={c: np.zeros(shape) for c in ("u", "v", "w")})
    dur = 12.0
    rec = measure_nacelle(box, lidar, dur, U)
    rec0 = measure_nacelle(still, lidar, dur, U)
    n = lidar.estimates_per_rev
    sim = _trailing(rec.vlos_e / rec.direction_ec[:, 0], n) - _trailing(rec0.vlos_e / rec0.direction_ec[:, 0], n)
    # the functional's estimate is formed at the last estimate of a revolution (its looks those of the schedule's
    # first revolution): the revolution means ending at estimates n - 1, 2 n - 1, ...
    sim, t = sim[::n], rec.time_e[n - 1::n]
    rotor, est = th.nacelle_functionals(lidar, r, U, ([0.0], [0.0], [1.0]), n_beams=None, preview_shift=0.0,
                                        probe="cells")

    def series(f):
        g = complex(f.transfer(k_c[0], k_c[1:2], k_c[2:3], U)[0, 0, 0])
        return np.real(np.exp(-1j * k_c[0] * U * t) * g)

    err = np.max(np.abs(sim - series(est)))
    assert err < 2e-3  # measured 2e-4 to 4e-4 (trilinear interpolation at k dx = 0.1)
    wrong = [th.nacelle_functionals(lidar, r, U, ([0.0], [0.0], [1.0]), n_beams=None, preview_shift=0.0)[1]]
    if case != "plain":
        wrong.append(th.nacelle_functionals(lidar.replace(yaw_misalignment_deg=0.0, motion=None), r, U,
                                            ([0.0], [0.0], [1.0]), n_beams=None, preview_shift=0.0,
                                            probe="cells")[1])
    for f in wrong:
        assert np.max(np.abs(sim - series(f))) > 5 * 2e-3
    # the rotor at the hub: u at the lidar's position, no delay
    np.testing.assert_allclose(complex(rotor.transfer(k_c[0], k_c[1:2], k_c[2:3], U)[0, 0, 0]), 1.0)


def test_nacelle_moving_platform_is_refused_by_name():
    moving = PlatformMotion(time=[0.0, 1.0, 2.0], pitch_deg=[0.0, 2.0, 0.0], surge=[0.0, 0.1, 0.0])
    lidar = NacelleLidar(focus_distances=(80.0,), motion=moving)
    with pytest.raises(ValueError, match=r"lidar\.motion.*motion\.surge.*motion\.pitch_deg"):
        th.nacelle_functionals(lidar, 80.0, 10.0, ([0.0], [0.0], [1.0]))
    with pytest.raises(ValueError, match="probe"):
        th.nacelle_functionals(lidar.replace(motion=None), 80.0, 10.0, ([0.0], [0.0], [1.0]), probe="gates")


def test_nacelle_n_beams_and_simulation_looks_agree_on_a_uniform_wind():
    """Both scan descriptions (8 beams, the simulation's looks) of a lidar yawed by gamma return a uniform u as
    cos(gamma) and a uniform v as sin(gamma) (the lidar takes v_los / m_x, v = w = 0 in its own frame; the circle's
    mean of m_y / m_x and m_z / m_x is 0)."""
    g = 12.0
    lidar = NacelleLidar(focus_distances=(80.0,), yaw_misalignment_deg=g)
    for nb in (8, None):
        est = th.nacelle_functionals(lidar, 80.0, 10.0, ([0.0], [0.0], [1.0]), n_beams=nb)[1]
        w = est.weight_olc[0].sum(axis=0)
        np.testing.assert_allclose(w, [math.cos(math.radians(g)), math.sin(math.radians(g)), 0.0], atol=1e-3)


@pytest.mark.parametrize("k_dx", [0.3, 2.5])
def test_node_interpolated_variance_is_the_simulation_between_nodes(k_dx):
    """A cup and a sonic in a field of one mode u = cos(k x) between the box's nodes along x: the simulation's
    series (sample_cup at 10 Hz, sample_sonic at 50 Hz, their variances about the mean) against
    node_interpolated_variance of the mode's one line; at k dx = 2.5 the plain line (the point functional through
    the continuous response, no interpolation) misses by more than 5 x the tolerance.  Many nodes past a still
    sensor give the interpolant's mean square, (2 + cos(k dx)) / 3 of the mode's variance."""
    from cwlidar_sim.analysis import linear_theory as lt
    from cwlidar_sim.sensors import Cup, Sonic, sample_cup, sample_sonic

    U, dx, n1 = 8.0, 2.0, 64
    n = round(k_dx * n1 / (2.0 * math.pi))
    k = 2.0 * math.pi * n / (n1 * dx)
    cos_box = _mode_box(np.array([k, 0.0, 0.0]), dx, (n1, 4, 4), (0.0, -3.0, 37.0))
    sin_box = cos_box.copy(data={"u": np.sin(k * cos_box["x"].values)[:, None, None] + 0.0 * cos_box["u"].values,
                                 "v": cos_box["v"].values, "w": cos_box["w"].values})
    cup = Cup(position=(0.7, -1.0, 39.0))
    t = np.arange(480) * 0.1  # three passes of the box: whole periods of the mode

    def mean_var(f):  # the two phases' mean: the mean over the mode's random phase
        return 0.5 * (f(cos_box) + f(sin_box))

    sim_cup = mean_var(lambda b: float(np.var(sample_cup(b, cup, t, U, wrap=True))))
    theory = th.node_interpolated_variance([k], [0.5], U, t, dx, offset=0.7, distance_constant=cup.distance_constant)
    assert sim_cup == pytest.approx(theory, rel=1e-6)
    t50 = np.arange(2400) * 0.02
    sonic = Sonic(position=cup.position)
    sim_sonic = mean_var(lambda b: float(np.var(sample_sonic(b, sonic, t50, U, wrap=True)[:, 0])))
    assert sim_sonic == pytest.approx(th.node_interpolated_variance([k], [0.5], U, t50, dx, offset=0.7), rel=1e-6)
    if k_dx > 2:
        resp = lt.first_order_response(cup.distance_constant / U)
        plain = 0.5 * float(np.abs(resp(U * k)) ** 2)
        assert abs(plain / sim_cup - 1.0) > 5e-3 and abs(0.5 / sim_sonic - 1.0) > 5e-3
    many = th.node_interpolated_variance([k], [0.5], 1.0, np.arange(20000) * 0.0137, dx)
    assert many == pytest.approx(0.5 * (2.0 + math.cos(k * dx)) / 3.0, rel=5e-3)
    with pytest.raises(ValueError, match="dx"):
        th.node_interpolated_variance([k], [0.5], U, t, 0.0)


def test_nacelle_lidar_reads_transverse_modes_through_the_interpolation():
    """What the functionals leave out (the nacelle lidar-rotor std ratio's residual, studies/theory_vs_simulation.py):
    the simulation's looks read the box between its nodes across the beam too, so a mode of transverse wavenumber
    k2 reaches the revolution mean lowered by about sinc^2(k2 dy / 2) (the mean of the interpolation's gain over
    the looks' positions between nodes): 0.91 at k2 dy = 1.05, 0.68 at 2.09; at k2 dy = 0.13 the two agree."""
    U, r, dx = 12.0, 100.0, 4.0
    lidar = NacelleLidar(focus_distances=(r,), half_angle_deg=15.0, estimates_per_rev=50, sub_dwells=2,
                         span=5.0, cell_length=dx)
    shape = (256, 48, 48)
    n = lidar.estimates_per_rev
    for k2n, lo, hi in ((1, 0.98, 1.02), (8, 0.87, 0.95), (16, 0.60, 0.74)):
        k_c = np.array([2.0 * math.pi * 3 / (shape[0] * dx), 2.0 * math.pi * k2n / (shape[1] * dx), 0.0])
        box = _mode_box(k_c, dx, shape, (-shape[0] * dx / 2, -94.0, -94.0))
        still = box.copy(data={c: np.zeros(shape) for c in ("u", "v", "w")})
        rec, rec0 = measure_nacelle(box, lidar, 12.0, U), measure_nacelle(still, lidar, 12.0, U)
        sim = _trailing(rec.vlos_e / rec.direction_ec[:, 0], n) - _trailing(rec0.vlos_e / rec0.direction_ec[:, 0], n)
        sim, t = sim[::n], rec.time_e[n - 1::n]
        est = th.nacelle_functionals(lidar, r, U, ([0.0], [0.0], [1.0]), n_beams=None, preview_shift=0.0,
                                     probe="cells")[1]
        g = complex(est.transfer(k_c[0], k_c[1:2], k_c[2:3], U)[0, 0, 0])
        gain = math.sqrt(np.mean(sim ** 2) / np.mean(np.real(np.exp(-1j * k_c[0] * U * t) * g) ** 2))
        assert lo < gain < hi, (k2n, gain)
        assert abs(gain - np.sinc(k_c[1] * dx / (2.0 * math.pi)) ** 2) < 0.04
