"""The platform-motion CSV (read_platform_csv): the time unit from the header, holes refused, bad times named."""

import numpy as np
import pytest

from cwlidar_sim.sensors.platform import read_platform_csv


def _write(path, header, t, heave):
    with open(path, "w") as f:
        f.write(f"{header},heave\n")
        for ti, h in zip(t, heave):
            f.write(f"{ti},{h}\n")
    return str(path)


def test_time_in_ms_named_by_the_header_is_seconds_in_the_motion(tmp_path):
    t_s = np.arange(0, 620) / 10.0
    heave = 0.5 * np.sin(2 * np.pi * t_s / 7.0)
    ms = read_platform_csv(_write(tmp_path / "ms.csv", "time_ms", [f"{x * 100}" for x in range(620)], heave))
    s = read_platform_csv(_write(tmp_path / "s.csv", "time", [f"{x:.1f}" for x in t_s], heave))
    np.testing.assert_array_equal(ms.time, s.time)
    np.testing.assert_allclose(ms.time[-1], 61.9)
    # the motion at a time between samples is the same physics whichever unit the file used
    d_ms, v_ms, _ = ms.at([3.05, 40.0])
    d_s, v_s, _ = s.at([3.05, 40.0])
    np.testing.assert_array_equal(d_ms, d_s) and np.testing.assert_array_equal(v_ms, v_s)
    assert read_platform_csv(_write(tmp_path / "us.csv", "time [us]", [f"{x * 100000}" for x in range(620)],
                                    heave)).time[-1] == pytest.approx(61.9)


def test_time_in_ms_without_its_unit_is_refused_naming_the_column_and_the_unit(tmp_path):
    p = _write(tmp_path / "m.csv", "time", [f"{x * 100}" for x in range(620)], np.zeros(620))
    with pytest.raises(ValueError, match=r"time column 'time': read in s, the times step by 100 s \(0.01 Hz\); "
                                         r"allowed: a platform series at 1-1000 Hz; read in ms it would be 10 Hz") as e:
        read_platform_csv(p)
    assert "\n" not in str(e.value)


def test_a_hole_longer_than_max_gap_is_refused_with_its_place(tmp_path):
    t = np.concatenate([np.arange(0, 300) / 10.0, 130.0 + np.arange(0, 300) / 10.0])  # 100-s hole after 29.9 s
    p = _write(tmp_path / "m.csv", "time", [f"{x:.1f}" for x in t], np.zeros(t.size))
    with pytest.raises(ValueError, match=r"a hole of 100.1 s between samples 299 and 300 \(t = 29.900000000 to "
                                         r"130.000000000 s\); allowed: steps up to max_gap = 1 s"):
        read_platform_csv(p)
    assert read_platform_csv(p, max_gap=200.0).time.size == 600  # a stated, larger limit accepts it
    with pytest.raises(ValueError, match="max_gap"):
        read_platform_csv(p, max_gap=0.0)


@pytest.mark.parametrize("cells, match", [
    (["0", "0.1", "0.1", "0.3"], "sample 2 at t = 0.100000000 s repeats"),
    (["0", "0.2", "0.1", "0.3"], "sample 2 .* goes back"),
    (["0", "nan", "0.2", "0.3"], "time is missing at sample 1"),
    (["0", "0.1", "", "0.3"], "time is missing at sample 2"),
    ([f"{i / 36000:.12f}" for i in range(10)], r"read in h it would be 10 Hz"),
])
def test_bad_times_are_named(tmp_path, cells, match):
    p = _write(tmp_path / "m.csv", "time", cells, np.zeros(len(cells)))
    with pytest.raises(ValueError, match=match):
        read_platform_csv(p)


def test_bad_columns_and_values_are_named(tmp_path):
    (tmp_path / "a.csv").write_text("time,bob\n0,1\n0.1,1\n")
    with pytest.raises(ValueError, match=r"columns \['time', 'bob'\]"):
        read_platform_csv(str(tmp_path / "a.csv"))
    (tmp_path / "b.csv").write_text("time,heave\n0,1\n0.1,x\n")
    with pytest.raises(ValueError, match=r"column 'heave' sample 1 is 'x'"):
        read_platform_csv(str(tmp_path / "b.csv"))
    (tmp_path / "c.csv").write_text("time,heave\n0,1\n")
    with pytest.raises(ValueError, match=r"1 sample row"):
        read_platform_csv(str(tmp_path / "c.csv"))


def test_negative_times_are_kept(tmp_path):
    t = np.arange(-10, 621) / 10.0  # from 1 s before the period, as the sinusoids are sampled
    m = read_platform_csv(_write(tmp_path / "m.csv", "time", [f"{x:.1f}" for x in t], 0.1 * t))
    assert m.time[0] == -1.0 and m.heave[0] == pytest.approx(-0.1)
    m.check_covers(0.0, 60.0)
    np.testing.assert_allclose(m.at([0.0])[0][0, 2], 0.0, atol=1e-12)


def test_the_scene_states_the_limit_and_keeps_its_identity_without_it(tmp_path):
    """[platform] max_gap: the stated limit (default 1 s); a scene that does not set it keeps its as_dict."""
    import importlib.util
    import pathlib

    from cwlidar_sim.campaign import loads_scene

    spec = importlib.util.spec_from_file_location(
        "nac_scene_tests", pathlib.Path(__file__).resolve().parents[1] / "campaign" / "scenes" / "test_nacelle_scene.py")
    small = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(small)
    t = np.concatenate([np.arange(0, 300) / 10.0, 130.0 + np.arange(0, 300) / 10.0])
    _write(tmp_path / "m.csv", "time", [f"{x:.1f}" for x in t], np.zeros(t.size))
    _write(tmp_path / "ok.csv", "time", [f"{x:.1f}" for x in np.arange(0, 650) / 10.0], np.zeros(650))
    plain = loads_scene(small.SMALL + '[platform]\ncsv = "ok.csv"\n', base_dir=str(tmp_path))
    assert "max_gap" not in plain.as_dict()["platform"]
    with pytest.raises(ValueError, match=r"hole of 100.1 s .* max_gap = 1 s"):  # checked as the scene loads
        loads_scene(small.SMALL + '[platform]\ncsv = "m.csv"\n', base_dir=str(tmp_path))
    wide = loads_scene(small.SMALL + '[platform]\ncsv = "m.csv"\nmax_gap = 120.0\n', base_dir=str(tmp_path))
    assert wide.sensor(wide.periods[0]).motion.time.size == 600
    with pytest.raises(ValueError, match="platform.max_gap applies to a csv series"):
        loads_scene(small.SMALL + "[platform]\nsurge = 1.0\nmax_gap = 2.0\n")
    with pytest.raises(ValueError, match="platform.max_gap"):
        loads_scene(small.SMALL + '[platform]\ncsv = "m.csv"\nmax_gap = 0.0\n')
