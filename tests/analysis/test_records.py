"""Reading measured records for the virtual twin: formats, units, cleaning, rotation and bad input."""

import math

import numpy as np
import pytest

from cwlidar_sim.analysis.records import (
    FLAG_GAP,
    FLAG_SPIKE,
    RecordSpec,
    parse_speed_units,
    parse_time_units,
    read_periods,
    read_record,
)

FS = 10.0


def _wind(n, seed, U=8.0, sig=(0.8, 0.6, 0.4)):
    """A smooth turbulent-looking record in the mean-wind frame (AR(1) at 0.98 per sample)."""
    rng = np.random.default_rng(seed)
    out = []
    for s in sig:
        e = rng.normal(0, s * math.sqrt(1 - 0.98**2), n)
        x = np.empty(n)
        x[0] = rng.normal(0, s)
        for i in range(1, n):
            x[i] = 0.98 * x[i - 1] + e[i]
        out.append(x - x.mean())
    out[0] += U
    return np.array(out)


def _to_sensor(vel, yaw_deg, pitch_deg=0.0):
    """Wind-frame velocities seen by a sonic yawed by yaw (about z) and pitched by pitch (about its y)."""
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    # Inverse of the double rotation: pitch back, then yaw back.
    u1 = vel[0] * math.cos(p) - vel[2] * math.sin(p)
    w = vel[0] * math.sin(p) + vel[2] * math.cos(p)
    u = u1 * math.cos(y) - vel[1] * math.sin(y)
    v = u1 * math.sin(y) + vel[1] * math.cos(y)
    return np.array([u, v, w])


def _write_csv(path, cols, header=None):
    names = header or list(cols)
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in zip(*cols.values()):
            f.write(",".join(x if isinstance(x, str) else ("" if math.isnan(x) else repr(float(x))) for x in row)
                    + "\n")


def test_csv_sonic_in_its_own_axes_is_rotated_back_into_the_wind(tmp_path):
    vel = _wind(3000, 1)
    sensor = _to_sensor(vel, 37.0, 4.0)
    p = tmp_path / "sonic.csv"
    _write_csv(p, {"time": list(np.arange(3000) / FS), "ux": list(sensor[0]), "uy": list(sensor[1]),
                   "uz": list(sensor[2])})
    rec = read_record(RecordSpec(str(p), columns={"u": "ux", "v": "uy", "w": "uz", "time": "time"},
                                 position=(0, 0, 40)))
    assert rec.sample_rate == pytest.approx(FS) and rec.n_samples == 3000 and rec.n_filled == 0
    assert rec.rotation["yaw_deg"] == pytest.approx(37.0, abs=1e-9)
    assert rec.rotation["pitch_deg"] == pytest.approx(4.0, abs=1e-9)
    for i, c in enumerate("uvw"):
        np.testing.assert_allclose(rec.values[c], vel[i], atol=1e-9)
    lr = rec.line_record()
    assert lr.position == (0.0, 0.0, 40.0) and lr.components == ("u", "v", "w")


def test_csv_cup_with_sample_rate_and_units_and_iso_times(tmp_path):
    speed = 8.0 + _wind(800, 2)[1]
    p = tmp_path / "cup.csv"
    _write_csv(p, {"ws": list(speed * 3.6)})
    rec = read_record(RecordSpec(str(p), kind="cup", columns={"speed": "ws"}, units={"speed": "km/h"},
                                 sample_rate=FS, distance_constant=2.3))
    np.testing.assert_allclose(rec.values["speed"], speed, rtol=1e-12)
    assert rec.line_record().kind == "cup" and rec.line_record().distance_constant == 2.3
    t = np.datetime64("2024-03-01T12:00:00") + (np.arange(800) * 100).astype("timedelta64[ms]")
    _write_csv(p, {"timestamp": [str(x) for x in t], "speed": list(speed)})
    rec = read_record(RecordSpec(str(p), kind="cup", columns={"time": "timestamp"}))
    assert rec.sample_rate == pytest.approx(FS)


