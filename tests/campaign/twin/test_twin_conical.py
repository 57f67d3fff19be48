"""The virtual twin of a conical scene, end to end at reduced size: boxes conditioned on a mast, Dask, resume.

The truth is a Mann line at the mast (the surface layer's tensor at 40 m), read by a sonic at the
circle's centre at U / dx = 5 Hz with 0.05 m/s of white noise: 60 s, two 30-s periods, two twins.
"""

import math
import os
import shutil
import signal
import threading

import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene, read_results

U, DX, T, NOISE, Z = 10.0, 2.0, 30.0, 0.05, 40.0
N_TWINS, N_PERIODS = 2, 2

SCENE = """
name = "ct"
kind = "conical"
seed = 5
duration = {T}
[scan]
heights = [{Z}]
scan_revs = [1]
[lidar]
tier = "los"
[turbulence]
condition_on = [{{ path = "mast.csv", kind = "sonic", position = [{pos}], noise_std = {NOISE}, rotation = "none" }}]
[[period]]
name = "p0"
mean_speed = 10.0
wind_direction_deg = {wd}
"""


def _scene(folder, pos=(0.0, 0.0, Z), wd=30.0):
    return loads_scene(SCENE.format(T=T, Z=Z, NOISE=NOISE, pos=", ".join(map(str, pos)), wd=wd),
                       base_dir=str(folder))


def _write_mast(path, seeds=(7, 8)):
    """The truth at the mast as a 5 Hz CSV: per period the row at (0, 0, Z) of its own box (seed ``seeds[k]``).

    Each truth box is one the twin could draw (the scene's lidar, tensor, spacing, lateral doubling, x
    period U T): the record is then a sample of the model the twin conditions, so the theory holds exactly.
    """
    from cwlidar_sim.sensors import Sonic, nearest_node, sample_sonic
    from cwlidar_sim.sensors.conical import ConicalLidar
    from cwlidar_sim.turbulence.cover import cover_box
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    scene = _scene(".")
    params = surface_layer_parameters(Z, U)[0]
    lidar = ConicalLidar(heights=(Z,), **scene.lidar_fields(DX))
    n = int(round(U * T / DX))
    t = np.arange(n) * DX / U
    vel = []
    for s in seeds:
        box = cover_box(lidar.box_region(DX), U, T, params, s, spacing=DX, period_x=U * T)
        # the truth's mast on a node, as the twin conditions and reads it
        vel.append(sample_sonic(box, Sonic(position=nearest_node(box, (0.0, 0.0, Z)), rate=U / DX), t, U))
    vel = np.concatenate(vel) + np.random.default_rng(seeds[0]).normal(0.0, NOISE, (n * len(seeds), 3))
    with open(path, "w") as f:
        f.write("time,u,v,w\n")
        for ti, (u, v, w) in zip(np.arange(vel.shape[0]) * DX / U, vel):
            f.write(f"{ti:.6f},{u:.6f},{v:.6f},{w:.6f}\n")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """Run the twins once, keeping each conditioned box (both lateral halves) as the twin generated it."""
    import cwlidar_sim.turbulence.conditioning as cond
    from cwlidar_sim.campaign.twin.run import run_twin

    d = tmp_path_factory.mktemp("ctwin")
    _write_mast(d / "mast.csv")
    scene = _scene(d)
    boxes = []
    orig = cond.condition_field

    def keep(box, *a, **k):
        out = orig(box, *a, **k)
        boxes.append(out.copy(deep=True))
        return out

    cond.condition_field = keep
    try:
        lines = []
        files = run_twin(scene, d / "out", n_twins=N_TWINS, progress=lines.append)
    finally:
        cond.condition_field = orig
    return {"dir": d, "scene": scene, "files": files, "boxes": boxes, "lines": lines}


def _at(box, pos, tp, U_box):
    """The box's (u - U, v, w) at the node nearest ``pos`` at the record's times, as the package's sonic reads it."""
    from cwlidar_sim.sensors import Sonic, nearest_node, sample_sonic

    rec = tp.records[0]
    t = np.arange(rec.n_samples) / rec.sample_rate
    vel = sample_sonic(box, Sonic(position=nearest_node(box, pos), rate=rec.sample_rate), t, U_box)
    vel[:, 0] -= U_box
    return vel


