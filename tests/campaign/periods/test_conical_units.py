"""Conical scenes: any wind direction, the cycle through heights as a scene option, distinct unit seeds."""

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import loads_scene, run_scene
from cwlidar_sim.campaign.periods import conical_simulation as conical_period
from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_cycle
from cwlidar_sim.turbulence import cover as turbulence_cover
from cwlidar_sim.sensors.conical import measure_conical
from cwlidar_sim.turbulence import MannParameters

PHI = math.radians(30.0)
DWELL = math.radians(7.2)

TEXT = """
name = "dirs"
kind = "conical"
seed = 4
duration = {duration}
[scan]
heights = {heights}
scan_revs = {revs}
{scan}
[lidar]
tier = "los"
[turbulence]                # a fixed tensor: the surface layer's sigma_u would cost a one-point spectrum
source = "fixed"
alpha_eps = 0.05
length_scale = 15.0
gamma = 3.9
{periods}
"""


def scene(periods, scan="", heights="[20.0]", revs="[1]", duration=10.0):
    return loads_scene(TEXT.format(scan=scan, periods=periods, heights=heights, revs=revs, duration=duration))


def period(name, speed=8.0, direction=None, wind_from=None):
    return f'[[period]]\nname = "{name}"\nmean_speed = {speed}\n' + (
        "" if direction is None else f"wind_direction_deg = {direction}\n") + (
        "" if wind_from is None else f"wind_from_deg = {wind_from}\n")


def dirichlet(n_sub, dwell_rad):
    """Mean of cos(theta + delta_j) / cos(theta) over the n_sub looks of a dwell (the sweep's attenuation)."""
    h = dwell_rad / n_sub
    return math.sin(n_sub * h / 2) / (n_sub * math.sin(h / 2))


def calm_box(lidar, d=2.0, nx=64):
    """A box of zero fluctuations covering the lidar's cells."""
    ext = [lidar.beam_extent(z) for z in lidar.heights]
    r = max(e["radius"] for e in ext) + 2 * d
    y = np.arange(-r, r + d, d)
    z = np.arange(min(e["z_lo"] for e in ext) - d, max(e["z_hi"] for e in ext) + d, d)
    zero = np.zeros((nx, y.size, z.size))
    return xr.Dataset({c: (("x", "y", "z"), zero) for c in "uvw"}, coords={"x": d * np.arange(nx), "y": y, "z": z})


@pytest.fixture
def sheared(monkeypatch):
    """Each unit's turbulence replaced by a frozen field u = a (z - z0), v = w = 0 (a = 0: a uniform wind)."""
    real = turbulence_cover.cover_box
    shear = {"a": 0.0, "z0": 0.0}

    def field(*args, **kw):
        f = real(*args, **kw)
        u = (shear["a"] * (f.z - shear["z0"])).broadcast_like(f.u).transpose(*f.u.dims)
        return f.assign(u=u.astype(f.u.dtype), v=0.0 * f.v, w=0.0 * f.w)

    monkeypatch.setattr(turbulence_cover, "cover_box", field)
    return shear


@pytest.fixture
def no_model(monkeypatch):
    """CS's filter model left out of a scene's units (it is tested in tests/analysis/test_cs_model.py; here it
    would only cost a Mann one-point spectrum)."""
    from cwlidar_sim.analysis import cs_model

    monkeypatch.setattr(cs_model, "model_ratios", lambda *a, **k: {"std_ratio": np.nan, "radial_variance_ratio": np.nan})


# ---------------------------------------------------------------------------
# wind from every side
# ---------------------------------------------------------------------------
def test_a_conical_period_takes_any_wind_direction():
    sc = scene(period("a", direction=200.0) + period("b", direction=-135.0))
    assert [p.wind_direction_deg for p in sc.periods] == [200.0, -135.0]
    assert type(sc).from_dict(sc.as_dict()) == sc
    with pytest.raises(ValueError, match=r"misalignment_deg is the staring beam's angle.*wind_direction_deg"):
        scene(period("a") + "misalignment_deg = 30.0\n")
    with pytest.raises(ValueError, match=r"wind_direction_deg=inf is not finite"):
        scene(period("a", direction="inf"))
    with pytest.raises(ValueError, match="start is for staring scenes"):
        scene(period("a") + "start = 5.0\n")


