"""Conditioned Mann fields (the virtual twin's turbulence): exactness, theory and the dense reference."""

import math

import numpy as np
import pytest

import reference
from cwlidar_sim import _config
from cwlidar_sim.turbulence import MannParameters, generate_box, generate_line, generate_plane
from cwlidar_sim.turbulence._discrete import PAIRS6, discrete_field
from cwlidar_sim.turbulence.conditioning import (
    LineRecord,
    PointValues,
    condition_field,
    conditional_mean,
    conditional_variance,
    conditioned_box,
    conditioned_line,
    conditioned_plane,
    twin_spacing,
)

P = MannParameters(alpha_eps=0.1, length_scale=20.0, gamma=3.9)
U = 8.0


def _row(field, c, iy=None, iz=None):
    a = np.asarray(field[c].values, dtype=np.float64)
    return a if iy is None else (a[:, iy] if iz is None else a[:, iy, iz])


def _record_of_row(row, U_add=0.0):
    """What a sensor at x = 0 records of a grid row at fs = U / dx: sample i sees node -i (mod n)."""
    return row[(-np.arange(row.size)) % row.size] + U_add


# ---------------------------------------------------------------------------
# the discrete spectra are those the generators draw from
# ---------------------------------------------------------------------------
def _group_ratio(emp_k, phi_k, K, self_var=2.0):
    """sum of an ensemble's mode powers over sum of the expected ones, and its standard error."""
    ratio = emp_k.sum() / (K * phi_k.sum())
    se = math.sqrt(self_var * np.sum(phi_k**2) / K) / phi_k.sum()
    return ratio, se


