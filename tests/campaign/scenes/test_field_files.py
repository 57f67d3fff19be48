"""Scenes fly their instruments through a field the user already has ([turbulence] file): every kind, every format."""

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.beam.sampling import direction_from_angles
from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.registry import kind_of
from cwlidar_sim.turbulence import (MannParameters, generate_box, read_bladed, read_turbsim, write_bladed,
                                    write_hawc2, write_netcdf, write_turbsim)
from cwlidar_sim.turbulence import cover as turbulence_cover
from cwlidar_sim.turbulence.io_source import FieldFile

U = 8.0
STARING = """
name = "s"
duration = 60.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
{file}
[lidar]
tier = "los"
[analysis]
segment_duration = 30.0
fit = false
[[period]]
name = "a"
mean_speed = {U}
"""
CONICAL = """
name = "c"
kind = "conical"
seed = 4
duration = 10.0
[scan]
heights = [20.0]
scan_revs = [1]
[lidar]
tier = "los"
[turbulence]
source = "fixed"
alpha_eps = 0.05
length_scale = 15.0
gamma = 3.9
{file}
[[period]]
name = "a"
mean_speed = 8.0
"""
NACELLE = """
name = "n"
kind = "nacelle"
seed = 3
duration = 30.0
[scan]
half_angle_deg = 15.0
focus_distances = [40.0]
rotor_radius = 20.0
spacing = 8.0
segment_duration = 10.0
k_min = 0.04
k_max = 0.3
n_k = 5
theory_beams = 4
[lidar]
tier = "los"
[turbulence]
alpha_eps = 0.1
length_scale = 20.0
gamma = 3.9
{file}
[[period]]
name = "p0"
mean_speed = 10.0
"""


#: The probe volume's weight beyond the simulated span sees the mean wind by default (beam.cells.probe_cells); the
#: exactness checks renormalise it, so that every bit of the weight sees the field.
WHOLE = STARING.replace('tier = "los"', 'tier = "los"\ntail = "renormalise"')


def run(text, folder, file="", **kw):
    sc = loads_scene(text.format(file=file, U=kw.get("U", U)), base_dir=str(folder))
    k = kind_of(sc)
    return k.run_unit(sc, 0, k.scene_params(sc, lambda *a: None)[0])


def uniform(nx=400, n=8, d=2.0, values=(0.5, 0.25, -0.125)):
    return xr.Dataset({c: (("x", "y", "z"), np.full((nx, n, n), v, np.float32)) for c, v in zip("uvw", values)},
                      coords={a: np.arange(m) * d for a, m in zip("xyz", (nx, n, n))})


def staring_box(seed=7):
    return generate_box(MannParameters(0.06, 20.0, 3.9), (720, 8, 8), (1.0, 2.0, 2.0), seed)


def in_memory(monkeypatch, box):
    """FieldFile.read gives ``box`` (as placed by the same code): the field used in memory."""
    monkeypatch.setattr(FieldFile, "read", lambda self, base_dir=".": box)


WRITERS = {"netcdf": ("f.nc", lambda b, p: write_netcdf(b, p)),
           "hawc2": ("f.bin", lambda b, p: write_hawc2(b, p)),
           "turbsim": ("f.bts", lambda b, p: write_turbsim(b, p, mean_speed=U)),
           "bladed": ("f.wnd", lambda b, p: write_bladed(b, p, mean_speed=U))}
READERS = {"turbsim": read_turbsim, "bladed": lambda p: read_bladed(p)}


