"""A point sensor's variance below a field's grid: the box's own expectation, the continuum, and convergence."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.analysis import point_subgrid as ps
from cwlidar_sim.sensors import Cup, Sonic, sample_cup, sample_sonic
from cwlidar_sim.turbulence import MannParameters, generate_box, generate_line, generate_plane

P = MannParameters(alpha_eps=0.05, length_scale=5.0, gamma=3.0)
U, DX, SHAPE = 10.0, 4.0, (256, 16, 16)
T, DT = 90.0, 0.05
L0 = 0.8  # the cup's distance constant [m]: short, so that its sub-grid part stands out of 24 seeds' scatter


def _simulated(sensor, offset, seeds=range(24)):
    """Per seed, the mean over four nodes' (1/N) sample variance of u (sonic) or of the cup's speed."""
    t = np.arange(0.0, T, DT)
    out = []
    for s in seeds:
        box = generate_box(P, SHAPE, (DX,) * 3, s)
        v = []
        for j in (0, 4, 8, 12):
            pos = (0.0, (j + offset) * DX, (j + offset) * DX)
            if sensor == "sonic":
                v.append(sample_sonic(box, Sonic(position=pos), t, U, wrap=True)[:, 0].var())
            else:
                c = Cup(position=pos, rate=1.0 / DT, distance_constant=L0)
                v.append(sample_cup(box, c, t, U, wrap=True).var())
        out.append(np.mean(v))
    return np.array(out)


@pytest.mark.parametrize("sensor, offset", [("sonic", 0.0), ("cup", 0.0), ("sonic", 0.5)])
def test_restored_variance_is_the_continuum_and_without_it_is_not(sensor, offset):
    tau = L0 / U if sensor == "cup" else None
    r = ps.point_subgrid_variance(P, U, T, "box", SHAPE, (DX,) * 3, offset=(offset, offset), time_constant=tau,
                                  sample_interval=DT)
    v = _simulated(sensor, offset)
    se = v.std(ddof=1) / math.sqrt(v.size)
    # the box's own expectation (its modes, the x interpolation, the lateral interpolation off the nodes)
    assert abs(v.mean() - r["field"]) < 3 * se
    # restored: the continuum; the fix removed (raw) or its sign flipped: far from it
    assert abs(v.mean() + r["subgrid"] - r["continuum"]) < 3 * se
    assert r["subgrid"] > 6 * se
    assert abs(v.mean() - r["continuum"]) > 3 * se and abs(v.mean() - r["subgrid"] - r["continuum"]) > 3 * se


@pytest.mark.parametrize("kind, offset, n_seeds", [("line", 0.0, 64), ("plane", 0.5, 24)])
def test_a_sonic_in_a_line_or_a_plane_reads_its_modes_and_the_rest_is_the_continuum(kind, offset, n_seeds):
    """A line holds every lateral mode but none above the k1 Nyquist; a plane truncates k2 as well.

    Monte Carlo (seeded): per seed, the sonic's (1/N) variance of u (a plane: the mean over four
    positions half a cell off the y nodes, whose bilinear average the sensor reads).  The tolerance
    is three standard errors of the seeds' mean (line 0.0057, plane 0.0041 m^2/s^2), the sub-grid
    variance 7.6 (line) and 22 (plane) of them.
    """
    t = np.arange(0.0, T, DT)
    v = []
    for s in range(n_seeds):
        if kind == "line":
            f = generate_line(P, 256, DX, s)
            v.append(sample_sonic(f, Sonic(position=(0.0, 0.0, 0.0)), t, U)[:, 0].var())
        else:
            f = generate_plane(P, (256, 16), (DX, DX), s, z=0.0)
            v.append(np.mean([sample_sonic(f, Sonic(position=(0.0, (j + offset) * DX, 0.0)), t, U, wrap=True)[:, 0]
                              .var() for j in (0, 4, 8, 12)]))
    v = np.array(v)
    se = v.std(ddof=1) / math.sqrt(v.size)
    shape = (256,) if kind == "line" else (256, 16)
    r = ps.point_subgrid_variance(P, U, T, kind, shape, (DX,) * len(shape), offset=(offset, 0.0), sample_interval=DT)
    assert abs(v.mean() - r["field"]) < 3 * se
    assert abs(v.mean() + r["subgrid"] - r["continuum"]) < 3 * se
    assert r["subgrid"] > 6 * se and abs(v.mean() - r["continuum"]) > 3 * se
    if kind == "plane":  # on the nodes the plane would hold more: the off-node average is part of the sub-grid share
        on = ps.point_subgrid_variance(P, U, T, kind, shape, (DX, DX), sample_interval=DT)
        assert on["field"] - v.mean() > 3 * se


def test_subgrid_variance_converges_with_the_spacing():
    """Grids of one physical size, refined: the box's expectation rises to the continuum, the sub-grid part to 0."""
    sub, field, cont = [], [], []
    for n in (1, 2, 4):
        r = ps.point_subgrid_variance(P, U, T, "box", (256 * n, 16 * n, 16 * n), (DX / n,) * 3, sample_interval=DT)
        sub.append(r["subgrid"]), field.append(r["field"]), cont.append(r["continuum"])
    assert np.ptp(cont) < 1e-5 * cont[0] and np.all(np.diff(field) > 0) and np.all(np.diff(sub) < 0)
    # the inertial range's k^(-2/3) law: each halving of the spacing leaves about 2^(-2/3) of the sub-grid variance
    assert sub[2] / sub[1] == pytest.approx(2 ** (-2 / 3), rel=0.15)
    assert sub[2] < 0.15 * cont[2] < sub[0]


