"""A scene's fit_to: the twin's reader (units), the scene's mean checked against the record's, a suspect fit flagged."""

import json
import warnings

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.periods import staring_field as planning
from cwlidar_sim.campaign.periods.staring_field import MEAN_SPEED_TOLERANCE, scene_params

SCENE = """
name = "f"
seed = 3
duration = 60.0
[turbulence]
fit_to = "r.nc"
[lidar]
tier = "los"
[analysis]
segment_duration = 30.0
fit = false
[[period]]
name = "a"
mean_speed = {U}
"""
U, FS, N = 8.0, 10.0, 2**12


@pytest.fixture(scope="module")
def line():
    from cwlidar_sim.turbulence import MannParameters, generate_line

    ln = generate_line(MannParameters(0.063, 18.8, 3.2), N, U / FS, 5, dtype=np.float64)
    return {c: ln[c].values[::-1] + (U if c == "u" else 0.0) for c in "uvw"}


def _write(folder, vals, units="m s-1", scale=1.0):
    xr.Dataset({c: ("time", vals[c] * scale, {"units": units}) for c in "uvw"},
               coords={"time": ("time", np.arange(N) / FS, {"units": "s"})}).to_netcdf(folder / "r.nc",
                                                                                       engine="h5netcdf")


def _scene(folder, mean_speed=U):
    return loads_scene(SCENE.format(U=mean_speed), base_dir=str(folder))


def test_fit_to_is_read_by_the_twin_s_reader_in_its_units(tmp_path, line):
    assert planning.read_record.__module__ == "cwlidar_sim.analysis.records"
    _write(tmp_path, line)
    p_ms, info_ms = scene_params(_scene(tmp_path))
    _write(tmp_path, line, "km h-1", 3.6)  # new contents, new key: fitted again
    p_kmh, info_kmh = scene_params(_scene(tmp_path))
    np.testing.assert_allclose([p_kmh.alpha_eps, p_kmh.length_scale, p_kmh.gamma],
                               [p_ms.alpha_eps, p_ms.length_scale, p_ms.gamma], rtol=1e-9)
    assert info_ms["units"]["u"] == "m s-1" and info_kmh["units"]["u"] == "km h-1"
    assert info_kmh["quality"] == "ok" and info_kmh["at_bound"] == [] and info_kmh["n_filled"] == 0
    assert info_kmh["mean_speed"] == pytest.approx(U, rel=0.02)
    json.dumps(info_kmh)  # the results' turbulence_fit attribute


def test_a_period_in_another_wind_than_the_record_s_is_refused_naming_both(tmp_path, line):
    _write(tmp_path, line)
    Ur = float(np.mean(line["u"]))
    scene_params(_scene(tmp_path, round(Ur * (1 + 0.9 * MEAN_SPEED_TOLERANCE), 3)))  # within: accepted
    with pytest.raises(ValueError, match=rf"has mean speed {Ur:.4g} m/s but period 'a' has mean_speed = 12 m/s; "
                                         rf"allowed: within 30 %"):
        scene_params(_scene(tmp_path, 12.0))
    with pytest.raises(ValueError, match=r"mean_speed = 5\.5 m/s"):
        scene_params(_scene(tmp_path, 5.5))


def test_a_fit_on_its_bounds_is_warned_about_and_flagged(tmp_path):
    rng = np.random.default_rng(1)
    _write(tmp_path, {c: rng.normal(size=N) * 0.8 + (U if c == "u" else 0.0) for c in "uvw"})
    with pytest.warns(UserWarning, match=r"fit_to: the fit to .*r\.nc' is suspect: length_scale=0\.5 \(lower bound\)"):
        p, info = scene_params(_scene(tmp_path))
    assert info["quality"] == "suspect" and info["at_bound"][0] == "length_scale=0.5 (lower bound)"
    assert p.length_scale == 0.5
    with pytest.warns(UserWarning, match="is suspect"):  # from the cache too: every run is told
        scene_params(_scene(tmp_path))


def test_a_good_fit_gives_no_warning(tmp_path, line):
    _write(tmp_path, line)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene_params(_scene(tmp_path))


def test_fit_to_takes_the_record_file_options_of_the_scene(tmp_path, line):
    """A logger's CSV (a preamble, ';' between fields, decimal commas) read with [turbulence.fit_to_options] fits
    the tensor the same record as NetCDF fits (written in full: the fit is sensitive to the 9th digit); without the
    options the reader cannot read it."""
    _write(tmp_path, line)
    p_nc, _ = scene_params(_scene(tmp_path))
    rows = ["logger X1 serial 42", "site: test", "time;u;v;w"]
    rows += [";".join(repr(float(x)).replace(".", ",") for x in (i / FS, line["u"][i], line["v"][i], line["w"][i]))
             for i in range(N)]
    (tmp_path / "r.csv").write_text("\n".join(rows) + "\n")
    text = SCENE.format(U=U).replace('fit_to = "r.nc"', 'fit_to = "r.csv"\n[turbulence.fit_to_options]\n'
                                     'sep = ";"\ndecimal = ","\nskiprows = 2')
    p_csv, info = scene_params(loads_scene(text, base_dir=str(tmp_path)))
    np.testing.assert_allclose([p_csv.alpha_eps, p_csv.length_scale, p_csv.gamma],
                               [p_nc.alpha_eps, p_nc.length_scale, p_nc.gamma], rtol=1e-6)
    plain = SCENE.format(U=U).replace('fit_to = "r.nc"', 'fit_to = "r.csv"')
    with pytest.raises(ValueError):
        scene_params(loads_scene(plain, base_dir=str(tmp_path)))
    with pytest.raises(ValueError, match=r"unknown key\(s\) in turbulence.fit_to_options: \['rotation'\].*allowed: "
                                         r"\['columns', 'comment', 'decimal'"):
        loads_scene(text.replace("skiprows = 2", 'skiprows = 2\nrotation = "double"'), base_dir=str(tmp_path))
    with pytest.raises(ValueError, match=r"turbulence.fit_to_options.decimal"):
        loads_scene(text.replace('decimal = ","', 'decimal = ";"'), base_dir=str(tmp_path))