def test_netcdf_cf_names_and_units(tmp_path):
    import xarray as xr

    vel = _wind(1200, 3)
    east = _to_sensor(vel, -120.0)
    t = np.arange(1200) / FS / 60.0  # minutes
    ds = xr.Dataset({"U_E": ("time", east[0] / 0.514444, {"standard_name": "eastward_wind", "units": "knots"}),
                     "U_N": ("time", east[1] / 0.514444, {"standard_name": "northward_wind", "units": "kt"}),
                     "W": ("time", east[2] * 100.0, {"standard_name": "upward_air_velocity", "units": "cm s-1"})},
                    coords={"time": ("time", t, {"units": "minutes since 2024-01-01 00:00:00"})})
    p = tmp_path / "sonic.nc"
    ds.to_netcdf(p, engine="h5netcdf")
    rec = read_record(RecordSpec(str(p)))
    assert rec.sample_rate == pytest.approx(FS)
    for i, c in enumerate("uvw"):
        np.testing.assert_allclose(rec.values[c], vel[i], atol=1e-5)  # knots are defined to 6 digits
    ds["W"].attrs["units"] = "furlongs per fortnight"
    ds.to_netcdf(p, engine="h5netcdf")
    with pytest.raises(ValueError, match=r"variable 'W' .* units 'furlongs per fortnight' do not parse"):
        read_record(RecordSpec(str(p)))
    plain = xr.Dataset({c: ("time", vel[i], {"units": "m/s"}) for i, c in enumerate("uvw")},
                       coords={"time": ("time", np.arange(1200) / FS, {"units": "s"})})
    plain.to_netcdf(p, engine="h5netcdf")
    rec = read_record(RecordSpec(str(p), rotation="none"))
    np.testing.assert_allclose(rec.values["w"], vel[2])


def test_unit_parsers():
    assert parse_speed_units("m s-1") == 1.0 and parse_speed_units("m/s") == 1.0
    assert parse_speed_units("m s^-1") == 1.0 and parse_speed_units("cm s-1") == pytest.approx(0.01)
    assert parse_speed_units("km h-1") == pytest.approx(1 / 3.6) and parse_speed_units("mph") == pytest.approx(0.44704)
    assert parse_time_units("seconds since 2000-01-01") == 1.0 and parse_time_units("h") == 3600.0
    for bad in ("m", "parsec s-1", "m s-2", ""):
        with pytest.raises(ValueError, match="do not parse"):
            parse_speed_units(bad)


def test_spikes_are_found_flagged_and_filled(tmp_path):
    vel = _wind(6000, 4)
    spiky = vel.copy()
    at = [500, 1700, 1701, 3333, 5900]
    spiky[2, at] += 6.0  # 15 sigma_w, one double spike
    spiky[0, 4200] -= 9.0
    p = tmp_path / "s.csv"
    _write_csv(p, {c: list(spiky[i]) for i, c in enumerate("uvw")})
    rec = read_record(RecordSpec(str(p), sample_rate=FS, rotation="none"))
    found = np.nonzero(rec.flags & FLAG_SPIKE)[0]
    assert list(found) == sorted(at + [4200])  # every spike, and no clean sample
    # Filled by interpolation: within the record's local variation of the truth.
    step = np.abs(np.diff(vel[2])).max()
    assert np.all(np.abs(rec.values["w"][at] - vel[2][at]) < 3 * step)
    # A longer excursion is not a spike: kept, not flagged.
    spiky2 = vel.copy()
    spiky2[2, 1000:1010] += 6.0
    _write_csv(p, {c: list(spiky2[i]) for i, c in enumerate("uvw")})
    rec = read_record(RecordSpec(str(p), sample_rate=FS, rotation="none"))
    assert rec.n_spikes == 0 and rec.values["w"][1005] == pytest.approx(spiky2[2, 1005])


def test_gaps_short_filled_long_refused_naming_period_and_gap(tmp_path):
    vel = _wind(6000, 5)
    t = np.arange(6000) / FS
    keep = np.ones(6000, bool)
    keep[2000:2005] = False  # 0.5 s of missing time stamps
    v = vel.copy()
    v[:, 4000:4008] = np.nan  # 0.8 s of missing values
    p = tmp_path / "g.csv"
    _write_csv(p, {"time": list(t[keep]), **{c: list(v[i][keep]) for i, c in enumerate("uvw")}})
    rec = read_record(RecordSpec(str(p), rotation="none"))
    assert rec.n_samples == 6000
    assert np.all(rec.flags[2000:2005] == FLAG_GAP) and np.all(rec.flags[4000:4008] == FLAG_GAP)
    assert rec.n_filled == 13
    v[:, 4500:4530] = np.nan  # 3 s
    _write_csv(p, {"time": list(t), **{c: list(v[i]) for i, c in enumerate("uvw")}})
    with pytest.raises(ValueError, match=r"period 1 \(t = 300-600 s\): gap of 3 s \(30 samples\) at t = 450 s"):
        read_periods(RecordSpec(str(p), rotation="none"), 300.0)
    ok = read_periods(RecordSpec(str(p), rotation="none", max_gap=5.0), 300.0)
    assert len(ok) == 2 and ok[1].n_filled == 38


