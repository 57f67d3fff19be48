"""Every error raised while reading a scene names the TOML path the user wrote, once, in one line.

A corpus of small edits of the bundled scenes (staring a2012, conical cs,
nacelle), each with the path its message must name: ``lidar.instrument.focus``,
``period[0] ('A').mean_speed``, ``lidar.variants[0] ('raise5')...``, the
``turbulence.`` prefix of the Mann parameters' own checks.  An unknown key is
reported with the table it was written in, and with where it probably belongs:
a nested table that has it (``[lidar] focus`` -> ``lidar.instrument.focus``), a
sibling table (``[lidar] segment_duration`` -> ``analysis.segment_duration``),
else the table's closest key.  No message names a class of the code.
"""

import re

import pytest

from cwlidar_sim import cli
from cwlidar_sim.campaign.scenes import conical as conical_scene, lidar_spec, nacelle as nacelle_scene, staring as scene, spec
from cwlidar_sim.campaign.execution.reproduce import bundled_text
from cwlidar_sim.campaign.scenes.load import loads_scene
from cwlidar_sim.campaign.execution.sweep import expand, loads_campaign

TEXT = {name: bundled_text(name) for name in ("a2012", "cs", "nacelle")}

#: Classes of the code that a message about a scene file must not name (the user wrote TOML, not them).
INTERNAL = sorted({name for mod in (scene, conical_scene, nacelle_scene, lidar_spec, spec)
                   for name, obj in vars(mod).items() if isinstance(obj, type) and obj.__module__ == mod.__name__}
                  | {"Instrument", "RecordSpec", "MannParameters", "LidarBase", "ConicalLidar", "NacelleLidar",
                     "CampaignSpec"})
INTERNAL_RE = re.compile(r"\b(" + "|".join(map(re.escape, INTERNAL)) + r")\b")


#: A path named twice in a row.
DOUBLED = re.compile(r"\b([a-z_]+)(?:\[\d+\])?(?: \('[^']*'\))?(?:\.|: )\1\b")


def edit(name, old, new):
    text = TEXT[name]
    assert old in text, (name, old)
    return text.replace(old, new, 1)


def error_of(fn, *args):
    with pytest.raises((ValueError, TypeError)) as err:
        fn(*args)
    return str(err.value)


def assert_names_path_once(msg, path):
    """``path`` is in the one-line message exactly once, not repeated right after itself, and no class is named."""
    assert "\n" not in msg, msg
    assert msg.count(path) == 1, (path, msg)
    head = re.match(r"[A-Za-z_]+", path).group()
    after = msg[msg.index(path) + len(path):]
    assert not re.match(rf"[.:]\s*{head}\b", after), msg  # 'period[0] ('A').period...', 'lidar: lidar.'
    assert not DOUBLED.search(msg), msg  # 'turbulence.turbulence.gamma', 'lidar: lidar.span', "period[0] ('A').period"
    assert not INTERNAL_RE.search(msg), msg