@pytest.mark.parametrize("direction", [0.0, 90.0, 180.0, 270.0, 225.0])
def test_the_beam_turns_with_the_wind(direction):
    """A beam at the lidar's own azimuth alpha = azimuth0 + 360 t / T sees U sin Phi cos(alpha - direction).

    alpha comes from the scan's definition, not from the record, so a scan turned the wrong way (or not
    at all) fails for every direction but 0 (and 180 for the sign).
    """
    U, az0 = 8.0, 10.0
    lid = conical_period._conical_lidar((20.0,), "los", 2.0, 8, {"azimuth0_deg": az0}, direction)
    rec = measure_conical(calm_box(lid), lid, 2.0, U)
    alpha = np.radians(az0 + 360.0 * rec.time_e / lid.revolution_time - direction)
    want = U * math.sin(PHI) * np.cos(alpha) * dirichlet(8, DWELL)
    np.testing.assert_allclose(rec.vlos_e, want, rtol=0, atol=1e-12)


def test_a_uniform_wind_from_every_side_gives_one_speed_and_its_direction(sheared, no_model):
    """VAD speed, direction and the sonic's direction for winds toward 0, 90, 180, 270, 225 and -40 deg."""
    dirs = [0.0, 90.0, 180.0, 270.0, 225.0, -40.0]
    sc = scene("".join(period(f"d{i}", direction=d) for i, d in enumerate(dirs)))
    ds = run_scene(sc, None, progress=False)
    U = 8.0
    # the fit of a uniform wind is exact (to rounding) whichever points the blind zone removes: the speed is
    # the sweep-attenuated U, the same for every direction; the cup reads U itself
    np.testing.assert_allclose(ds.lidar_mean_unit.values[:, 0], U * dirichlet(8, DWELL), rtol=1e-12)
    np.testing.assert_allclose(ds.cup_mean_unit.values, U, rtol=1e-12)
    wrap = lambda d: (np.asarray(d) + 180.0) % 360.0 - 180.0  # noqa: E731
    np.testing.assert_allclose(wrap(ds.lidar_direction_unit.values[:, 0] - np.array(dirs)), 0.0, atol=1e-9)
    np.testing.assert_allclose(wrap(ds.sonic_direction_unit.values - np.array(dirs)), 0.0, atol=1e-9)
    assert np.all(ds.ambiguity_rate_unit.values == 0.0)
    assert np.all(ds.lidar_direction_unit.values >= -180.0) and np.all(ds.lidar_direction_unit.values < 180.0)


#: Meteorological directions (from, clockwise from north) and where each wind blows, counter-clockwise from the
#: lidar's x axis (east; y is north): a westerly blows east (0), a northerly south (270), an easterly west (180),
#: a south-westerly north-east (45), from 10 deg (east of north) toward 190 deg clockwise from north (260).
FROM_TOWARD = [(270.0, 0.0), (0.0, 270.0), (90.0, 180.0), (225.0, 45.0), (10.0, 260.0)]


def test_a_period_takes_the_meteorological_direction_or_the_direction_toward_not_both():
    sc = scene(period("a", wind_from=270.0) + period("b", direction=30.0) + period("c"))
    a, b, c = sc.periods
    assert (a.wind_from_deg, a.wind_direction_deg, a.toward_deg) == (270.0, None, 0.0)
    assert (b.wind_from_deg, b.toward_deg) == (None, 30.0) and c.toward_deg == 0.0
    back = type(sc).from_dict(sc.as_dict())
    assert back == sc and "wind_direction_deg" not in sc.as_dict()["period"][0]
    with pytest.raises(ValueError, match=r"period\[0\] \('a'\): gives both wind_direction_deg=0.0 .* and wind_from_deg=270.0 "
                                         r".*allowed: one of them"):
        scene(period("a", direction=0.0, wind_from=270.0))
    with pytest.raises(ValueError, match=r"wind_from_deg=nan is not finite"):
        scene(period("a", wind_from="nan"))


