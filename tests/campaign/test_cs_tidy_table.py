"""The CS table (docs/reproductions/cs.md, README) from the tidy statistics CSV alone, with pandas.

The CS page's table is built from the results file: per height and scan length, the lidar/cup standard
deviation ratio's mean and standard error over the periods that pass CS's selection (``std_ratio``,
``std_ratio_sigma``: :func:`cwlidar_sim.campaign.periods.conical.summarise`), the filter models' means
over every period, and the radial-variance ratio's mean and standard error.  A user with only
``<scene>.stats.csv`` gets the same numbers, to round-off, from the per-period rows.
"""

import numpy as np
import pandas as pd

from cwlidar_sim.campaign import bundled_scene, run_scene
from cwlidar_sim.campaign.registry import kind_of


def test_the_cs_table_from_the_tidy_csv_is_the_netcdf_table(tmp_path):
    cs = bundled_scene("cs")
    scene = kind_of(cs).quick(cs).with_values({"duration": 60.0, "lidar.tier": "los", "scan.heights": [40.0, 100.0],
                                               "scan.spacing": 4.0})
    ds = run_scene(scene, tmp_path, progress=False)
    df = pd.read_csv(tmp_path / f"{scene.name}.stats.csv")
    wide = df[df.statistic == "value"].pivot_table(index=["unit", "height_m", "scan_s"], columns="quantity",
                                                   values="value", aggfunc="first").reset_index()
    assert len(wide) == len(ds.period) * len(ds.scan_s)
    checked = 0
    for (z, s), g in wide.groupby(["height_m", "scan_s"]):
        iz, js = list(ds.height.values).index(z), list(ds.scan_s.values).index(s)
        sel = g[g.selected_unit > 0.5]
        for var in ("std_ratio", "radial_variance_ratio"):
            x = sel[f"{var}_unit"].dropna()
            np.testing.assert_allclose(x.mean(), ds[var].values[iz, js], rtol=1e-12)
            np.testing.assert_allclose(x.std(ddof=1) / np.sqrt(x.size), ds[f"{var}_sigma"].values[iz, js], rtol=1e-10)
            assert int(ds["n_selected"].values[iz, js]) == sel["std_ratio_unit"].notna().sum()
        for var in ("std_ratio_model", "std_ratio_model_mann"):  # the filter models: over every period
            np.testing.assert_allclose(g[f"{var}_unit"].mean(), ds[var].values[iz, js], rtol=1e-12)
        checked += 1
    assert checked == len(ds.height) * len(ds.scan_s) == 4
    # the cup and the sonic are rows of their own instruments, one per period and height
    cup = df[(df.quantity == "cup_std_unit")]
    assert set(cup.instrument) == {"cup"} and len(cup) == len(ds.period)
    np.testing.assert_array_equal(cup.value.values, ds["cup_std_unit"].values)