# ---------------------------------------------------------------------------
def test_a_uniform_field_gives_exactly_its_line_of_sight_speed(tmp_path):
    write_netcdf(uniform(), tmp_path / "uni.nc")
    ds = run(WHOLE, tmp_path, 'file = "uni.nc"')
    sc = loads_scene(STARING.format(file="", U=U))
    n = direction_from_angles(180.0, sc.lidar.elevation_deg)
    toward = -np.dot([U + 0.5, 0.25, -0.125], n)  # the speed toward the lidar
    np.testing.assert_allclose(ds["lidar_speed"].values, toward, rtol=2e-7)
    np.testing.assert_allclose(ds["sonic_velocity"].values[0], np.broadcast_to([U + 0.5, 0.25, -0.125],
                                                                               ds["sonic_velocity"].shape[1:]), rtol=2e-7)


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_a_box_written_in_each_format_flies_as_it_does_in_memory(tmp_path, monkeypatch, fmt):
    """HAWC2 and NetCDF hold float32 exactly: bit-identical to the box itself; TurbSim and Bladed quantise to
    16 bits: bit-identical to the box they read back, and within the quantisation step of the box itself."""
    box = staring_box()
    name, write = WRITERS[fmt]
    write(box, tmp_path / name)
    spec = f'file = "{name}"'
    got = run(STARING, tmp_path, spec)["lidar_speed"].values
    same = box if fmt in ("netcdf", "hawc2") else READERS[fmt](tmp_path / name)
    in_memory(monkeypatch, same)
    want = run(STARING, tmp_path, spec)["lidar_speed"].values
    np.testing.assert_array_equal(got, want)
    in_memory(monkeypatch, box)
    exact = run(STARING, tmp_path, spec)["lidar_speed"].values
    step = max(float(box[c].max() - box[c].min()) for c in "uvw") / 65535 if fmt == "turbsim" else 0.0
    if fmt == "bladed":
        step = 0.001 * max(float(box[c].std()) * 3 for c in "uvw")
    assert np.max(np.abs(got - exact)) <= step + 1e-6
    assert np.std(exact) > 0.1  # turbulence, not a constant
    in_memory(monkeypatch, 0.0 * box)  # the scene's field is the file's: a calm one gives the mean wind alone
    assert np.ptp(run(STARING, tmp_path, spec)["lidar_speed"].values) == 0.0


def _captured(monkeypatch):
    real, boxes = turbulence_cover.cover_box, []

    def capture(*a, **kw):
        out = real(*a, **kw)
        if kw.get("source") is None:
            boxes.append(out)
        return out

    monkeypatch.setattr(turbulence_cover, "cover_box", capture)
    return boxes


@pytest.mark.parametrize("text", [CONICAL, NACELLE], ids=["conical", "nacelle"])
def test_conical_and_nacelle_scenes_fly_through_a_turbsim_file(tmp_path, monkeypatch, text):
    """The box a kind generates, written by our TurbSim writer and named in the scene: the tier-los results are the
    box's read back, in memory, bit for bit, and within the 16-bit step of the generated box's (placed alike)."""
    boxes = _captured(monkeypatch)
    generated = run(text, tmp_path)
    box = boxes[0]
    write_turbsim(box, tmp_path / "f.bts", mean_speed=U)
    got = run(text, tmp_path, 'file = "f.bts"')
    in_memory(monkeypatch, read_turbsim(tmp_path / "f.bts"))
    want = run(text, tmp_path, 'file = "f.bts"')
    keys = [k for k in got.data_vars if got[k].dtype.kind == "f" and "cost" not in k and "wall" not in k]
    assert keys
    for k in keys:
        np.testing.assert_array_equal(got[k].values, want[k].values, err_msg=k)
    in_memory(monkeypatch, box)  # the generated box itself, placed by the same rule (not the generator's placement)
    direct = run(text, tmp_path, 'file = "f.bts"')
    step = max(float(box[c].max() - box[c].min()) for c in "uvw") / 65535
    main = "lidar_mean" if "lidar_mean" in got else "rews_std"
    assert np.nanmax(np.abs(got[main].values - direct[main].values)) <= step
    assert np.all(np.abs(direct[main].values) > 0.05)
    assert not np.array_equal(got[main].values, generated[main].values)  # placed as stated, not as generated
    if "lidar_mean" in got:  # conical: the [turbulence] tensor is not the file's, so no theory by default
        assert "std_ratio_theory" in generated and "std_ratio_theory" not in got


