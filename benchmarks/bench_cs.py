"""Wall time and peak memory of ``cwlidar-sim reproduce cs`` against its tier-1 floor.

    python benchmarks/bench_cs.py [--quick] [--json PATH] [--threads N]

One fresh interpreter (``--child``, the shared protocol of ``benchmarks/_protocol.py``)
per measurement: it imports the package,
warms the JIT on one 60-s unit at each tier, then times the bundled scene
(its plan of 18-42 ten-minute periods per height, 138 units; ``--quick``: two
periods per height) with the spectral tier, and the same
scene with the scanning lidar at tier 1 (weighted line-of-sight averages, no
Doppler spectra: the floor any tier must pay for the boxes, the sampling, the
cup, the sonic, the fits and the filter model).  Peak memory is the child's
VmHWM.  Targets (issue 14): full run under 10 minutes and --quick under
3 minutes on 2 cores with the spectral tier.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import vmhwm  # noqa: E402

TARGET_S = {"full": 600.0, "quick": 180.0}


def _child(task) -> dict:
    quick, threads = task["quick"], task["threads"]
    from cwlidar_sim import _config
    from cwlidar_sim.campaign import bundled_scene, run_scene
    from cwlidar_sim.campaign.figures.staring import make_figures

    _config.set_num_threads(threads)
    scene = bundled_scene("cs", quick=quick)
    for tier in ("los", "spectral"):
        warm = scene.replace(duration=60.0, periods=scene.periods[:1],
                             scan=dataclasses.replace(scene.scan, heights=scene.scan.heights[:1],
                                                      periods_per_height=()),
                             lidar=dataclasses.replace(scene.lidar, tier=tier))
        run_scene(warm, progress=False)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        ds = run_scene(scene, tmp, progress=False)
        make_figures(ds, tmp)
        out["wall_s"] = time.perf_counter() - t
    floor = scene.replace(lidar=dataclasses.replace(scene.lidar, tier="los", variants=()))
    t = time.perf_counter()
    run_scene(floor, progress=False)
    out["floor_s"] = time.perf_counter() - t
    out["units"] = len(scene.unit_names())
    out["peak_bytes"] = vmhwm()
    out["std_ratio"] = ds.std_ratio.values.round(4).tolist()
    return out


def main(argv=None) -> int:
    return _protocol.scene_benchmark_main(__file__, _child, name="cs", targets=TARGET_S, what="units", argv=argv)


if __name__ == "__main__":
    sys.exit(main())
