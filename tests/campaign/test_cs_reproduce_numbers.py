"""The CS page's numbers are those ``cwlidar-sim reproduce cs`` wrote (docs/cs_reproduce.json), at their stated rounding.

studies/cs_reproduce.py summarises the run (minutes, too long for the suite); these tests hold the
table of docs/reproductions/cs.md and its claims about the standard errors to the JSON, and the bundled
scene's plan of periods per height to the plan the JSON was run with (the README's summary of it is
generated: tests/test_readme.py).
"""

import json
import os
import re

from cwlidar_sim.campaign import bundled_scene

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CELL = r"\**([\d.]+) ± ([\d.]+)\** \(([\d.]+) / ([\d.]+); theory ([\d.]+)\)"
ROW = re.compile(rf"^\| (\d+) m \| (\d+) \| {CELL} \| {CELL} \| ([\d.]+) ± ([\d.]+) \|$", re.M)


def _load():
    with open(os.path.join(ROOT, "docs", "cs_reproduce.json")) as f:
        res = json.load(f)
    with open(os.path.join(ROOT, "docs", "cs_theory.json")) as f:
        res["theory"] = json.load(f)
    with open(os.path.join(ROOT, "docs", "reproductions", "cs.md"), encoding="utf-8") as f:
        page = f.read()
    return res, page


def test_page_table_is_the_run():
    """Every number of the CS page's table (3 decimals) is the JSON's (the simulation's, and the linear theory's of
    docs/cs_theory.json over the same periods), and every height is there."""
    res, page = _load()
    rows = {m.group(1): m.groups()[1:] for m in ROW.finditer(page)}
    assert sorted(rows, key=float) == sorted(res["heights"], key=float) == ["40", "60", "80", "100"]
    for z, cells in rows.items():
        h = res["heights"][z]
        assert int(cells[0]) == h["periods"] == h["n_periods"] == res["plan"][z], z
        t = res["theory"]["heights"][z]
        assert t["periods"] == h["periods"], z
        want = []
        for s in ("1s", "3s"):
            want += [h[f"std_ratio_{s}"], h[f"std_ratio_{s}_se"], h[f"std_ratio_{s}_model_kaimal"],
                     h[f"std_ratio_{s}_model_mann"], t[f"std_ratio_{s}_theory"]]
        want += [h["radial_variance_ratio_1s"], h["radial_variance_ratio_1s_se"]]
        assert [float(c) for c in cells[1:]] == [round(w, 3) for w in want], z


def test_standard_errors_are_as_the_page_says():
    """The acceptance: every std ratio's standard error <= 0.01, over every period of the plan."""
    res, page = _load()
    assert not res["quick"] and res["se_target"] == 0.01
    worst = max(max(h["std_ratio_1s_se"], h["std_ratio_3s_se"]) for h in res["heights"].values())
    assert worst == res["largest_std_ratio_se"]
    assert res["se_target_met"] == (worst <= 0.01)
    assert f"largest {worst:.4f}" in page
    assert ("every standard error is at most 0.01" in page.lower()) == res["se_target_met"]
    for h in res["heights"].values():  # every period passed CS's selection, so the errors are over all of them
        assert h["n_selected_1s"] == h["n_selected_3s"] == h["periods"]


def test_the_bundled_scene_runs_the_plan_of_the_json():
    res, _ = _load()
    scene = bundled_scene("cs")
    assert {f"{z:g}": n for z, n in scene.periods_at().items()} == res["plan"]
    assert len(scene.unit_names()) == res["units"] == sum(res["plan"].values())
    assert sum(c["units"] for c in res["cost"].values()) == res["units"]
