"""Scene texts the tests of several kinds share (imported as ``kind_scenes``: tests/ is on the path)."""

#: A small tier-los WindScanner scene: 30 s, a 4-m box, 10-s segments, one period at 8 m/s.
WINDSCANNER = """
name = "ws"
kind = "windscanner"
seed = 4
duration = 30.0
[scanner]
spacing = 4.0
segment_duration = 10.0
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.05
length_scale = 33.6
gamma = 3.9
[[period]]
name = "a"
mean_speed = 8.0
"""
