"""A staring period where nothing is left (docs/stability.md): NaN, flagged and counted, never a crash."""

import dataclasses

import numpy as np

from cwlidar_sim.campaign import bundled_scene, run_scene
from cwlidar_sim.signal.processing import Flag


def test_period_with_no_signal_is_all_nan_flagged_and_counted():
    sc = bundled_scene("a2012")
    (pc,) = [p for p in sc.periods if p.name == "C"]
    # the lowest CNR a scene accepts and a 6-sigma threshold: no estimate survives, no false alarm either
    lid = dataclasses.replace(sc.lidar, cnr_db=-40.0, variants=({"name": "centroid", "estimator": "centroid"},),
                              instrument={"focus": 67.5, "estimator": "median", "threshold_value": 6.0})
    sc = sc.replace(duration=20.0, periods=(dataclasses.replace(pc, duration=None),), lidar=lid,
                    analysis=dataclasses.replace(sc.analysis, segment_duration=10.0, fit=False))
    ds = run_scene(sc, progress=False)
    n50 = ds.sizes["time_50hz"]
    assert np.all(np.isnan(ds["lidar_speed"].values)) and np.all(np.isnan(ds["lidar_10hz"].values))
    assert np.all(ds["lidar_flags"].values & np.uint8(Flag.NO_SIGNAL))
    counts = dict(zip(ds["flag"].values, ds["flag_count"].values[0]))
    assert counts["NO_SIGNAL"] == n50
    assert ds["availability"].values[0] == 0.0 and ds["availability_variant"].values[0, 0] == 0.0
    assert np.all(ds["lidar_10hz_valid"].values == 0)
    # no usable segment: both methods NaN in every bin, the segments counted as rejected
    for v in ("transfer_ratio", "transfer_cross", "transfer_ratio_variant", "transfer_cross_variant"):
        assert np.all(np.isnan(ds[v].values)), v
    assert ds["n_segments"].values[0] == 0 and ds["n_segments_rejected"].values[0] == 2
    # the noise-free tier-1 reference of the same period is unaffected
    assert np.isfinite(ds["transfer_cross_ideal"].values).any()