def test_a_field_smaller_than_the_scan_is_refused_naming_the_sizes(tmp_path, monkeypatch):
    write_netcdf(uniform(nx=64), tmp_path / "small.nc")
    import cwlidar_sim.sensors as sensors

    monkeypatch.setattr(sensors, "measure_staring", lambda *a, **k: pytest.fail("sampled a too-small field"))
    with pytest.raises(ValueError, match=r"turbulence.file 'small.nc' is too small for the record: it spans "
                                         r"126 x 14 x 14 m \(64 x 8 x 8 nodes at 2, 2, 2 m\) but the record needs "
                                         r"6\d\d\.\d x .*\|U\| = 8 m/s, duration = 60 s.*too small along x"):
        run(STARING, tmp_path, 'file = "small.nc"')


def test_the_file_is_checked_when_the_scene_is_loaded(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"turbulence.file: turbsim field file not found: .*nothere\.bts.*"
                                                r"scene file's folder"):
        loads_scene(STARING.format(file='file = "nothere.bts"', U=U), base_dir=str(tmp_path))
    with pytest.raises(ValueError, match=r"turbulence.file.reverse_x = True applies to format 'hawc2', not 'netcdf'"):
        loads_scene(STARING.format(file='file = {path = "a.nc", reverse_x = true}', U=U), base_dir=str(tmp_path))
    with pytest.raises(ValueError, match=r"turbulence: unknown key|turbulence.file.*unknown|'pth'"):
        loads_scene(STARING.format(file='file = {pth = "a.nc"}', U=U), base_dir=str(tmp_path))
    with pytest.raises(ValueError, match=r"give file or condition_on, not both"):
        loads_scene(STARING.format(file='file = "a.nc"\ncondition_on = [{path = "r.nc"}]', U=U))


def ramp(nx=400, n=8, d=2.0, slope=0.01):
    """u = slope x: a field that is not its own mirror image in x."""
    u = np.broadcast_to((slope * d * np.arange(nx))[:, None, None], (nx, n, n)).astype(np.float32)
    z = np.zeros((nx, n, n), np.float32)
    return xr.Dataset({"u": (("x", "y", "z"), u), "v": (("x", "y", "z"), z), "w": (("x", "y", "z"), z)},
                      coords={a: np.arange(m) * d for a, m in zip("xyz", (nx, n, n))})


@pytest.mark.parametrize("written, read, sign", [
    ("reverse_x = false", "", -1), ("reverse_x = true", "", -1), ("reverse_x = true", "reverse_x = false", 1),
    ('convention = "openfast"', "", -1), ('convention = "openfast"', 'convention = "hawc2"', 1)])
def test_the_orientation_options_read_an_asymmetric_field_the_right_way_round(tmp_path, written, read, sign):
    """u = a x advected at U past a staring lidar: u at the lidar falls as a U t (Taylor: it sees x - U t). A box
    written reversed (or for OpenFAST) and read with its sidecar's orientation falls; read the other way, it rises."""
    kw = dict(p.strip().split(" = ") for p in [written] if p)
    kw = {k: (v == "true") if v in ("true", "false") else v.strip('"') for k, v in kw.items()}
    write_hawc2(ramp(), tmp_path / "r", **kw)
    opts = f", {read}" if read else ""
    ds = run(WHOLE, tmp_path, f'file = {{path = "r.json"{opts}}}')
    speed = ds["lidar_speed"].values[0]
    slope = np.polyfit(np.arange(speed.size) / 50.0, speed, 1)[0]
    sc = loads_scene(STARING.format(file="", U=U))
    cos_el = np.cos(np.radians(sc.lidar.elevation_deg))
    np.testing.assert_allclose(slope, sign * 0.01 * U * cos_el, rtol=1e-3)