def test_continuum_is_the_linear_theory_of_a_point():
    k = np.geomspace(1e-3, 10.0, 7)
    cup = lt.point_functional((0, 0, 0), ("u",), response=lt.first_order_response(0.23))
    F = lt.functional_spectra(k, P, cup, U).spectrum("u")
    kk, Fc = ps._continuum_spectrum(P, (1.0, 0.0, 0.0), 1e-4, 1e3)
    h2 = 1.0 / (1.0 + (U * k * 0.23) ** 2)
    assert np.allclose(np.exp(np.interp(np.log(k), np.log(kk), np.log(Fc))) * h2, F, rtol=2e-3)


def test_interpolation_images_of_a_sampled_cosine():
    """A cosine on the x nodes, read between them by the sensor: (2 + cos(k dx)) / 3 of its mean square."""
    n, dx = 64, 2.0
    x = np.arange(n) * dx
    for m in (3, 16, 32):
        k = 2 * math.pi * m / (n * dx)
        u = np.cos(k * x)[:, None, None] * np.ones((1, 2, 2))
        f = xr.Dataset({c: (("x", "y", "z"), u if c == "u" else 0 * u) for c in "uvw"},
                       coords={"x": x, "y": [0.0, dx], "z": [0.0, dx]})
        t = np.arange(0.0, n * dx / U, 0.0137)
        s = sample_sonic(f, Sonic(position=(0.0, 0.0, 0.0)), t, U, wrap=True)[:, 0] - U
        q, w = ps.interpolation_images(np.array([k]), dx)
        assert w.sum() == pytest.approx((2 + math.cos(k * dx)) / 3, rel=1e-5)
        # of the nodes' own mean square (1/2; 1 at the Nyquist, where the nodes hold the peaks)
        assert np.mean(s ** 2) == pytest.approx(np.mean(u[:, 0, 0] ** 2) * w.sum(), rel=0.01)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="direction"):
        ps.point_subgrid_variance(P, U, T, "box", SHAPE, (DX,) * 3, direction=(1.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="offset"):
        ps.point_subgrid_variance(P, U, T, "box", SHAPE, (DX,) * 3, offset=(1.0, 0.0))
    with pytest.raises(ValueError, match="shape"):
        ps.point_subgrid_variance(P, U, T, "plane", SHAPE, (DX,) * 3)
