"""Thread count: the environment variable and set_num_threads take effect, and results are bit-identical
(3, 1 and 2 threads).

Run in a subprocess because numba fixes its pool size (NUMBA_NUM_THREADS) when it is
first imported and caps numba.set_num_threads at it: the test process may have been
started with NUMBA_NUM_THREADS=1.
"""

import json
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

SCRIPT = r"""
import hashlib, json, threading
import numpy as np
import numba
from cwlidar_sim import _config
from cwlidar_sim.sensors import StaringLidar, measure_staring
from cwlidar_sim.turbulence import MannParameters, generate_box, generate_line, generate_plane

out = {"env_threads": _config.get_num_threads(), "numba_cap": numba.config.NUMBA_NUM_THREADS}
P = MannParameters(0.06, 18.76, 3.9)

def digest(*arrays):
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()

def run():
    box = generate_box(P, (64, 16, 16), (2.0, 2.0, 2.0), 3)
    plane = generate_plane(P, (128, 16), (1.0, 1.0), 4)
    line = generate_line(P, 2048, 0.5, 5)
    t = np.arange(200) / 50.0
    spec = measure_staring(line, StaringLidar(tier="spectral", position=(100.0, 0.0, 0.0)), t, 8.0, 6)
    sig = measure_staring(line, StaringLidar(tier="signal", position=(100.0, 0.0, 0.0)), t[:8], 8.0, 7)
    return {"box": digest(*(box[c].values for c in "uvw")), "plane": digest(*(plane[c].values for c in "uvw")),
            "spectral": digest(spec.speed_e, spec.flags_e), "signal": digest(sig.speed_e, sig.flags_e),
            "numba_threads": numba.get_num_threads(),
            "pool_threads": sum(th.name.startswith("cwlidar_sim") for th in threading.enumerate())}

out["first"] = run()
_config.set_num_threads(1)
out["one"] = run()
_config.set_num_threads(2)
out["two"] = run()
print(json.dumps(out))
"""


def _run(env_threads, numba_threads):
    env = dict(os.environ, CWLIDAR_SIM_NUM_THREADS=str(env_threads), NUMBA_NUM_THREADS=str(numba_threads))
    r = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="needs 2 CPUs to start 2 numba threads")
def test_thread_count_takes_effect_and_results_are_bit_identical():
    # 3 (not the machine's CPU count, so the variable must have been read) against a numba pool of 2
    out = _run(3, 2)
    assert out["env_threads"] == 3 and out["numba_cap"] == 2
    first, one, two = out["first"], out["one"], out["two"]
    # the count took effect in the package's thread pool, and in numba's kernels up to numba's cap
    assert first["pool_threads"] == 3
    assert first["numba_threads"] == 2 and one["numba_threads"] == 1 and two["numba_threads"] == 2
    for key in ("box", "plane", "spectral", "signal"):
        assert first[key] == one[key] == two[key], key
