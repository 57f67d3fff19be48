"""The lattice theory of a generated plane (lattice_spectra with shape (N1, N2); analysis/_linear_lattice.py notes).

A plane (``generate_plane``) holds the tensor integrated over all k3 on its (k1, k2) modes, k2 up to pi / dy; a
slightly misaligned staring beam passes the modes whose k.n ~ 0 (k2 ~ -k1 / tan(theta), 48 k1 at 1.2 deg), which
the plane cuts off above k1 ~ (pi / dy) tan(theta).  These tests hold the plane's lattice to the generator (its
discrete matrices, its seeds read bilinearly across y) and to the continuum as dy -> 0.
"""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.turbulence import MannParameters, generate_plane
from cwlidar_sim.turbulence._discrete import discrete_field, plane_phi_rows

P = MannParameters(alpha_eps=0.06, length_scale=18.76, gamma=3.9)
U = 8.0


@pytest.mark.parametrize("shape", [(64, 16), (63, 15), (40, 32)])
def test_plane_rows_are_the_generators_matrices(shape):
    """plane_phi_rows (the rows a lattice sum needs, computed alone) is the plane's DiscreteField table bit for bit,
    every row, odd and even axes (the Hermitian columns' drawn rows and the mirrored columns included)."""
    rows = np.arange(shape[0])
    full = discrete_field("plane", P, shape, (0.5, 0.7)).phi_rows(rows)
    assert np.array_equal(plane_phi_rows(P, shape, (0.5, 0.7), rows), full)


def _staring(theta_deg=1.2, focus=67.5, zR=5.6):
    """A beam misaligned by theta (Lorentzian probe) and a sonic's n.u at its focus, in the plane z = 0."""
    th = math.radians(theta_deg)
    n = np.array([-math.cos(th), -math.sin(th), 0.0])
    p = [[focus * n[0], focus * n[1], 0.0]]
    beam = lt.lidar_functional(lt.Looks(p, [n], None, lt.lorentzian_probe(zR)), [1.0], ["lidar"])
    sonic = lt.LinearFunctional(lt.Looks(p, [n], None, None), n.reshape(1, 1, 3), ["sonic"])
    return [beam, sonic]


def test_plane_lattice_tends_to_the_continuum_as_dy_shrinks():
    """On a plane 1024 m x 128 m, at k1 = 0.05 and 0.3 rad/m: the beam's and the sonic's lattice spectra approach
    the continuum as dy shrinks from 0.5 m to 0.125 m (pi / dy from 6.3 to 25 rad/m, past the beam's k.n ~ 0 ridge
    at k2 ~ 14 rad/m for k1 = 0.3): the lidar at 0.3 rad/m from 2.8 % low to within 1e-3, both within 2e-3 at the
    finest (the rest: the k2 sum's cells, dk2 = 0.05 rad/m)."""
    fs = _staring()
    err = {}
    for dy in (0.5, 0.125):
        shape, spacing = (1024, int(round(128.0 / dy))), (1.0, dy)
        rows = np.rint(np.array([0.05, 0.3]) * 1024.0 / (2.0 * math.pi)).astype(int)
        s = lt.lattice_spectra(P, fs, U, shape, spacing, rows=rows)
        c = lt.functional_spectra(s.k1_k, P, fs, U, resolution=8.0)
        err[dy] = np.array([np.abs(s.spectrum(a) / c.spectrum(a) - 1.0) for a in ("0.lidar", "1.sonic")])
    assert err[0.5][0, 1] > 0.02  # the coarse plane misses the ridge
    assert np.all(err[0.125] <= err[0.5] + 1e-4)
    assert np.all(err[0.125] < 2e-3), err[0.125]