A, C, N = "a2012", "cs", "nacelle"
CDL = 'condition_on = [{ path = "m.csv", kind = "sonic", %s }]'
CORPUS = [
    # -- staring (a2012) --------------------------------------------------------------------------------
    (A, "span = 20.0", "span = 20.0\nfocus = 60.0", "unknown key(s) in lidar: ['focus']"),
    (A, "[sonic]", "[sonics]", "unknown key(s) in scene: ['sonics']"),
    (A, "noise_std = 0.02", "noise_sd = 0.02", "unknown key(s) in sonic: ['noise_sd']"),
    (A, "gamma = 3.9", "gamma = 30", "turbulence.gamma=30 is above 8"),
    (A, "gamma = 3.9", "gamma = -3", "turbulence.gamma=-3 is out of range"),
    (A, "length_scale = 18.76", "length_scale = 5e4", "turbulence.length_scale=50000.0"),
    (A, "gamma = 3.9", "gamma = 3.9\nwidth = 2", "unknown key(s) in turbulence: ['width']"),
    (A, "threshold_raise_percent = 5.0", "threshold_raise_percent = -5.0",
     "lidar.variants[0] ('raise5').threshold_raise_percent=-5.0 is out of range"),
    (A, 'estimator = "centroid"', 'estimator = "mode"', "lidar.variants[3] ('centroid').estimator='mode'"),
    (A, 'threshold_raise_percent = 5.0 }', 'threshold_raise = 5.0 }',
     "unknown key(s) in lidar.variants[0] ('raise5'): ['threshold_raise']"),
    (A, '{ name = "raise10", ', '{ name = "raise5", ', "lidar.variants[1]: duplicate name 'raise5'"),
    (A, "mean_speed = 8.5", "mean_speed = -1", "period[0] ('A').mean_speed=-1 is out of range"),
    (A, "misalignment_deg = 3.5", "misalignment_deg = 50.0", "period[1] ('B').misalignment_deg=50.0"),
    (A, "misalignment_deg = 6.0", "misalignment = 6.0", "unknown key(s) in period[0] ('A'): ['misalignment']"),
    (A, "mean_speed = 7.6", "", "period[1] ('B') is missing the required key(s) ['mean_speed']"),
    (A, 'name = "A"', "name = 3", "period[0].name must be a string"),
    (A, "duration = 3600.0", "duration = 300.0", "period[0] ('A') lasts 300.0 s"),
    (A, "mean_speed = 7.6", "mean_speed = 1.0", "period[1] ('B'): the tensor"),
    (A, "focus = 67.5", "focus = -67.5", "lidar.instrument.focus=-67.5"),
    (A, "focus = 67.5", "focs = 67.5", "unknown key(s) in lidar.instrument: ['focs']"),
    (A, "span = 20.0", "span = -2", "lidar.span=-2"),
    (A, 'tier = "spectral"', 'tier = "fast"', "lidar.tier='fast'"),
    (A, "dx = 0.5", "dx = 50", "field.dx=50"),
    (A, "per_decade = 10", "per_decade = 1", "analysis.per_decade=1"),
    (A, 'instrument = { focus = 67.5, estimator = "median" }', "instrument = 3",
     "lidar.instrument must be a table of overrides, got int"),
    (A, "gamma = 3.9", "gamma = 3.9\n" + CDL % "nois = 1", "unknown key(s) in turbulence.condition_on[0]: ['nois']"),
    (A, "gamma = 3.9", "gamma = 3.9\n" + CDL % "noise_std = -1", "turbulence.condition_on[0].noise_std=-1"),
    (A, "gamma = 3.9", "gamma = 3.9\n" + CDL % 'columns = { q = "a" }',
     "turbulence.condition_on[0].columns has unknown role(s) ['q']"),
    # -- conical (cs) -----------------------------------------------------------------------------------
    (C, "sub_dwells = 8", "sub_dwells = 8\nfoo = 1", "unknown key(s) in scan: ['foo']"),
    (C, "cnr_db = -10.0", "cnr_db = -10.0\nhalf_angle_deg = 30.0", "unknown key(s) in lidar: ['half_angle_deg']"),
    (C, "cnr_db = -10.0", "cnr_db = -10.0\nfocus = 3.0", "unknown key(s) in lidar: ['focus']"),
    (C, "cnr_db = -10.0", 'cnr_db = -10.0\nvariants = [{ name = "p", estimator = "pk" }]',
     "lidar.variants[0] ('p').estimator='pk'"),
    (C, "mean_speed = 8.0\n[[period]]", "mean_speed = 8.0\nmisalignment_deg = 2.0\n[[period]]",
     "period[0] ('p0'): misalignment_deg is the staring beam's angle"),
    (C, "mean_speed = 6.0", "mean_speed = 0.5", "period[2] ('p2').mean_speed=0.5"),
    (C, 'source = "mann1994"\nz0 = 0.01', 'source = "mann1994"\nz0 = -1.0', "turbulence.z0=-1.0"),
    (C, 'source = "mann1994"', 'source = "mann1994"\ngama = 3.0', "unknown key(s) in turbulence: ['gama']"),
    (C, "heights = [40.0, 60.0, 80.0, 100.0]", "heights = [40.0, 60.0, 80.0, -100.0]", "scan.heights[3]=-100.0"),
    # -- nacelle ----------------------------------------------------------------------------------------
    (N, "n_k = 12", "n_k = 1", "scan.n_k=1"),
    (N, "n_k = 12", "nk = 12", "unknown key(s) in scan: ['nk']"),
    (N, "gamma = 3.9", "gamma = 30", "turbulence.gamma=30 is above 8"),
    (N, "gamma = 3.9", "gamma = 3.9\nz0 = 0.1", "turbulence.z0 is the surface layer's roughness; it needs source"),
    (N, "lifetime = 15.0", "lifetime = -15.0", "period[1] ('evolving').lifetime=-15.0"),
    (N, '{ name = "median", estimator = "median" }', '{ name = "median", estimator = "mode" }',
     "lidar.variants[0] ('median').estimator='mode'"),
    (N, "cnr_db = -5.0", "cnr_db = -5.0\nsegment_duration = 60.0", "unknown key(s) in lidar: ['segment_duration']"),
    (N, "duration = 600.0", "duration = 100.0", "period[0] ('frozen') lasts 100 s"),
    (N, "[lidar]", "[platform]\nsurge = -1.0\n\n[lidar]", "platform.surge=-1.0"),
    (N, "[lidar]", "[platform]\nsurg = 1.0\n\n[lidar]", "unknown key(s) in platform: ['surg']"),
    (N, "seed = 20", "seed = 20\nplatform = 3", "platform must be a table, got int 3"),
    (N, "[lidar]", "[platform]\nsurge = 1.0\nphase_deg = { surg = 3.0 }\n\n[lidar]",
     "unknown key(s) in platform.phase_deg: ['surg']"),
]
@pytest.mark.parametrize("name, old, new, path", CORPUS, ids=[f"{c[0]}-{c[3][:40]}" for c in CORPUS])
def test_every_scene_error_names_its_toml_path_once(name, old, new, path):
    msg = error_of(loads_scene, edit(name, old, new))
    assert path in msg, msg
    assert_names_path_once(msg, path)


