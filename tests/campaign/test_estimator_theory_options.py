"""Scene options of issue 13: the estimator theory's size, the instrument's line broadening."""

import math

import pytest

from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.periods.staring import _subcell_spread, estimator_theory
from cwlidar_sim.turbulence import subcell_variance

BASE = """
name = "t"
[turbulence]
alpha_eps = 0.06
length_scale = 18.76
gamma = 3.9
[lidar]
tier = "{tier}"
{lidar}
[analysis]
segment_duration = 300.0
{analysis}
[[period]]
name = "P"
mean_speed = 8.0
"""


def scene(tier="spectral", lidar="", analysis=""):
    return loads_scene(BASE.format(tier=tier, lidar=lidar, analysis=analysis))


def test_line_broadening_adds_to_the_subcell_spread_in_quadrature():
    s = scene(lidar="line_broadening = 1.0e6")
    p = s.turbulence.params()
    dv = 0.5 * s.lidar.build_instrument().wavelength * 1.0e6       # 0.774 m/s per MHz
    assert dv == pytest.approx(0.7738, rel=1e-3)
    assert _subcell_spread(s, p) == pytest.approx(math.sqrt(subcell_variance(p, s.field.dx) + dv**2), rel=1e-12)
    # default: the field's own, the tensor's variance below the grid, as the sensor takes it
    assert _subcell_spread(scene(), p) == pytest.approx(math.sqrt(subcell_variance(p, s.field.dx)), rel=1e-12)


@pytest.mark.parametrize("text, match", [
    ("line_broadening = -1.0", "lidar.line_broadening"),
    ("line_broadening = 1e7", "lidar.line_broadening"),
])
def test_line_broadening_out_of_range(text, match):
    with pytest.raises(ValueError, match=match):
        scene(lidar=text)


def test_theory_only_when_asked_and_for_a_tier_with_an_estimator():
    p = scene().turbulence.params()
    assert estimator_theory(scene(analysis="estimator_theory_lines = 0"), p) is None
    assert estimator_theory(scene(tier="los"), p) is None
    with pytest.raises(ValueError, match="analysis.estimator_theory_lines"):
        scene(analysis="estimator_theory_lines = -1")