def test_conditioned_box_reproduces_the_record_at_the_mast_within_the_noise(run):
    """Hoffman-Ribak: at the sensor the twin minus the record has variance sigma_n^2 exactly.

    Per Fourier coefficient (signal S, noise N, K = S / (S + N)): twin - record = (1 - K)(f - s - e) - K e~,
    of variance (1 - K)^2 (2 S + N) + K^2 N = N whatever S, when the record is a sample of the twin's own
    model (here: it is).  Over n samples the mean square lies in sigma_n^2 (1 +- 4 sqrt(2 / n)); without
    the noise draw e~ it would be (1 - K)^2 (2 S + N) < N, forced through the record's own noise.
    """
    from cwlidar_sim.campaign.twin.run import twin_periods

    tps = twin_periods(run["scene"])
    assert len(tps) == N_PERIODS and len(run["boxes"]) == N_PERIODS * N_TWINS
    for k, tp in enumerate(tps):
        rec = tp.records[0]
        d = np.stack([rec.values[c] - rec.values[c].mean() for c in "uvw"], axis=1)
        n = d.shape[0]
        for j in range(N_TWINS):
            box = run["boxes"][k * N_TWINS + j]
            assert float(box.attrs["convection_speed"]) == pytest.approx(rec.mean_speed)
            diff = _at(box, (0.0, 0.0, Z), tp, rec.mean_speed) - d
            var = np.mean(diff**2, axis=0)
            band = 4 * math.sqrt(2.0 / n)
            assert np.all(var < NOISE**2 * (1 + band)) and np.all(var > NOISE**2 * (1 - band)), (k, j, var)


def test_twins_share_the_conditioned_part_and_differ_away_from_it(run):
    """At the mast two twins differ by two noise draws (2 sigma_n^2); 20 m across the wind by much more."""
    from cwlidar_sim.campaign.twin.run import twin_periods

    tp = twin_periods(run["scene"])[0]
    a, b = run["boxes"][0], run["boxes"][1]
    Ub = tp.records[0].mean_speed
    at_mast = np.mean((_at(a, (0.0, 0.0, Z), tp, Ub) - _at(b, (0.0, 0.0, Z), tp, Ub)) ** 2, axis=0)
    assert np.all(at_mast < 2 * NOISE**2 * (1 + 4 * math.sqrt(2.0 / tp.records[0].n_samples)))
    off = np.mean((_at(a, (0.0, 20.0, Z), tp, Ub) - _at(b, (0.0, 20.0, Z), tp, Ub)) ** 2, axis=0)
    assert np.all(off > 20 * at_mast), (off, at_mast)
    # different twins, different seeds: their lidars differ
    ds = read_results(run["files"][0])
    seeds = ds["twin_seed"].values.ravel()
    assert len(set(seeds.tolist())) == N_TWINS
    lid = ds["lidar_std"].values.ravel()
    assert np.all(np.diff(lid) != 0)


def test_twin_file_holds_each_twin_its_spread_and_the_records_statistics(run):
    ds = read_results(run["files"][0])
    assert ds.sizes["twin"] == N_TWINS and ds.attrs["scene_kind"] == "conical"
    for v in ds.data_vars:
        assert "units" in ds[v].attrs, v
    for v in ("lidar_std", "lidar_mean", "std_ratio", "tp", "cup_std"):
        assert v in ds and f"{v}_twin_mean" in ds and f"{v}_twin_std" in ds
    sd = np.std(ds["lidar_std"].values, axis=0, ddof=1)
    assert np.allclose(ds["lidar_std_twin_std"].values, sd)
    assert ds["lidar_std"].dims == ("twin", "height", "scan_s")
    assert float(ds["record0_std"]) > 0 and ds["records_used"].values.ravel().tolist() == ["[0]"]
    assert any("twin 2/2" in s for s in run["lines"])


def test_seeds_are_distinct_per_period_twin_and_height_and_the_field_reproducible(run):
    from cwlidar_sim.campaign.twin.run import conical_twin_scene, twin_periods

    import dataclasses

    scene = run["scene"]
    tps = twin_periods(scene)
    two = scene.replace(scan=dataclasses.replace(scene.scan, heights=(Z, 60.0)))
    s = {conical_twin_scene(two, tp, h, j, U).periods[0].seed for tp in tps for h in (0, 1) for j in (0, 1)}
    assert len(s) == 8
    assert conical_twin_scene(two, tps[0], 1, 0, U).scan.heights == (60.0,)
    a = read_results(run["files"][1])
    b = read_results(run["files"][1])
    assert a["twin_seed"].values.tolist() == b["twin_seed"].values.tolist()


