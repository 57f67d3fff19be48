"""The one signal chain: what every sensor gets from it, tested through the chain and through both lidars.

* looks: the continuum model of an estimate whose M blocks come in n_looks disjoint looks is the looks'
  M / n_looks-block averages combined as independent; identical looks must give the one-look answer;
* processing variants: a variant is the same spectra processed otherwise, so a variant with estimator X
  is bit for bit the run whose instrument uses X (same seed), for the staring and the conical lidar;
* clouds: a staring beam that rises reaches a cloud layer (tier 1: the power-weighted mean; tier 2: a
  second line of the expected relative power); a horizontal beam never does;
* continuum speckle and variants in a conical scan; the chain's invariance to ``chunk``.
"""

import math

import numpy as np
import pytest

from cwlidar_sim.sensors import ConicalLidar, StaringLidar, measure_conical, measure_staring
from cwlidar_sim.signal import CS_SERIES, PROTOTYPE_2003, Flag
from cwlidar_sim.signal.chain import ChainSettings, FocusGroup, run_chain
from cwlidar_sim.signal.spectral import continuum_moments

import xarray as xr


def uniform_line(speed_u=0.0, n=4096, dx=0.5, dtype=np.float64):
    """A field of zero fluctuations along x (a line), so every cell sees the mean wind exactly."""
    x = np.arange(n) * dx - 0.5 * n * dx
    z = np.zeros(n, dtype=dtype)
    return xr.Dataset({c: (("x",), z + (speed_u if c == "u" else 0.0)) for c in "uvw"}, coords={"x": x},
                      attrs={"y": 0.0, "z": 0.0})


def calm_box(lidar, U=0.0, d=4.0):
    """A box of zero fluctuations holding a conical lidar's cone."""
    ext = max(lidar.beam_extent(z)["radius"] for z in lidar.heights) + 2 * d
    top = max(lidar.beam_extent(z)["z_hi"] for z in lidar.heights) + 2 * d
    x = np.arange(-ext - 200.0, ext + 200.0, d)
    y = np.arange(-ext, ext + d, d)
    zz = np.arange(-d, top + d, d)
    shape = (x.size, y.size, zz.size)
    return xr.Dataset({c: (("x", "y", "z"), np.zeros(shape)) for c in "uvw"}, coords={"x": x, "y": y, "z": zz})


