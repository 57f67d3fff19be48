"""The mast kind: one period of the mast (a Mann box, a sonic and a cup at every height), its estimates, summary
and figures -- every member of :class:`cwlidar_sim.campaign.registry.SceneKind`."""

from __future__ import annotations

import json
import math
import os

import numpy as np

from cwlidar_sim import __version__
from cwlidar_sim.campaign.registry import KindBase
from cwlidar_sim.campaign.scenes.spec import RESULTS_VERSION

from .scene import MastScene

#: Wall time of the box per generated point and component on one core [s] (as the built-in kinds assume).
BOX_S_PER_POINT = 30e-9


def box_shape(scene: MastScene, index: int) -> tuple:
    """(nx, ny, nz) of period ``index``'s box: the advected length plus margins, 2 L across, the mast's height."""
    from scipy.fft import next_fast_len

    d, L = scene.mast.spacing, scene.turbulence.length_scale
    U = scene.periods[index].mean_speed
    nx = next_fast_len(int(math.ceil((U * scene.duration + 8 * d) / d)), real=True)
    ny = next_fast_len(max(8, int(math.ceil(2 * L / d))), real=True)
    nz = next_fast_len(max(8, int(math.ceil((max(scene.mast.heights) + L) / d))), real=True)
    return nx, ny, nz


class MastKind(KindBase):
    """``kind = "mast"``: a met mast of sonics and cups in a Mann box, one unit per period."""

    name = "mast"
    scene_class = MastScene

    def run_unit(self, scene: MastScene, index: int, params=None, *, status=None):
        """Period ``index``: the box, then a sonic and a cup at every height; one row on ``period``, by ``height``."""
        import xarray as xr

        from cwlidar_sim.sensors import Cup, Sonic, nearest_node, sample_cup, sample_sonic
        from cwlidar_sim.turbulence import MannParameters, generate_box

        p = scene.periods[index]
        m, U, T = scene.mast, p.mean_speed, scene.duration
        if status is not None:
            status(f"{p.name}: box")
        box_seq, noise_seq = np.random.SeedSequence(scene.unit_seed(index)).spawn(2)
        shape = box_shape(scene, index)
        tensor = MannParameters(scene.turbulence.alpha_eps, scene.turbulence.length_scale, scene.turbulence.gamma)
        box = generate_box(tensor, shape, (m.spacing,) * 3, int(box_seq.generate_state(1, np.uint64)[0] >> np.uint64(1)))
        x0 = U * T + 4 * m.spacing  # the field at x0 - U t stays inside the box for t in [0, T)
        rng = np.random.default_rng(noise_seq)
        rows = {k: [] for k in ("sonic_mean", "sonic_std", "cup_mean", "cup_std", "w_std")}
        for z in m.heights:
            pos = nearest_node(box, (x0, 0.0, z))
            sonic = Sonic(position=pos, rate=m.sonic_rate, noise_std=m.sonic_noise_std)
            vel = sample_sonic(box, sonic, sonic.times(T), U, seed=rng)
            speed = np.hypot(vel[:, 0], vel[:, 1])
            cup = Cup(position=pos, distance_constant=m.cup_distance_constant)
            cup_t = sample_cup(box, cup, cup.times(T), U)
            rows["sonic_mean"].append(speed.mean())
            rows["sonic_std"].append(speed.std(ddof=1))
            rows["cup_mean"].append(cup_t.mean())
            rows["cup_std"].append(cup_t.std(ddof=1))
            rows["w_std"].append(vel[:, 2].std(ddof=1))
        meaning = {"sonic_mean": "sonic mean horizontal speed", "sonic_std": "sonic horizontal-speed std",
                   "cup_mean": "cup mean speed", "cup_std": "cup speed std", "w_std": "sonic vertical-wind std"}
        dv = {k: (("period", "height"), np.array([v]), {"units": "m s-1", "long_name": meaning[k]})
              for k, v in rows.items()}
        dv["cup_sonic_std_ratio"] = (("period", "height"), np.array([rows["cup_std"]]) / np.array([rows["sonic_std"]]),
                                     {"units": "1", "long_name": "cup std / sonic std (the cup's first-order filter)"})
        dv["mean_speed"] = (("period",), np.array([U]), {"units": "m s-1"})
        coords = {"period": ("period", np.array([p.name], dtype=object)),
                  "height": ("height", np.array(m.heights), {"units": "m"})}
        attrs = {"title": f"mast campaign {scene.name}", "results_version": RESULTS_VERSION, "sensor": self.name,
                 "scene": json.dumps(scene.as_dict()), "cwlidar_sim_version": __version__, "period_index": int(index),
                 "field_reason": f"box {'x'.join(map(str, shape))} at {m.spacing:g} m", "timing": json.dumps({})}
        return xr.Dataset(dv, coords=coords, attrs=attrs)

    def estimate_bytes(self, scene: MastScene) -> float:
        """A few numbers per period and height, and the file's overhead."""
        return 64.0 * 8 * len(scene.periods) * len(scene.mast.heights) + 1e6

    def estimate_unit(self, scene: MastScene, index: int, params=None) -> dict:
        """The box dominates: 30 ns per point and component, three float32 components and their transform."""
        points = math.prod(box_shape(scene, index))
        return {"seconds": 3 * points * BOX_S_PER_POINT + 1.0, "memory_bytes": 3 * 4 * points * 2.0}

    def summary(self, scene: MastScene, ds) -> dict:
        """The cup / sonic std ratio per period and height."""
        return {"cup_sonic_std_ratio": {str(p): {f"{float(z):g} m": round(float(r), 4) for z, r in zip(ds.height.values, row)}
                                        for p, row in zip(ds.period.values, ds.cup_sonic_std_ratio.values)}}

    def figures(self, ds, out_dir) -> list:
        """``std_profile.png``: the sonic's and the cup's std against height, one line per period."""
        import matplotlib.pyplot as plt

        os.makedirs(out_dir, exist_ok=True)
        fig, ax = plt.subplots(figsize=(5, 4))
        for i, p in enumerate(ds.period.values):
            line, = ax.plot(ds.sonic_std.values[i], ds.height.values, "o-", label=f"{p}: sonic")
            ax.plot(ds.cup_std.values[i], ds.height.values, "s--", color=line.get_color(), label=f"{p}: cup")
        ax.set_xlabel("horizontal-speed std [m/s]")
        ax.set_ylabel("height [m]")
        ax.legend(fontsize=8)
        path = os.path.join(os.fspath(out_dir), "std_profile.png")
        fig.savefig(path, dpi=100)
        plt.close(fig)
        return [path]

    def quick(self, scene: MastScene) -> MastScene:
        """Two-minute periods: the same boxes' statistics, noisier."""
        return scene.replace(duration=120.0)


KIND = MastKind()