def test_bad_records_give_one_line_errors_before_anything_is_computed(tmp_path):
    vel = _wind(400, 6)
    p = tmp_path / "b.csv"

    def err(cols, match, **kw):
        _write_csv(p, cols)
        with pytest.raises(ValueError, match=match) as e:
            read_record(RecordSpec(str(p), **kw))
        assert "\n" not in str(e.value)

    t = list(np.arange(400) / FS)
    err({"a": list(vel[0]), "b": list(vel[1]), "w": list(vel[2])}, r"lacks column\(s\) \['u', 'v'\]", sample_rate=FS)
    t_bad = t.copy()
    t_bad[100], t_bad[101] = t_bad[101], t_bad[100]
    err({"time": t_bad, "u": list(vel[0]), "v": list(vel[1]), "w": list(vel[2])}, r"not strictly increasing: sample 101")
    nanrun = vel.copy()
    nanrun[:, 50:80] = np.nan
    err({"u": list(nanrun[0]), "v": list(nanrun[1]), "w": list(nanrun[2])}, r"gap of 3 s", sample_rate=FS)
    slow = _wind(400, 7, U=0.4, sig=(0.1, 0.1, 0.05))
    err({"u": list(slow[0]), "v": list(slow[1]), "w": list(slow[2])}, r"mean speed 0.4.*Taylor", sample_rate=FS)
    gusty = _wind(400, 8, U=2.0, sig=(1.5, 0.5, 0.3))
    err({"u": list(gusty[0]), "v": list(gusty[1]), "w": list(gusty[2])}, r"turbulence intensity .*Taylor",
        sample_rate=FS)
    err({"u": ["x"] * 400, "v": list(vel[1]), "w": list(vel[2])}, r"column 'u' .* not numeric", sample_rate=FS)
    err({"u": list(vel[0]), "v": list(vel[1]), "w": list(vel[2])}, r"no time column; give sample_rate")
    err({"time": t, "u": list(vel[0]), "v": list(vel[1]), "w": list(vel[2])}, r"sample_rate = 20.0 Hz but",
        sample_rate=20.0)
    with pytest.raises(ValueError, match="no such file"):
        read_record(RecordSpec(str(tmp_path / "none.csv")))


def test_planar_fit_recovers_the_sonic_tilt_over_periods_of_several_directions(tmp_path):
    # Six 5-minute periods, wind from six directions; a sonic tilted 3 deg about an axis at 30 deg and offset
    # by b0 = 0.05 m/s in w.  The tilt is the instrument's, so every period shares one plane.
    tilt, axis = math.radians(3.0), math.radians(30.0)
    a = np.array([math.cos(axis), math.sin(axis), 0.0])
    Kx = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    Rm = np.eye(3) + math.sin(tilt) * Kx + (1 - math.cos(tilt)) * Kx @ Kx  # Rodrigues
    chunks, truth = [], []
    for k, d in enumerate((0, 60, 120, 180, 240, 300)):
        vel = _wind(3000, 20 + k, U=6.0 + k)
        earth = _to_sensor(vel, d)
        truth.append(vel)
        chunks.append(Rm.T @ earth + np.array([[0.0], [0.0], [0.05]]))
    sensor = np.concatenate(chunks, axis=1)
    p = tmp_path / "pf.csv"
    _write_csv(p, {c: list(sensor[i]) for i, c in enumerate("uvw")})
    recs = read_periods(RecordSpec(str(p), sample_rate=FS, rotation="planar"), 300.0)
    assert len(recs) == 6
    assert recs[0].rotation["tilt_deg"] == pytest.approx(3.0, abs=0.02)
    assert recs[0].rotation["b0"] == pytest.approx(0.05, abs=0.005)
    for r, vel in zip(recs, truth):
        assert abs(r.values["w"].mean()) < 0.01 and abs(r.values["v"].mean()) < 1e-9
        np.testing.assert_allclose(r.values["w"], vel[2], atol=0.02)
    with pytest.raises(ValueError, match="needs several periods"):
        read_record(RecordSpec(str(p), sample_rate=FS, rotation="planar"))