def test_plane_lattice_refuses_looks_off_the_plane():
    """A plane holds one height and horizontal directions; with origin given, a slanted probe is refused (its
    sub-points read different fractions of a cell: expand it into point looks)."""
    off = lt.point_functional((0.0, 0.0, 1.0), ("u",))
    on = lt.point_functional((0.0, 0.0, 0.0), ("u",))
    with pytest.raises(ValueError, match="one height"):
        lt.lattice_spectra(P, [on, off], U, (32, 8), (1.0, 1.0))
    with pytest.raises(ValueError, match="expand a slanted beam"):
        lt.lattice_spectra(P, _staring()[0], U, (32, 8), (1.0, 1.0), interpolation="linear", origin=(0.0, 0.3))
    with pytest.raises(ValueError, match="hf_compensation"):
        lt.lattice_spectra(P, on, U, (32, 8), (1.0, 1.0), hf_compensation=True)
    with pytest.raises(ValueError, match="origin is a plane's"):
        lt.lattice_spectra(P, on, U, (8, 8, 8), (1.0, 1.0, 1.0), origin=(0.0, 0.0))


#: A small coarse plane: its high-k2 modes hold much of the variance, so the reading across y matters.
SHAPE, SPACING, N_SEEDS = (16, 8), (2.0, 2.0), 1200
#: Looks in the plane's frame (nodes at j dy): off the nodes across y (fractions 0.5 and 0.2), on them along x.
Y_A, Y_B = 3.0, 8.4


@pytest.fixture(scope="module")
def plane_rows():
    """Per seed and k1 row n, the power of ``a = u(y_a) + 0.5 v(y_b)`` and ``b = u(y_b)`` along x, read bilinearly."""
    n1 = SHAPE[0]

    def read(c, y):
        u = y / SPACING[1]
        j0 = int(math.floor(u))
        f = u - j0
        return (1.0 - f) * c[:, j0 % SHAPE[1]] + f * c[:, (j0 + 1) % SHAPE[1]]

    out = np.empty((N_SEEDS, 2, n1))
    for s in range(N_SEEDS):
        p = generate_plane(P, SHAPE, SPACING, s, dtype=np.float64)
        u, v = np.asarray(p.u.values), np.asarray(p.v.values)
        for i, x in enumerate((read(u, Y_A) + 0.5 * read(v, Y_B), read(u, Y_B))):
            out[s, i] = np.abs(np.fft.fft(x) / n1) ** 2
    return out


def _line_z(plane_rows, spec):
    """z of each line (rows n and N1 - n; the Nyquist row once) against ``spec``'s line times dk1."""
    n1 = SHAPE[0]
    dk1 = 2.0 * math.pi / (n1 * SPACING[0])
    z = np.empty((2, n1 // 2))
    for i, name in enumerate(("a.a", "b.b")):
        line = spec.spectrum(i) * dk1
        for r in range(1, n1 // 2 + 1):
            mc = plane_rows[:, i, [r] if 2 * r == n1 else [r, n1 - r]].sum(axis=1)
            z[i, r - 1] = (mc.mean() - line[r - 1]) / (mc.std(ddof=1) / math.sqrt(mc.size))
    return z


def test_plane_lattice_is_the_generators_bilinear_reading(plane_rows):
    """Two outputs of points read bilinearly across y between the plane's nodes (fractions 0.5 and 0.2 of a cell),
    the generator's power in each k1 row over 1200 seeds: the lattice with the plane's placement (origin) within
    4 standard errors at every line; the aliases summed in power (the mean over placements), the modes read at
    the points (no interpolation) and the plane placed a fifth of a cell off are rejected."""
    a = lt.LinearFunctional(lt.Looks([[0.0, Y_A, 0.0], [0.0, Y_B, 0.0]], [[1.0, 0.0, 0.0]] * 2, None, None),
                            np.array([[[1.0, 0.0, 0.0], [0.0, 0.5, 0.0]]]), ["a"])
    b = lt.point_functional((0.0, Y_B, 0.0), ("u",))
    kw = dict(interpolation=("none", "linear"))
    exact = lt.lattice_spectra(P, [a, b], U, SHAPE, SPACING, origin=(0.0, 0.0), **kw)
    z = _line_z(plane_rows, exact)
    assert np.all(np.abs(z) < 4.0), np.round(z, 1)
    for other in (lt.lattice_spectra(P, [a, b], U, SHAPE, SPACING, aliases=4, **kw),
                  lt.lattice_spectra(P, [a, b], U, SHAPE, SPACING),
                  lt.lattice_spectra(P, [a, b], U, SHAPE, SPACING, origin=(0.0, 0.4), **kw)):
        assert np.max(np.abs(_line_z(plane_rows, other))) > 6.0  # measured 8.3, 26, 9.2
