"""Conically scanning lidar: scan validation, sweep within the dwell, homodyne zero crossing, kernels, tier 2."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis.vad import fit_record
from cwlidar_sim.sensors.conical import (
    FOCUS_RANGE,
    ConicalLidar,
    measure_conical,
)
from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters
from cwlidar_sim.signal import CS_SERIES, Flag
from cwlidar_sim.turbulence import MannParameters
from cwlidar_sim.turbulence.cover import cover_box

PHI = math.radians(30.0)


def calm_box(lidar, value=(0.0, 0.0, 0.0), d=4.0, nx=64):
    """A constant-fluctuation box covering the lidar's cells."""
    ext = [lidar.beam_extent(z) for z in lidar.heights]
    R = max(e["radius"] for e in ext) + 2 * d
    z0, z1 = min(e["z_lo"] for e in ext) - d, max(e["z_hi"] for e in ext) + d
    y = np.arange(-R, R + d, d)
    z = np.arange(z0, z1 + d, d)
    shape = (nx, y.size, z.size)
    data = {c: (("x", "y", "z"), np.full(shape, val)) for c, val in zip("uvw", value)}
    return xr.Dataset(data, coords={"x": d * np.arange(nx), "y": y, "z": z})


def dirichlet(n_sub, dwell_rad):
    """Mean of cos(theta + delta_j) / cos(theta) over the n_sub look offsets of a dwell."""
    h = dwell_rad / n_sub
    return math.sin(n_sub * h / 2) / (n_sub * math.sin(h / 2))


# ---------------------------------------------------------------------------
# parameters
# ---------------------------------------------------------------------------
def test_scan_parameters_validation_and_geometry():
    lid = ConicalLidar(heights=(40.0, 100.0), revs_per_height=3, refocus_time=0.5)
    assert ConicalLidar.from_dict(lid.as_dict()) == lid
    assert lid.dwell_time == pytest.approx(0.02) and lid.dwell_angle_deg == pytest.approx(7.2)
    assert lid.focus(100.0) == pytest.approx(100.0 / math.cos(PHI))
    assert lid.circle_diameter(100.0) == pytest.approx(2 * 100.0 * math.tan(PHI))  # 115.5 m
    # the spot moves at 2 pi r sin Phi per revolution: over 300 m/s at 100 m (the number)
    assert lid.spot_speed(100.0) == pytest.approx(2 * math.pi * 115.47 * 0.5, rel=1e-4)
    assert lid.spot_speed(100.0) > 300.0
    # thousands of looks: tau_c = w0 / v_spot is a few blocks, M_eff ~ M / (1 + 2 r / (1 - r))
    tau = lid.speckle_time(100.0)
    inst = CS_SERIES
    r = math.exp(-2 * inst.block_duration / tau)
    assert lid.speckle_looks(100.0) == pytest.approx(4000 / (1 + 2 * r / (1 - r)), rel=2e-3)
    assert lid.speckle_looks(100.0) > 1000
    assert lid.speckle_looks(40.0) == pytest.approx(lid.speckle_looks(100.0), rel=1e-9)  # w0, v_spot both ~ r
    with pytest.raises(ValueError, match="half_angle_deg=5.0 is out of range"):
        ConicalLidar(half_angle_deg=5.0)
    with pytest.raises(ValueError, match="half_angle_deg=75 is out of range"):
        ConicalLidar(half_angle_deg=75)
    lo = FOCUS_RANGE[0] * math.cos(PHI)
    with pytest.raises(ValueError, match=r"heights\[1\]=5.0 m needs focus .* allowed heights: \[8.66"):
        ConicalLidar(heights=(40.0, 5.0))
    ConicalLidar(heights=(lo + 1e-9,))
    with pytest.raises(ValueError, match="revolution_time=0"):
        ConicalLidar(revolution_time=0)
    with pytest.raises(ValueError, match="estimates_per_rev=0"):
        ConicalLidar(estimates_per_rev=0)
    with pytest.raises(ValueError, match="revs_per_height=0"):
        ConicalLidar(revs_per_height=0)
    with pytest.raises(ValueError, match="blocks_per_estimate=4000 does not fit"):
        ConicalLidar(estimates_per_rev=100)
    with pytest.raises(ValueError, match="unknown key.*'cone'"):
        ConicalLidar.from_dict({"cone": 30})
    with pytest.raises(ValueError, match="tier='heterodyne'"):
        ConicalLidar(tier="heterodyne")
    with pytest.raises(ValueError, match="sub_dwells=3 to divide"):
        ConicalLidar(tier="signal", sub_dwells=3)
    with pytest.raises(ValueError, match="duration=0.5 s holds no revolution"):
        ConicalLidar().schedule(0.5)