def test_a_wind_from_a_meteorological_direction_is_the_same_wind_and_reads_back(sheared, no_model):
    """wind_from_deg gives the same bits as the wind_direction_deg of the same wind; the results give the VAD's and
    the sonic's directions both ways, the 'from' ones in [0, 360)."""
    met = run_scene(scene("".join(period(f"d{i}", wind_from=f) for i, (f, _) in enumerate(FROM_TOWARD))), None,
                    progress=False)
    old = run_scene(scene("".join(period(f"d{i}", direction=t) for i, (_, t) in enumerate(FROM_TOWARD))), None,
                    progress=False)
    assert set(met.data_vars) == set(old.data_vars)
    for name in met.data_vars:
        np.testing.assert_array_equal(met[name].values, old[name].values, err_msg=name)
    wrap = lambda d: (np.asarray(d) + 180.0) % 360.0 - 180.0  # noqa: E731
    froms = np.array([f for f, _ in FROM_TOWARD])
    np.testing.assert_allclose(wrap(met.lidar_wind_from_unit.values[:, 0] - froms), 0.0, atol=1e-9)
    np.testing.assert_allclose(wrap(met.sonic_wind_from_unit.values - froms), 0.0, atol=1e-9)
    assert np.all((met.lidar_wind_from_unit.values >= 0.0) & (met.lidar_wind_from_unit.values < 360.0))
    assert "clockwise from north" in met.lidar_wind_from_unit.attrs["long_name"]
    assert "from = (270 - toward) mod 360" in met.attrs["wind_direction_convention"]


# ---------------------------------------------------------------------------
# the cycle through heights
# ---------------------------------------------------------------------------
CYCLE = 'cycle = true\nrevs_per_height = 2\nrefocus_time = 1.0'


def test_cycle_scene_validation():
    sc = scene(period("a") + period("b"), CYCLE, heights="[20.0, 30.0]", revs="[1, 2]", duration=30.0)
    assert sc.unit_names() == ["a", "b"] and sc.row_names(1) == ["b_z20", "b_z30"]
    assert sc.simulated_hours() == pytest.approx(60.0 / 3600.0)
    assert type(sc).from_dict(sc.as_dict()) == sc
    for kw, match in [
        (dict(scan=CYCLE), "needs at least 2"),
        (dict(scan=CYCLE, heights="[20.0, 30.0]", revs="[3]"), r"scan.scan_revs \[3\] must divide"),
        (dict(scan="revs_per_height = 2", heights="[20.0, 30.0]"), r"revs_per_height.*cycle = true"),
        (dict(scan=CYCLE.replace("= 2", "= 6"), heights="[20.0, 30.0]", duration=10.0), "shorter than one cycle"),
    ]:
        with pytest.raises(ValueError, match=match):
            scene(period("a"), **kw)


def test_cycling_lidar_gives_each_height_its_share_and_its_own_cup_and_sonic(sheared):
    """One box for both heights, sheared u = a (z - 25 m): each height's row reads its own height's wind.

    2 revolutions per height and 1 s to refocus: blocks of 3 s, 10 in 31 s, 5 per height: 10 revolutions
    (500 estimates, ten 1-s and five 2-s scans) at each height.  The cup at z reads U + a (z - 25)
    exactly; the VAD speed its sweep-attenuated probe-volume average, which differs from the cup's by at
    most a times the weighting's height offset (the exact weighting's asymmetry, ~z_R cos Phi = 0.6 m)
    plus the tail beyond the span, which sees the mean wind only (~15 % of the weight at 5 z_R):
    0.15 x a x 5 m = 0.04 m/s at a = 0.05 s^-1, against the 0.5 m/s between the heights.
    """
    a, U = 0.05, 8.0
    sheared.update(a=a, z0=25.0)
    rows = simulate_conical_cycle((20.0, 30.0), 7, revs_per_height=2, refocus_time=1.0, speed=U, duration=31.0,
                                  scan_revs=(1, 2), model=False, params=MannParameters(0.05, 15.0, 3.9))
    assert [r["height"] for r in rows] == [20.0, 30.0]
    for r in rows:
        assert r["n_estimates"] == 500 and r["scans"][1]["n_scans"] == 10 and r["scans"][2]["n_scans"] == 5
        assert r["box_shape"] == rows[0]["box_shape"]  # one box
        # the cup stands on the box's node nearest its height (at most half a cell, 0.5 m, off)
        z_cup = r["in_situ_position"][2]
        assert abs(z_cup - r["height"]) <= 0.5
        cup = U + a * (z_cup - 25.0)
        assert r["cup_mean"] == pytest.approx(cup, rel=1e-6)
        assert r["scans"][1]["lidar_mean"] / dirichlet(8, DWELL) == pytest.approx(U + a * (r["height"] - 25.0),
                                                                                  abs=0.06)
        assert r["sonic_radial_variance"] == pytest.approx(0.0, abs=1e-12)  # each sonic: a constant wind
    assert rows[1]["cup_mean"] - rows[0]["cup_mean"] == pytest.approx(10 * a, rel=1e-6)
    with pytest.raises(ValueError, match="must divide revs_per_height"):
        simulate_conical_cycle((20.0, 30.0), 7, revs_per_height=2, scan_revs=(3,), duration=31.0)


