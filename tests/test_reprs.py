"""The public objects that hold arrays print their shapes, not their numbers."""

import dataclasses
import importlib
import inspect

import numpy as np

from cwlidar_sim._repr import summary_repr

STAGES = ("turbulence", "beam", "signal", "sensors", "analysis", "campaign")


def test_a_transfer_estimate_of_740_bins_prints_in_one_line():
    from cwlidar_sim.analysis import log_bins, transfer_functions

    rng = np.random.default_rng(1)
    x = rng.standard_normal(60000)
    tf = transfer_functions(x, x + 0.1 * rng.standard_normal(x.size), fs=10.0, U=8.0,
                            k_edges=log_bins(0.001, 5.0, 200), segment_duration=600.0)
    assert tf.k_k.size == 740  # under numpy's 1000-element threshold: its repr printed all 740 of each array
    text = repr(tf)
    assert len(text) < 1000 and "\n" not in text, len(text)
    assert "transfer_cross_k=<float64 (740,)>" in text and "n_segments=10" in text


def test_a_lidar_record_prints_its_shapes_and_its_small_values():
    from cwlidar_sim.sensors import StaringLidar, measure_staring
    from cwlidar_sim.turbulence import MannParameters, generate_line

    field = generate_line(MannParameters.iec(100.0, 1.5), 4096, 0.5, 2)
    rec = measure_staring(field, StaringLidar(tier="los"), np.arange(900) / 50.0, 8.0)
    text = repr(rec)
    assert len(text) < 3000, len(text)
    assert "speed_e=<float64 (900,)>" in text


def test_small_arrays_and_nested_containers():
    from cwlidar_sim._repr import short

    assert short(np.array([1.0, 2.0])) == "[1., 2.]"
    assert short({"a": (np.zeros(50), np.ones(3, dtype=np.uint8))}) == "{'a': (<float64 (50,)>, [1, 1, 1])}"
    assert short([np.zeros((20, 3))]) == "[<float64 (20, 3)>]"


def test_every_public_dataclass_with_array_fields_uses_the_short_repr():
    missing = []
    for stage in STAGES:
        mod = importlib.import_module(f"cwlidar_sim.{stage}")
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isclass(obj) and dataclasses.is_dataclass(obj):
                arrays = [f.name for f in dataclasses.fields(obj) if "ndarray" in str(f.type)]
                if arrays and obj.__repr__ is not summary_repr:
                    missing.append(f"cwlidar_sim.{stage}.{name}")
    assert missing == [], "add __repr__ = summary_repr (cwlidar_sim._repr) to these classes"