def test_a_hawc2_box_written_by_mannrs_flies_as_its_arrays_do(tmp_path, monkeypatch):
    mannrs = pytest.importorskip("mannrs", reason="peer generator mannrs not installed")
    nx, ny, nz, d = 720, 8, 8, (1.0, 2.0, 2.0)
    stencil = mannrs.Stencil(L=20.0, gamma=3.9, Lx=nx * d[0], Ly=ny * d[1], Lz=nz * d[2], Nx=nx, Ny=ny, Nz=nz,
                             aperiodic_x=False, aperiodic_y=False, aperiodic_z=False)
    wf = stencil.build(parallel=False).turbulence(0.06, 11, parallel=False)
    wf.write(tmp_path / "box.bin", format="HAWC2")  # mannrs' own writer: box_u.bin, box_v.bin, box_w.bin
    spec = f'file = {{path = "box.bin", shape = [{nx}, {ny}, {nz}], spacing = [1.0, 2.0, 2.0]}}'
    got = run(STARING, tmp_path, spec)["lidar_speed"].values
    arrays = xr.Dataset({c: (("x", "y", "z"), np.asarray(a, dtype=np.float32)) for c, a in zip("uvw", (wf.U, wf.V, wf.W))},
                        coords={a: np.arange(m) * s for a, m, s in zip("xyz", (nx, ny, nz), d)})
    in_memory(monkeypatch, arrays)
    np.testing.assert_array_equal(got, run(STARING, tmp_path, spec)["lidar_speed"].values)
    assert np.std(got) > 0.05
    monkeypatch.undo()
    with pytest.raises(ValueError, match=r"shape of the HAWC2 box is needed: no sidecar"):
        run(STARING, tmp_path, 'file = "box.bin"')


def test_a_time_resolved_field_is_interpolated_linearly_in_time(tmp_path):
    """u = a + b t (uniform in space, 7 snapshots over 60 s, not advected): the tier-los speed is exactly the
    projection of U + a + b t at every estimate's time (linear in t: the interpolation is exact)."""
    t = np.linspace(0.0, 60.0, 7) + 100.0  # the file's clock: record time 0 is its first time
    a, b = 0.3, 0.02
    shape = (t.size, 6, 5, 5)
    u = np.broadcast_to((a + b * (t - 100.0))[:, None, None, None], shape).astype(np.float64)
    ds = xr.Dataset({"u": (("time", "x", "y", "z"), u), "v": (("time", "x", "y", "z"), np.zeros(shape)),
                     "w": (("time", "x", "y", "z"), np.zeros(shape))},
                    coords={"time": t, "x": np.arange(6) * 60.0, "y": np.arange(5) * 3.0, "z": np.arange(5) * 3.0})
    ds.to_netcdf(tmp_path / "les.nc", engine="h5netcdf")
    res = run(WHOLE, tmp_path, 'file = {path = "les.nc", dims = {t = "time"}}')
    sc = loads_scene(STARING.format(file="", U=U))
    cos_el = np.cos(np.radians(sc.lidar.elevation_deg))
    t50 = (np.arange(res["lidar_speed"].shape[1]) + 0.5) / 50.0
    np.testing.assert_allclose(res["lidar_speed"].values[0], (U + a + b * t50) * cos_el, rtol=3e-7)
    t32 = 1.0 / 64.0 + np.arange(res["sonic_velocity"].shape[1]) / 32.0
    np.testing.assert_allclose(res["sonic_velocity"].values[0][:, 0], U + a + b * t32, rtol=3e-7)
    short = ds.isel(time=slice(0, 4))
    short.to_netcdf(tmp_path / "short.nc", engine="h5netcdf")
    with pytest.raises(ValueError, match=r"it lasts 30 s of the record's 60 s"):
        run(STARING, tmp_path, 'file = {path = "short.nc", dims = {t = "time"}}')
