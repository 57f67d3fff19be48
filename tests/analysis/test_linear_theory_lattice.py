"""The lattice theory with the sampler's trilinear interpolation (lattice_spectra(interpolation="linear"))."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.beam.sampling import sample_los
from cwlidar_sim.turbulence import MannParameters
from cwlidar_sim.turbulence._discrete import discrete_field

P = MannParameters(alpha_eps=0.1, length_scale=8.0, gamma=3.0)
U = 8.0
SHAPE, SPACING = (8, 8, 8), (4.0, 3.0, 2.0)
# three point looks (u, v, w weights), each at its own place in its cell; x at 0.3 dx in every cell (see _brute)
POINTS = np.array([[4.0 * 1 + 1.2, 3.0 * 2 + 0.4, 2.0 * 3 + 1.1],
                   [4.0 * 3 + 1.2, 3.0 * 5 + 2.5, 2.0 * 1 + 0.3],
                   [4.0 * 6 + 1.2, 3.0 * 3 + 1.7, 2.0 * 6 + 1.8]])
W_LC = np.array([[0.8, 0.3, -0.2], [0.1, -0.7, 0.4], [-0.5, 0.2, 0.9]])


def _functional():
    looks = lt.Looks(POINTS, np.tile([1.0, 0.0, 0.0], (3, 1)))
    return lt.LinearFunctional(looks, W_LC[None], ("a",))


def _tent(x, d, n, k):
    """Linear interpolation of the mode exp(i k x_j) (nodes x_j = j d, periodic over n nodes) at x."""
    j = np.floor(x / d)
    f = x / d - j
    return (1.0 - f) * np.exp(1j * k * d * (j % n)) + f * np.exp(1j * k * d * ((j + 1) % n))


def test_tent_is_the_sampler():
    # one lattice mode in a box, read by sample_los at arbitrary points and times: the product of the tents
    k = [2.0 * math.pi * m / (n * d) for m, n, d in zip((3, -2, 1), SHAPE, SPACING)]
    xyz = [np.arange(n) * d for n, d in zip(SHAPE, SPACING)]
    X, Y, Z = np.meshgrid(*xyz, indexing="ij")
    mode = np.exp(1j * (k[0] * X + k[1] * Y + k[2] * Z))
    ds = xr.Dataset({c: (("x", "y", "z"), f(mode)) for c, f in (("u", np.real), ("v", np.imag),
                                                             ("w", lambda a: 0.0 * a.real))},
                    coords=dict(zip("xyz", xyz)))
    rng = np.random.default_rng(3)
    t = rng.uniform(0.0, 10.0, 5)
    origin = np.array([3.3, 5.1, 4.7])
    n = np.array([0.6, 0.48, 0.64])
    r = rng.uniform(0.0, 6.0, 7)
    vel, _ = sample_los(ds, origin, n, r, t, U, wrap=True)
    p = origin + r[None, :, None] * n  # (1, n_s, 3)
    val = (_tent(p[..., 0] - U * t[:, None], SPACING[0], SHAPE[0], k[0])
           * _tent(p[..., 1], SPACING[1], SHAPE[1], k[1]) * _tent(p[..., 2], SPACING[2], SHAPE[2], k[2]))
    np.testing.assert_allclose(vel[..., 0] + 1j * vel[..., 1], val, rtol=0, atol=1e-12)


def _brute(n_off=24):
    """The box's variance of the functional read through the tents: 2 sum_modes mean v^H Phi_d v, the mean over
    the box's period (Simpson on each node-to-node piece: exact) and over the box's lateral offset (n_off^2 points)."""
    df = discrete_field("box", P, SHAPE, SPACING, correction="cell", hf_compensation=False)
    q2 = 2.0 * math.pi * np.fft.fftfreq(SHAPE[1], SPACING[1])
    q3 = 2.0 * math.pi * np.fft.fftfreq(SHAPE[2], SPACING[2])
    g2, g3 = (a.ravel() for a in np.meshgrid(q2, q3, indexing="ij"))
    dx = SPACING[0]
    n_seg = SHAPE[0]
    t = (0.3 * dx + 0.5 * dx * np.arange(2 * n_seg + 1)) / U  # x - U t runs over the nodes, kinks at the pieces' ends
    simpson = np.tile([1.0, 4.0, 1.0], n_seg).reshape(n_seg, 3)
    w_t = np.zeros(t.size)
    for s in range(n_seg):
        w_t[2 * s:2 * s + 3] += simpson[s] / (6.0 * n_seg)
    off = (np.arange(n_off) + 0.5) / n_off
    oy, oz = (a.ravel() for a in np.meshgrid(off * SPACING[1], off * SPACING[2], indexing="ij"))
    total = 0.0
    for r in range(1, SHAPE[0] // 2 + 1):
        k1 = float(df.k1_of_rows(np.array([r]))[0])
        phi6 = df.phi_rows(np.array([r]))[0].reshape(-1, 6)
        tx = _tent(POINTS[:, 0][:, None] - U * t[None, :], dx, SHAPE[0], k1)  # (l, t)
        for n, (k2, k3) in enumerate(zip(g2, g3)):
            ty = _tent(POINTS[:, 1][:, None] + oy[None, :], SPACING[1], SHAPE[1], k2)  # (l, o)
            tz = _tent(POINTS[:, 2][:, None] + oz[None, :], SPACING[2], SHAPE[2], k3)
            v = np.einsum("lt,lo,lc->otc", tx, ty * tz, W_LC)
            a = phi6[n]
            phi = np.array([[a[0], a[4], a[3]], [a[4], a[1], a[5]], [a[3], a[5], a[2]]])
            q = np.einsum("otc,cd,otd->ot", np.conj(v), phi, v).real
            total += (1.0 if 2 * r == SHAPE[0] else 2.0) * float(np.mean(q @ w_t))
    return total


def test_linear_interpolation_matches_the_tents():
    brute = _brute()
    spec = lt.lattice_spectra(P, _functional(), U, SHAPE, SPACING, interpolation="linear", aliases=3)
    dk = 2.0 * math.pi / (SHAPE[0] * SPACING[0])
    theory = float(np.sum(spec.spectrum("a")) * dk)
    # measured: -1.1e-4 (aliases 3), -6.7e-5 (5), 48 offsets instead of 24 move the brute force by 6e-5; the gain
    # alone (aliases 0) is 2.4 % low, the plain lattice 61 % high
    assert theory == pytest.approx(brute, rel=5e-4)
    plain = lt.lattice_spectra(P, _functional(), U, SHAPE, SPACING)
    assert abs(float(np.sum(plain.spectrum("a")) * dk) / brute - 1.0) > 0.02  # what the option adds


def test_interpolation_lines_and_axes():
    f = _functional()
    spec = lt.lattice_spectra(P, f, U, SHAPE, SPACING, interpolation="linear", aliases=1)
    dk = 2.0 * math.pi / (SHAPE[0] * SPACING[0])
    # x's aliases put lines beyond the box's Nyquist, on the box's line grid
    assert spec.k1_k.max() > math.pi / SPACING[0]
    np.testing.assert_allclose(spec.k1_k / dk, np.round(spec.k1_k / dk), atol=1e-9)
    assert np.all(np.diff(spec.k1_k) > 0)
    # only x interpolated: y and z stay on the box's modes, lines alone move
    only_x = lt.lattice_spectra(P, f, U, SHAPE, SPACING, interpolation=("linear", "none", "none"), aliases=0)
    plain = lt.lattice_spectra(P, f, U, SHAPE, SPACING)
    L2 = np.sinc(plain.k1_k * SPACING[0] / (2.0 * math.pi)) ** 4
    np.testing.assert_allclose(only_x.spectrum("a"), plain.spectrum("a") * L2, rtol=1e-12)
    with pytest.raises(ValueError, match="interpolation"):
        lt.lattice_spectra(P, f, U, SHAPE, SPACING, interpolation="cubic")
    with pytest.raises(ValueError, match="aliases"):
        lt.lattice_spectra(P, f, U, SHAPE, SPACING, interpolation="linear", aliases=-1)