def test_schedule_dwell_and_cycle():
    s = ConicalLidar(heights=(60.0,)).schedule(3.0)
    assert s.time_e.size == 150
    np.testing.assert_allclose(s.time_e[:2], [0.01, 0.03])
    np.testing.assert_allclose(np.diff(s.azimuth_e), 7.2)
    assert np.all(s.revolution_e == np.repeat(np.arange(3), 50))
    # cycle through 3 heights, 1 revolution each, 0.5 s lost refocusing: 4 blocks in 5.5 s
    c = ConicalLidar(heights=(40.0, 60.0, 80.0), refocus_time=0.5).schedule(5.5)
    assert c.time_e.size == 4 * 50
    assert list(c.focus_index_e[::50]) == [0, 1, 2, 0]
    np.testing.assert_allclose(c.time_e[50], 1.5 + 0.01)  # after the refocus gap
    np.testing.assert_allclose(c.azimuth_e[50], 360.0 * 1.51)  # the scanner kept turning


# ---------------------------------------------------------------------------
# uniform flow: the sweep within the dwell, the zero crossing
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("n_sub", [1, 8])
def test_uniform_flow_sweep_average_and_zero_crossing(n_sub):
    U = 10.0
    lid = ConicalLidar(heights=(60.0,), sub_dwells=n_sub, cell_length=4.0)
    rec = measure_conical(calm_box(lid), lid, 2.0, U)
    # each look sees n.(U,0,0) in every cell and in the tail: the dwell mean of U sin Phi cos(theta)
    want = U * math.sin(PHI) * np.cos(np.radians(rec.azimuth_e)) * dirichlet(n_sub, math.radians(7.2))
    np.testing.assert_allclose(rec.vlos_e, want, rtol=0, atol=1e-12)
    # homodyne: |v|; below the blind zone NaN (NO_SIGNAL | NEAR_ZERO), just above it flagged NEAR_ZERO
    inst = lid.instrument
    a = np.abs(want)
    low = a < inst.blind_zone_speed
    near = (a >= inst.blind_zone_speed) & (a < inst.blind_zone_speed + inst.edge_guard_speed)
    # dwell centres at 3.6 + 7.2 j deg, A = 5 m/s: |cos| < 0.1 only at 90 deg itself, 0.1..0.2 at 82.8 and
    # 97.2 deg (|cos| 0.125): per crossing one lost and two flagged points, 2 crossings/rev, 2 revolutions
    assert low.sum() == 4 and near.sum() == 8
    assert np.all(np.isnan(rec.speed_e[low]))
    assert np.all(rec.flags_e[low] & Flag.NO_SIGNAL) and np.all(rec.flags_e[low] & Flag.NEAR_ZERO)
    assert np.all(rec.flags_e[near] & Flag.NEAR_ZERO) and not np.any(rec.flags_e[near] & Flag.NO_SIGNAL)
    np.testing.assert_allclose(rec.speed_e[~low], a[~low], rtol=0, atol=1e-12)
    # the fit sees the sweep's attenuation of the cosine, nothing else; TP = 0
    fit = fit_record(rec, 60.0, 1, reference_deg=0.0)
    np.testing.assert_allclose(fit.speed_p, U * dirichlet(n_sub, math.radians(7.2)), rtol=1e-12)
    np.testing.assert_allclose(fit.direction_p, 0.0, atol=1e-9)
    assert np.all(fit.tp_p < 1e-12)
    assert np.all(fit.n_used_p == 50 - (low | near).reshape(2, 50).sum(axis=1))


