"""The lattice theory's Nyquist modes against the box generator on even grids (lattice_spectra, _linear_lattice),
and expected_box_covariance's rows (its Nyquist row, with and without the high-frequency compensation)."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.turbulence import BoxGenerator, MannParameters, expected_box_covariance, one_point_spectra
from cwlidar_sim.turbulence._discrete import discrete_field

P = MannParameters(alpha_eps=0.1, length_scale=8.0, gamma=3.0)
U = 8.0
#: Even on every axis: a Nyquist row (x), column (y) and plane (z); a small box so that they hold much variance.
SHAPE, SPACING = (8, 6, 4), (4.0, 3.0, 2.0)
N_SEEDS = 1500
#: Seeds of the compensated box (its Nyquist row's gain was 10 % (u) to 20 % (v) high: z ~ 15 at 400 seeds).
N_SEEDS_HF = 400


def _mode_power(n_seeds, **kw):
    gen = BoxGenerator(P, SHAPE, SPACING, **kw)
    out = np.empty((n_seeds, 4) + SHAPE)
    for s in range(n_seeds):
        b = gen.generate(s, dtype=np.float64)
        c = [np.fft.fftn(np.asarray(b[n].values)) / np.prod(SHAPE) for n in "uvw"]
        out[s, :3] = [np.abs(a) ** 2 for a in c]
        out[s, 3] = (c[0] * np.conj(c[2])).real
    return out


@pytest.fixture(scope="module")
def mode_power():
    """The generator's per-mode power ``|c_k|^2`` of u, v, w and ``Re c_u c_w*`` per seed: (seeds, 4) + SHAPE."""
    return _mode_power(N_SEEDS)


