"""Wall time and peak memory of ``cwlidar-sim reproduce nacelle`` against its tier-1 floor.

    python benchmarks/bench_nacelle.py [--quick] [--json PATH] [--threads N]

One fresh interpreter (``--child``, the shared protocol of ``benchmarks/_protocol.py``)
per measurement: it imports the package, warms the JIT on a 60-s version of the scene at
each tier, then times the bundled nacelle scene (``--quick``: 5-min periods) with its
spectral tier and three estimators, and the same scene with the lidar at tier 1 (weighted
line-of-sight averages, no Doppler spectra: the floor any tier pays for the boxes, the
sampling, the REWS, the coherence and the analytic theory).  The scene's own per-period
timing (box, lidar, coherence and theory) is reported beside.  Peak memory is the child's
VmHWM.  Target (issue 20): --quick under 3 minutes on 2 cores.
"""

from __future__ import annotations

import dataclasses
import json
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
    scene = bundled_scene("nacelle", quick=quick)
    for tier in ("los", "spectral"):
        warm = scene.replace(duration=60.0, lidar=dataclasses.replace(scene.lidar, tier=tier),
                             scan=dataclasses.replace(scene.scan, segment_duration=20.0, theory_beams=2))
        run_scene(warm, progress=False)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        ds = run_scene(scene, tmp, progress=False)
        make_figures(ds, tmp)
        out["wall_s"] = time.perf_counter() - t
    out["timing"] = json.loads(ds.attrs["timing"])
    floor = scene.replace(lidar=dataclasses.replace(scene.lidar, tier="los", variants=()))
    t = time.perf_counter()
    fl = run_scene(floor, progress=False)
    out["floor_s"] = time.perf_counter() - t
    out["floor_timing"] = json.loads(fl.attrs["timing"])
    out["units"] = len(scene.unit_names())
    out["peak_bytes"] = vmhwm()
    out["k_half"] = ds.k_half.values.round(4).tolist()
    out["k_half_theory"] = ds.k_half_theory.values.round(4).tolist()
    return out


def main(argv=None) -> int:
    return _protocol.scene_benchmark_main(__file__, _child, name="nacelle", targets=TARGET_S, what="periods", argv=argv,
                                          extra=lambda r: print(json.dumps({"timing": r["timing"], "floor_timing": r["floor_timing"]})))


if __name__ == "__main__":
    sys.exit(main())