def test_a_cycle_scene_runs_one_unit_per_period_with_results_per_height(sheared, no_model, tmp_path):
    sheared.update(a=0.05, z0=25.0)
    sc = scene(period("a"), CYCLE, heights="[20.0, 30.0]", revs="[1, 2]", duration=31.0)
    ds = run_scene(sc, tmp_path, progress=False)
    assert list(ds.period.values) == ["a_z20", "a_z30"] and list(ds.height.values) == [20.0, 30.0]
    assert list(ds.n_periods.values) == [1, 1]
    np.testing.assert_allclose(ds.cup_mean_unit.values, 8.0 + 0.05 * (ds.in_situ_height_unit.values - 25.0), rtol=1e-6)
    np.testing.assert_allclose(ds.in_situ_height_unit.values, [20.0, 30.0], atol=0.5)
    assert ds.std_ratio.dims == ("height", "scan_s") and list(ds.scan_s.values) == [1.0, 2.0]
    assert sorted(p.name for p in (tmp_path / "dirs.periods").iterdir()) == ["000_a.nc"]
    again = run_scene(sc, tmp_path, progress=False)
    assert again.attrs["periods_reused"] == '["a"]'
    np.testing.assert_array_equal(again.lidar_mean_unit.values, ds.lidar_mean_unit.values)


# ---------------------------------------------------------------------------
# seeds
# ---------------------------------------------------------------------------
def test_conical_units_get_distinct_seeds_across_periods_and_heights():
    three = "[20.0, 30.0, 40.0]"
    sc = scene(period("a") + period("b") + period("c"), heights=three)
    seeds = [sc.unit_seed(i) for i in range(len(sc.unit_names()))]
    assert len(seeds) == 9 and len(set(seeds)) == 9
    own = scene(period("a") + "seed = 12\n" + period("b"), heights=three)
    s2 = [own.unit_seed(i) for i in range(6)]
    assert len(set(s2)) == 6 and s2[3:] == seeds[3:6]  # a period's own seed leaves the others alone
    cyc = scene(period("a") + period("b") + period("c"), CYCLE, heights=three, revs="[1, 2]", duration=30.0)
    c = [cyc.unit_seed(i) for i in range(3)]
    assert len(set(c)) == 3


# ---------------------------------------------------------------------------
# periods per height
# ---------------------------------------------------------------------------
TWO = "[20.0, 30.0]"


