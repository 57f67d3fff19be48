"""Scene files: validation by name, round-trip, field choice."""

import dataclasses

import pytest

from cwlidar_sim.campaign import bundled_scene, choose_field, load_scene, loads_scene
from cwlidar_sim.campaign.execution.reproduce import bundled_text
from cwlidar_sim.campaign.scenes.staring import LidarSpec, PeriodSpec, Scene

MINIMAL = """
name = "t"
[turbulence]
alpha_eps = 0.05
length_scale = 20.0
gamma = 3.9
[[period]]
name = "A"
mean_speed = 8.0
"""


def test_minimal_scene_defaults():
    s = loads_scene(MINIMAL)
    assert s.periods[0].misalignment_deg == 0.0
    assert s.lidar.tier == "spectral" and s.sonic.rate == 32.0
    assert s.period_duration(s.periods[0]) == 3600.0


def test_round_trip_bundled():
    s = bundled_scene("a2012")
    assert Scene.from_dict(s.as_dict()) == s
    assert [p.name for p in s.periods] == ["A", "B", "C", "D"]
    assert s.lidar.build_instrument().focus == 67.5
    # A2012 Eq. 1: zR = lambda r^2 / (pi a0^2) = 5.61 m at 67.5 m
    assert abs(s.lidar.build_instrument().rayleigh_length - 5.61) < 0.01


def test_quick_keeps_geometry_and_seeds():
    full, quick = bundled_scene("a2012"), bundled_scene("a2012", quick=True)
    assert quick.duration < full.duration
    assert [p.misalignment_deg for p in quick.periods] == [p.misalignment_deg for p in full.periods]
    assert [quick.unit_seed(i) for i in range(4)] == [full.unit_seed(i) for i in range(4)]


@pytest.mark.parametrize("text, match", [
    ("colour = 3\n" + MINIMAL, r"unknown key\(s\) in scene: \['colour'\]"),
    (MINIMAL.replace("gamma = 3.9", "gamma = 3.9\nwidth = 2"), r"unknown key\(s\) in turbulence: \['width'\]"),
    (MINIMAL + "[lidar]\ntier = 'fast'\n", r"lidar.tier"),
    (MINIMAL + "[lidar]\ncnr_db = 500\n", r"lidar.cnr_db"),
    (MINIMAL + "[lidar]\ninstrument = { focal = 60 }\n", r"focal"),
    (MINIMAL + "[lidar]\nvariants = [{ name = 'x', estimator = 'mode' }]\n", r"estimator"),
    (MINIMAL + "[lidar]\nvariants = [{ estimator = 'peak' }]\n", r"variants\[0\]"),
    (MINIMAL + "[sonic]\nrate = 20\n", r"sonic.rate"),
    (MINIMAL + "[field]\nkind = 'cube'\n", r"field.kind"),
    (MINIMAL + "[analysis]\nk_min = 2.0\nk_max = 1.0\n", r"analysis.k_max"),
    (MINIMAL.replace("mean_speed = 8.0", "mean_speed = 0.1"), r"mean_speed"),
    (MINIMAL.replace("mean_speed = 8.0", "mean_speed = 8.0\nmisalignment = 5"), r"unknown key\(s\) in period\[0\] \('A'\): \['misalignment'\]"),
    (MINIMAL.replace("length_scale = 20.0", "length_scale = -20.0"), r"length_scale"),
    (MINIMAL + "[[period]]\nname = 'A'\nmean_speed = 7\n", r"unique"),
    (MINIMAL.replace('name = "t"', 'name = "a/b"'), r"name"),
    (MINIMAL + "duration = 100.0\n", None),
])
def test_bad_scenes_rejected_by_name(text, match):
    if match is None:
        # a period shorter than the 600 s analysis segment
        text = MINIMAL.replace('name = "t"', 'name = "t"\nduration = 100.0')
        match = "segment_duration"
    with pytest.raises((ValueError, TypeError), match=match):
        loads_scene(text)


def test_fit_to_exclusive_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match="not both"):
        loads_scene(MINIMAL.replace("gamma = 3.9", "gamma = 3.9\nfit_to = 'x.nc'"))
    p = tmp_path / "s.toml"
    p.write_text(MINIMAL.replace("alpha_eps = 0.05\nlength_scale = 20.0\ngamma = 3.9", "fit_to = 'missing.nc'"))
    s = load_scene(p)
    assert s.resolve(s.turbulence.fit_to) == str(tmp_path / "missing.nc")
    from cwlidar_sim.campaign.periods.staring_field import scene_params

    with pytest.raises(ValueError, match="missing.nc"):
        scene_params(s)


def test_invalid_toml_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match="not valid TOML"):
        loads_scene("name = ")
    with pytest.raises(ValueError, match="cannot read scene file"):
        load_scene(tmp_path / "nope.toml")


def test_field_choice():
    s = loads_scene(MINIMAL)
    p0 = s.periods[0]
    assert choose_field(s, p0)[0] == "line"
    p5 = dataclasses.replace(p0, misalignment_deg=5.0)
    assert choose_field(s, p5)[0] == "plane"
    tilted = s.replace(lidar=LidarSpec(elevation_deg=2.0))
    assert choose_field(tilted, p0)[0] == "box"
    forced = s.replace(field=dataclasses.replace(s.field, kind="plane"))
    assert choose_field(forced, p0) == ("plane", "forced by field.kind = 'plane'")
    line = s.replace(field=dataclasses.replace(s.field, kind="line"))
    with pytest.raises(ValueError, match="cannot hold period"):
        choose_field(line, p5)


