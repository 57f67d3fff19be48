"""Staring lidar records through tiers 1-3: uniform winds, turbulence, failures, reproducibility, variants."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim import _config
from cwlidar_sim.beam import sample_los
from cwlidar_sim.sensors import StaringLidar, measure_staring
from cwlidar_sim.signal.chain import DRAW_BLOCK, SIGNAL_MAX_ESTIMATES
from cwlidar_sim.signal import FAIL_FLAGS, PROTOTYPE_2003, Flag
from cwlidar_sim.signal.processing import SUSPECT_FLAGS
from cwlidar_sim.turbulence import MannParameters, generate_line

import reference  # noqa: E402

P = PROTOTYPE_2003
U = 8.0
RATE = P.estimate_rate


@pytest.fixture(scope="module")
def field():
    # 2048 m periodic line at 0.5 m (IEC Mann parameters above 60 m, sigma_u = 1.5 m/s)
    return generate_line(MannParameters.iec(100.0, 1.5), 4096, 0.5, 2)


def calm(n=4096, dx=0.5):
    z = np.zeros(n)
    return xr.Dataset({"u": ("x", z), "v": ("x", z), "w": ("x", z)}, coords={"x": dx * np.arange(n)})


def times(n, dt=1 / RATE):
    return np.arange(n) * dt


# ---------------------------------------------------------------------------
# parameters
# ---------------------------------------------------------------------------
def test_lidar_parameters_round_trip_and_validation():
    lid = StaringLidar(position=(1.0, 2.0, 3.0), azimuth_deg=180.0, tier="los", cnr_db=-20.0, transverse_speed=0.7)
    assert StaringLidar.from_dict(lid.as_dict()) == lid
    d = StaringLidar.from_dict({"instrument": {"preset": "prototype_2003", "threshold_raise_percent": 10}})
    assert d.instrument == P.replace(threshold_raise_percent=10)
    assert StaringLidar.from_dict({"instrument": {"preset": "cs"}}).instrument.estimator == "centroid"
    # the default cells: [max(-20 zR, -r), 20 zR] cut into ceil(length / 0.5 m) cells (exact weighting)
    zr = P.rayleigh_length
    assert StaringLidar().n_cells == math.ceil((P.focus + 20 * zr) / 0.5)
    np.testing.assert_allclose(StaringLidar(azimuth_deg=90, elevation_deg=30).direction,
                               [0.0, math.cos(math.pi / 6), 0.5], atol=1e-15)
    with pytest.raises(ValueError, match="unknown key.*'colour'"):
        StaringLidar.from_dict({"colour": "red"})
    with pytest.raises(ValueError, match="unknown key.*'focal'"):
        StaringLidar.from_dict({"instrument": {"preset": "prototype", "focal": 50}})
    with pytest.raises(ValueError, match="instrument preset='zephyr'"):
        StaringLidar.from_dict({"instrument": {"preset": "zephyr"}})
    for kw, match in [({"tier": "fast"}, "tier='fast'"), ({"weighting": "gauss"}, "weighting"),
                      ({"span": 0.0}, "span"), ({"cell_length": -1.0}, "cell_length"), ({"cnr_db": 300.0}, "cnr_db"),
                      ({"transverse_speed": -1.0}, "transverse_speed"), ({"speckle": "none"}, "speckle"),
                      ({"elevation_deg": 91.0}, "elevation_deg"), ({"position": (0, 0)}, "position"),
                      ({"cell_length": 1e-4}, "number of range cells")]:
        with pytest.raises(ValueError, match=match):
            StaringLidar(**kw)
    with pytest.raises(TypeError, match="exact_background must be a bool"):
        StaringLidar(exact_background=1)
    with pytest.raises(TypeError, match="instrument must be an Instrument"):
        StaringLidar(instrument={"preset": "prototype"})


# ---------------------------------------------------------------------------
# uniform winds
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("az, el", [(0.0, 0.0), (30.0, 10.0), (180.0, 0.0), (120.0, -20.0)])
def test_uniform_wind_tier_los_is_the_projected_wind(az, el):
    box = xr.Dataset({c: (("x", "y", "z"), np.zeros((8, 8, 8))) for c in "uvw"},
                     coords={a: 4.0 * np.arange(8) for a in "xyz"})
    lid = StaringLidar(tier="los", azimuth_deg=az, elevation_deg=el, cell_length=2.0)
    rec = measure_staring(box, lid, times(50), U, None, wrap=True, variants=[{"name": "v", "estimator": "peak"}])
    proj = U * math.cos(math.radians(az)) * math.cos(math.radians(el))
    # weights sum to 1 (renormalised): the projection of the mean wind, up to rounding over ~90 cells
    np.testing.assert_allclose(rec.vlos_e, proj, rtol=1e-13, atol=1e-13)
    assert np.array_equal(rec.speed_e, np.abs(rec.vlos_e))  # homodyne: the sign is lost
    assert not rec.flags_e.any() and rec.availability == 1.0
    assert np.array_equal(rec.variants["v"][0], rec.speed_e)


def test_uniform_wind_tier_spectral_within_a_tenth_of_a_bin():
    """High CNR (+10 dB, per-bin SNR ~ 40 dB): only speckle (M_eff ~ 12) scatters the estimates.

    At a bin centre the Fejer line fills one bin and the prototype's median returns it; off-centre the
    rect window pulls the median toward bin centres by up to 0.2 bin (signal/processing notes), so the
    'peak' estimator (exact for one tone) is checked there.  Tolerance: 0.1 bin on the mean of 300
    estimates, whose standard error (sd / sqrt(300)) is asserted to be 10x smaller.
    """
    for bins, est in ((100.0, "median"), (100.37, "peak")):
        speed = bins * P.bin_speed
        lid = StaringLidar(cnr_db=10.0, transverse_speed=1.0, cell_length=2.0)
        rec = measure_staring(calm(), lid, times(300), speed, 3, variants=[{"name": "peak", "estimator": "peak"}])
        s = rec.speed_e if est == "median" else rec.variants["peak"][0]
        assert rec.availability == 1.0 and np.isfinite(s).all()
        np.testing.assert_allclose(rec.vlos_e, speed, rtol=1e-13)
        assert abs(s.mean() - speed) < 0.1 * P.bin_speed, (est, s.mean() - speed)
        assert s.std() / math.sqrt(s.size) < 0.01 * P.bin_speed
        assert rec.info["m_eff"] == pytest.approx(12.0, rel=0.15)


# ---------------------------------------------------------------------------
# turbulence
# ---------------------------------------------------------------------------
def test_tier1_is_the_weighted_line_of_sight_average_of_the_total_wind(field):
    """Tier 1 against a plain-Python reference built from the physics, not from the package's cells.

    A2012 Eq. 4: the Lorentzian weight (zR / pi) / (zR^2 + s^2) with zR = lambda r^2 / (pi a0^2)
    (Eq. 1) integrates to (arctan(b / zR) - arctan(a / zR)) / pi over a cell [a, b], and to
    1/2 + arctan(r / zR) / pi in front of the telescope, where all the air is (the weighting is
    Eq. 4 cut there and renormalised: nothing behind the telescope); the cells
    cut [max(-20 zR, -r), 20 zR] into equal lengths.  Each cell's centre samples the total wind
    (U + u, v, w) of the frozen field advected by U (reference.beam_sample_points, trilinear
    interpolation in plain Python), projected on the beam; the weight outside the span sees the
    mean wind U along the beam (the tail rule of cwlidar_sim.beam.cells), or, with
    tail = 'renormalise', the cells' weights are divided by their sum.
    """
    lid = StaringLidar(tier="los", weighting="lorentzian", position=(100.0, 0.0, 0.0), azimuth_deg=0.0)
    t = times(60, dt=0.5)  # 240 m of field
    rec = measure_staring(field, lid, t, U, None)
    zR = P.wavelength * P.focus**2 / (math.pi * P.telescope_radius**2)
    assert zR == pytest.approx(5.61, abs=0.005)
    n = lid.n_cells
    edges = np.linspace(max(-20 * zR, -P.focus), 20 * zR, n + 1)
    w = np.diff(np.arctan(edges / zR)) / math.pi / (0.5 + math.atan(P.focus / zR) / math.pi)
    n3 = np.array([1.0, 0.0, 0.0])  # azimuth 0, elevation 0: along +x
    np.testing.assert_allclose(lid.direction, n3, atol=1e-15)
    x = field.x.values
    u, v, ww = (field[c].values.astype(np.float64).reshape(-1, 1, 1) for c in "uvw")
    grid = np.array([x[0], 0.0, 0.0, x[1] - x[0], 1.0, 1.0])
    _, vlos_ts = reference.beam_sample_points(u, v, ww, grid, False, [100.0, 0.0, 0.0], np.tile(n3, (t.size, 1)),
                                              P.focus + 0.5 * (edges[:-1] + edges[1:]), t, U, add_mean=True)
    ref = vlos_ts @ w + (1.0 - w.sum()) * U
    np.testing.assert_allclose(rec.vlos_e, ref, rtol=0, atol=1e-12)
    assert rec.info["n_cells"] == n and rec.vlos_e.std() > 0.3  # the record does carry turbulence
    assert 1.0 - w.sum() == pytest.approx(rec.info["truncated_fraction"], rel=1e-9)
    rec = measure_staring(field, lid.replace(tail="renormalise"), t, U, None)
    np.testing.assert_allclose(rec.vlos_e, vlos_ts @ (w / w.sum()), rtol=0, atol=1e-12)


def test_spectral_tracks_tier1_in_turbulence(field):
    """Tier 2 (prototype, median, -10 dB) against the ideal vlos: 1000 estimates, one every 0.1 s (800 m of field).

    Expected error budget: the rect window pulls the median by <= 0.2 bin (0.015 m/s); the median of the
    probe volume's speed distribution differs from its weighted mean by at most that distribution's sd
    in each estimate, with either sign, so the difference averages out over the record; speckle scatters
    each estimate by ~0.15 m/s (measured), a standard error of ~0.005 m/s on 1000 estimates.  0.1 m/s is
    5x that budget.  Correlation: sd(vlos) against 0.15 m/s of noise gives
    1 / sqrt(1 + (0.15 / sd)^2), 0.95 at sd = 0.47 m/s; the record's sd (a random draw of 800 m
    of field, 0.56 m/s with this seed) must be at least 3x the noise (0.45 m/s) for the
    correlation to test tracking rather than noise, and the noise itself is checked directly.
    """
    lid = StaringLidar()
    t = times(1000, dt=0.1)
    rec = measure_staring(field, lid, t, U, 12)
    assert rec.availability == 1.0
    d = rec.speed_e - rec.vlos_e
    assert abs(d.mean()) < 0.1
    assert np.corrcoef(rec.speed_e, rec.vlos_e)[0, 1] > 0.95
    assert rec.vlos_e.std() > 3 * 0.15  # the record carries turbulence well above the speckle noise
    assert d.std() < 2 * 0.15  # and the estimates scatter about it by the speckle budget, not more
    # the derived transverse speed is the rms of (v, w) at the focus for a beam along x
    vel, _ = sample_los(field, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [P.focus], t, U, add_mean=True)
    assert rec.info["transverse_speed"] == pytest.approx(math.sqrt(np.mean(vel[:, 0, 1] ** 2 + vel[:, 0, 2] ** 2)),
                                                         rel=1e-12)
    assert rec.info["correlation_time"] == pytest.approx(P.waist_radius / rec.info["transverse_speed"], rel=1e-12)


def test_spectral_tier_with_a_misaligned_beam_in_a_plane():
    """Tier 2 with the beam 20 deg off the wind, in a horizontal plane (y periodic).

    The same budget as the aligned case holds for the speed (tracks tier 1).  The speckle
    correlation time comes from the aerosols' speed across the beam: the rms over the record
    of the total wind's component perpendicular to the beam at the focus, which for a
    misaligned beam is dominated by the mean wind's U sin(theta) = 2.7 m/s.  Checked against
    the plain-Python sampler.
    """
    from cwlidar_sim.turbulence import generate_plane

    theta = 20.0
    plane = generate_plane(MannParameters.iec(100.0, 1.5), (1024, 32), (1.0, 2.0), 3)
    lid = StaringLidar(position=(600.0, 30.0, 0.0), azimuth_deg=180.0 + theta)
    t = times(600, dt=0.1)
    rec = measure_staring(plane, lid, t, U, 13, wrap=True)
    assert rec.availability == 1.0
    d = rec.speed_e - np.abs(rec.vlos_e)
    assert abs(d.mean()) < 0.1
    assert np.corrcoef(rec.speed_e, np.abs(rec.vlos_e))[0, 1] > 0.95
    assert rec.vlos_e.std() > 3 * 0.15  # as in the aligned case: turbulence well above the noise
    assert d.std() < 2 * 0.15
    n3 = lid.direction
    np.testing.assert_allclose(n3, [-math.cos(math.radians(theta)), -math.sin(math.radians(theta)), 0.0], atol=1e-15)
    u, v, w = (plane[c].values.astype(np.float64)[:, :, None] for c in "uvw")
    x, y = plane.x.values, plane.y.values
    grid = np.array([x[0], y[0], 0.0, x[1] - x[0], y[1] - y[0], 1.0])
    vel, _ = reference.beam_sample_points(u, v, w, grid, True, [600.0, 30.0, 0.0], np.tile(n3, (t.size, 1)),
                                          [P.focus], t, U, add_mean=True)
    vel = vel[:, 0, :]
    # the record's mean is the total wind at the focus projected on the beam (U cos(theta) + the record's own
    # mean turbulence, which over 480 m of field is a random draw of ~0.7 m/s sd): the probe volume's
    # smoothing (+-20 z_R along a 60-s record) moves the mean by ~ sigma_u * 40 m / 480 m at most
    assert np.mean(rec.vlos_e) == pytest.approx(np.mean(vel @ n3), abs=0.15)
    perp = vel - (vel @ n3)[:, None] * n3[None, :]
    vt = math.sqrt(np.mean(np.sum(perp**2, axis=1)))
    assert vt > U * math.sin(math.radians(theta))
    assert rec.info["transverse_speed_source"] == "field rms at the focus"
    assert rec.info["transverse_speed"] == pytest.approx(vt, rel=1e-9)
    assert rec.info["correlation_time"] == pytest.approx(P.waist_radius / vt, rel=1e-9)


def test_low_cnr_fails_with_flags_counted(field):
    """At -45 dB the whole line holds CNR N / 2 = 0.008 of the noise per bin, far below the 4 sigma_y = 0.09
    threshold: estimates fail (NaN, NO_SIGNAL) except for false alarms of the noise (~1 % per estimate)."""
    lid = StaringLidar(cnr_db=-45.0, cell_length=2.0)
    rec = measure_staring(field, lid, times(400), U, 4, variants=[{"name": "raise", "threshold_raise_percent": 20}])
    failed = np.isnan(rec.speed_e)
    # availability counts the usable estimates: a false alarm near the blind zone is finite but NEAR_ZERO
    usable = ~failed & ((rec.flags_e & int(SUSPECT_FLAGS)) == 0)
    assert rec.availability == pytest.approx(usable.mean(), rel=1e-12) and rec.availability < 0.1
    assert np.array_equal(failed, (rec.flags_e & int(FAIL_FLAGS)) != 0)  # NaN if and only if a failure flag
    assert np.all(rec.flags_e[failed] & Flag.NO_SIGNAL)
    assert rec.info["flag_counts"]["NO_SIGNAL"] == int(np.count_nonzero(rec.flags_e & Flag.NO_SIGNAL))
    assert rec.info["n_failed"] == int(failed.sum())
    assert rec.info["variant_availability"]["raise"] <= 0.1


# ---------------------------------------------------------------------------
# reproducibility
# ---------------------------------------------------------------------------
def _same(a, b):
    assert np.array_equal(a.time_e, b.time_e) and np.array_equal(a.vlos_e, b.vlos_e)
    assert np.array_equal(a.speed_e, b.speed_e, equal_nan=True) and np.array_equal(a.flags_e, b.flags_e)
    assert a.variants.keys() == b.variants.keys()
    for k in a.variants:
        assert np.array_equal(a.variants[k][0], b.variants[k][0], equal_nan=True)
        assert np.array_equal(a.variants[k][1], b.variants[k][1])


@pytest.mark.parametrize("speckle, cnr_db", [("independent", -28.0), ("continuum", -25.0)])
def test_same_seed_same_bits_for_any_chunk_and_thread_count(field, speckle, cnr_db):
    lid = StaringLidar(cell_length=3.0, transverse_speed=0.8, cnr_db=cnr_db, speckle=speckle)  # some failures too
    t = times(DRAW_BLOCK + 300)  # crosses a block of speckle draws
    var = [{"name": "c", "estimator": "centroid"}]
    ref = measure_staring(field, lid, t, U, 9, variants=var)
    assert 0.3 < ref.availability < 1.0
    old = _config.get_num_threads()
    try:
        for nth, chunk in ((1, 4096), (2, 1000), (1, 777), (2, 5000)):
            _config.set_num_threads(nth)
            _same(ref, measure_staring(field, lid, t, U, 9, variants=var, chunk=chunk))
    finally:
        _config.set_num_threads(old)
    # a shorter record with the same settings is a prefix of the longer one
    short = measure_staring(field, lid, t[:1500], U, 9, chunk=600)
    assert np.array_equal(short.speed_e, ref.speed_e[:1500], equal_nan=True)
    assert ref.info["speckle"] == speckle
    assert not np.array_equal(ref.speed_e, measure_staring(field, lid, t, U, 10).speed_e, equal_nan=True)
    # the coherent speckle model and the exact background run through the same path
    lc = lid.replace(speckle="coherent", exact_background=True)
    _same(measure_staring(field, lc, t[:900], U, 9, chunk=250), measure_staring(field, lc, t[:900], U, 9))


def test_variants_equal_direct_runs_with_the_overridden_instrument(field):
    lid = StaringLidar(cell_length=2.0, cnr_db=-24.0)
    t = times(300)
    variants = [{"name": "raise10", "threshold_raise_percent": 10}, {"name": "peak", "estimator": "peak"},
                {"name": "ml", "estimator": "ml"}, {"name": "snr", "threshold_kind": "snr", "threshold_value": 0.5}]
    rec = measure_staring(field, lid, t, U, 21, variants=variants)
    assert list(rec.variants) == ["raise10", "peak", "ml", "snr"]
    for v in variants:
        over = {k: x for k, x in v.items() if k != "name"}
        direct = measure_staring(field, lid.replace(instrument=P.replace(**over)), t, U, 21)
        s, f = rec.variants[v["name"]]
        assert np.array_equal(s, direct.speed_e, equal_nan=True) and np.array_equal(f, direct.flags_e), v
        assert rec.info["variant_availability"][v["name"]] == direct.availability
    # raising the threshold keeps fewer bins: fewer or as many estimates survive
    assert rec.info["variant_availability"]["raise10"] <= rec.availability


# ---------------------------------------------------------------------------
# tier 3
# ---------------------------------------------------------------------------
def test_signal_tier_agrees_with_spectral_statistics(field):
    """Tier 3 (50 MHz signal) against tier 2 on the same record: the error sd within 10 % (or 4 standard
    errors of the sd ratio, from the sample kurtosis), the mean errors within 4 standard errors.

    Short estimates (M = 64) keep tier 3 cheap; tau_c = w0 / 5 m/s = 32 blocks keeps the speckle frozen
    within a block, as tier 2 assumes.  Estimates 0.1 s apart see distinct turbulence.
    """
    inst = P.replace(blocks_per_estimate=64)
    lid = StaringLidar(instrument=inst, cell_length=4.0, transverse_speed=5.0)
    t = times(600, dt=0.1)
    var = [{"name": "centroid", "estimator": "centroid"}]
    r2 = measure_staring(field, lid, t, U, 11, variants=var)
    r3 = measure_staring(field, lid.replace(tier="signal"), t, U, 11, variants=var)
    assert np.array_equal(r2.vlos_e, r3.vlos_e)

    def rel_var(x):
        d = x - x.mean()
        return (np.mean(d**4) / np.mean(d**2) ** 2 - 1) / (4 * x.size)

    for s2, s3 in ((r2.speed_e, r3.speed_e), (r2.variants["centroid"][0], r3.variants["centroid"][0])):
        a = (s2 - r2.vlos_e)[np.isfinite(s2)]
        b = (s3 - r3.vlos_e)[np.isfinite(s3)]
        assert a.size > 0.95 * t.size and b.size > 0.95 * t.size
        tol = max(0.10, 4 * math.sqrt(rel_var(a) + rel_var(b)))
        assert abs(b.std() / a.std() - 1) < tol, (a.std(), b.std(), tol)
        se = math.sqrt(a.var() / a.size + b.var() / b.size)
        assert abs(a.mean() - b.mean()) < 4 * se, (a.mean(), b.mean(), se)


# ---------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------
def test_bad_input_is_rejected_by_name(field):
    lid = StaringLidar(cell_length=4.0)
    t = times(10)
    with pytest.raises(TypeError, match="lidar must be a StaringLidar"):
        measure_staring(field, {"tier": "los"}, t, U, 1)
    with pytest.raises(ValueError, match=r"key\(s\) \['n_fft'\] would change the spectra"):
        measure_staring(field, lid, t, U, 1, variants=[{"name": "x", "n_fft": 256}])
    with pytest.raises(ValueError, match="needs a non-empty str 'name'"):
        measure_staring(field, lid, t, U, 1, variants=[{"estimator": "peak"}])
    with pytest.raises(ValueError, match="duplicate name 'a'"):
        measure_staring(field, lid, t, U, 1, variants=[{"name": "a"}, {"name": "a", "estimator": "peak"}])
    with pytest.raises(TypeError, match="variants must be a list"):
        measure_staring(field, lid, t, U, 1, variants={"name": "a"})
    with pytest.raises(ValueError, match="estimator='best'"):
        measure_staring(field, lid, t, U, 1, variants=[{"name": "a", "estimator": "best"}])
    with pytest.raises(ValueError, match=f"allowed: <= {SIGNAL_MAX_ESTIMATES}"):
        measure_staring(field, lid.replace(tier="signal"), times(SIGNAL_MAX_ESTIMATES + 1), U, 1)
    with pytest.raises(ValueError, match="seed is required for tier 'spectral'"):
        measure_staring(field, lid, t, U)
    with pytest.raises(TypeError, match="seed must be an integer"):
        measure_staring(field, lid, t, U, 1.5)
    with pytest.raises(ValueError, match="times contains non-finite"):
        measure_staring(field, lid, np.array([0.0, np.nan]), U, 1)
    with pytest.raises(ValueError, match="beam leaves the line field in y"):
        measure_staring(field, lid.replace(azimuth_deg=30.0), t, U, 1)
    with pytest.raises(ValueError, match="chunk=0"):
        measure_staring(field, lid, t, U, 1, chunk=0)
    with pytest.raises(ValueError, match="U=inf"):
        measure_staring(field, lid, t, math.inf, 1)
    with pytest.raises(ValueError, match="transverse_speed"):
        measure_staring(field, lid, t, U, 1, transverse_speed=-2.0)


def test_one_seed_rule_for_the_lidars(field):
    """seed: optional in every measure_*, required (by name) by the tiers that draw noise, unused by 'los'."""
    import inspect

    from cwlidar_sim.sensors import measure_conical, measure_nacelle

    for fn in (measure_staring, measure_conical, measure_nacelle):
        p = inspect.signature(fn).parameters["seed"]
        assert p.default is None and p.kind is p.POSITIONAL_OR_KEYWORD, fn.__name__
    t = times(20)
    lid = StaringLidar(tier="los")
    a = measure_staring(field, lid, t, U)
    np.testing.assert_array_equal(a.speed_e, measure_staring(field, lid, t, U, 5).speed_e)
    with pytest.raises(ValueError, match="seed is required for tier 'spectral'"):
        measure_staring(field, lid.replace(tier="spectral"), t, U)
