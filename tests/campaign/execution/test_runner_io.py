"""Runner outputs: results file, units, determinism (local and Dask), CLI, fit_to, background pause."""

import json
import math

import numpy as np
import pytest

from cwlidar_sim.campaign import load_scene, loads_scene, read_results, run_scene
from cwlidar_sim.cli import main

TEXT = """
name = "io"
seed = 3
duration = 600.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "los"
[analysis]
segment_duration = 300.0
fit = false
[[period]]
name = "aligned"
mean_speed = 8.0
[[period]]
name = "turned"
mean_speed = 6.0
misalignment_deg = 3.0
"""


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    ds = run_scene(loads_scene(TEXT), out, progress=False)
    return ds, out


def test_results_file_layout(result):
    ds, out = result
    back = read_results(out / "io.nc")
    for name in ("transfer_ratio", "transfer_cross"):
        assert back[name].dims == ("period", "k")
    assert back["transfer_theory"].dims == ("k",)
    assert back["k"].attrs["units"] == "rad m-1"
    assert abs(back.attrs["rayleigh_length"] - 5.61) < 0.01
    assert list(back.period.values) == ["aligned", "turned"]
    assert list(back.field_kind.values) == ["line", "plane"]
    # every physical variable carries units; flags carry their meanings
    for name, var in back.data_vars.items():
        if name in ("field_kind", "field_shape", "field_seed"):
            continue
        assert "units" in var.attrs or "flag_meanings" in var.attrs, name
    assert json.loads(back.attrs["scene"]) == loads_scene(TEXT).as_dict()
    np.testing.assert_array_equal(back.transfer_cross.values, ds.transfer_cross.values)
    # raw and 10 Hz series of both sensors
    assert back.sonic_velocity.shape == (2, 600 * 32, 3)
    assert back.lidar_speed.shape == (2, 600 * 50) and back.lidar_10hz.shape == (2, 6000)


def test_sonic_and_lidar_are_consistent(result):
    ds, _ = result
    U = ds.mean_speed.values
    th = np.radians(ds.misalignment.values)
    for p in range(2):
        # radial speed toward the lidar: U cos(theta) plus fluctuations of a few tenths
        assert abs(np.nanmean(ds.sonic_10hz[p]) - U[p] * math.cos(th[p])) < 0.5
        assert abs(np.nanmean(ds.lidar_10hz[p]) - U[p] * math.cos(th[p])) < 0.5
    # noise-free tier 1: the lidar is the weighted average of what the sonic sees at its focus
    assert np.corrcoef(ds.lidar_10hz[0], ds.sonic_10hz[0])[0, 1] > 0.9


def test_same_seed_same_bits_local_and_dask(result):
    ds, _ = result
    again = run_scene(loads_scene(TEXT), progress=False)
    np.testing.assert_array_equal(again.lidar_speed.values, ds.lidar_speed.values)
    np.testing.assert_array_equal(again.sonic_velocity.values, ds.sonic_velocity.values)
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = run_scene(loads_scene(TEXT), client=client, progress=False)
    np.testing.assert_array_equal(remote.lidar_speed.values, ds.lidar_speed.values)
    np.testing.assert_array_equal(remote.transfer_cross.values, ds.transfer_cross.values)


def test_background_pause_is_flagged_and_counted():
    text = TEXT.replace('name = "turned"\nmean_speed = 6.0\nmisalignment_deg = 3.0', 'name = "turned"\nmean_speed = 6.0\nstart = 10500.0')
    text = text.replace('name = "aligned"', 'name = "aligned"\nstart = 600.0')
    text = text.replace('tier = "los"', 'tier = "los"\nbackground_pause = true')
    ds = run_scene(loads_scene(text), progress=False)
    # the second period starts 300 s before the 3-h mark: its second half is the 10-min pause
    flags = list(ds.flag.values)
    n_paused = ds.flag_count.values[:, flags.index("PAUSED")]
    assert n_paused[0] == 0 and n_paused[1] == 300 * 50
    assert np.all(np.isnan(ds.lidar_speed[1].values[15000:]))
    assert ds.availability.values[1] == pytest.approx(0.5)
    assert list(ds.n_segments.values) == [2, 1] and list(ds.n_segments_rejected.values) == [0, 1]
    # a period that lies wholly in a pause has no spectra: NaN, counted, not an error
    whole = run_scene(loads_scene(text.replace("start = 600.0", "start = 0.0")), progress=False)
    assert np.all(np.isnan(whole.transfer_cross[0].values)) and whole.n_segments_rejected.values[0] == 2


def test_cli_run_report_and_errors(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(TEXT.replace('[[period]]\nname = "turned"\nmean_speed = 6.0\nmisalignment_deg = 3.0\n', ""))
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--no-progress"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["results"].endswith("io.nc")
    assert main(["report", str(out)]) == 0
    figs = {p.rsplit("/", 1)[-1] for p in json.loads(capsys.readouterr().out)["figures"]}
    assert figs >= {"spectra.png", "transfer_ratio.png", "transfer_cross.png", "methods.png"}
    assert "misalignment_5deg.png" not in figs  # the scene's one period is aligned
    bad = tmp_path / "bad.toml"
    bad.write_text(TEXT.replace("gamma = 3.9", "gamma = 3.9\nsigma = 1"))
    assert main(["run", str(bad), "--out", str(out)]) == 2
    assert "unknown key(s) in turbulence: ['sigma']" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "empty")]) == 2


def test_fit_to_a_sonic_record(tmp_path):
    """turbulence.fit_to: the parameters are fitted to a record; a long line's are recovered."""
    import xarray as xr

    from cwlidar_sim.turbulence import MannParameters, generate_line

    true = MannParameters(0.06, 20.0, 3.9)
    U, fs = 8.0, 10.0
    line = generate_line(true, 2**17, U / fs, 11, dtype=np.float64)  # one sample per grid point
    t = np.arange(2**17) / fs
    rec = xr.Dataset({c: ("time", line[c].values[::-1] + (U if c == "u" else 0.0)) for c in ("u", "v", "w")},
                     coords={"time": t})
    rec.to_netcdf(tmp_path / "sonic.nc", engine="h5netcdf")
    p = tmp_path / "s.toml"
    p.write_text(TEXT.replace("alpha_eps = 0.06\nlength_scale = 20.0\ngamma = 3.9", "fit_to = 'sonic.nc'"))
    from cwlidar_sim.campaign.periods.staring_field import scene_params

    fitted, info = scene_params(load_scene(p))
    for name in ("length_scale", "gamma", "alpha_eps"):
        err = abs(getattr(fitted, name) - getattr(true, name))
        assert err < 3 * info["std"][name], (name, getattr(fitted, name), info["std"][name])