def test_dask_gives_the_same_bits_as_local(run, tmp_path):
    distributed = pytest.importorskip("distributed")
    from cwlidar_sim.campaign.twin.run import run_twin

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        files = run_twin(run["scene"], tmp_path / "dask", n_twins=N_TWINS, client=client)
    assert [os.path.basename(f) for f in files] == [os.path.basename(f) for f in run["files"]]
    for f, g in zip(files, run["files"]):
        a, b = read_results(f), read_results(g)
        for v in a.data_vars:
            assert np.array_equal(a[v].values, b[v].values), v
        assert a.attrs["identity"] == b.attrs["identity"]


def test_resume_recomputes_only_what_changed_records_or_twin_count_affect(run, tmp_path):
    from cwlidar_sim.campaign.twin.run import run_twin

    out = tmp_path / "out"
    shutil.copytree(run["dir"] / "out", out)
    mtimes = [os.stat(out / os.path.basename(f)).st_mtime_ns for f in run["files"]]
    lines = []
    run_twin(run["scene"], out, n_twins=N_TWINS, progress=lines.append)
    assert sum("done already" in s for s in lines) == N_PERIODS
    # the second period's record changes: only P001 is recomputed
    _write_mast(tmp_path / "mast2.csv", seeds=(7, 9))
    lines = []
    files = run_twin(run["scene"], out, paths=[tmp_path / "mast2.csv"], n_twins=N_TWINS, progress=lines.append)
    assert any("P000: done already" in s for s in lines)
    assert any("P001" in s and "from other inputs; recomputing" in s for s in lines)
    assert os.stat(files[0]).st_mtime_ns == mtimes[0] and os.stat(files[1]).st_mtime_ns != mtimes[1]
    # another twin count: every period recomputed
    lines = []
    files = run_twin(run["scene"], out, paths=[tmp_path / "mast2.csv"], n_twins=1, progress=lines.append,
                     periods=[0])
    assert any("P000" in s and "recomputing" in s for s in lines) and read_results(files[0]).sizes["twin"] == 1


def test_bad_input_is_refused_before_compute(run, tmp_path, monkeypatch):
    import cwlidar_sim.campaign.periods.conical as conical
    from cwlidar_sim.campaign.twin.run import run_twin

    def boom(*a, **k):
        raise AssertionError("computed before the input was checked")

    shutil.copy(run["dir"] / "mast.csv", tmp_path / "mast.csv")
    # a mast outside every box: 500 m across the wind
    far = _scene(tmp_path, pos=(0.0, 500.0, Z))
    monkeypatch.setattr(conical, "run_unit", boom)
    with pytest.raises(ValueError, match=r"no record of condition_on lies in the box") as e:
        run_twin(far, tmp_path / "o", n_twins=2)
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match=r"n_twins"):
        run_twin(run["scene"], tmp_path / "o", n_twins=0)
    with pytest.raises(ValueError, match=r"--records gives 2 file\(s\)"):
        run_twin(run["scene"], tmp_path / "o", paths=[tmp_path / "mast.csv"] * 2)
    monkeypatch.undo()
    # the scene runs only as a twin
    with pytest.raises(ValueError, match="run it with 'cwlidar-sim twin'"):
        conical.run_unit(run["scene"], 0)


def test_cli_twin_runs_a_conical_scene(run, tmp_path, capsys):
    import json

    from cwlidar_sim.cli import main

    scene_path = run["dir"] / "ct.toml"
    scene_path.write_text(SCENE.format(T=T, Z=Z, NOISE=NOISE, pos=f"0.0, 0.0, {Z}", wd=30.0))
    out = tmp_path / "o"
    shutil.copytree(run["dir"] / "out", out)
    rc = main(["twin", str(scene_path), "--twins", str(N_TWINS), "--out", str(out), "--no-progress"])
    assert rc == 0 and len(json.loads(capsys.readouterr().out)["periods"]) == N_PERIODS