def test_spec_round_trip_and_validation():
    s = RecordSpec("m.csv", kind="cup", position=(1, 2, 3), columns={"speed": "ws"}, sample_rate=1.0,
                   noise_std=0.05, distance_constant=2.3)
    assert RecordSpec.from_dict(s.as_dict()) == s and s.name == "m.csv"
    with pytest.raises(ValueError, match=r"unknown key\(s\) for RecordSpec: \['colour'\]"):
        RecordSpec.from_dict({"path": "a.csv", "colour": "red"})
    with pytest.raises(ValueError, match="unknown role"):
        RecordSpec("a.csv", columns={"speed": "ws"})
    with pytest.raises(ValueError, match="kind"):
        RecordSpec("a.csv", kind="lidar")
    with pytest.raises(ValueError, match="distance_constant applies to a cup"):
        RecordSpec("a.csv", distance_constant=2.0)


def test_virtual_mast_csv_conditions_a_twin_that_holds_the_truth(tmp_path):
    """Closed loop at reduced size: truth -> package sonic -> CSV in the sonic's own axes -> read -> twin."""
    from cwlidar_sim.sensors.sonic import Sonic, sample_sonic
    from cwlidar_sim.turbulence import MannParameters, generate_box
    from cwlidar_sim.turbulence.conditioning import conditioned_box

    P, U, dx = MannParameters(0.05, 20.0, 3.9), 8.0, 1.0
    fs = U / dx
    shape, sp = (1024, 8, 8), (dx, 4.0, 4.0)
    truth = generate_box(P, shape, sp, 3, dtype=np.float64)
    pos = (0.0, 12.0, 16.0)
    t = np.arange(shape[0]) / fs
    vel = sample_sonic(truth, Sonic(position=pos, rate=fs, noise_std=0.02), t, U, seed=9).T
    p = tmp_path / "mast.csv"
    _write_csv(p, {"t": list(t), **{c: list(x) for c, x in zip("uvw", _to_sensor(vel, 25.0))}})
    rec = read_record(RecordSpec(str(p), position=pos, columns={"time": "t"}, noise_std=0.02))
    twin = conditioned_box(P, shape, sp, 1, rec.line_record(), U=U, dtype=np.float64)
    back = sample_sonic(twin, Sonic(position=pos, rate=fs), t, U)
    res = back[:, 0] - U - (rec.values["u"] - rec.values["u"].mean())
    assert np.sqrt(np.mean(res**2)) < 1.5 * 0.02  # within the stated noise (E = sigma_n^2: exchangeability)
    # The record's own small rotation (the row's mean v) aside, the twin is the truth at the sensor.
    tr = truth["u"].values[(-np.arange(shape[0])) % shape[0], 3, 4]
    assert np.corrcoef(back[:, 0], tr)[0, 1] > 0.99


def test_mann_parameters_fitted_to_a_read_record_recover_the_tensor(tmp_path):
    """The scene's fit_to path on a record read from file: a line of the tensor, sampled as a sonic."""
    from cwlidar_sim.analysis.records import fit_mann_to_record
    from cwlidar_sim.turbulence import MannParameters, generate_line

    P, U, n = MannParameters(0.06, 20.0, 3.9), 8.0, 2**14
    line = generate_line(P, n, 0.5, 4, dtype=np.float64)
    fs = U / 0.5
    rev = (-np.arange(n)) % n
    p = tmp_path / "fit.csv"
    _write_csv(p, {"u": list(U + line["u"].values[rev]), "v": list(line["v"].values[rev]),
                   "w": list(line["w"].values[rev])})
    fit = fit_mann_to_record(read_record(RecordSpec(str(p), sample_rate=fs, rotation="none")), k_min=0.01,
                             segment_duration=n / fs / 4)
    # Four segments of 2 km: the fit's own 1-sigma (chi-square) uncertainties set the tolerance.
    for name, true in (("length_scale", 20.0), ("gamma", 3.9), ("alpha_eps", 0.06)):
        assert abs(getattr(fit.params, name) - true) < 4 * fit.std[name] + 0.02 * true, (name, fit.params, fit.std)