def test_discrete_box_spectra_match_the_generator_mode_by_mode():
    # Even sizes: the Nyquist planes and rows and the corrected cells all occur.
    shape, sp = (32, 16, 12), (3.0, 4.0, 4.0)
    df = discrete_field("box", P, shape, sp, correction="cell")
    phi = df.phi_rows(np.arange(shape[0]))  # (N1, N2, N3, 6), full FFT layout
    K = 24
    emp = np.zeros(shape + (6,))
    for s in range(K):
        b = generate_box(P, shape, sp, 1000 + s, dtype=np.float64)
        S = [np.fft.fftn(_row(b, c)) / np.prod(shape) for c in "uvw"]
        for ci, (i, j) in enumerate(PAIRS6):
            emp[..., ci] += (S[i] * np.conj(S[j])).real
    j1, j2, j3 = np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")
    signed = [np.where(2 * j < n, j, j - n) for j, n in zip((j1, j2, j3), shape)]
    dk = [2 * math.pi / (n * d) for n, d in zip(shape, sp)]
    r = [min((n - 1) // 2, math.floor(3 * max(dk) / k + 1e-9)) for n, k in zip(shape, dk)]  # the cell region
    region = (np.abs(signed[0]) <= r[0]) & (np.abs(signed[1]) <= r[1]) & (np.abs(signed[2]) <= r[2])
    nyq = (2 * j1 == shape[0]) | (2 * j2 == shape[1]) | (2 * j3 == shape[2])
    groups = {"near k = 0": region, "Nyquist": nyq & ~region, "rest": ~nyq & ~region}
    for name, g in groups.items():
        for ci in range(3):
            r, se = _group_ratio(emp[..., ci][g], phi[..., ci][g], K)
            assert abs(r - 1) < 4 * se, (name, ci, r, se)
        # u-w cross-spectrum: var of Re(S_u S_w*) is (Phi11 Phi33 + Phi13^2) / 2 per circular mode.
        num = emp[..., 3][g].sum() / K
        se13 = math.sqrt(np.sum(phi[..., 0][g] * phi[..., 2][g] + phi[..., 3][g] ** 2) / K)
        assert abs(num - phi[..., 3][g].sum()) < 4 * se13, (name, num, phi[..., 3][g].sum(), se13)
    # The x-Nyquist row alone, where the conjugate rule matters most (its u-w cross-spectrum).
    g = j1 == shape[0] // 2
    num = emp[..., 3][g].sum() / K
    se13 = math.sqrt(np.sum(phi[..., 0][g] * phi[..., 2][g] + phi[..., 3][g] ** 2) / K)
    assert abs(num - phi[..., 3][g].sum()) < 4 * se13, (num, phi[..., 3][g].sum(), se13)


@pytest.mark.parametrize("hf", [False, True])
def test_discrete_box_spectra_sum_to_the_expected_one_point_spectra(hf):
    """Summed over (k2, k3) the modes give expected_box_covariance's F(k1) (its own kernel), gains included."""
    from cwlidar_sim.turbulence import expected_box_covariance

    # The configuration of test_turbulence_box's hf test: one set-up serves both in a suite run.
    p, shape, sp = MannParameters(1.0, 33.6, 3.9), (1024, 16, 16), (1.0, 4.0, 4.0)
    df = discrete_field("box", p, shape, sp, hf_compensation=hf)
    e = expected_box_covariance(p, shape, sp, hf_compensation=hf)
    # Not the x-Nyquist row: there a mode with k3 < 0 is the conjugate of the stored mode (-n1, -n2, -n3),
    # which the generator draws at (-pi/dx, -k2, |k3|), while expected_box_covariance sums the tensor at
    # (-pi/dx, k2, k3); the generator's ensemble follows the former (the mode-by-mode test above).
    rows = df.rows_half[:-1]
    F = 2.0 * df.phi_rows(rows).sum(axis=(1, 2)) / df.dk1  # one-sided, as F_k4
    np.testing.assert_allclose(F[:, :4], e.F_k4[:-1], rtol=1e-9, atol=1e-12 * e.F_k4[:, 0].max())


def test_discrete_plane_and_line_spectra_match_their_generators():
    K = 60
    shape, sp = (32, 8), (2.0, 4.0)
    dfp = discrete_field("plane", P, shape, sp)
    phi = dfp.phi_rows(np.arange(shape[0]))[:, 0]
    emp = np.zeros(shape + (6,))
    for s in range(K):
        f = generate_plane(P, shape, sp, s, dtype=np.float64)
        S = [np.fft.fftn(_row(f, c)) / np.prod(shape) for c in "uvw"]
        for ci, (i, j) in enumerate(PAIRS6):
            emp[..., ci] += (S[i] * np.conj(S[j])).real
    for ci in range(3):
        r, se = _group_ratio(emp[..., ci], phi[..., ci], K)
        assert abs(r - 1) < 4 * se, ("plane", ci, r, se)
    dfl = discrete_field("line", P, (128,), (2.0,))
    phil = dfl.phi_rows(dfl.rows_half)[:, 0, 0]
    emp = np.zeros((65, 6))
    for s in range(K):
        f = generate_line(P, 128, 2.0, s, dtype=np.float64)
        S = [np.fft.rfft(_row(f, c)) / 128 for c in "uvw"]
        for ci, (i, j) in enumerate(PAIRS6):
            emp[:, ci] += (S[i] * np.conj(S[j])).real
    for ci in range(3):
        r, se = _group_ratio(emp[1:, ci], phil[1:, ci], K)
        assert abs(r - 1) < 4 * se, ("line", ci, r, se)


# ---------------------------------------------------------------------------
# exactness at the records
# ---------------------------------------------------------------------------
def test_zero_noise_twins_pass_exactly_through_the_records():
    n, dx = 256, U / 4.0
    truth = generate_line(P, n, dx, 99, dtype=np.float64)
    rec = LineRecord((0.0, 0.0, 0.0), 4.0, {c: _record_of_row(_row(truth, c), U if c == "u" else 0.0) for c in "uvw"})
    tw = conditioned_line(P, n, dx, 5, rec, dtype=np.float64)
    for c in "uvw":
        np.testing.assert_allclose(_row(tw, c), _row(truth, c), atol=1e-12)  # a line has zero mean
    # Box: two sensors of a mast; a plane: two sensors across it.  The record's
    # mean is the mean wind: the twin's line mean at the sensor is zero.
    shape, sp = (128, 12, 10), (dx, 3.0, 3.0)
    tb = generate_box(P, shape, sp, 7, dtype=np.float64)
    mast = [(4, 2), (4, 7)]
    recs = [LineRecord((0.0, iy * 3.0, iz * 3.0), 4.0, {c: _record_of_row(_row(tb, c, iy, iz)) for c in "uvw"},
                       name=f"z{iz}") for iy, iz in mast]
    twb = conditioned_box(P, shape, sp, 3, recs, U=U, dtype=np.float64)
    for iy, iz in mast:
        for c in "uvw":
            tr = _row(tb, c, iy, iz)
            np.testing.assert_allclose(_row(twb, c, iy, iz), tr - tr.mean(), atol=1e-12)
    assert np.abs(_row(twb, "u", 9, 5) - _row(tb, "u", 9, 5)).max() > 0.1  # elsewhere it is a cousin
    tp = generate_plane(P, (128, 12), (dx, 3.0), 11, dtype=np.float64)
    recs = [LineRecord((0.0, 3.0 * iy, 0.0), 4.0, {"u": _record_of_row(_row(tp, "u", iy)),
                                                  "w": _record_of_row(_row(tp, "w", iy))}) for iy in (2, 9)]
    twp = conditioned_plane(P, (128, 12), (dx, 3.0), 1, recs, U=U, dtype=np.float64)
    for iy in (2, 9):
        for c in "uw":
            tr = _row(tp, c, iy)
            np.testing.assert_allclose(_row(twp, c, iy), tr - tr.mean(), atol=1e-12)


def test_taylor_convention_matches_the_package_sensors():
    """A sonic of the package (sensors.sample_sonic, x - U t) records the truth; the twin holds the truth there."""
    from cwlidar_sim.sensors.sonic import Sonic, sample_sonic

    shape, dx = (128, 10, 10), 2.0
    fs = U / dx
    truth = generate_box(P, shape, (dx, 3.0, 3.0), 21, dtype=np.float64)
    pos = (7.3, 13.1, 16.4)  # between nodes in x, y and z
    t = np.arange(shape[0]) / fs
    vel = sample_sonic(truth, Sonic(position=pos, rate=fs), t, U)
    rec = LineRecord(pos, fs, {c: vel[:, i] for i, c in enumerate("uvw")}, name="sonic")
    twin = conditioned_box(P, shape, (dx, 3.0, 3.0), 4, rec, U=U, dtype=np.float64)
    back = sample_sonic(twin, Sonic(position=pos, rate=fs), t, U)
    for i in range(3):
        np.testing.assert_allclose(back[:, i] - (U if i == 0 else 0.0), vel[:, i] - vel[:, i].mean(), atol=1e-11)
    # At the nearest node the twin follows the truth; a twin of the record read the other way (x + U t) does not.
    rev = LineRecord(pos, fs, {c: vel[::-1, i] for i, c in enumerate("uvw")})
    twin_rev = conditioned_box(P, shape, (dx, 3.0, 3.0), 4, rev, U=U, dtype=np.float64)
    assert np.corrcoef(_row(twin, "u", 4, 5), _row(truth, "u", 4, 5))[0, 1] > 0.8
    assert abs(np.corrcoef(_row(twin_rev, "u", 4, 5), _row(truth, "u", 4, 5))[0, 1]) < 0.3


def test_twin_differs_from_the_record_by_the_measurement_noise():
    """Twin and truth are exchangeable given the record: E|twin - d|^2 = sigma_n^2 per sample, whatever the spectra."""
    shape, dx, sig = (256, 8, 8), 2.0, 0.15
    fs = U / dx
    ms, ms_truth = [], []
    for k in range(16):
        truth = generate_box(P, shape, (dx, 4.0, 4.0), 500 + k, dtype=np.float64)
        rng = np.random.default_rng(k)
        d = {c: _record_of_row(_row(truth, c, 3, 4)) + rng.normal(0, sig, shape[0]) for c in "uvw"}
        rec = LineRecord((0.0, 12.0, 16.0), fs, d, noise_std=sig)
        twin = conditioned_box(P, shape, (dx, 4.0, 4.0), 900 + k, rec, U=U, dtype=np.float64)
        for c in "uvw":
            dc = d[c] - d[c].mean()
            ms.append(np.mean((_record_of_row(_row(twin, c, 3, 4)) - dc) ** 2))
            tr = _record_of_row(_row(truth, c, 3, 4))
            ms_truth.append(np.mean((tr - tr.mean() - dc) ** 2))
    ms = np.array(ms)
    se = ms.std(ddof=1) / math.sqrt(ms.size)
    assert abs(ms.mean() - sig**2) < 4 * se + 0.01 * sig**2, (ms.mean(), sig**2, se)
    # The truth's own deviation has the same law (a check of the test itself).
    assert abs(np.mean(ms_truth) - sig**2) < 4 * np.std(ms_truth) / math.sqrt(len(ms_truth))


# ---------------------------------------------------------------------------
# away from the records: sigma^2 (1 - gamma^2)
# ---------------------------------------------------------------------------
def test_twin_ensemble_variance_follows_the_conditional_theory_with_separation():
    shape, sp = (256, 16, 16), (2.0, 2.0, 2.0)
    fs = U / sp[0]
    truth = generate_box(P, shape, sp, 77, dtype=np.float64)
    rng = np.random.default_rng(3)
    sig = 0.05
    rec = LineRecord((0.0, 16.0, 16.0), fs, {c: _record_of_row(_row(truth, c, 8, 8)) + rng.normal(0, sig, shape[0])
                                             for c in "uvw"}, noise_std=sig)
    targets = [(8, 8), (8, 9), (8, 10), (8, 12), (8, 15), (12, 8)]  # dz = 0, 2, 4, 8, 14 m; dy = 8 m
    th = conditional_variance(truth, rec, [(0.0, 2.0 * iy, 2.0 * iz) for iy, iz in targets], U=U)
    mean = conditional_mean(truth, rec, U=U)
    K = 24
    q = np.empty((K, len(targets), 3))
    for k in range(K):
        tw = conditioned_box(P, shape, sp, 40 + k, rec, U=U, dtype=np.float64)
        for it, (iy, iz) in enumerate(targets):
            for i, c in enumerate("uvw"):
                q[k, it, i] = np.mean((_row(tw, c, iy, iz) - _row(mean, c, iy, iz)) ** 2)
    emp, se = q.mean(axis=0), q.std(axis=0, ddof=1) / math.sqrt(K)
    assert np.all(np.abs(emp - th.posterior) < 4 * se), (emp, th.posterior, se)
    # The test discriminates: the spread grows from the noise level at the sensor towards the prior.
    ratio = th.posterior / th.prior
    assert np.all(ratio[0] < 0.05) and np.all(ratio[4] > 0.4) and np.all(np.diff(ratio[:5, 0]) > 0)
    # And per wavenumber: the coherence falls with k at 4 m; the twins' spectrum follows sigma^2 (1 - gamma^2).
    coh = th.coherence_ktc[:, 2, 0]
    assert coh[2] > 0.8 and coh[-20:].mean() < 0.3
    spec = np.zeros(shape[0] // 2 + 1)
    for k in range(4):
        tw = conditioned_box(P, shape, sp, 80 + k, rec, U=U, dtype=np.float64)
        a = np.fft.rfft(_row(tw, "u", 8, 10) - _row(mean, "u", 8, 10)) / shape[0]
        spec += np.abs(a) ** 2 / 4
    band = slice(1, 33)
    assert abs(spec[band].sum() / th.posterior_ktc[band, 2, 0].sum() - 1) < 4 / math.sqrt(4 * 32)


# ---------------------------------------------------------------------------
# against brute-force dense conditioning on a tiny grid (tests/reference.py)
# ---------------------------------------------------------------------------
TINY = (9, 5, 5)
TINY_SP = (2.0, 3.0, 3.0)


@pytest.fixture(scope="module")
def tiny():
    S = reference.conditioning_box_covariance(TINY, TINY_SP, P.alpha_eps, P.length_scale, P.gamma)
    tmpl = generate_box(P, TINY, TINY_SP, 0, correction="none", dtype=np.float64)
    return S, tmpl


def test_full_line_records_match_dense_conditioning(tiny):
    S, tmpl = tiny
    n = TINY[0]
    fs = U / TINY_SP[0]
    rng = np.random.default_rng(5)
    sensors = [((0.0, 3.0, 3.0), ("u", "v", "w"), 0.1), ((5.0, 7.5, 9.0), ("u",), 0.05)]  # the second off the nodes
    recs, rows, d, nv = [], [], [], []
    for pos, comps, sig in sensors:
        vals = {}
        for c in comps:
            v = rng.normal(0, 0.5, n)
            vals[c] = v - v.mean()
            for i in range(n):
                rows.append(reference.conditioning_trilinear_row(TINY, TINY_SP, (pos[0] - i * U / fs, pos[1], pos[2]),
                                                                 "uvw".index(c)))
            d.extend(vals[c])
            nv.extend([sig**2] * n)
        recs.append(LineRecord(pos, fs, vals, noise_std=sig))
    mean_ref, cov_ref = reference.conditioning_dense(S, np.array(rows), np.array(d), np.array(nv))
    got = conditional_mean(tmpl, recs, U=U)
    N = np.prod(TINY)
    # The box's tabulated tensor (lifetime to 3.6e-7, power to 1e-7, generate_box's notes) against the
    # reference's exact one, amplified by the solve: agreement to a few 1e-5.
    for i, c in enumerate("uvw"):
        np.testing.assert_allclose(_row(got, c).ravel(), mean_ref[i * N:(i + 1) * N], rtol=2e-4, atol=2e-6)
    targets = [(0.0, 3.0 * iy, 3.0 * iz) for iy in range(5) for iz in range(5)]
    th = conditional_variance(tmpl, recs, targets, U=U)
    post = np.diag(cov_ref).reshape(3, *TINY)[:, 0].reshape(3, -1).T  # x = 0 nodes; stationary in x
    np.testing.assert_allclose(th.posterior, post, rtol=2e-4)
    np.testing.assert_allclose(th.prior, np.diag(S).reshape(3, *TINY)[:, 0].reshape(3, -1).T, rtol=2e-6)


def test_scattered_points_match_dense_conditioning_mean_and_variance(tiny):
    S, tmpl = tiny
    rng = np.random.default_rng(8)
    pts = np.column_stack([rng.uniform(0, 18, 6), rng.uniform(0, 12, 6), rng.uniform(0, 12, 6)])
    sig = {"u": 0.05, "w": 0.1}
    vals = {c: rng.normal(0, 0.6, 6) for c in sig}
    pv = PointValues(pts, vals, noise_std=sig)
    Hm = np.array([reference.conditioning_trilinear_row(TINY, TINY_SP, p, "uvw".index(c)) for c in sig for p in pts])
    nv = np.concatenate([np.full(6, s**2) for s in sig.values()])
    mean_ref, cov_ref = reference.conditioning_dense(S, Hm, np.concatenate(list(vals.values())), nv)
    got = conditional_mean(tmpl, pv)
    N = np.prod(TINY)
    for i, c in enumerate("uvw"):
        np.testing.assert_allclose(_row(got, c).ravel(), mean_ref[i * N:(i + 1) * N], rtol=2e-4, atol=2e-6)
    targets = np.vstack([pts[:2], [[4.0, 6.0, 6.0], [10.5, 1.2, 11.0]]])
    th = conditional_variance(tmpl, pv, targets)
    T = np.array([[reference.conditioning_trilinear_row(TINY, TINY_SP, t, i) for i in range(3)] for t in targets])
    np.testing.assert_allclose(th.posterior, np.einsum("tim,mn,tin->ti", T, cov_ref, T), rtol=2e-4)
    # The twins scatter about the mean by the dense posterior covariance (the noise draw included).
    K = 60
    var_ref = np.diag(cov_ref).reshape(3, N)
    q = np.empty(K)
    zs = np.empty((K, 3, N))
    for k in range(K):
        tw = conditioned_box(P, TINY, TINY_SP, 10 + k, pv, correction="none", dtype=np.float64)
        zs[k] = np.array([(_row(tw, c) - _row(got, c)).ravel() for c in "uvw"])
        q[k] = np.mean(zs[k] ** 2 / var_ref)
    assert abs(q.mean() - 1) < 4 * q.std(ddof=1) / math.sqrt(K), q.mean()
    zbar = zs.mean(axis=0) / np.sqrt(var_ref / K)  # each ~ N(0, 1)
    assert abs(zbar.mean()) < 4 / math.sqrt(3 * N) * 3 and np.abs(zbar).max() < 5


# ---------------------------------------------------------------------------
# cups, reproducibility, bad input
# ---------------------------------------------------------------------------
def test_cup_record_is_reproduced_through_its_own_response():
    from cwlidar_sim.sensors.cup import Cup, cup_response, sample_cup

    shape, dx = (512, 8, 8), 1.0
    fs = U / dx
    truth = generate_box(P, shape, (dx, 4.0, 4.0), 31, dtype=np.float64)
    pos = (0.0, 12.0, 16.0)
    t = np.arange(shape[0]) / fs
    speed = sample_cup(truth, Cup(position=pos, distance_constant=2.3, rate=fs), t, U)
    sig_lin = float(np.var(_row(truth, "v"))) / math.sqrt(2.0) / U  # the linearisation error (module notes)

    def residual(rec):
        twin = conditioned_box(P, shape, (dx, 4.0, 4.0), 3, rec, U=U, dtype=np.float64)
        through = cup_response(U + _record_of_row(_row(twin, "u", 3, 4)), 1.0 / fs, 2.3, mean_speed=U)
        res = through - through.mean() - (speed - speed.mean())
        return np.sqrt(np.mean(res[20:] ** 2))  # past the cup's start-up (tau = 0.29 s = 2.3 samples)

    # Through the cup's response the twin reproduces the record within the stated (linearisation) noise,
    # and is not forced through it: without that noise in the model the residual would be ~0.05 sig_lin.
    r = residual(LineRecord(pos, fs, {"speed": speed}, distance_constant=2.3, name="cup"))
    assert 0.25 * sig_lin < r < 1.2 * sig_lin, (r, sig_lin)
    # Ignoring the response leaves the twin's u as filtered as the record: 3 sig_lin off.
    assert residual(LineRecord(pos, fs, {"speed": speed})) > 2 * sig_lin


def test_conditioned_fields_are_bit_reproducible_for_any_thread_count():
    shape, sp = (64, 8, 8), (2.0, 4.0, 4.0)
    rng = np.random.default_rng(0)
    recs = [LineRecord((0.0, 8.0, z), U / 2.0, {c: rng.normal(size=64) for c in "uvw"}, noise_std=0.1)
            for z in (8.0, 20.0)]
    old = _config.get_num_threads()
    try:
        _config.set_num_threads(1)
        a = conditioned_box(P, shape, sp, 5, recs, U=U)
        _config.set_num_threads(2)
        b = conditioned_box(P, shape, sp, 5, recs, U=U)
    finally:
        _config.set_num_threads(old)
    c = conditioned_box(P, shape, sp, 6, recs, U=U)
    base = generate_box(P, shape, sp, 5)
    for comp in "uvw":
        assert np.array_equal(a[comp].values, b[comp].values)
        assert not np.array_equal(a[comp].values, c[comp].values)
        assert not np.array_equal(a[comp].values, base[comp].values)
    assert a.attrs["conditioned"] == 1 and a.attrs["noise_seed"] == 5 and a.attrs["convection_speed"] == U


def test_bad_records_and_fields_are_refused_by_name():
    fs = 4.0
    good = {"u": np.ones(64) + np.arange(64) * 0.01}
    with pytest.raises(ValueError, match="values has keys"):
        LineRecord((0, 0, 0), fs, {"x": np.ones(64)})
    with pytest.raises(ValueError, match="non-finite"):
        LineRecord((0, 0, 0), fs, {"u": np.r_[np.ones(63), np.nan]})
    with pytest.raises(ValueError, match="length 64"):
        LineRecord((0, 0, 0), fs, {"u": np.ones(64), "v": np.ones(63)})
    with pytest.raises(ValueError, match="distance_constant"):
        LineRecord((0, 0, 0), fs, good, distance_constant=2.0)
    with pytest.raises(ValueError, match="noise_std"):
        LineRecord((0, 0, 0), fs, good, noise_std=-1.0)
    box = generate_box(P, (64, 8, 8), (2.0, 4.0, 4.0), 0)
    rec = LineRecord((0.0, 8.0, 8.0), fs, good, name="mast")
    with pytest.raises(ValueError, match=r"mast: the record spans U T .*dx = U T / Nx"):
        condition_field(box, rec, seed=0, U=U / 2)
    with pytest.raises(ValueError, match=r"mean speed is 0.* pass U"):
        condition_field(box, LineRecord((0.0, 8.0, 8.0), fs, {"u": np.sin(np.arange(64.0))}), seed=0)
    with pytest.raises(ValueError, match="z = 40 m is outside"):
        condition_field(box, LineRecord((0.0, 8.0, 40.0), fs, good), seed=0, U=U)
    with pytest.raises(ValueError, match="mixes PointValues"):
        condition_field(box, [rec, PointValues([[0, 8, 8]], {"u": [1.0]})], seed=0, U=U)
    twin = condition_field(box, rec, seed=0, U=U)
    with pytest.raises(ValueError, match="already conditioned"):
        condition_field(twin, rec, seed=1, U=U)
    with pytest.raises(ValueError, match="sigma_u"):
        condition_field(generate_box(P, (64, 8, 8), (2.0, 4.0, 4.0), 0, sigma_u=1.0), rec, seed=0, U=U)
    line = generate_line(P, 64, 2.0, 0)
    with pytest.raises(ValueError, match="use a plane or box"):
        condition_field(line, LineRecord((0.0, 3.0, 0.0), fs, good), seed=0, U=U)
    assert twin_spacing(rec, 64, U=U) == pytest.approx(2.0)
