"""The atomic writers (cwlidar_sim._atomic) and SIGTERM as an exception (cwlidar_sim._interrupt)."""

import os
import signal
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim import cli
from cwlidar_sim._atomic import atomic_open, atomic_path, check_output_file, temp_name_pattern, write_netcdf_atomic
from cwlidar_sim._interrupt import Terminated, sigterm_raises
from cwlidar_sim._preflight import PreflightError

ROOT = Path(__file__).resolve().parent.parent


def _leftovers(folder, target):
    prefix, _ = temp_name_pattern(target)
    return sorted(p.name for p in Path(folder).iterdir() if p.name.startswith(prefix))


def test_failed_write_keeps_the_old_file_and_removes_the_temporary(tmp_path):
    target = tmp_path / "r.json"
    target.write_text("old", encoding="utf-8")
    with pytest.raises(RuntimeError, match="boom"):
        with atomic_open(target, "w") as fh:
            fh.write("new, half")
            raise RuntimeError("boom")
    assert target.read_text(encoding="utf-8") == "old"
    assert _leftovers(tmp_path, target) == []
    with atomic_open(target, "w") as fh:
        fh.write("new")
    assert target.read_text(encoding="utf-8") == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json"]


def test_temporary_names_are_unpredictable_and_keep_the_extension(tmp_path):
    names = []
    for _ in range(3):
        with atomic_path(tmp_path / "fig.png") as tmp:
            names.append(os.path.basename(tmp))
            assert os.path.dirname(tmp) == str(tmp_path)  # same folder: the rename is atomic
    assert len(set(names)) == 3
    assert all(n.startswith(".fig.png.") and n.endswith(".tmp.png") for n in names)
    assert str(os.getpid()) not in "".join(names)


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_permissions_are_those_of_a_new_file_under_the_umask(tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        with atomic_open(tmp_path / "a.txt") as fh:
            fh.write("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "a.txt").st_mode) == mode


def test_a_symlink_at_the_old_predictable_temporary_name_is_not_followed(tmp_path, capsys):
    """scenes --write used ``.NAME.<pid>.tmp``: a link planted there wrote through to its target."""
    victim = tmp_path / "victim.txt"
    victim.write_text("precious", encoding="utf-8")
    (tmp_path / f".z.toml.{os.getpid()}.tmp").symlink_to(victim)
    assert cli.main(["scenes", "--write", "a2012", str(tmp_path / "z.toml")]) == 0
    assert victim.read_text(encoding="utf-8") == "precious"
    assert "[turbulence]" in (tmp_path / "z.toml").read_text(encoding="utf-8")


def test_a_symlink_at_the_target_is_replaced_not_written_through(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious", encoding="utf-8")
    (tmp_path / "out.json").symlink_to(victim)
    with atomic_open(tmp_path / "out.json") as fh:
        fh.write("{}")
    assert victim.read_text(encoding="utf-8") == "precious"
    assert not (tmp_path / "out.json").is_symlink()
    assert (tmp_path / "out.json").read_text(encoding="utf-8") == "{}"


def test_check_output_file_refuses_what_cannot_receive_a_file(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for path, kind in [("/dev/null", "a device"), (fifo, "a FIFO"), (tmp_path, "a directory")]:
        with pytest.raises(PreflightError, match=f"{kind}; allowed: a regular file"):
            check_output_file(path, label="--out")
    with pytest.raises(PreflightError, match=r"folder '.*nodir' of --out .* does not exist"):
        check_output_file(tmp_path / "nodir" / "x.nc", label="--out")
    assert not (tmp_path / "nodir").exists()
    check_output_file(tmp_path / "nodir" / "x.nc", label="--out", create_folder=True)
    assert (tmp_path / "nodir").is_dir()
    (tmp_path / "ok.nc").write_bytes(b"old")
    assert check_output_file(tmp_path / "ok.nc") == str(tmp_path / "ok.nc")


def test_sigterm_inside_a_write_removes_the_temporary_and_keeps_the_old_file(tmp_path):
    target = tmp_path / "box_u.bin"
    target.write_bytes(b"old")
    def before(signum, frame):  # a handler of the caller's, to be put back
        raise AssertionError("the caller's handler ran inside sigterm_raises")

    original = signal.signal(signal.SIGTERM, before)
    try:
        with pytest.raises(Terminated):
            with sigterm_raises():
                with atomic_open(target, "wb") as fh:
                    fh.write(b"new, half")
                    os.kill(os.getpid(), signal.SIGTERM)  # the handler raises at the next bytecode
                    raise AssertionError("SIGTERM did not raise")
        assert signal.getsignal(signal.SIGTERM) is before  # the previous handler is back
    finally:
        signal.signal(signal.SIGTERM, original)
    assert target.read_bytes() == b"old"
    assert _leftovers(tmp_path, target) == []


def test_write_netcdf_atomic_stores_what_to_netcdf_stores(tmp_path):
    ds = xr.Dataset({"u": (("x", "y"), np.arange(12, dtype="f4").reshape(4, 3), {"units": "m s-1"}),
                     "n": (("x",), np.array([1, 2, 3, 4], dtype="u1"))},
                    coords={"x": np.arange(4.0)}, attrs={"seed": 3, "name": "t", "v": [1.0, 2.5]})
    enc = {n: {"_FillValue": None} for n in ds.variables}
    ds.to_netcdf(tmp_path / "a.nc", engine="h5netcdf", encoding=enc)
    write_netcdf_atomic(ds.chunk({"x": 2}), tmp_path / "b.nc", encoding=enc)  # dask-backed: written at sync
    with xr.open_dataset(tmp_path / "a.nc", engine="h5netcdf") as a, \
            xr.open_dataset(tmp_path / "b.nc", engine="h5netcdf") as b:
        assert a.load().identical(b.load())
        assert a["u"].dtype == b["u"].dtype == np.float32 and "_FillValue" not in b["u"].encoding
        np.testing.assert_array_equal(b["u"].values, ds["u"].values)


_FULL_DISK = textwrap.dedent("""
    import errno, os, resource, signal, sys
    import numpy as np, xarray as xr
    from cwlidar_sim._atomic import write_netcdf_atomic
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # a write past the limit fails with EFBIG, no signal
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[2]), resource.RLIM_INFINITY))
    rng = np.random.default_rng(0)
    ds = xr.Dataset({c: (("x", "y"), rng.random((512, 8)).astype("f4"), {"units": "m s-1"}) for c in "uvw"},
                    coords={"x": np.arange(512.0)}, attrs={"seed": 1, "note": "a box"})
    try:
        write_netcdf_atomic(ds, sys.argv[1], encoding={n: {"_FillValue": None} for n in ds.variables})
    except OSError as e:
        print("OSError", e.errno, type(e).__name__, flush=True)
    print("exited cleanly", flush=True)
""")


@pytest.mark.parametrize("limit", [1_000, 20_000, 40_000])
def test_a_netcdf_write_that_fails_on_a_full_disk_does_not_segfault(tmp_path, limit):
    """h5netcdf's File closed from __del__ after a failed write segfaulted at exit (status 139)."""
    target = tmp_path / "f.nc"
    target.write_bytes(b"the old file")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", _FULL_DISK, str(target), str(limit)], capture_output=True, text=True,
                         env=env, cwd=tmp_path, timeout=120)
    assert out.returncode == 0 and out.stderr == "", (out.returncode, out.stderr[-2000:])
    assert out.stdout.split() == ["OSError", "27", "ResultsWriteError", "exited", "cleanly"]
    assert target.read_bytes() == b"the old file"
    assert _leftovers(tmp_path, target) == []


def test_a_hawc2_triplet_is_replaced_whole_or_not_at_all(tmp_path, monkeypatch):
    """A full disk that surfaces only at fsync of the v file leaves the old u, v, w, sidecar and snippet (no mix)."""
    import errno

    import cwlidar_sim._atomic as atomic
    from cwlidar_sim.turbulence import write_hawc2

    rng = np.random.default_rng(1)
    box = xr.Dataset({c: (("x", "y", "z"), rng.standard_normal((4, 3, 2)).astype("f4")) for c in "uvw"})
    paths = [*write_hawc2(box, tmp_path / "t"), tmp_path / "t.json", tmp_path / "t.htc"]  # with its sidecar
    old = [p.read_bytes() for p in paths]
    real = atomic._fsync_path

    def failing(path, directory=False):
        if os.path.basename(path).startswith(".t_v.bin."):
            raise OSError(errno.ENOSPC, "No space left on device")
        real(path, directory=directory)

    monkeypatch.setattr(atomic, "_fsync_path", failing)
    new = box * 2
    new.attrs["seed"] = 9  # a sidecar and snippet that differ too
    with pytest.raises(OSError, match="No space left on device"):
        write_hawc2(new, tmp_path / "t")
    assert [p.read_bytes() for p in paths] == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.htc", "t.json", "t_u.bin", "t_v.bin", "t_w.bin"]