@pytest.mark.parametrize("name, old, new, where, hint", [
    # a key of a nested table, written in the table around it
    (A, "span = 20.0", "span = 20.0\nfocus = 60.0", "lidar",
     "did you mean lidar.instrument.focus for 'focus', i.e. instrument = { focus = ... }?"),
    (C, "cnr_db = -10.0", "cnr_db = -10.0\nestimator = 'peak'", "lidar",
     "did you mean lidar.instrument.estimator for 'estimator', i.e. instrument = { estimator = ... }?"),
    (A, "span = 20.0", "span = 20.0\nthreshold_raise_percent = 5.0", "lidar",
     "lidar.instrument.threshold_raise_percent for 'threshold_raise_percent'"),
    (A, "span = 20.0", "span = 20.0\nfocs = 60.0", "lidar",  # misspelt too: the nested table's closest key
     "did you mean lidar.instrument.focus for 'focs', i.e. instrument = { focus = ... }?"),
    # a key of a sibling table
    (A, "span = 20.0", "span = 20.0\nsegment_duration = 600.0", "lidar",
     "did you mean analysis.segment_duration for 'segment_duration'?"),
    (N, "cnr_db = -5.0", "cnr_db = -5.0\nsegment_duration = 60.0", "lidar",
     "did you mean scan.segment_duration for 'segment_duration'?"),
    (C, "cnr_db = -10.0", "cnr_db = -10.0\nhalf_angle_deg = 30.0", "lidar",
     "did you mean scan.half_angle_deg for 'half_angle_deg'?"),
    # a table's key at the top, a period's key at the top
    (A, "seed = 2012", "seed = 2012\nfocus = 60.0", "scene", "did you mean lidar.instrument.focus for 'focus'?"),
    (N, "seed = 20", "seed = 20\nlifetime = 15.0", "nacelle scene",
     "did you mean period[i].lifetime for 'lifetime', i.e. lifetime in each [[period]]?"),
    # a variant entry can only change the processing: the spectra's keys are the instrument's
    (A, '{ name = "raise5", threshold_raise_percent = 5.0 }', '{ name = "raise5", focus = 5.0 }',
     "lidar.variants[0] ('raise5')", "did you mean lidar.instrument.focus for 'focus'?"),
    # else the table's own closest key
    (A, "noise_std = 0.02", "noise_sd = 0.02", "sonic", "(did you mean 'noise_std' for 'noise_sd'?)"),
    (A, "[sonic]", "[sonics]", "scene", "(did you mean 'sonic' for 'sonics'?)"),
    (A, "threshold_raise_percent = 5.0 }", "threshold_raise = 5.0 }", "lidar.variants[0] ('raise5')",
     "(did you mean 'threshold_raise_percent' for 'threshold_raise'?)"),
    (N, "[lidar]", "[platform]\nsurg = 1.0\n\n[lidar]", "platform", "(did you mean 'surge' for 'surg'?)"),
    (N, "[lidar]", "[platform]\nsurge = 1.0\nphase_deg = { surg = 3.0 }\n\n[lidar]", "platform.phase_deg",
     "(did you mean 'surge' for 'surg'?)"),
    (A, "gamma = 3.9", "gamma = 3.9\n" + CDL % "nois = 1", "turbulence.condition_on[0]",
     "(did you mean 'noise_std' for 'nois'?)"),
])
def test_an_unknown_key_is_pointed_to_where_it_belongs(name, old, new, where, hint):
    msg = error_of(loads_scene, edit(name, old, new))
    assert msg.startswith(f"unknown key(s) in {where}: "), msg
    assert hint in msg, msg
    assert "; allowed: [" in msg and "\n" not in msg  # the table's keys, in one line
    assert not INTERNAL_RE.search(msg), msg


