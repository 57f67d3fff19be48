"""The conical period's point sensors report their sub-grid variance and their sigma with it restored."""

import math

import pytest

from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
from kind_scenes import WINDSCANNER


def test_conical_period_reports_the_cup_and_sonic_below_the_grid():
    r = simulate_conical_period(20.0, 3, speed=8.0, duration=30.0, scan_revs=(1,), model=False)
    # the sonic misses more than the cup, whose response removes most of what the grid cannot hold
    assert 0 < r["cup_subgrid_variance"] < r["sonic_subgrid_variance"] < 0.5 * r["sonic_std"] ** 2  # a 30-s period: mostly small scales
    assert r["cup_std_continuum"] == pytest.approx(math.sqrt(r["cup_std"] ** 2 + r["cup_subgrid_variance"]))
    assert r["sonic_std_continuum"] == pytest.approx(math.sqrt(r["sonic_std"] ** 2 + r["sonic_subgrid_variance"]))
    s = r["scans"][1]
    assert s["std_ratio_cup_continuum"] == pytest.approx(s["lidar_std"] / r["cup_std_continuum"])
    assert s["std_ratio_cup_continuum"] < s["std_ratio"]


STARING = """
name = "t"
seed = 7
duration = 300.0
[turbulence]
alpha_eps = 0.0622
length_scale = 18.76
gamma = 3.9
[lidar]
tier = "los"
[analysis]
segment_duration = 300.0
fit = false
[[period]]
name = "P"
mean_speed = 8.0
misalignment_deg = {theta}
"""


@pytest.mark.parametrize("theta, kind", [(0.0, "line"), (10.0, "plane")])
def test_staring_sonic_reports_its_beam_projection_below_the_grid(theta, kind):
    """The staring sonic reads the wind along the beam: its 32-Hz series' sub-grid variance, in the period's field."""
    from cwlidar_sim.analysis.point_subgrid import point_subgrid_variance
    from cwlidar_sim.campaign import loads_scene, registry
    from cwlidar_sim.campaign.periods.staring_field import period_params, plan_field

    scene = loads_scene(STARING.format(theta=theta))
    ds = registry.kind_of(scene).run_unit(scene, 0)
    assert str(ds.field_kind.values[0]) == kind
    plan = plan_field(scene, 0, None)
    v = ds.sonic_velocity.values[0].astype(float)
    n = v.shape[0]
    # the raw sigma is the series' own: the sonic's 32 Hz wind projected on the beam
    assert float(ds.sonic_std[0]) == pytest.approx((v @ plan.direction).std(ddof=1), rel=1e-5)
    a = (plan.sonic_position[1] / plan.spacing[1]) % 1.0 if kind == "plane" else 0.0

    def expected(direction):
        r = point_subgrid_variance(period_params(scene, 0), 8.0, n / 32.0, kind, plan.shape, plan.spacing,
                                   direction=direction, offset=(a, 0.0), sample_interval=1 / 32.0)
        return r["subgrid"] * n / (n - 1)

    sub = float(ds.sonic_subgrid_variance[0])
    assert 0 < sub < 0.1 * float(ds.sonic_std[0]) ** 2
    assert sub == pytest.approx(expected(tuple(plan.direction)), rel=1e-6)
    if kind == "plane":  # a misaligned beam reads some v, whose sub-grid share is not u's
        assert abs(sub - expected((1.0, 0.0, 0.0))) > 1e-3 * sub
    assert float(ds.sonic_std_continuum[0]) == pytest.approx(math.sqrt(float(ds.sonic_std[0]) ** 2 + sub))
    assert "comment" not in ds.sonic_subgrid_variance.attrs




def test_windscanner_sonic_reports_each_component_below_the_grid():
    import numpy as np

    from cwlidar_sim.campaign import loads_scene, registry

    scene = loads_scene(WINDSCANNER)
    ds = registry.kind_of(scene).run_unit(scene, 0)
    sub = ds.sonic_subgrid_variance.values[0]
    std = ds.sonic_std.values[0]
    # at 4 m (a 30-s period) the box misses a large share of each component, each its own: more of v than of u
    # (the inertial range's transverse spectrum is 4/3 of the longitudinal one), w's unlike u's
    assert np.all(sub > 0) and np.all(sub < std ** 2)
    assert sub[1] > 1.02 * sub[0] and abs(sub[2] - sub[0]) > 0.05 * sub[0]
    assert np.allclose(ds.sonic_std_continuum.values[0], np.sqrt(std ** 2 + sub))
    assert np.allclose(ds.std_ratio_sonic_continuum.values[0], ds.wind_std.values[0] / np.sqrt(std ** 2 + sub),
                       equal_nan=True)


def test_a_field_not_generated_from_the_tensor_has_no_subgrid_variance_and_says_why():
    import xarray as xr

    from cwlidar_sim.campaign.periods.in_situ import field_subgrid_variance, subgrid_unavailable
    from cwlidar_sim.turbulence import MannParameters

    f = xr.Dataset(coords={"x": [0.0, 1.0], "y": [0.0, 1.0], "z": [0.0, 1.0]})
    p = MannParameters(alpha_eps=0.05, length_scale=5.0, gamma=3.0)
    assert math.isnan(field_subgrid_variance(f, (0.0, 0.0, 0.0), p, 8.0, 60.0))
    assert "read from a file" in subgrid_unavailable(f)
    f.attrs.update(generator="cwlidar_sim.turbulence.generate_box", sigma_u_target=1.0)
    assert "rescaled" in subgrid_unavailable(f)
    assert math.isnan(field_subgrid_variance(f, (0.0, 0.0, 0.0), p, 8.0, 60.0))


def test_conical_summary_gives_each_heights_mean_ratio_against_the_continuum_cup(tmp_path, monkeypatch):
    import numpy as np

    from cwlidar_sim.analysis import cs_model
    from cwlidar_sim.campaign import loads_scene, run_scene

    monkeypatch.setattr(cs_model, "model_ratios", lambda *a, **k: {"std_ratio": np.nan, "radial_variance_ratio": np.nan})
    sc = loads_scene("""
name = "c"
kind = "conical"
seed = 4
duration = 30.0
[scan]
heights = [20.0]
scan_revs = [1]
[lidar]
tier = "los"
[turbulence]
source = "fixed"
alpha_eps = 0.05
length_scale = 15.0
gamma = 3.9
[[period]]
name = "a"
mean_speed = 8.0
[[period]]
name = "b"
mean_speed = 9.0
""")
    ds = run_scene(sc, tmp_path, progress=False)
    unit = ds.std_ratio_cup_continuum_unit.values[:, 0]
    keep = ds.selected_unit.values[:, 0] > 0.5  # (period, scan_s)
    assert keep.any()
    assert float(ds.std_ratio_cup_continuum.values[0, 0]) == pytest.approx(float(np.mean(unit[keep])))
    # the continuum cup's sigma is the larger: the ratio against it is the lower
    assert float(ds.std_ratio_cup_continuum.values[0, 0]) < float(ds.std_ratio.values[0, 0])
    assert ds.std_ratio_cup_continuum_sigma.dims == ("height", "scan_s")