def _row_z(mode_power, expect):
    """z of each k1 row's power (rows n and N1 - n, per component 11, 22, 33, 13) against ``F_k4 dk1 / 2`` per row."""
    n1 = SHAPE[0]
    dk1 = 2.0 * math.pi / (n1 * SPACING[0])
    z = np.empty((n1 // 2 + 1, 4))
    for r in range(n1 // 2 + 1):
        rows = [r] if r in (0, n1 - r) else [r, n1 - r]
        for c in range(4):
            z[r, c] = _z(mode_power[:, c, rows].sum(axis=(1, 2, 3)), len(rows) * expect.F_k4[r, c] * dk1 / 2.0)
    return z


def test_expected_box_covariance_rows_are_the_generators(mode_power):
    """expected_box_covariance's one-point spectra F_k4 (11, 22, 33, 13), row by row, are the power the generator
    puts in each k1 row of the even 8x6x4 box (1500 seeds, within 4 of their standard errors), its Nyquist row
    included: that row pairs its modes within itself (the mode with k3 < 0 is the conjugate of a stored mode of the
    same row), which the expectation summed as independent modes at their own wavenumbers -- 17 % (u), 31 % (v),
    13 % (w) low and uw of the wrong sign here (z 20-40)."""
    z = _row_z(mode_power, expected_box_covariance(P, SHAPE, SPACING))
    assert np.all(np.abs(z) < 4.0), np.round(z, 1)


def test_hf_compensation_gives_the_nyquist_row_the_full_spectrum():
    """With hf_compensation the generator's every k1 row, the Nyquist row included, holds the continuum's
    one-point spectrum there (the compensation's aim; 400 seeds, within 4 standard errors): its gain is built from
    the row the generator draws.  Built from the old expectation's Nyquist row, the gain there was 10 % (u) to
    21 % (v) high, the row's power 20-45 % above the continuum (z ~ 15)."""
    power = _mode_power(N_SEEDS_HF, hf_compensation=True)
    expect = expected_box_covariance(P, SHAPE, SPACING, hf_compensation=True)
    z = _row_z(power, expect)
    assert np.all(np.abs(z[:, :3]) < 4.0), np.round(z, 1)
    full = np.array(one_point_spectra(expect.k1_k[1:], P))[:3].T  # one-sided, rows 1 .. N1 / 2
    np.testing.assert_allclose(expect.F_k4[1:, :3], full, rtol=1e-4)


def _z(mc_s, expect):
    """z of the seeds' mean of a per-seed sum against its expectation (the seeds' own scatter)."""
    return (mc_s.mean() - expect) / (mc_s.std(ddof=1) / math.sqrt(mc_s.size))


def test_generator_draws_the_discrete_matrices_at_the_nyquist_modes(mode_power):
    """Every Nyquist set of the even box (the x row, the y column, the z plane, in every row) holds, over 1500
    seeds, the variance of the discrete matrices lattice_spectra sums (DiscreteField.phi_rows): the generator's
    Hermitian partners and the z-Nyquist's averaged tensor included (expected_box_covariance's rows: the test
    below)."""
    df = discrete_field("box", P, SHAPE, SPACING)
    phi = df.phi_rows(np.arange(SHAPE[0]))  # (N1, N2, N3, 6): 11, 22, 33, 13, ...
    n1, n2, n3 = SHAPE
    sets = {"x row": (slice(n1 // 2, n1 // 2 + 1), slice(None), slice(None)),
            "y column": (slice(None), slice(n2 // 2, n2 // 2 + 1), slice(None)),
            "z plane": (slice(None), slice(None), slice(n3 // 2, n3 // 2 + 1))}
    for name, sl in sets.items():
        for c, comp in ((0, 0), (1, 1), (2, 2), (3, 3)):
            mc = mode_power[(slice(None), c) + sl].sum(axis=(1, 2, 3))
            z = _z(mc, phi[sl + (comp,)].sum())
            assert abs(z) < 4.0, (name, c, z)


def test_lattice_nyquist_line_is_the_generators_row(mode_power):
    """A point on a node (u, v, w): each line of lattice_spectra times dk1 is the variance the generator puts in
    that k1 (rows n and N1 - n; the Nyquist row N1 / 2 once), within the seeds' scatter; the Nyquist row counted
    as an ordinary (doubled) row is rejected."""
    f = lt.point_functional((0.0, 0.0, 0.0), ("u", "v", "w"))
    spec = lt.lattice_spectra(P, f, U, SHAPE, SPACING)
    dk1 = 2.0 * math.pi / (SHAPE[0] * SPACING[0])
    n1 = SHAPE[0]
    assert np.allclose(spec.k1_k / dk1, np.arange(1, n1 // 2 + 1))
    for c, name in enumerate("uvw"):
        line = spec.spectrum(name) * dk1
        for r in range(1, n1 // 2 + 1):
            rows = [r] if 2 * r == n1 else [r, n1 - r]
            mc = mode_power[:, c, rows].sum(axis=(1, 2, 3))
            assert abs(_z(mc, line[r - 1])) < 4.0, (name, r)
        mc_nyq = mode_power[:, c, n1 // 2].sum(axis=(1, 2))
        assert abs(_z(mc_nyq, 2.0 * line[-1])) > 8.0  # doubled: rejected


def _lidar_like():
    """Looks off the nodes along slanted beams with a probe: the transfer differs between +-pi / d."""
    rng = np.random.default_rng(1)
    n = rng.normal(size=(5, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    looks = lt.Looks(rng.uniform(0.0, 10.0, (5, 3)), n, None, lt.lorentzian_probe(3.0))
    return lt.LinearFunctional(looks, rng.normal(size=(2, 5, 3)), ("a", "b"))


def test_nyquist_index_stands_for_both_signs():
    """A Nyquist index stands for +-pi / d at half weight each (module notes of _linear_lattice): without
    interpolation the Nyquist line of the box's even grid is the mean of the plain sums over its modes with each
    axis's Nyquist named -pi / d or +pi / d (eight namings; to round-off), where the generator's naming alone is
    off by several per cent.  (With the sampler's interpolation the tent series holds both signs anyway:
    tests/analysis/test_linear_theory_lattice.py checks it against the tents on an even box.)"""
    f = _lidar_like()
    df = discrete_field("box", P, SHAPE, SPACING)
    dk1 = df.dk1
    # the plain sum over the modes, each Nyquist index named with one sign, the Nyquist row not doubled
    q = [2.0 * math.pi * np.fft.fftfreq(n, d) for n, d in zip(SHAPE, SPACING)]
    probes = lt._fast_probes([f])

    def plain(sign, sy, sz):
        out = np.zeros((2, 2), dtype=complex)
        k2, k3 = (np.where(2 * np.arange(n) == n, s * np.abs(a), a) for a, n, s in zip(q[1:], SHAPE[1:], (sy, sz)))
        g2, g3 = (a.ravel() for a in np.meshgrid(k2, k3, indexing="ij"))
        r = SHAPE[0] // 2
        p6 = df.phi_rows(np.array([r]))[0].reshape(-1, 6)
        phi = np.empty((g2.size, 3, 3))
        for c, (a, b) in enumerate(((0, 0), (1, 1), (2, 2), (0, 2), (0, 1), (1, 2))):
            phi[:, a, b] = phi[:, b, a] = p6[:, c]
        lt._accumulate([f], sign * math.pi / SPACING[0], g2, g3, np.ones(g2.size), phi, U, out, probes)
        return 0.5 * (np.conj(out) if sign < 0 else out) / dk1

    spec = lt.lattice_spectra(P, f, U, SHAPE, SPACING)
    namings = [(a, b, c) for a in (-1.0, 1.0) for b in (-1.0, 1.0) for c in (-1.0, 1.0)]
    expect = sum(plain(*s) for s in namings) / 8.0
    np.testing.assert_allclose(spec.matrix_kab[-1], expect, rtol=1e-12, atol=1e-12 * np.abs(expect).max())
    one = plain(-1.0, -1.0, -1.0)  # the generator's fftfreq names alone
    assert np.max(np.abs(one - expect)) > 0.03 * np.abs(expect).max()