def test_a_key_far_from_every_key_gets_no_guess_from_another_table():
    # 'colour' is near 'columns' of turbulence.condition_on: no guess across the scene from the top
    msg = error_of(loads_scene, edit(A, "seed = 2012", "seed = 2012\ncolour = 3"))
    assert "did you mean" not in msg and msg.startswith("unknown key(s) in scene: ['colour']")


CAMPAIGN = 'name = "c"\nbase = "{base}"\n'


@pytest.mark.parametrize("text, path, hint", [
    (CAMPAIGN.format(base="a2012") + '[set]\n"lidar.cnr" = 1.0\n',
     "campaign [set]: scene key 'lidar.cnr': unknown key(s) in lidar: ['cnr']", "'cnr_db' for 'cnr'"),
    (CAMPAIGN.format(base="a2012") + '[set]\n"lidar.focus" = 60.0\n',
     "campaign [set]: scene key 'lidar.focus': unknown key(s) in lidar: ['focus']",
     "lidar.instrument.focus for 'focus'"),
    (CAMPAIGN.format(base="a2012") + '[[sweep]]\n"period.0.mean_sped" = [8.0]\n',
     "campaign sweep[0]: scene key 'period.0.mean_sped': unknown key(s) in period[0]: ['mean_sped']",
     "'mean_speed' for 'mean_sped'"),
    (CAMPAIGN.format(base="cs") + '[[sweep]]\n"lidar.cnr_db" = [-10.0]\n[[sweep]]\n"scan.hieghts" = [[40.0]]\n',
     "campaign sweep[1]: scene key 'scan.hieghts': unknown key(s) in scan: ['hieghts']",
     "'heights' for 'hieghts'"),
    (CAMPAIGN.format(base="nacelle") + '[set]\n"lidar.variants.0.estimator" = "mode"\n',
     "lidar.variants[0] ('median').estimator='mode'", None),
    (CAMPAIGN.format(base="a2012") + '[[sweep]]\n"period.0.mean_speed" = [-9.0]\n',
     "period[0] ('A').mean_speed=-9.0 is out of range", None),
    (CAMPAIGN.format(base="a2012") + "replica = 2\n", "unknown key(s) in campaign: ['replica']",
     "'replicas' for 'replica'"),
    (CAMPAIGN.format(base="a2012") + '[[sweep]]\n"lidar.cnr_db" = { start = -20.0, stop = -10.0, nmu = 3 }\n',
     "unknown key(s) in sweep key 'lidar.cnr_db': ['nmu']", "'num' for 'nmu'"),
])
def test_a_campaign_names_the_key_it_set_or_swept(text, path, hint):
    msg = error_of(lambda t: expand(loads_campaign(t)), text)
    assert path in msg, msg
    assert msg.count(path) == 1 and "\n" not in msg and not INTERNAL_RE.search(msg) and not DOUBLED.search(msg), msg
    if hint:
        assert f"(did you mean {hint}" in msg, msg


def test_campaign_dotted_keys_that_exist_are_accepted():
    text = (CAMPAIGN.format(base="a2012") + '[[sweep]]\n"lidar.instrument.estimator" = ["peak"]\n'
            '"lidar.variants.0.threshold_raise_percent" = [3.0]\n"period.0.mean_speed" = [9.0]\n')
    (task,) = expand(loads_campaign(text))
    assert task.scene.lidar.build_instrument().estimator == "peak"
    assert task.scene.lidar.variants[0]["threshold_raise_percent"] == 3.0 and task.scene.periods[0].mean_speed == 9.0


def test_doppler_set_names_the_closest_instrument_field(capsys):
    assert cli.main(["doppler", "--speed", "5", "--cnr", "-10", "--n", "4", "--set", "focs=60"]) == 2
    err = capsys.readouterr().err
    assert "--set focs: unknown instrument field (did you mean 'focus' for 'focs'?)" in err, err
