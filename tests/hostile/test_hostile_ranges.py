"""Hostile corpus, area "ranges": physical ranges of the scene's parameters, and what availability counts.

A value in the wrong unit (a focus in km, a wavelength in nm, a radius in mm,
a rate in MHz) or turbulence the frozen-field model cannot carry is refused
before any computation, in one line that names the field, the value and the
reason; a measurement the instrument cannot make (within the edge guard of its
blind zone) runs, flagged, and is not counted as available.
"""

import json

import numpy as np
import pytest
import xarray as xr
from conftest import assert_one_line_error, run_cli

from cwlidar_sim.campaign.execution.reproduce import bundled_text

SCENE = """
name = "tiny"
seed = 1
duration = 20.0
[turbulence]
alpha_eps = {alpha_eps}
length_scale = {length_scale}
gamma = {gamma}
[lidar]
tier = "spectral"
instrument = {{ {instrument} }}
[field]
dx = 1.0
[analysis]
segment_duration = 10.0
fit = false
k_min = 0.05
k_max = 1.0
per_decade = 2
[[period]]
name = "A"
mean_speed = {mean_speed}
misalignment_deg = {misalignment}
"""


def scene_file(tmp_path, *, alpha_eps=0.06, length_scale=20.0, gamma=3.9, instrument='focus = 67.5',
               mean_speed=8.0, misalignment=0.0):
    path = tmp_path / "tiny.toml"
    path.write_text(SCENE.format(alpha_eps=alpha_eps, length_scale=length_scale, gamma=gamma, instrument=instrument,
                                 mean_speed=mean_speed, misalignment=misalignment))
    return path


def refused(tmp_path, corpus, *fragments, **scene):
    child = run_cli(["run", scene_file(tmp_path, **scene), "--out", tmp_path / "o", "--no-progress"], cwd=tmp_path)
    assert_one_line_error(child, *fragments)
    assert not (tmp_path / "o" / "tiny.nc").exists()  # refused before any computation
    corpus.record("error", child)
    return child


@pytest.mark.parametrize("instrument, fragments", [
    ("focus = 0.1", ("lidar.instrument.focus=0.1", "10 m minimum", "zR would be 1.2e-05 m", "km")),
    ("focus = 67500.0", ("focus=67500.0", "collimation distance")),
    ("wavelength = 1547.615", ("lidar.instrument.wavelength=1547.615", "coherent doppler lidars", "nm or um")),
    ("telescope_radius = 20.0", ("telescope_radius=20.0", "mm or cm")),
    ("sample_rate = 50.0, blocks_per_estimate = 1", ("sample_rate=50.0", "mhz")),
    ("estimate_rate = 10.0", ("estimate_rate=10", "50 hz")),
], ids=["focus-in-km", "focus-in-mm", "wavelength-in-nm", "radius-in-mm", "rate-in-mhz", "staring-rate"])
def test_an_instrument_value_in_the_wrong_unit_is_refused(tmp_path, corpus, instrument, fragments):
    refused(tmp_path, corpus, *fragments, instrument=instrument)


def test_turbulence_the_mean_wind_cannot_carry_is_refused(tmp_path, corpus):
    # the alpha_eps = 1e3: sigma_u ~ 1e2 m/s at U = 8 m/s used to run with availability 1.0
    refused(tmp_path, corpus, "period[0] ('A')", "alpha_eps=1000", "sigma_u/u", "taylor", alpha_eps=1e3)


def test_gamma_outside_the_fitted_range_is_refused(tmp_path, corpus):
    refused(tmp_path, corpus, "turbulence.gamma=1000", "fitted for", gamma=1000)


def test_a_length_scale_in_the_wrong_unit_is_refused(tmp_path, corpus):
    refused(tmp_path, corpus, "turbulence.length_scale=50000.0", "boundary layer", length_scale=5e4)


def test_a_nacelle_scene_checks_its_turbulence_too(tmp_path, corpus):
    path = tmp_path / "nac.toml"
    path.write_text(bundled_text("nacelle").replace("alpha_eps = 0.1", "alpha_eps = 50.0"))
    child = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], cwd=tmp_path)
    assert_one_line_error(child, "period[0] ('frozen')", "alpha_eps=50", "taylor")
    corpus.record("error", child)


def test_doppler_refuses_a_focus_in_km(tmp_path, corpus):
    child = run_cli(["doppler", "--speed", "5", "--cnr", "-10", "--n", "4", "--set", "focus=0.1"], cwd=tmp_path)
    assert_one_line_error(child, "focus=0.1", "10 m minimum")
    corpus.record("error", child)


def test_near_zero_estimates_run_flagged_and_are_not_available(tmp_path, corpus):
    """U = 1 m/s at 35 deg: radial speeds about 0.8 m/s, within the 0.5 m/s guard of the 0.5 m/s blind
    zone.  The run completes; those estimates are flagged NEAR_ZERO, counted, and not available (the right answer:
    the instrument cannot measure there, and says so)."""
    path = scene_file(tmp_path, alpha_eps=0.001, mean_speed=1.0, misalignment=35.0)  # sigma_u 0.14 m/s
    child = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], cwd=tmp_path, timeout=600)
    assert child.rc == 0, child.stderr[-3000:]
    ds = xr.open_dataset(tmp_path / "o" / "tiny.nc", engine="h5netcdf")
    flags = ds["lidar_flags"].values[0]
    speed = ds["lidar_speed"].values[0]
    near = (flags & 4) != 0  # Flag.NEAR_ZERO
    assert near.sum() > 0.1 * flags.size and np.isfinite(speed[near]).all()
    assert float(ds["availability"].values[0]) == pytest.approx(1.0 - near.mean(), abs=1e-12)
    counts = dict(zip(ds["flag"].values, ds["flag_count"].values[0]))
    assert counts["NEAR_ZERO"] == near.sum()
    # the command's summary reports the same availability
    assert json.loads(child.stdout)["availability"]["A"] == pytest.approx(1.0 - near.mean(), abs=1e-4)
    corpus.record("right", child)


def test_box_refuses_gamma_outside_the_fitted_range(tmp_path, corpus):
    child = run_cli(["box", "--alpha-eps", "0.05", "--length-scale", "20", "--gamma", "1000", "--shape", "16", "4",
                     "4", "--spacing", "1", "1", "1", "--seed", "1", "--out", "x.nc"], cwd=tmp_path)
    assert_one_line_error(child, "gamma=1000", "fitted for", "[0, 8]")
    assert not (tmp_path / "x.nc").exists()
    corpus.record("error", child)
