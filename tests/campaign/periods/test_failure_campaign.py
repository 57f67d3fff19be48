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


def test_near_zero_estimates_are_not_available_and_never_averaged():
    """U = 1 m/s at 25 deg to the beam (0.91 m/s along it): about a quarter of the estimates fall within the
    prototype's 0.5 m/s edge guard of its 0.5 m/s blind zone (below 1 m/s), finite but flagged NEAR_ZERO.  They are
    not counted and do not enter the 10 Hz series."""
    sc = bundled_scene("a2012")
    (pc,) = [p for p in sc.periods if p.name == "C"]
    lid = dataclasses.replace(sc.lidar, variants=({"name": "centroid", "estimator": "centroid"},))
    # weak turbulence (sigma_u = 0.4 m/s, an intensity 0.4 the frozen field can carry) at U = 1 m/s
    turb = dataclasses.replace(sc.turbulence, alpha_eps=0.01)
    sc = sc.replace(duration=20.0, periods=(dataclasses.replace(pc, duration=None, mean_speed=1.0,
                                                                        misalignment_deg=25.0),), lidar=lid,
                    turbulence=turb, analysis=dataclasses.replace(sc.analysis, segment_duration=10.0, fit=False))
    ds = run_scene(sc, progress=False)
    speed = ds["lidar_speed"].values[0].astype(np.float64)
    flags = ds["lidar_flags"].values[0]
    near = (flags & np.uint8(Flag.NEAR_ZERO)) != 0
    finite = np.isfinite(speed)
    assert (near & finite).sum() > 0.2 * speed.size  # the case the test is about: many finite flagged estimates
    usable = finite & ((flags & np.uint8(Flag.NEAR_ZERO | Flag.NEAR_NYQUIST)) == 0)
    assert ds["availability"].values[0] == usable.mean() < finite.mean()
    counts = dict(zip(ds["flag"].values, ds["flag_count"].values[0]))
    assert counts["NEAR_ZERO"] == near.sum()
    # the 10 Hz mean of each block of 5 is over its usable estimates only; a block with none is NaN
    blocks = np.where(usable, speed, np.nan).reshape(-1, 5)
    n_ok = usable.reshape(-1, 5).sum(axis=1)
    want = np.full(blocks.shape[0], np.nan)
    want[n_ok > 0] = np.nansum(blocks[n_ok > 0], axis=1) / n_ok[n_ok > 0]
    np.testing.assert_allclose(ds["lidar_10hz"].values[0], want, rtol=1e-6, equal_nan=True)
    assert np.array_equal(ds["lidar_10hz_valid"].values[0], n_ok)
    assert ds["availability_10hz"].values[0] == (n_ok > 0).mean()
    # the variant: the same definition on its own estimates
    vs = ds["lidar_10hz_variant"].values[0, 0]
    assert 0.0 < ds["availability_variant"].values[0, 0] < 1.0 and np.isnan(vs).any()


def test_a_fitted_tensor_too_strong_for_the_wind_is_refused_before_the_field(monkeypatch):
    """With fit_to the tensor is known only when the run starts: run_unit checks it before planning a field."""
    import pytest

    from cwlidar_sim.campaign.periods import staring
    from cwlidar_sim.turbulence import MannParameters

    def no_field(*a, **k):
        raise AssertionError("a field was planned")

    monkeypatch.setattr(staring, "plan_field", no_field)
    sc = bundled_scene("a2012", quick=True)
    with pytest.raises(ValueError, match=r"period\[0\] \('A'\): the tensor alpha_eps=1000 .* Taylor"):
        staring.run_unit(sc, 0, MannParameters(1e3, 18.76, 3.9))