def test_periods_per_height_cycle_through_the_templates_with_their_own_names_and_seeds():
    sc = scene(period("a", 6.0) + period("b", 10.0), "periods_per_height = [5, 2]", heights=TWO)
    assert sc.unit_names() == ["a_z20", "a_z30", "b_z20", "b_z30", "a_1_z20", "b_1_z20", "a_2_z20"]
    assert [p.mean_speed for p, _ in sc.units()] == [6.0, 6.0, 10.0, 10.0, 6.0, 10.0, 6.0]
    assert sc.periods_at() == {20.0: 5, 30.0: 2}
    assert sc.simulated_hours() == pytest.approx(7 * 10.0 / 3600.0)
    seeds = [sc.unit_seed(i) for i in range(7)]
    assert len(set(seeds)) == 7
    plain = scene(period("a", 6.0) + period("b", 10.0), heights=TWO)  # the first pass is the plain scene
    assert seeds[:4] == [plain.unit_seed(i) for i in range(4)] and sc.unit_names()[:4] == plain.unit_names()
    own = scene(period("a", 6.0) + "seed = 12\n" + period("b", 10.0), "periods_per_height = [5, 2]", heights=TWO)
    s2 = [own.unit_seed(i) for i in range(7)]
    assert len(set(s2)) == 7 and s2[2:4] == seeds[2:4]  # a template's own seed: a stream per height and pass
    assert type(sc).from_dict(sc.as_dict()) == sc and sc.as_dict()["scan"]["periods_per_height"] == [5, 2]
    assert "periods_per_height" not in plain.as_dict()["scan"]


@pytest.mark.parametrize("plan, err, match", [
    ("[3]", ValueError, r"periods_per_height has 1 counts for 2 heights.*one count per height"),
    ("[3, 0]", ValueError, r"periods_per_height\[1\]=0 is out of range; allowed: \[1, 10000\]"),
    ("[3, 2.5]", TypeError, r"periods_per_height\[1\] must be an integer"),
    ('"3, 2"', TypeError, "periods_per_height must be a list of integers"),
])
def test_periods_per_height_is_checked_by_name(plan, err, match):
    with pytest.raises(err, match=match):
        scene(period("a"), f"periods_per_height = {plan}", heights=TWO)


def test_periods_per_height_needs_dwell_and_distinct_unit_names():
    with pytest.raises(ValueError, match="periods_per_height needs scan.cycle = false"):
        scene(period("a"), CYCLE + "\nperiods_per_height = [2, 2]", heights=TWO, revs="[1, 2]", duration=30.0)
    with pytest.raises(ValueError, match=r"units \['a_1_z20'\] are named twice"):
        scene(period("a") + period("a_1"), "periods_per_height = [3, 1]", heights=TWO)
    with pytest.raises(ValueError, match=r"unknown key.*periods_per_heigth"):
        scene(period("a"), "periods_per_heigth = [3, 1]", heights=TWO)


def test_a_plan_runs_each_height_its_periods_at_its_templates_speeds(sheared, no_model, tmp_path):
    """u = a (z - 25 m): every unit's cup reads its template's speed plus its height's shear."""
    a = 0.05
    sheared.update(a=a, z0=25.0)
    sc = scene(period("a", 6.0) + period("b", 10.0), "periods_per_height = [3, 1]", heights=TWO)
    ds = run_scene(sc, tmp_path, progress=False)
    assert list(ds.period.values) == ["a_z20", "a_z30", "b_z20", "a_1_z20"]
    assert list(ds.height.values) == [20.0, 30.0] and list(ds.n_periods.values) == [3, 1]
    # each cup on its box's node nearest its height (half a cell at most: 0.5 m at 20 m, 0.75 m at 30 m)
    zc = ds.in_situ_height_unit.values
    np.testing.assert_allclose(zc, [20.0, 30.0, 20.0, 20.0], atol=0.75)
    want = np.array([6.0, 6.0, 10.0, 6.0]) + a * (zc - 25.0)
    np.testing.assert_allclose(ds.cup_mean_unit.values, want, rtol=1e-6)
    np.testing.assert_allclose(ds.mean_speed_unit.values, [6.0, 6.0, 10.0, 6.0])
    plain = run_scene(scene(period("a", 6.0) + period("b", 10.0), heights=TWO), progress=False)
    np.testing.assert_array_equal(ds.lidar_mean_unit.values[:3], plain.lidar_mean_unit.values[:3])


def test_quick_cs_is_the_full_runs_first_units():
    from cwlidar_sim.campaign import bundled_scene

    full, quick = bundled_scene("cs"), bundled_scene("cs", quick=True)
    n = len(quick.unit_names())
    assert n == 8 and quick.unit_names() == full.unit_names()[:n]
    assert [quick.unit_seed(i) for i in range(n)] == [full.unit_seed(i) for i in range(n)]
    assert [p for p, _ in quick.units()] == [p for p, _ in full.units()[:n]]

