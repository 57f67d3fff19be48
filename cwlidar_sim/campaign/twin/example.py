"""The virtual twin's bundled example: a truth, its virtual mast, a CSV, twins from the CSV only, the closed loop.

1. :func:`write_twin_example` runs the bundled ``examples/twin/truth.toml``
   (a staring lidar and a sonic at its focus in a simulated "truth" field),
   writes the sonic's 32 Hz record as ``mast_sonic.csv`` (time, u, v, w; the
   record the mast "measured", noise included), the truth's own 10 Hz lidar
   and sonic as ``truth.nc``, and ``twin.toml`` (the twin scene naming the
   CSV) into one folder.
2. ``cwlidar-sim twin DIR/twin.toml --twins N --out OUT`` (or
   :func:`cwlidar_sim.campaign.twin.run.run_twin`) builds the twins from the CSV
   alone.
3. :func:`closed_loop` compares each twin's lidar with the truth's lidar:
   the squared coherence against the theory ``gamma^4``, the lidar's 10-minute
   std of the truth against the twins' spread.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from ..._atomic import atomic_open

__all__ = ["example_text", "write_twin_example", "closed_loop"]


def example_text(name: str) -> str:
    """Text of a bundled twin example file (``truth.toml`` or ``twin.toml``)."""
    from importlib import resources

    if name not in ("truth.toml", "twin.toml"):
        raise ValueError(f"no bundled twin example {name!r}; allowed: 'truth.toml', 'twin.toml'")
    return resources.files("cwlidar_sim.campaign").joinpath("data", "examples", "twin", name).read_text(encoding="utf-8")


def write_twin_example(out_dir, *, periods: int = 1, duration: float | None = None, seed: int | None = None,
                       status=None) -> dict:
    """Run the truth and write the example's folder (see the module notes).

    Parameters
    ----------
    out_dir : str or path
        Folder (created); gets ``mast_sonic.csv``, ``truth.nc``, ``twin.toml``.
    periods : int
        Consecutive truth periods (independent fields, one record); in [1, 1000].
    duration : float, optional
        Period length [s] instead of the scenes' 600 s (both scenes get it;
        the analysis segment follows); in [10, 3600].
    seed : int, optional
        Seed of the truth scene (default its file's).

    Returns
    -------
    dict
        Paths: ``csv``, ``truth``, ``scene`` (the twin scene file).
    """
    import xarray as xr

    from ..._validation import check_int, check_real, check_seed
    from ..periods.staring_field import scene_params
    from ..scenes.load import loads_scene
    from ..scenes.staring import PeriodSpec
    from ..periods.staring import SONIC_DELAY, run_unit
    from ..execution.store import write_results

    periods = check_int("periods", periods, lo=1, hi=1000)
    truth = loads_scene(example_text("truth.toml"))
    T = truth.duration if duration is None else check_real("duration", duration, lo=10.0, hi=3600.0)
    tmpl = truth.periods[0]
    ps = tuple(PeriodSpec(name=f"P{k:03d}", mean_speed=tmpl.mean_speed, duration=T, start=k * T)
               for k in range(periods))
    an = dataclasses.replace(truth.analysis, segment_duration=min(truth.analysis.segment_duration, T))
    truth = truth.replace(periods=ps, duration=T, analysis=an,
                          seed=truth.seed if seed is None else check_seed("seed", seed))
    params, _ = scene_params(truth)
    os.makedirs(out_dir, exist_ok=True)
    t_all, v_all, lid, son = [], [], [], []
    for k in range(periods):
        if status:
            status(f"truth period {k + 1}/{periods}")
        ds = run_unit(truth, k, params)
        vel = np.asarray(ds["sonic_velocity"].values[0], dtype=np.float64)
        t_all.append(k * T + SONIC_DELAY + np.arange(vel.shape[0]) / 32.0)
        v_all.append(vel)
        lid.append(np.asarray(ds["lidar_10hz"].values[0], dtype=np.float64))
        son.append(np.asarray(ds["sonic_10hz"].values[0], dtype=np.float64))
    t, vel = np.concatenate(t_all), np.concatenate(v_all)
    csv = os.path.join(out_dir, "mast_sonic.csv")
    with atomic_open(csv, "w") as fh:
        fh.write("time,u,v,w\n")
        for ti, (u, v, w) in zip(t, vel):
            fh.write(f"{ti:.6f},{u:.5f},{v:.5f},{w:.5f}\n")
    n10 = lid[0].size
    tr = xr.Dataset({"lidar_10hz": (("period", "time_10hz"), np.stack(lid),
                                    {"units": "m s-1", "long_name": "the truth's lidar speed, 10 Hz"}),
                     "sonic_10hz": (("period", "time_10hz"), np.stack(son),
                                    {"units": "m s-1", "long_name": "the truth's sonic speed toward the lidar, 10 Hz"})},
                    coords={"time_10hz": ("time_10hz", 0.05 + 0.1 * np.arange(n10), {"units": "s"})},
                    attrs={"scene": truth.name, "duration": T, "seed": truth.seed})
    truth_path = os.path.join(out_dir, "truth.nc")
    write_results(tr, truth_path)
    text = example_text("twin.toml").replace("duration = 600.0", f"duration = {T!r}")
    text = text.replace("segment_duration = 600.0", f"segment_duration = {an.segment_duration!r}")
    scene_path = os.path.join(out_dir, "twin.toml")
    with atomic_open(scene_path, "w") as fh:
        fh.write(text)
    return {"csv": csv, "truth": truth_path, "scene": scene_path}


def closed_loop(twin_files, truth_path, *, k_edges=None) -> list:
    """Per period: each twin's lidar against the truth's lidar.

    Parameters
    ----------
    twin_files : list of str
        The twin's period files (:func:`cwlidar_sim.campaign.twin.run.run_twin`).
    truth_path : str
        ``truth.nc`` of :func:`write_twin_example`.
    k_edges : array_like, optional
        Wavenumber bins [rad/m]; default the twin files' ``k`` bins are not
        kept, so 10 per decade from 1e-3 to 5 rad/m.

    Returns
    -------
    list of dict
        Per period: ``k`` [rad/m], ``coherence`` (squared coherence of each
        twin's lidar with the truth's, shape (N, K)), ``coherence_theory``
        (``gamma^4`` of the twin file), ``truth_std`` / ``truth_mean`` [m/s]
        (the truth lidar's 10-minute statistics), ``twin_std`` / ``twin_mean``
        (the twins', shape (N,)).
    """
    from ...analysis import log_bins, transfer_functions
    from ..execution.store import read_results

    tr = read_results(truth_path)
    if k_edges is None:
        k_edges = log_bins(1e-3, 5.0, 10)
    out = []
    for f in twin_files:
        ds = read_results(f)
        p = int(ds.attrs["period_index"])
        truth = np.asarray(tr["lidar_10hz"].values[p], dtype=np.float64)
        U, T = float(ds.attrs["convection_speed"]), float(ds.attrs["duration"])
        coh, k = [], None
        for lid in np.asarray(ds["lidar_10hz"].values, dtype=np.float64):
            tf = transfer_functions(lid, truth, fs=10.0, U=U, k_edges=k_edges, segment_duration=T)
            with np.errstate(invalid="ignore", divide="ignore"):
                coh.append(np.abs(tf.chi_k) ** 2 / (tf.F_r_k * tf.F_s_k))
            k = np.asarray(tf.k_k)
        th = np.full(k.size, np.nan)
        if "coherence_theory_twin_truth" in ds and ds["k"].size == k.size:
            th = np.asarray(ds["coherence_theory_twin_truth"].values)
        out.append({"period": p, "k": k, "coherence": np.array(coh), "coherence_theory": th,
                    "truth_mean": float(np.nanmean(truth)), "truth_std": float(np.nanstd(truth)),
                    "twin_mean": np.asarray(ds["lidar_mean"].values), "twin_std": np.asarray(ds["lidar_std"].values)})
    return out