def test_identical_looks_give_the_one_look_continuum_moments():
    inst = CS_SERIES.replace(rin_level=0.0, reflection_level=0.0)
    rng = np.random.default_rng(1)
    v = 6.0 + 0.3 * rng.standard_normal((5, 20))
    w = np.full(20, 1 / 20)
    one = continuum_moments(inst, v, w, -12.0, 0.12, correlation_time=1e-5)
    out = {}

    def sample(lo, hi, nl):
        return np.repeat(v[lo:hi, None, :], nl, axis=1), v[lo:hi] @ w, None

    for nl in (1, 8):
        g = FocusGroup(instrument=inst, index_e=np.arange(5), time_e=np.arange(5) * 0.02, weight_s=w, n_looks=nl,
                       sample=lambda lo, hi, nl=nl: sample(lo, hi, nl), seed=np.random.SeedSequence(3),
                       transverse_speed=300.0, subcell_spread=0.12)
        out[nl] = run_chain(ChainSettings(tier="spectral", cnr_db=-12.0, speckle="continuum"), [g], 5)
    # the moments: mean exactly, variance to the (1 - j / M) weights of the kept block lags (J / M' < 4 %)
    look = inst.replace(blocks_per_estimate=inst.blocks_per_estimate // 8)
    m8, v8, _ = continuum_moments(look, v, w, -12.0, 0.12, correlation_time=1e-5)
    np.testing.assert_allclose(m8, one[0], rtol=1e-12)
    np.testing.assert_allclose(v8 / 8, one[1], rtol=0.04)
    # and the chain's estimates from them agree to their own scatter (the same counter-based draws)
    np.testing.assert_allclose(out[8].speed_e, out[1].speed_e, atol=3 * inst.bin_speed)


def test_a_variant_is_the_same_spectra_processed_otherwise_staring_and_conical():
    field = uniform_line(0.4)
    lid = StaringLidar(position=(float(field.x[-1]) - 200.0, 0.0, 0.0), azimuth_deg=180.0, cell_length=2.0,
                       transverse_speed=1.0)
    t = (np.arange(300) + 0.5) / 50.0
    base = measure_staring(field, lid, t, 7.0, 5, variants=[{"name": "c", "estimator": "centroid"},
                                                           {"name": "r", "threshold_raise_percent": 20.0}])
    as_c = measure_staring(field, lid.replace(instrument=lid.instrument.replace(estimator="centroid")), t, 7.0, 5)
    np.testing.assert_array_equal(base.variants["c"][0], as_c.speed_e)
    np.testing.assert_array_equal(base.variants["c"][1], as_c.flags_e)
    assert not np.array_equal(base.variants["r"][0], base.speed_e)
    con = ConicalLidar(heights=(40.0,), tier="spectral", cell_length=4.0, speckle="continuum", subcell_spread=0.1)
    box = calm_box(con)
    rec = measure_conical(box, con, 2.0, 8.0, 4, variants=[{"name": "m", "estimator": "median"},
                                                            {"name": "r", "threshold_raise_percent": 20.0}])
    as_m = measure_conical(box, con.replace(instrument=con.instrument.replace(estimator="median")), 2.0, 8.0, 4)
    np.testing.assert_array_equal(rec.variants["m"][0], as_m.speed_e)
    np.testing.assert_array_equal(rec.variants["m"][1], as_m.flags_e)
    assert set(rec.info["variant_availability"]) == {"m", "r"}
    # a raised threshold can only remove bins: more of the zero crossings are lost, never fewer
    lost = lambda s: np.count_nonzero(~np.isfinite(s))  # noqa: E731
    assert lost(rec.variants["r"][0]) >= lost(rec.speed_e)


def test_conical_continuum_speckle_tracks_the_looks():
    # uniform wind, the continuum model with a sub-cell spread: far from the zero crossings every estimate
    # is the mean of its looks' |v_r| to the centroid's bias and scatter (the same bound as the point-cell
    # model's, tests/sensors/test_conical.py), and the scatter about it is the estimator noise of M_eff looks
    U = 10.0
    out = {}
    for speckle in ("continuum", "independent"):
        lid = ConicalLidar(heights=(40.0,), tier="spectral", cell_length=4.0, speckle=speckle, subcell_spread=0.1)
        rec = measure_conical(calm_box(lid), lid, 4.0, U, seed=2)
        far = np.abs(np.cos(np.radians(rec.azimuth_e))) > 0.5
        truth = np.abs(rec.vlos_e)
        out[speckle] = rec.speed_e[far] - truth[far]
        assert rec.info["heights"][40.0]["speckle"] == speckle
        assert np.all(np.isfinite(rec.speed_e[far]))
    assert abs(out["continuum"].mean()) < 0.03 and out["continuum"].std() < 0.05
    # both speckle models of a fast-scanning spot hold thousands of looks: scatters of one order
    assert 0.3 < out["continuum"].std() / out["independent"].std() < 3.0


def test_a_rising_staring_beam_reaches_a_cloud_and_a_horizontal_one_never():
    # a staring beam at 30 deg elevation, a cloud layer 1200 m above it moving at 12 m/s along the beam's
    # azimuth: the cloud's weight is cloud_strength * int phi over its ranges, and tier 1 returns the
    # power-weighted mean of aerosol and cloud radial speeds
    el = 30.0
    n_z = math.sin(math.radians(el))
    kw = dict(cloud_base=1200.0, cloud_strength=3e4, cloud_speed=12.0, cloud_direction_deg=180.0,
              position=(0.0, 0.0, 0.0), azimuth_deg=180.0, cell_length=2.0, transverse_speed=1.0)
    up = StaringLidar(elevation_deg=el, tier="los", **kw)
    flat = StaringLidar(elevation_deg=0.0, tier="los", **kw)
    assert flat.cloud_weight() == 0.0
    from cwlidar_sim.beam.cells import interval_weight

    opt = up.instrument.optics()
    wc = 3e4 * interval_weight(opt, "exact", 1200.0 / n_z - 67.5, 1230.0 / n_z - 67.5)
    assert up.cloud_weight() == pytest.approx(wc, rel=1e-12)
    # a box is needed for a rising beam: a calm one, 0 m/s wind, the aerosol at rest
    x = np.arange(-110.0, 10.0, 2.0)
    zz = np.arange(-2.0, 100.0, 2.0)
    box = xr.Dataset({c: (("x", "y", "z"), np.zeros((x.size, 3, zz.size))) for c in "uvw"},
                     coords={"x": x, "y": [-2.0, 0.0, 2.0], "z": zz})
    t = (np.arange(50) + 0.5) / 50.0
    rec = measure_staring(box, up, t, 0.0, None)
    v_cloud = 12.0 * math.cos(math.radians(el))  # the cloud moves along the beam's azimuth: away from the lidar
    np.testing.assert_allclose(rec.vlos_e, 0.0, atol=1e-12)  # the ideal stays the aerosol's
    np.testing.assert_allclose(rec.speed_e, wc * v_cloud / (1 + wc), rtol=1e-12)
    assert rec.info["cloud_fraction"] == pytest.approx(wc / (1 + wc))
    # tier 2: the spectrum holds a second line at the cloud's radial speed (10.4 m/s) carrying w_c / (1 + w_c)
    # (0.3-0.5) of the power, the aerosol's at 5 m/s the rest; the median lies in the stronger aerosol line
    # (within 2 bins of its centre: it splits the aerosol line at its 0.5 (1 + w_c) quantile) and the cloud's
    # group of bins, above second_peak_fraction = 0.2 of the aerosol's, raises SECOND_PEAK
    U = -5.0 / math.cos(math.radians(el))  # the wind toward -x: the aerosol moves away from the lidar at 5 m/s
    sp = measure_staring(box, up.replace(tier="spectral", speckle="independent"), t, U, 7)
    assert 0.2 < wc < 1.0
    assert abs(np.nanmedian(sp.speed_e) - 5.0) < 2 * PROTOTYPE_2003.bin_speed
    assert np.count_nonzero(sp.flags_e & np.uint8(Flag.SECOND_PEAK)) > 0.9 * t.size
    clear = measure_staring(box, flat.replace(tier="spectral", speckle="independent"), t, -5.0, 7)
    assert np.count_nonzero(clear.flags_e & np.uint8(Flag.SECOND_PEAK)) == 0


def test_chunk_and_thread_count_do_not_change_a_bit():
    field = uniform_line(0.3)
    lid = StaringLidar(position=(float(field.x[-1]) - 200.0, 0.0, 0.0), azimuth_deg=180.0, cell_length=2.0,
                       transverse_speed=1.0, speckle="independent")
    t = (np.arange(700) + 0.5) / 50.0
    a = measure_staring(field, lid, t, 7.0, 9, chunk=4096)
    b = measure_staring(field, lid, t, 7.0, 9, chunk=97)
    np.testing.assert_array_equal(a.speed_e, b.speed_e)
    con = ConicalLidar(heights=(40.0, 60.0), tier="spectral", cell_length=4.0, revs_per_height=1)
    box = calm_box(con)
    c = measure_conical(box, con, 4.0, 8.0, 4, chunk=4096)
    d = measure_conical(box, con, 4.0, 8.0, 4, chunk=33)
    np.testing.assert_array_equal(c.speed_e, d.speed_e)


def test_line_broadening_is_a_speed_spread_of_lambda_over_two_in_quadrature():
    # the chain's continuum spread is sqrt(subcell^2 + (lambda lb / 2)^2): a lidar with line broadening lb and
    # sub-cell spread s is, bit for bit, the lidar with spread sqrt(s^2 + dv^2) and no broadening
    field = uniform_line(0.3)
    base = StaringLidar(position=(float(field.x[-1]) - 200.0, 0.0, 0.0), azimuth_deg=180.0, cell_length=2.0,
                        transverse_speed=1.0, subcell_spread=0.05)
    t = (np.arange(200) + 0.5) / 50.0
    lb = 2.0e5
    dv = 0.5 * base.instrument.wavelength * lb
    a = measure_staring(field, base.replace(line_broadening=lb), t, 7.0, 3)
    b = measure_staring(field, base.replace(subcell_spread=math.sqrt(0.05 * 0.05 + dv * dv)), t, 7.0, 3)
    np.testing.assert_array_equal(a.speed_e, b.speed_e)
    assert a.info["subcell_spread"] == pytest.approx(math.hypot(0.05, dv), rel=1e-15)
    c = measure_staring(field, base, t, 7.0, 3)
    assert not np.array_equal(a.speed_e, c.speed_e)
    with pytest.raises(ValueError, match="line_broadening"):
        base.replace(line_broadening=-1.0)