@pytest.mark.parametrize("growth", [0.0, 0.3])
def test_scan_kernel_matches_reference(growth):
    """The one line-of-sight kernel (BeamSampler) against plain-Python point sampling: cells, sub-points, tail."""
    from reference import beam_sample_points

    from cwlidar_sim.sensors import BeamSampler

    lid = ConicalLidar(heights=(40.0,), cell_length=3.0, span=8.0, cell_growth=growth)
    box = calm_box(lid, d=3.0, nx=40)
    rng = np.random.default_rng(3)
    for c in "uvw":
        box[c].values[...] = rng.standard_normal(box[c].shape)
    cells = lid.cells(40.0)
    assert (cells.sub_j.size > cells.n_cells) == (growth > 0)
    sampler = BeamSampler(box, np.zeros(3), lid.focus(40.0), cells, 7.0, False)
    range_j = np.maximum(lid.focus(40.0) + cells.sub_j, 0.0)
    t_l = np.linspace(0.0, 2.0, 17)
    n_lc = lid.direction(np.linspace(0.0, 400.0, 17))
    vl_ls, vl_l = sampler.sample(t_l, n_lc)
    _, ref_p = beam_sample_points(sampler.fld.u, sampler.fld.v, sampler.fld.w, sampler.fld.grid, False, np.zeros(3),
                                  n_lc, range_j, t_l, 7.0, True)
    # a cell's speed is its sub-points' weighting-weighted mean
    ref = np.stack([ref_p[:, cells.ptr_s[s]:cells.ptr_s[s + 1]] @ cells.fraction_j[cells.ptr_s[s]:cells.ptr_s[s + 1]]
                    for s in range(cells.n_cells)], axis=1)
    np.testing.assert_allclose(vl_ls[:, :-1], ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(vl_ls[:, -1], 7.0 * n_lc[:, 0], rtol=1e-15)
    np.testing.assert_allclose(vl_l, ref @ cells.weight_s + cells.truncated_fraction * 7.0 * n_lc[:, 0],
                               rtol=1e-12, atol=1e-12)
    # tier 1 is the same sum as equal cells of the base length: growth regroups the sub-points, nothing else
    w_p = cells.fraction_j * np.repeat(cells.weight_s, np.diff(cells.ptr_s))
    np.testing.assert_allclose(vl_l, ref_p @ w_p + cells.truncated_fraction * 7.0 * n_lc[:, 0], rtol=1e-12, atol=1e-12)


def test_field_must_hold_the_cone():
    lid = ConicalLidar(heights=(100.0,))
    small = calm_box(ConicalLidar(heights=(40.0,)))
    with pytest.raises(ValueError, match="beam leaves the field"):
        measure_conical(small, lid, 1.0, 10.0)


# ---------------------------------------------------------------------------
# tier 2 in frozen uniform flow: TP is the estimator's noise, nothing more
# ---------------------------------------------------------------------------
def test_spectral_tier_uniform_flow_tp_is_estimator_noise():
    U = 10.0
    lid = ConicalLidar(heights=(40.0,), tier="spectral", cell_length=4.0, sub_dwells=4)
    rec = measure_conical(calm_box(lid), lid, 4.0, U, seed=11)
    rec2 = measure_conical(calm_box(lid), lid, 4.0, U, seed=11)
    np.testing.assert_array_equal(rec.speed_e, rec2.speed_e)
    fit = fit_record(rec, 40.0, 1, reference_deg=0.0)
    ok = np.isfinite(rec.speed_e) & ((rec.flags_e & (Flag.NEAR_ZERO | Flag.NO_SIGNAL)) == 0)
    err = rec.speed_e[ok] - np.abs(rec.vlos_e[ok])
    # thousands of speckle looks: the centroid scatters by well under a bin (0.155 m/s)
    assert np.std(err) < 0.05
    # the fit absorbs the mean error into B; what is left is the estimator's scatter
    n = ok.sum()
    rv = np.nansum(fit.residual_var_p * (fit.n_used_p - 3)) / (n - 3 * fit.n)
    sd = np.var(err, ddof=1)
    assert rv == pytest.approx(sd, rel=4 * math.sqrt(2 / n))  # 4 sigma of a variance from n points
    assert np.all(fit.tp_p < 0.01)
    np.testing.assert_allclose(fit.speed_p, U * dirichlet(4, math.radians(7.2)), rtol=1e-3)


def test_cover_box_of_a_cone_lateral_doubling_and_extent():
    lid = ConicalLidar(heights=(40.0,), cell_length=4.0)
    p = MannParameters.iec(40.0, 1.0)
    f1 = cover_box(lid.box_region(4.0), 5.0, 30.0, p, 4, spacing=4.0, lateral_doubling=True)
    f0 = cover_box(lid.box_region(4.0), 5.0, 30.0, p, 4, spacing=4.0, lateral_doubling=False)
    assert f1.sizes == f0.sizes
    assert f1.attrs["generated_shape"][1] == 2 * f1.sizes["y"]
    assert f1.attrs["period_x"] >= 5.0 * 30.0 + lid.circle_diameter(40.0)
    rec = measure_conical(f1, lid, 30.0, 5.0)  # holds the whole cone: no estimate lost outside the box
    assert np.isfinite(rec.speed_e).mean() > 0.8
    params, su, us = surface_layer_parameters(40.0, 10.0)
    assert us == pytest.approx(0.4 * 10.0 / math.log(40.0 / 0.01))
    assert params.length_scale == pytest.approx(0.59 * 40.0)
    assert params.alpha_eps == pytest.approx(3.2 * us**2 / 40 ** (2 / 3))
    # Mann (1994) fitted Kaimal's spectra: sigma_u^2 close to Kaimal's 102 / 33 * 3 / 2 = 4.64 u*^2
    assert su / us == pytest.approx(math.sqrt(102 / 33 * 1.5), rel=0.05)
    p2, su2, _ = surface_layer_parameters(40.0, 10.0, source="iec")
    assert su2 == pytest.approx(2.4 * us) and p2.length_scale == pytest.approx(0.56 * 40.0)


# Scatter from 12 seeds (one revolution of tier 3, 20 s of tier 2): tier 3's estimates scatter by 0.0116 m/s
# about the mean of the looks and its one-revolution fit by 0.0076 m/s about a bias of 0.009; tier 2's fit
# has the centroid's bias 0.0106 +- 0.0006 and its estimates scatter by 0.0076 m/s.  The bounds are the
# bias allowance plus 4 standard deviations (per estimate) and 3 (the fit).
@pytest.mark.parametrize("tier, duration, est_atol, fit_scatter", [("spectral", 20.0, 0.03, 0.0),
                                                                   ("signal", 1.0, 4 * 0.0116, 3 * 0.0076)])
def test_tiers_2_and_3_follow_the_sweep_within_a_wide_dwell(tier, duration, est_atol, fit_scatter):
    # 10 estimates per revolution: each dwell sweeps 36 deg, and the averaged spectrum's centroid is the mean
    # of the looks' |v_r| where no look comes near the blind zone (dwells centred at |cos| > 0.5): A is cut by
    # the Dirichlet factor 0.984.  (Dwells reaching the
    # blind zone are biased high: the centroid loses the spectrum below blind_zone_speed.)
    from cwlidar_sim.analysis.vad import fit_rectified_cosine, scan_arrays

    U = 10.0
    lid = ConicalLidar(heights=(40.0,), tier=tier, cell_length=4.0, sub_dwells=8, estimates_per_rev=10,
                       azimuth0_deg=-18.0)
    rec = measure_conical(calm_box(lid), lid, duration, U, seed=2)
    d8 = dirichlet(8, math.radians(36.0))
    far = np.abs(np.cos(np.radians(rec.azimuth_e))) > 0.5
    assert far.sum() == 6 * duration and np.all(rec.flags_e[far] == 0)
    mean_abs = U * math.sin(PHI) * np.abs(np.cos(np.radians(rec.azimuth_e))) * d8
    np.testing.assert_allclose(rec.speed_e[far], mean_abs[far], rtol=0, atol=est_atol)
    az, sp, ok = (scan_arrays(a, rec.revolution_e, 1) for a in (rec.azimuth_e, rec.speed_e, far))
    fit = fit_rectified_cosine(az, sp, 30.0, valid=ok, reference_deg=0.0, min_points=5)
    # the sweep's 1.6 % dominates: the centroid's own bias (its threshold subtraction weighs the dense,
    # high-speed end of a swept line) is a tenth of it
    assert abs(np.mean(fit.speed_p) - U * d8) < 0.1 * U * (1 - d8) + fit_scatter


def test_cycle_through_heights():
    U = 6.0
    lid = ConicalLidar(heights=(40.0, 60.0), refocus_time=0.2, cell_length=4.0)
    rec = measure_conical(calm_box(lid), lid, 4.6, U)  # 4 blocks of 1 s and 3 refocus gaps of 0.2 s
    assert rec.time_e.size == 200 and set(rec.height_e) == {40.0, 60.0}
    for z in (40.0, 60.0):
        sel = rec.select(z)
        assert sel["time_e"].size == 100
        want = U * math.sin(PHI) * np.cos(np.radians(sel["azimuth_e"])) * dirichlet(8, math.radians(7.2))
        np.testing.assert_allclose(sel["vlos_e"], want, atol=1e-12)
        assert fit_record(rec, z, 1, reference_deg=0.0).n == 2
    assert rec.info["heights"][60.0]["focus"] == pytest.approx(60.0 / math.cos(PHI))


def test_spectral_tier_bits_do_not_depend_on_threads():
    from cwlidar_sim import _config

    lid = ConicalLidar(heights=(40.0,), tier="spectral", cell_length=4.0, sub_dwells=2)
    box = calm_box(lid)
    rng = np.random.default_rng(9)
    for c in "uvw":
        box[c].values[...] = 0.5 * rng.standard_normal(box[c].shape)
    old = _config.get_num_threads()
    out = []
    try:
        for nth in (1, 2):
            _config.set_num_threads(nth)
            out.append(measure_conical(box, lid, 1.0, 6.0, seed=4, wrap=True))
    finally:
        _config.set_num_threads(old)
    np.testing.assert_array_equal(out[0].speed_e, out[1].speed_e)
    np.testing.assert_array_equal(out[0].vlos_e, out[1].vlos_e)
    np.testing.assert_array_equal(out[0].flags_e, out[1].flags_e)


def test_cover_box_of_one_extent_is_one_realisation_on_two_grids():
    # A fixed physical size makes boxes of two spacings one realisation (their shared Fourier
    # coefficients equal to round-off) placed at the same physical points: what a paired study of
    # the spacing needs.  Without doubling the kept box is the whole periodic box.
    lid = ConicalLidar(heights=(40.0,), cell_length=4.0)
    p = MannParameters.iec(40.0, 1.0)
    ext = (480.0, 96.0, 72.0)
    kw = dict(lateral_doubling=False, extent=ext, dtype=np.float64)
    c = cover_box(lid.box_region((8.0, 6.0, 6.0)), 5.0, 30.0, p, 4, spacing=(8.0, 6.0, 6.0), **kw)
    f = cover_box(lid.box_region((4.0, 3.0, 3.0)), 5.0, 30.0, p, 4, spacing=(4.0, 3.0, 3.0), **kw)
    assert c.u.shape == (60, 16, 12) and f.u.shape == (120, 32, 24)
    for ax in "xyz":  # every coarse point is a fine point
        np.testing.assert_allclose(f[ax].values[::2], c[ax].values, atol=1e-9)
    sc, sf = c.u.shape, f.u.shape
    idx = [np.arange(-((n - 1) // 2), (n + 1) // 2) for n in sc[:2]] + [np.arange((sc[2] + 1) // 2)]
    g = np.meshgrid(*idx, indexing="ij")
    for comp in "uvw":
        a = np.fft.rfftn(c[comp].values) / c[comp].size
        b = np.fft.rfftn(f[comp].values) / f[comp].size
        x = a[g[0] % sc[0], g[1] % sc[1], g[2]]
        y = b[g[0] % sf[0], g[1] % sf[1], g[2]]
        assert np.abs(x - y).max() < 1e-12 * math.sqrt(np.mean(np.abs(x) ** 2))
    # the default sizing of the same spacings is another realisation
    d = cover_box(lid.box_region((8.0, 6.0, 6.0)), 5.0, 30.0, p, 4, spacing=(8.0, 6.0, 6.0), lateral_doubling=False,
                  dtype=np.float64)
    assert d.u.shape != c.u.shape
    with pytest.raises(ValueError, match=r"extent\[0\]"):
        cover_box(lid.box_region(8.0), 5.0, 30.0, p, 4, spacing=8.0, extent=(100.0, 96.0, 72.0))
    hf = cover_box(lid.box_region((8.0, 6.0, 6.0)), 5.0, 30.0, p, 4, spacing=(8.0, 6.0, 6.0), hf_compensation=True,
                   **kw)
    assert hf.attrs["hf_compensation"] == 1 and float(hf.u.var()) > float(c.u.var())
