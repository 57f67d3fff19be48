"""WindScanner (sensors/windscanner.py): three beams meeting at one point, against closed forms.

Tier 1 in an analytic field: every line-of-sight speed is ``n . (U + u, v, w)`` at the common focus, with
``n`` the unit vector from the unit's position to the focus written here from the positions (not read from
the sensor); the wind reconstructed from the three speeds (analysis.reconstruction) is the field's at the
focus.  Uniform wind with the exact weighting (a uniform field is the same along the beam), a linear shear
and veer with the point weighting on a vanishing span (a linear field's value at the focus: the point weighting's
one cell is sampled at its centre, which beam/cells.py puts half a cell from the focus, so the span is made
1e-9 z_R for the cell to shrink onto the focus).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.analysis.reconstruction import ReconstructionFlag, homodyne_signs, reconstruct_uvw
from cwlidar_sim.sensors.windscanner import (WindScanner, layout_from_angles, measure_windscanner,
                                             record_steps)
from cwlidar_sim.turbulence.cover import plan_box

U = 8.0
#: Shear and veer: u = SU (z - Z0), v = SV (z - Z0), w = SW (y - Y0) + SX (x - X0) [1/s].
SU, SV, SW, SX, Z0, Y0, X0 = 0.05, -0.03, 0.01, 0.02, 40.0, 3.0, -5.0


def sym_layout(elev_deg, r=60.0, target=(0.0, 0.0, 60.0), az0=15.0):
    """Three units at 120 deg around the target, each beam at ``elev_deg`` elevation, range r."""
    t = np.asarray(target)
    out = []
    for a in np.radians(az0 + np.array([0.0, 120.0, 240.0])):
        e = math.radians(elev_deg)
        out.append(tuple(t - r * np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])))
    return tuple(out)


#: A point probe at the focus (module notes).
POINT = {"weighting": "point", "span": 1e-9}

LAYOUTS = {
    "published": {},
    "symmetric45": {"positions": sym_layout(45.0), "target": (0.0, 0.0, 60.0)},
    "skewed": {"positions": ((-40.0, 10.0, 2.0), (30.0, 35.0, 0.0), (-20.0, -50.0, 8.0)), "target": (4.0, 2.0, 45.0)},
    "lissajous": {"positions": sym_layout(50.0), "target": (0.0, 0.0, 60.0), "pattern": "lissajous",
                  "points_per_pattern": 24, "amplitude": 6.0},
    "lissajous_xy": {"pattern": "lissajous", "points_per_pattern": 16, "amplitude": 8.0, "pattern_plane": "xy",
                     "lissajous_ratio": (1, 2)},
}


def box_for(ws, duration, field=None, d=4.0):
    plan = plan_box(ws.box_region(d), U, duration, d, min_extent=0.0)
    (nx, ny, nz), (x0, y0, z0) = plan.shape, plan.origin
    x, y, z = x0 + d * np.arange(nx), y0 + d * np.arange(ny), z0 + d * np.arange(nz)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    comps = (np.zeros_like(X),) * 3 if field is None else field(X, Y, Z)
    return xr.Dataset({c: (("x", "y", "z"), a.astype(np.float64)) for c, a in zip("uvw", comps)},
                      coords={"x": x, "y": y, "z": z})


def shear(X, Y, Z):
    return SU * (Z - Z0), SV * (Z - Z0), SW * (Y - Y0) + SX * (X - X0)


def shear_at(p_kc, t_k):
    """The total wind (U + u, v, w) of the frozen sheared field advected at U: the field at x - U t."""
    x = p_kc[:, 0] - U * t_k
    return np.stack([U + SU * (p_kc[:, 2] - Z0), SV * (p_kc[:, 2] - Z0),
                     SW * (p_kc[:, 1] - Y0) + SX * (x - X0)], axis=1)


def unit_vectors(ws, focus_kc):
    d = focus_kc[:, None, :] - np.asarray(ws.positions)[None, :, :]
    return d / np.linalg.norm(d, axis=2)[:, :, None]


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_uniform_wind_every_speed_and_the_wind_are_exact(name):
    ws = WindScanner(**LAYOUTS[name])
    dur = 0.2
    rec = measure_windscanner(box_for(ws, dur), ws, dur, U)
    st = record_steps(rec)
    n_kic = unit_vectors(ws, st["focus_kc"])
    np.testing.assert_allclose(st["direction_kic"], n_kic, rtol=0, atol=1e-14)
    np.testing.assert_allclose(st["vlos_ki"], n_kic @ np.array([U, 0.0, 0.0]), rtol=0, atol=1e-12)
    res = reconstruct_uvw(st["direction_kic"], st["vlos_ki"])
    np.testing.assert_allclose(res.uvw_kc, [[U, 0.0, 0.0]] * st["point_k"].size, rtol=0, atol=1e-12)
    # the homodyne speeds with the mean wind's sign give the same wind
    signed = st["speed_ki"] * homodyne_signs(st["direction_kic"], (U, 0.0, 0.0))
    res2 = reconstruct_uvw(st["direction_kic"], signed, flags_ki=st["flags_ki"])
    np.testing.assert_allclose(res2.uvw_kc, res.uvw_kc, rtol=0, atol=1e-12)
    assert res2.n_ill_conditioned == 0 and np.all(res2.flags_k == 0)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_shear_and_veer_at_the_common_focus_are_exact(name):
    ws = WindScanner(**LAYOUTS[name], **POINT)
    dur = 0.1
    rec = measure_windscanner(box_for(ws, dur, shear), ws, dur, U)
    st = record_steps(rec)
    t_k = st["time_ki"][:, 0]
    want_kc = shear_at(st["focus_kc"], t_k)
    n_kic = unit_vectors(ws, st["focus_kc"])
    np.testing.assert_allclose(st["vlos_ki"], np.einsum("kic,kc->ki", n_kic, want_kc), rtol=0, atol=1e-11)
    res = reconstruct_uvw(st["direction_kic"], st["vlos_ki"])
    np.testing.assert_allclose(res.uvw_kc, want_kc, rtol=0, atol=1e-11)
    # the wind at the focus is not the mean wind: the test sees the shear and veer
    assert np.abs(want_kc - [U, 0.0, 0.0]).max(axis=0).min() > 0.05


def test_timing_offsets_measure_each_unit_on_its_own_clock():
    off = (0.0, 0.011, -0.02)
    ws = WindScanner(**POINT, time_offsets=off)
    dur = 0.1
    rec = measure_windscanner(box_for(ws, dur + 0.1, shear), ws, dur, U, start=0.05)
    st = record_steps(rec)
    t0_k = 0.05 + (np.arange(st["point_k"].size) + 0.5) / ws.instrument.estimate_rate
    np.testing.assert_allclose(st["time_ki"], t0_k[:, None] + np.asarray(off)[None, :], rtol=0, atol=1e-12)
    n_kic = unit_vectors(ws, st["focus_kc"])
    for i in range(3):
        want = shear_at(st["focus_kc"], st["time_ki"][:, i])
        np.testing.assert_allclose(st["vlos_ki"][:, i], np.einsum("kc,kc->k", n_kic[:, i], want), atol=1e-11)
    # the wind reconstructed from speeds taken at three times is not the wind at any one of them (x gradient)
    res = reconstruct_uvw(st["direction_kic"], st["vlos_ki"])
    assert np.abs(res.uvw_kc - shear_at(st["focus_kc"], t0_k)).max() > 1e-4


def test_condition_number_of_a_symmetric_layout_is_analytic():
    for e in (20.0, 45.0, 70.0):
        ws = WindScanner(positions=sym_layout(e), target=(0.0, 0.0, 60.0))
        c, s = math.cos(math.radians(e)), math.sin(math.radians(e))
        sv = (math.sqrt(1.5) * c, math.sqrt(3.0) * s)  # N^T N = diag(1.5 c^2, 1.5 c^2, 3 s^2)
        np.testing.assert_allclose(ws.condition_numbers(), [max(sv) / min(sv)], rtol=1e-12)


def test_ill_conditioned_geometry_is_flagged_counted_and_kept():
    # beams 2 deg above the horizon: cond = sqrt(1.5) cos / (sqrt(3) sin) = 20.2 > 10
    ws = WindScanner(positions=sym_layout(2.0, r=60.0, target=(0.0, 0.0, 10.0)), target=(0.0, 0.0, 10.0),
                     min_elevation_deg=0.0)
    dur = 0.05
    rec = measure_windscanner(box_for(ws, dur), ws, dur, U)
    st = record_steps(rec)
    res = reconstruct_uvw(st["direction_kic"], st["vlos_ki"])
    nk = st["point_k"].size
    assert res.uvw_kc.shape == (nk, 3) and res.n_ill_conditioned == nk
    assert np.all(np.isnan(res.uvw_kc))
    assert np.all(res.flags_k & ReconstructionFlag.ILL_CONDITIONED)
    np.testing.assert_allclose(res.condition_k, 0.5 * math.sqrt(2.0) / math.tan(math.radians(2.0)), rtol=1e-9)
    # a looser threshold solves it, exactly
    ok = reconstruct_uvw(st["direction_kic"], st["vlos_ki"], max_condition=100.0)
    np.testing.assert_allclose(ok.uvw_kc, [[U, 0.0, 0.0]] * nk, atol=1e-10)


def test_layout_from_angles_points_the_beams_as_published():
    pos = layout_from_angles((0.0, 0.0, 100.0), (186.0, 56.0, 335.0), (56.5, 51.7, 56.4), 11.0)
    ws = WindScanner(positions=pos, target=(0.0, 0.0, 100.0))
    n = ws.directions()[0]
    np.testing.assert_allclose(np.degrees(np.arcsin(n[:, 2])), [56.5, 51.7, 56.4], atol=1e-12)
    np.testing.assert_allclose(np.degrees(np.arctan2(n[:, 1], n[:, 0])) % 360.0, [186.0, 56.0, 335.0], atol=1e-12)
    np.testing.assert_allclose([p[2] for p in pos], 11.0, atol=1e-12)
    # the default is the published layout about a target at a mean range of 125 m
    assert abs(WindScanner().ranges().mean() - 125.0) < 1e-9


def test_spectral_tier_returns_the_uniform_wind_to_the_estimators_scatter():
    ws = WindScanner(tier="spectral", positions=sym_layout(45.0), target=(0.0, 0.0, 60.0))
    dur = 0.3
    rec = measure_windscanner(box_for(ws, dur), ws, dur, U, seed=3)
    st = record_steps(rec)
    signed = st["speed_ki"] * homodyne_signs(st["direction_kic"], (U, 0.0, 0.0))
    res = reconstruct_uvw(st["direction_kic"], signed, flags_ki=st["flags_ki"])
    assert res.n_missing == 0
    # each speed within a few bins (0.0775 m/s at 100 MHz) of the truth, the wind within a few times that
    assert np.abs(st["speed_ki"] - np.abs(st["vlos_ki"])).max() < 0.3
    assert np.abs(np.nanmean(res.uvw_kc, axis=0) - [U, 0.0, 0.0]).max() < 0.05
    rec2 = measure_windscanner(box_for(ws, dur), ws, dur, U, seed=3)
    np.testing.assert_array_equal(rec2.speed_e, rec.speed_e)


@pytest.mark.parametrize("kw, match", [
    ({"target": (0.0, 0.0, 900.0)}, r"target: .*collimation distance.*never meet"),
    ({"target": (0.0, 0.0, 5.0)}, r"target: unit 0 .*below min_elevation_deg"),
    ({"positions": ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (30.0, 0.0, 0.0))}, r"positions\[1\] and positions\[0\]"),
    ({"positions": ((-50.0, 0.0, 60.0), (50.0, 0.0, 60.0), (0.0, 40.0, 60.0)), "target": (0.0, 0.0, 60.0)},
     r"positions: the three beams are coplanar"),
    ({"positions": ((-50.0, 0.0, 0.0), (-100.0, 0.0, -60.0), (0.0, 40.0, 0.0)), "target": (0.0, 0.0, 60.0),
      "min_elevation_deg": -90.0}, r"positions: the three beams are coplanar or collinear"),
    ({"positions": ((0.0, 0.0, 55.0), (50.0, 0.0, 0.0), (0.0, 40.0, 0.0)), "target": (0.0, 0.0, 60.0)},
     r"positions\[0\] is 5 m .*closer than"),
    ({"pattern": "lissajous", "lissajous_ratio": (0, 2)}, r"lissajous_ratio\[0\]"),
    ({"pattern": "lissajous", "points_per_pattern": 8}, r"points_per_pattern=8 is too few"),
    ({"pattern": "lissajous", "amplitude": 0.0}, r"amplitude"),
    ({"pattern": "spiral"}, r"pattern='spiral'"),
    ({"pattern_plane": "zz"}, r"pattern_plane"),
    ({"time_offsets": (0.0, 11.0, 0.0)}, r"time_offsets\[1\]"),
    ({"positions": ((0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))}, r"positions\[0\] must have 3 values"),
    ({"target": (0.0, float("nan"), 50.0)}, r"target\[1\]"),
])
def test_bad_input_is_refused_by_name(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        WindScanner(**kw)


def test_record_steps_refuses_other_records():
    ws = WindScanner()
    rec = measure_windscanner(box_for(ws, 0.02), ws, 0.02, U)
    bad = rec.__class__(**{**{k: getattr(rec, k) for k in ("time_e", "vlos_e", "speed_e", "flags_e", "variants",
                                                            "availability", "info")}, "extras": {}})
    with pytest.raises(ValueError, match="WindScanner"):
        record_steps(bad)


def test_lissajous_focus_follows_the_closed_form_and_repeats():
    ws = WindScanner(pattern="lissajous", points_per_pattern=32, amplitude=7.0, lissajous_ratio=(3, 2))
    dur = 70 / ws.instrument.estimate_rate
    rec = measure_windscanner(box_for(ws, dur), ws, dur, U)
    st = record_steps(rec)
    k = np.arange(st["point_k"].size)
    ph = 2.0 * np.pi * k / 32
    want = np.stack([np.zeros_like(ph), 7.0 * np.cos(3 * ph), 7.0 * np.sin(2 * ph)], axis=1) + np.asarray(ws.target)
    np.testing.assert_allclose(st["focus_kc"], want, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(st["point_k"], k % 32)
    # every unit is focused at its own distance to the moving focus
    np.testing.assert_allclose(rec.range_e.reshape(-1, 3),
                               np.linalg.norm(want[:, None, :] - np.asarray(ws.positions)[None], axis=2), atol=1e-12)