def test_mast_positions_turn_with_the_wind_into_the_field_frame(run, tmp_path):
    """A mast 10 m toward the lidar's azimuth 90 deg, the wind blowing toward 90 deg: 10 m downwind (x), y = 0."""
    from cwlidar_sim.campaign.twin.run import conical_unit_records, twin_periods
    from cwlidar_sim.sensors.conical import ConicalLidar
    from cwlidar_sim.turbulence.cover import cover_yz
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    shutil.copy(run["dir"] / "mast.csv", tmp_path / "mast.csv")
    # toward 270 deg the mast is upwind; toward 180 deg it lies to the right of the wind (field y < 0)
    for wd, expect in ((90.0, (10.0, 0.0)), (0.0, (0.0, 10.0)), (270.0, (-10.0, 0.0)), (180.0, (0.0, -10.0))):
        sc = _scene(tmp_path, pos=(0.0, 10.0, Z), wd=wd)
        tp = twin_periods(sc)[0]
        used, (line,), Ub = conical_unit_records(sc, tp, 0)
        assert used == [0] and Ub == pytest.approx(tp.records[0].mean_speed)
        assert line.position[0] == pytest.approx(expect[0] - Ub * tp.delay, abs=1e-9)
        # on the box's node nearest the mast across the wind (at most half a cell off)
        y_n, z_n = cover_yz(ConicalLidar(heights=(Z,), **sc.lidar_fields(DX)).box_region(DX), DX,
                            params=surface_layer_parameters(Z, Ub)[0])
        assert np.min(np.abs(y_n - line.position[1])) < 1e-9 and np.min(np.abs(z_n - line.position[2])) < 1e-9
        assert abs(line.position[1] - expect[1]) <= 0.5 * DX + 1e-9 and abs(line.position[2] - Z) <= 0.5 * DX + 1e-9


def test_cycle_mode_conditions_one_box_on_the_records_at_every_height(run, tmp_path):
    """A cycling lidar's one box holds both heights' records (here the mast's CSV read at 40 and 60 m)."""
    from cwlidar_sim.campaign.twin.run import run_twin

    shutil.copy(run["dir"] / "mast.csv", tmp_path / "mast.csv")
    text = SCENE.format(T=T, Z=Z, NOISE=NOISE, pos=f"0.0, 0.0, {Z}", wd=0.0)
    text = text.replace(f"heights = [{Z}]", f"heights = [{Z}, 60.0]\ncycle = true\nrevs_per_height = 1")
    text = text.replace('rotation = "none" }]', 'rotation = "none", name = "m40" }, { path = "mast.csv", '
                        'kind = "sonic", position = [0.0, 0.0, 60.0], noise_std = 0.05, rotation = "none", '
                        'name = "m60" }]')
    sc = loads_scene(text, base_dir=str(tmp_path))
    (f,) = run_twin(sc, tmp_path / "o", n_twins=1, periods=[0])
    ds = read_results(f)
    assert ds["height"].values.tolist() == [Z, 60.0] and ds.sizes["twin"] == 1
    assert ds["records_used"].values.tolist() == ["[0, 1]", "[0, 1]"]
    assert np.all(np.isfinite(ds["lidar_std"].values))



#: Released at the end of a test so that a worker thread held in a twin may end.
_RELEASE = threading.Event()


def _held_twin(scene, tp, j, params=None, status=None):
    """Held until the test ends (module level: the cluster pickles it by name)."""
    _RELEASE.wait(120)


def test_a_twin_run_whose_workers_die_stops(run, tmp_path, monkeypatch):
    """The last worker goes while twins are pending: a clear error in bounded time, not a wait forever."""
    distributed = pytest.importorskip("distributed")
    from cwlidar_sim._dask import WorkersLostError
    from cwlidar_sim.campaign.twin import run as twin

    def ring(signum, frame):
        raise AssertionError("still waiting after 60 s")

    monkeypatch.setattr(twin, "twin_task", _held_twin)
    _RELEASE.clear()
    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(60)
    try:
        with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                      dashboard_address=None) as cluster, distributed.Client(cluster) as client:
            threading.Timer(0.5, cluster.scale, (0,)).start()
            with pytest.raises(WorkersLostError, match="no worker for 1 s"):
                twin.run_twin(run["scene"], tmp_path / "dask", n_twins=N_TWINS, client=client, worker_timeout=1.0)
    finally:
        _RELEASE.set()
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
