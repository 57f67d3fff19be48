"""The lattice theory beside the continuum in a conical scene's results (campaign/periods/lattice_theory.py)."""

import dataclasses
import math

import numpy as np
import pytest

from cwlidar_sim.campaign.execution.reproduce import bundled_scene
from cwlidar_sim.campaign.figures.conical import plot_std_ratio
from cwlidar_sim.campaign.periods import conical, conical_theory as ct, lattice_theory as lat
from cwlidar_sim.sensors import Cup


def _scene(duration=60.0):
    cs = bundled_scene("cs")
    return cs.replace(scan=dataclasses.replace(cs.scan, heights=(40.0,), periods_per_height=(), theory="lattice"),
                      periods=cs.periods[:1], lidar=dataclasses.replace(cs.lidar, tier="los"), duration=duration)


def test_sparse_rows():
    r = lat.sparse_rows(562)
    assert r[0] == 1 and r[-1] == 562 and np.all(np.diff(r) > 0)
    assert np.array_equal(r[:lat.DENSE_ROWS], np.arange(1, lat.DENSE_ROWS + 1))
    assert np.all(r[lat.DENSE_ROWS:-1] / r[lat.DENSE_ROWS - 1:-2] < 1.13)  # about ROW_RATIO apart (rounded)
    assert r.size < 70
    np.testing.assert_array_equal(lat.sparse_rows(10), np.arange(1, 11))


@pytest.mark.slow  # about 100 s on 2 loaded cores (every row of the box)
def test_sparse_rows_move_the_ratios_by_less_than_the_stated_accuracy():
    """The CS scene's 40-m lidar and cup over the box of a 60-s period (320 x 136 x 60 at 2 m): the lines on
    sparse rows (44 of 160) against every row move the std ratios and sigmas by < 1e-4 (the attributes'
    accuracy_ratio; measured here 1e-5, for 600-s boxes 8e-5 at 100 m)."""
    scene = _scene()
    lidar, z = ct.scene_lidar(scene, 0, 2.0)
    params = scene.turbulence.params(z, 8.0)
    cup = Cup(position=(0.0, 0.0, z))
    args = (lidar, z, 8.0, 60.0, params, (1, 3), cup, (320, 136, 60), (2.0, 2.0, 2.0))
    full = lat.unit_lattice_theory(*args, all_rows=True)
    sparse = lat.unit_lattice_theory(*args)
    assert sparse["rows"] < 0.3 * full["rows"]
    assert abs(sparse["cup_std"] / full["cup_std"] - 1.0) < 1e-4
    for n in (1, 3):
        assert abs(sparse["scans"][n]["std_ratio"] - full["scans"][n]["std_ratio"]) < 1e-4
        assert abs(sparse["scans"][n]["lidar_std"] / full["scans"][n]["lidar_std"] - 1.0) < 1e-4


def test_results_carry_the_lattice_beside_the_continuum(monkeypatch):
    """A tier-los unit with the theory carries *_theory_lattice in the unit and the summary, its attributes naming
    the generated box (shape laterally doubled, spacing, correction) and the lattice's numerics; the lattice is the
    theory of the row's own box and cup node, and differs from the continuum by the box's effect (a few 0.01 at
    most for a 60-s box)."""
    monkeypatch.setattr(ct, "N_START", 5)
    monkeypatch.setattr(ct, "TOL", 2e-2)
    scene = _scene()
    unit = conical.run_unit(scene, 0)
    s = conical.summarise(unit)
    for v in lat.LATTICE_VARS:
        assert v in unit and f"{v}_unit" in s
        assert v in s and s[v].dims == s[v.replace("_lattice", "")].dims
    a = s.std_ratio_theory_lattice.attrs
    assert a["theory_box"].startswith("lattice: the unit's box 320x136x60 at 2/2/2 m")
    assert "laterally doubled" in a["theory_box"] and "cell correction" in a["theory_box"]
    assert a["theory_weighting"] == "exact" and "theory_numerics" not in a and "theory_lattice_numerics" in a
    assert "theory_u" not in a and "theory_u" in s.std_ratio_theory.attrs  # the lattice is never interpolated in U
    lidar, z = ct.scene_lidar(scene, 0, 2.0)
    direct = lat.unit_lattice_theory(lidar, z, 8.0, 60.0, scene.turbulence.params(z, 8.0), (1, 3),
                                     Cup(position=(0.0, float(unit.in_situ_y[0]), float(unit.in_situ_height[0]))),
                                     (320, 136, 60), (2.0, 2.0, 2.0))
    assert float(s.std_ratio_theory_lattice[0, 0]) == pytest.approx(direct["scans"][1]["std_ratio"], rel=1e-12)
    assert float(s.cup_std_theory_lattice[0]) == pytest.approx(direct["cup_std"], rel=1e-12)
    box_effect = s.std_ratio_theory_lattice.values - s.std_ratio_theory.values
    assert np.all(np.abs(box_effect) < 0.03) and np.all(np.abs(box_effect) > 1e-4)
    labels = [t.get_text() for t in plot_std_ratio(s).axes[0].get_legend().get_texts()]
    assert sum("linear theory (lattice)" in t for t in labels) == s.sizes["scan_s"]  # the figure draws it


def test_no_lattice_for_a_conditioned_box():
    """A box conditioned on records (or read from a file) is not the Mann lattice's ensemble: NaN, and why."""
    scene = _scene()
    row = {"box_shape": (320, 68, 60), "lateral_doubling": True, "box_spacing": (2.0, 2.0, 2.0),
           "in_situ_position": (0.0, 0.0, 40.0), "theory_attrs": {"theory_weighting": "exact"}}
    lat.add_lattice_theory([row], scene, 0, scene.turbulence.params(40.0, 8.0), 2.0, condition=lambda box: box)
    dv = lat.unit_variables([row], [1, 3], "60-s")
    assert set(dv) == set(lat.LATTICE_VARS)
    assert np.all(np.isnan(dv["std_ratio_theory_lattice"][1])) and math.isnan(dv["cup_std_theory_lattice"][1][0])
    assert "not computed" in dv["std_ratio_theory_lattice"][2]["theory_box"]
    assert lat.unit_variables([{"theory_attrs": {}}], [1], "60-s") == {}  # no theory asked: nothing
