"""The worked example of a new sensor (examples/two_beam_lidar.py) runs and measures the wind it is given."""

import importlib.util
import os
import sys


def test_two_beam_lidar_example_reconstructs_the_wind():
    path = os.path.join(os.path.dirname(__file__), os.pardir, "examples", "two_beam_lidar.py")
    spec = importlib.util.spec_from_file_location("two_beam_lidar", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses resolve their annotations through the module
    try:
        spec.loader.exec_module(mod)
    finally:
        del sys.modules[spec.name]
    u, v = mod.main()
    # uniform wind: each beam's median estimate is within a fifth of a bin (0.015 m/s) of |v_r| (the
    # rectangular window's pull toward bin centres, tests/signal/test_estimators.py), so u and v are within
    # 0.015 / cos(15 deg) and 0.015 / sin(15 deg) of the truth
    assert abs(u - 8.0) < 0.016 and abs(v - 1.0) < 0.06
