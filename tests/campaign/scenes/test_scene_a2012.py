"""The bundled a2012 scene explains every key it sets, and its comments changed nothing of the scene.

The commented file must parse to the very scene of the uncommented one below
(its keys and values as they were before the comments were written), with the
same identity (:func:`cwlidar_sim.campaign.execution.store.scene_digest`): results stored
by earlier runs stay valid.
"""

import re

from cwlidar_sim.campaign.execution.reproduce import bundled_scene, bundled_text
from cwlidar_sim.campaign.scenes.load import loads_scene
from cwlidar_sim.campaign.execution.store import scene_digest

#: a2012.toml's keys and values before its keys were commented.
UNCOMMENTED = '''
name = "a2012"
description = "A2012: staring ZephIR prototype against a sonic at its 67.5 m focus, four 1-h periods"
seed = 2012
duration = 3600.0
[turbulence]
alpha_eps = 0.06224407174474577
length_scale = 18.76
gamma = 3.9
[lidar]
preset = "prototype"
tier = "spectral"
cnr_db = -10.0
weighting = "exact"
span = 20.0
instrument = { focus = 67.5, estimator = "median" }
variants = [
    { name = "raise5", threshold_raise_percent = 5.0 },
    { name = "raise10", threshold_raise_percent = 10.0 },
    { name = "raise20", threshold_raise_percent = 20.0 },
    { name = "centroid", estimator = "centroid" },
    { name = "peak", estimator = "peak" },
]
[sonic]
noise_std = 0.02
[field]
kind = "auto"
dx = 0.5
dy = 0.5
[analysis]
segment_duration = 600.0
k_min = 0.001
k_max = 5.0
per_decade = 10
fit = true
[[period]]
name = "A"
mean_speed = 8.5
misalignment_deg = 6.0
[[period]]
name = "B"
mean_speed = 7.6
misalignment_deg = 3.5
[[period]]
name = "C"
mean_speed = 8.1
misalignment_deg = 1.2
[[period]]
name = "D"
mean_speed = 9.0
misalignment_deg = -2.5
'''


def test_the_commented_a2012_scene_is_the_scene_it_was():
    old, new = loads_scene(UNCOMMENTED), bundled_scene("a2012")
    assert new == old and new.as_dict() == old.as_dict()
    params = old.turbulence.params()
    assert scene_digest(new, new.turbulence.params()) == scene_digest(old, params)


def test_every_key_of_a2012_is_commented():
    """Each line that sets a key (or a variant) has a comment on it, or on the line just above it."""
    lines = bundled_text("a2012").splitlines()
    keyed = [i for i, line in enumerate(lines) if re.match(r"\s*([A-Za-z_]+\s*=|\{ name =)", line)]
    assert len(keyed) == 40  # 4 at the top, 3 + 7 + 5 variants + 1 + 3 + 5 in the tables, 4 periods x 3
    bare = [lines[i] for i in keyed if "#" not in lines[i] and not lines[i - 1].lstrip().startswith("#")]
    assert not bare, bare
