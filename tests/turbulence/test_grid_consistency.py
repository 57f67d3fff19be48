"""Grid-consistent realisations: at one physical size, one seed gives the same Fourier
coefficients at every wavenumber two grids share, for boxes, planes and lines."""

import math

import numpy as np
import pytest

import reference
from cwlidar_sim.turbulence import (
    MannParameters,
    common_extent,
    generate_box,
    generate_line,
    generate_plane,
    grid_for_extent,
)

P = MannParameters(alpha_eps=1.0, length_scale=33.6, gamma=3.9)
# Round-off of float64 fields and their forward FFTs, relative to the rms coefficient
# (measured 2e-15 .. 5e-15); anything keyed otherwise differs by O(1).
ROUND_OFF = 1e-12


def _interior(n):
    """Signed indices strictly inside the band of an axis of n points (the Nyquist index excluded)."""
    return np.arange(-((n - 1) // 2), (n + 1) // 2)


def _coeffs(field):
    return [np.fft.rfftn(field[c].values) / field[c].values.size for c in "uvw"]


def _shared_error(coarse, fine):
    """Largest difference of the coefficients at the coarse grid's interior modes, over the rms."""
    sc, sf = coarse.u.shape, fine.u.shape
    idx = [_interior(n) for n in sc[:-1]] + [np.arange((sc[-1] + 1) // 2)]  # last axis: half spectrum
    grids = np.meshgrid(*idx, indexing="ij")
    errs = []
    for a, b in zip(_coeffs(coarse), _coeffs(fine)):
        ia = tuple(g % n for g, n in zip(grids[:-1], sc[:-1])) + (grids[-1],)
        ib = tuple(g % n for g, n in zip(grids[:-1], sf[:-1])) + (grids[-1],)
        x, y = a[ia], b[ib]
        errs.append(np.abs(x - y).max() / math.sqrt(np.mean(np.abs(x) ** 2)))
    return max(errs)


def _band_limited(field, band_shape):
    """The field with every mode outside the interior band of ``band_shape`` removed."""
    out = []
    for c in "uvw":
        a = field[c].values
        X = np.fft.rfftn(a)
        keep = np.ones(X.shape, bool)
        for ax, (n_band, n) in enumerate(zip(band_shape, a.shape)):
            s = np.fft.fftfreq(n, 1.0 / n) if ax < a.ndim - 1 else np.arange(X.shape[-1])
            ok = np.abs(s) < n_band / 2.0
            keep &= ok.reshape((-1,) + (1,) * (a.ndim - 1 - ax))
        out.append(np.fft.irfftn(np.where(keep, X, 0.0), s=a.shape, axes=tuple(range(a.ndim))))
    return out


def test_boxes_of_one_physical_size_share_their_coefficients():
    # 128 x 36 x 32 m on two grids: x and z refined by 2, y from 3 m to 2 m (12 -> 18 points).
    coarse = generate_box(P, (32, 12, 16), (4.0, 3.0, 2.0), 5, dtype=np.float64)
    fine = generate_box(P, (64, 18, 32), (2.0, 2.0, 1.0), 5, dtype=np.float64)
    assert _shared_error(coarse, fine) < ROUND_OFF
    # Another seed on the fine grid is another realisation: the comparison can fail.
    other = generate_box(P, (64, 18, 32), (2.0, 2.0, 1.0), 6, dtype=np.float64)
    assert _shared_error(coarse, other) > 0.5
    # A different physical size shares no wavenumber but k = 0: other draws.
    longer = generate_box(P, (40, 12, 16), (4.0, 3.0, 2.0), 5, dtype=np.float64)
    assert _shared_error(coarse, longer) > 0.5
    # The coarse grid's x-Nyquist modes (index N1/2, signed -N1/2 as fftfreq and the tensor
    # take it) off the Hermitian planes are keyed by -N1/2: they equal the fine grid's mode
    # there (not cell-corrected on either grid here: r1 = 12 < 16).
    a, b = _coeffs(coarse)[0], _coeffs(fine)[0]
    s2 = _interior(12)
    np.testing.assert_allclose(a[16][s2 % 12, 1:8], b[64 - 16][s2 % 18, 1:8], rtol=0,
                               atol=ROUND_OFF * float(np.sqrt(np.mean(np.abs(a) ** 2))))


def test_box_fields_low_passed_to_the_coarse_band_agree_on_the_coarse_points():
    coarse = generate_box(P, (32, 8, 8), (4.0, 4.0, 4.0), 11, dtype=np.float64)
    fine = generate_box(P, (64, 16, 16), (2.0, 2.0, 2.0), 11, dtype=np.float64)
    band = (32, 8, 8)
    for a, b in zip(_band_limited(coarse, band), _band_limited(fine, band)):
        # The fine grid's points 0, 2, 4, .. are the coarse grid's points.
        assert np.abs(a - b[::2, ::2, ::2]).max() < ROUND_OFF * a.std()
    # What the band removes is the fine grid's own small scales: its full field differs.
    assert np.abs(coarse.u.values - fine.u.values[::2, ::2, ::2]).max() > 0.1 * coarse.u.values.std()


def test_planes_of_one_physical_size_share_their_coefficients():
    # 1024 x 36 m: x refined by 2, y from 3 m to 2 m; the plane's tables use their local
    # cubics beyond |s1| = 16 (row 17 .. 128 here) on both grids.
    coarse = generate_plane(P, (256, 12), (4.0, 3.0), 3, dtype=np.float64)
    fine = generate_plane(P, (512, 18), (2.0, 2.0), 3, dtype=np.float64)
    assert _shared_error(coarse, fine) < ROUND_OFF
    assert _shared_error(coarse, generate_plane(P, (512, 18), (2.0, 2.0), 4, dtype=np.float64)) > 0.5
    c8 = generate_plane(P, (128, 8), (4.0, 4.0), 9, dtype=np.float64)
    f8 = generate_plane(P, (256, 16), (2.0, 2.0), 9, dtype=np.float64)
    for a, b in zip(_band_limited(c8, (128, 8)), _band_limited(f8, (128, 8))):
        assert np.abs(a - b[::2, ::2]).max() < ROUND_OFF * a.std()


def test_lines_of_one_length_share_their_coefficients():
    coarse = generate_line(P, 300, 2.0, 3, dtype=np.float64)
    fine = generate_line(P, 600, 1.0, 3, dtype=np.float64)
    finer = generate_line(P, 900, 2.0 / 3.0, 3, dtype=np.float64)
    assert _shared_error(coarse, fine) < ROUND_OFF
    assert _shared_error(coarse, finer) < ROUND_OFF
    assert _shared_error(coarse, generate_line(P, 600, 1.0, 4, dtype=np.float64)) > 0.5
    for a, b in zip(_band_limited(coarse, (300,)), _band_limited(fine, (300,))):
        assert np.abs(a - b[::2]).max() < ROUND_OFF * a.std()


def test_noise_counters_are_keyed_by_the_signed_wavenumber_indices():
    # The definition (see _kernels.rng), checked against the plain-Python ziggurat: plane
    # mode (s1, s2) of seed s takes normals 6 m + j, m = (s1 + 2^31) 2^29 + s2, of the keys
    # of SeedSequence(s, spawn_key=(2,)); a line's mode s, normals 6 s + j of spawn key (1,).
    from cwlidar_sim.turbulence import _kernels as K

    ss = np.random.SeedSequence(7, spawn_key=(2,)).generate_state(2, dtype=np.uint64)
    key, key_b = int(ss[0]), int(ss[1])
    N1, n2h = 10, 3
    out = np.empty((4, n2h, 3, 2))
    K.plane_noise_kernel(np.uint64(key), np.uint64(key_b), 4, N1, out)  # rows 4 .. 7: s1 = 4, -5, -4, -3
    for r, s1 in enumerate((4, -5, -4, -3)):
        m0 = ((s1 + 2**31) << 29)
        ref = [reference.box_normal(key, key_b, 6 * (m0 + s2) + j) for s2 in range(n2h) for j in range(6)]
        assert np.array_equal(out[r].ravel(), np.array(ref))
    ls = np.random.SeedSequence(7, spawn_key=(1,)).generate_state(2, dtype=np.uint64)
    line = generate_line(P, 8, 1.0, 7, dtype=np.float64)
    z = np.array([reference.box_normal(int(ls[0]), int(ls[1]), c) for c in range(6 * 5)]).reshape(5, 3, 2)
    # Mode s = 1 of u: sqrt(dk) * (M z)_0 / sqrt(2), M the symmetric square root of F(k1), Mann's
    # two-sided matrix (half of line_spectra's one-sided one).
    from cwlidar_sim.turbulence import line_spectra

    k, F = line_spectra(P, 8, 1.0)
    F = F / 2.0
    lam, vec = np.linalg.eigh(F[1])
    M = vec @ np.diag(np.sqrt(np.clip(lam, 0, None))) @ vec.T
    c1 = math.sqrt(k[1]) * (M @ (z[1, :, 0] + 1j * z[1, :, 1]))[0] / math.sqrt(2.0)
    assert np.fft.rfft(line.u.values)[1] / 8 == pytest.approx(c1, rel=1e-12)


def test_counters_of_neighbouring_rows_are_independent():
    # Rows (s1, s2) start 6 * 2^18 counters apart, rows s1 and s1 + 1 6 * 2^36 apart: their
    # normals must be uncorrelated.  For independent N(0, 1) pairs the sample correlation
    # has sd 1 / sqrt(n): bound 4 / sqrt(n).
    from cwlidar_sim.turbulence import _kernels as K

    key, key_b = (np.uint64(k) for k in reference.box_noise_keys(3))
    rows = range(-300, 300)
    n_row = 600

    def row(s1, s2):
        z = np.empty(n_row)
        K.normals_kernel(key, key_b, K.box_row_counter(s1, s2), z)
        return z

    base = np.concatenate([row(s1, 0) for s1 in rows])
    next_y = np.concatenate([row(s1, 1) for s1 in rows])
    next_x = np.concatenate([row(s1 + 1, 0) for s1 in rows])
    mirror = np.concatenate([row(s1, -1) for s1 in rows])
    bound = 4 / math.sqrt(base.size)
    for other in (next_y, next_x, mirror):
        assert abs(np.corrcoef(base, other)[0, 1]) < bound
        assert abs(np.corrcoef(base**2 - 1, other**2 - 1)[0, 1]) < bound


def test_common_extent_and_grid_for_extent():
    L = common_extent(100.0, [2.0, 1.0, 0.5])
    assert L == 100.0
    assert common_extent(100.0, [2.0, 1.5]) == 108.0  # lcm 6, 18 cells of 6 m = 108 (54 and 72 points)
    assert common_extent(37.0, [0.7], fast=False) == pytest.approx(37.1)
    L7 = common_extent(37.0, [0.7])  # 54 cells (2 3^3), not 53
    assert L7 == pytest.approx(37.8) and round(L7 / 0.7) == 54
    shape, spacing = grid_for_extent((L, 36.0), (0.5, 3.0))
    assert shape == (200, 12) and spacing == (0.5, 3.0)
    shape, spacing = grid_for_extent((10.0,), (3.0,))
    assert shape == (3,) and spacing[0] * shape[0] == pytest.approx(10.0, rel=1e-15)
    with pytest.raises(ValueError, match="spacings\\[0\\]"):
        common_extent(10.0, [math.pi])
    with pytest.raises(ValueError, match="min_extent"):
        common_extent(-1.0, [1.0])
    with pytest.raises(TypeError, match="spacings"):
        common_extent(10.0, 1.0)
    with pytest.raises(ValueError, match="extent"):
        grid_for_extent((1.0, 2.0, 3.0, 4.0), (1.0, 1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="spacing"):
        grid_for_extent((10.0, 10.0), (1.0,))


def test_noise_key_range_is_checked():
    with pytest.raises(ValueError, match="shape\\[1\\].*noise keys"):
        generate_box(P, (4, 1 << 19, 2), (1.0, 1.0, 1.0), 0)