def test_period_seeds_distinct_and_stable():
    s = bundled_scene("a2012")
    seeds = [s.unit_seed(i) for i in range(4)]
    assert len(set(seeds)) == 4
    s2 = s.replace(periods=(dataclasses.replace(s.periods[0], seed=7),) + s.periods[1:])
    assert s2.unit_seed(0) == 7 and s2.unit_seed(1) == seeds[1]
    assert isinstance(s.periods[0], PeriodSpec)


CONE = """
name = "c"
kind = "conical"
[scan]
heights = [40.0]
[[period]]
name = "A"
mean_speed = 8.0
"""


@pytest.mark.parametrize("text, error, message", [
    (MINIMAL + "[lidar]\nexact_background = 1\n", TypeError, "lidar.exact_background must be a bool (true or false), got int 1"),
    (MINIMAL + "[analysis]\nfit = 'yes'\n", TypeError, "analysis.fit must be a bool (true or false), got str 'yes'"),
    (CONE.replace("[scan]", "[scan]\ncycle = 1"), TypeError, "scan.cycle must be a bool (true or false), got int 1"),
    (CONE.replace("[scan]", "[scan]\nlateral_doubling = 0"), TypeError, "scan.lateral_doubling must be a bool"),
    (MINIMAL + "[sonic]\noffset = [1.0, 2.0]\n", ValueError, "sonic.offset must be a list of 3 numbers [m], got [1.0, 2.0]"),
    (MINIMAL.replace('name = "A"', "name = 3"), TypeError, "period[0].name must be a string, got int 3"),
    (CONE.replace('name = "A"', 'name = ""'), ValueError, "period[0].name must not be empty"),
    (MINIMAL.replace('name = "t"', 'name = "a b"'), ValueError, "name 'a b' may hold only letters"),
    (CONE.replace('name = "c"', 'name = "a/b"'), ValueError, "name 'a/b' may hold only letters"),
    ("colour = 1\n" + MINIMAL, ValueError, "unknown key(s) in scene: ['colour']; allowed: "),
    ("colour = 1\n" + CONE, ValueError, "unknown key(s) in conical scene: ['colour']; allowed: "),
    (MINIMAL + '[[period]]\nname = "A"\nmean_speed = 7.0\n', ValueError, "period names must be unique, got ['A', 'A']"),
    (CONE + '[[period]]\nname = "A"\nmean_speed = 7.0\n', ValueError, "period names must be unique, got ['A', 'A']"),
])
def test_staring_and_conical_scenes_share_their_checks_and_messages(text, error, message):
    """One scene machinery (campaign/scenes/spec.py, _validation.py): the same mistake reads the same in both kinds."""
    with pytest.raises(error) as e:
        loads_scene(text)
    assert message in str(e.value)


@pytest.mark.parametrize("text_from, text_to, hint", [
    ("name =", "nmae =", "(did you mean 'name' for 'nmae'?)"),          # a typo
    ("[lidar]", "[lidar]\nTier = 'los'", "(did you mean 'tier' for 'Tier'?)"),  # the case
    ("seed =", "see =", "(did you mean 'seed' for 'see'?)"),
])
def test_an_unknown_key_names_the_closest_allowed_key(text_from, text_to, hint):
    text = bundled_text("a2012")
    assert text_from in text
    with pytest.raises(ValueError, match="unknown key") as err:
        loads_scene(text.replace(text_from, text_to, 1))
    assert hint in str(err.value)


def test_an_unknown_key_far_from_every_allowed_key_gets_no_guess():
    with pytest.raises(ValueError, match="unknown key") as err:
        loads_scene("zzqx = 1\n" + MINIMAL)
    assert "did you mean" not in str(err.value)


def test_turbulence_the_periods_wind_cannot_carry_is_refused_at_the_scene():
    """sigma_u / U <= 0.5 per period (turbulence.limits), checked when the scene is built, before any run."""
    strong = MINIMAL.replace("alpha_eps = 0.05", "alpha_eps = 0.5")  # sigma_u = 2.86 m/s (0.05: 0.91 m/s)
    assert loads_scene(strong).periods[0].mean_speed == 8.0  # intensity 0.36 at 8 m/s: accepted
    slow = strong + '[[period]]\nname = "calm"\nmean_speed = 5.0\n'  # 0.57 at 5 m/s
    with pytest.raises(ValueError, match=r"period\[1\] \('calm'\): the tensor alpha_eps=0.5 .* sigma_u = 2.86 m/s, "
                                         r"a turbulence intensity sigma_u/U = 0.57"):
        loads_scene(slow)
    with pytest.raises(ValueError, match=r"gamma=9.0 is above 8"):
        loads_scene(MINIMAL.replace("gamma = 3.9", "gamma = 9.0"))
    with pytest.raises(ValueError, match=r"lidar.instrument.estimate_rate=10 Hz: a staring scene samples .* 50 Hz"):
        loads_scene(MINIMAL + "[lidar]\ninstrument = { estimate_rate = 10.0, blocks_per_estimate = 1000 }\n")
