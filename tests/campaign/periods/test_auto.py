"""The automatic fidelity choice (campaign/periods/staring_auto.py): the cheapest setting within the chart's tolerance."""

import dataclasses
import json
import math

import pytest

from cwlidar_sim.campaign import Scene, bundled_scene, run_scene
from cwlidar_sim.campaign.periods.staring_auto import CELL_MAX_PER_ZR, CHART, DX_MAX_PER_ZR, TOLERANCE, resolve


def _auto(scene, **lidar):
    lid = dataclasses.replace(scene.lidar, tier="auto", cell_length="auto", **lidar)
    return scene.replace(lidar=lid, field=dataclasses.replace(scene.field, dx="auto"))


def _bare(scene):
    """No Doppler processing asked for: no variants, no estimator override."""
    return scene.replace(lidar=dataclasses.replace(scene.lidar, variants=(), instrument={"focus": 67.5}))


A2012 = bundled_scene("a2012")


def test_rule_constants_follow_the_chart():
    # within the tolerance (the reference's seed-to-seed scatter): dx up to 1 m, cells up to 4 m; not: tier 1
    assert all(CHART[k][1] <= TOLERANCE for k in ("plane dx.5 dy.5", "plane dx1 dy1", "cells 4 m"))
    assert CHART["los tier"][1] > TOLERANCE
    # and each chosen one is cheaper than the settings it replaces
    assert CHART["cells 4 m"][0] < CHART["plane dx.5 dy.5"][0] < CHART["plane dx.25 dy.25 c.25 (reference)"][0]
    assert DX_MAX_PER_ZR * 5.61 == pytest.approx(1.0) and CELL_MAX_PER_ZR * 5.61 == pytest.approx(4.0)


def test_tier_follows_what_the_scene_asks():
    sc, why = resolve(_auto(A2012))  # five variants and a median estimator
    assert sc.lidar.tier == "spectral" and "variant" in why["lidar.tier"]
    sc, why = resolve(_auto(_bare(A2012)))
    assert sc.lidar.tier == "los" and "noise-free" in why["lidar.tier"]
    for change in ({"instrument": {"focus": 67.5, "threshold_raise_percent": 10.0}},
                   {"instrument": {"focus": 67.5, "estimator": "centroid"}},
                   {"background_pause": True}, {"exact_background": True}):
        sc, why = resolve(_auto(_bare(A2012), **change))
        assert sc.lidar.tier == "spectral", change
    # tier 3 is never chosen
    assert all(resolve(_auto(s))[0].lidar.tier != "signal" for s in (A2012, _bare(A2012)))


def test_field_spacing_is_the_coarsest_within_both_limits():
    # A2012: z_R = 5.61 m -> dx <= 1 m; analysis to min(5, pi 10 / 7.6) = 4.13 rad/m -> dx <= 0.76 m: 0.5 m
    sc, why = resolve(_auto(A2012))
    assert sc.field.dx == 0.5 and "0.5 m" in why["field.dx"]
    # the same with the analysis to 3 rad/m: pi/dx >= 3 -> dx <= 1.05 m, and dx <= 1 m: 1 m
    a3 = _auto(A2012).replace(analysis=dataclasses.replace(A2012.analysis, k_max=3.0))
    assert resolve(a3)[0].field.dx == 1.0
    # a far focus (z_R grows as r^2) and an analysis to 1 rad/m: dx <= 4.9 m and pi/dx >= 1 -> 2 m
    far = _auto(A2012, instrument={"focus": 150.0, "estimator": "median"})
    far = far.replace(analysis=dataclasses.replace(far.analysis, k_max=1.0))
    zr = far.lidar.build_instrument().rayleigh_length
    assert DX_MAX_PER_ZR * zr > 2.0
    assert resolve(far)[0].field.dx == 2.0
    # the same focus with the analysis to the sonic's 10-Hz Nyquist (pi 10 / 7.6 = 4.1 rad/m): dx <= 0.76 -> 0.5
    far5 = far.replace(analysis=dataclasses.replace(far.analysis, k_max=5.0))
    assert resolve(far5)[0].field.dx == 0.5
    # a short focus: z_R = 1.4 m -> dx <= 0.25 m: the ladder's finest step
    near = _auto(A2012, instrument={"focus": 33.75, "estimator": "median"})
    assert resolve(near)[0].field.dx == 0.25


def test_cells_are_the_longest_within_tolerance_only_for_continuum_speckle():
    sc, why = resolve(_auto(A2012))
    zr = A2012.lidar.build_instrument().rayleigh_length
    assert sc.lidar.cell_length == math.floor(CELL_MAX_PER_ZR * zr / 0.5) * 0.5 == 4.0
    sc, why = resolve(_auto(A2012, speckle="independent"))
    assert sc.lidar.cell_length is None and "point cells" in why["lidar.cell_length"]
    sc, _ = resolve(_auto(_bare(A2012)))  # tier 1
    assert sc.lidar.cell_length is None


def test_scenes_without_auto_are_untouched_and_auto_round_trips():
    sc, why = resolve(A2012)
    assert sc is A2012 and why == {}
    s = _auto(A2012)
    back = Scene.from_dict(s.as_dict())
    assert back == s and back.lidar.tier == "auto" and back.field.dx == "auto"
    with pytest.raises(ValueError, match="lidar.tier"):
        dataclasses.replace(A2012.lidar, tier="fast")
    with pytest.raises(TypeError, match="field.dx"):
        dataclasses.replace(A2012.field, dx="coarse")


def test_the_run_says_what_it_chose_and_why():
    (pc,) = [p for p in A2012.periods if p.name == "C"]
    sc = _auto(_bare(A2012)).replace(duration=20.0, periods=(dataclasses.replace(pc, duration=None),),
                                     analysis=dataclasses.replace(A2012.analysis, segment_duration=10.0, fit=False))
    lines = []
    ds = run_scene(sc, progress=False, log=lines.append)
    assert any(line.startswith("lidar.tier = los") for line in lines)
    assert any(line.startswith("field.dx = 0.5 m") for line in lines)
    chosen = json.loads(ds.attrs["auto_choice"])
    assert set(chosen) == {"lidar.tier", "field.dx", "lidar.cell_length"}
    assert ds.attrs["lidar_tier"] == "los"
    assert json.loads(ds.attrs["scene"])["field"]["dx"] == 0.5
