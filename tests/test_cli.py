"""The command line: fast start, box command, clear errors."""

import json
import subprocess
import sys

import numpy as np

from cwlidar_sim import cli


def test_help_imports_no_heavy_module():
    code = (
        "import sys; from cwlidar_sim import cli; "
        "p = cli.build_parser(); p.format_help(); "
        "print(sorted(m for m in ('numba', 'pyfftw', 'xarray', 'scipy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_box_command_writes_netcdf_and_reports(tmp_path, capsys):
    from cwlidar_sim.turbulence import read_netcdf

    out = tmp_path / "sub" / "box.nc"
    rc = cli.main(["box", "--alpha-eps", "1", "--length-scale", "20", "--gamma", "3", "--shape", "64", "8", "8",
                   "--spacing", "2", "2", "2", "--seed", "3", "--out", str(out), "--stats"])
    assert rc == 0
    rep = json.loads(capsys.readouterr().out)
    assert set(rep) >= {"sample", "expected", "grid_resolved", "full"}
    box = read_netcdf(out)
    assert box.u.shape == (64, 8, 8) and box.attrs["seed"] == 3
    assert np.isclose(float(box.u.var()), rep["sample"]["uu"], rtol=1e-5)


def test_box_command_hawc2(tmp_path):
    rc = cli.main(["box", "--alpha-eps", "1", "--length-scale", "20", "--gamma", "3", "--shape", "16", "4", "4",
                   "--spacing", "1", "1", "1", "--seed", "1", "--out", str(tmp_path / "t"), "--format", "hawc2"])
    assert rc == 0
    for c in "uvw":
        assert (tmp_path / f"t_{c}.bin").stat().st_size == 16 * 4 * 4 * 4


def test_bad_input_is_one_clear_line(tmp_path, capsys):
    rc = cli.main(["box", "--alpha-eps", "1", "--length-scale", "-20", "--gamma", "3", "--shape", "16", "4", "4",
                   "--spacing", "1", "1", "1", "--seed", "1", "--out", str(tmp_path / "b.nc")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "length_scale" in err and "allowed" in err and "Traceback" not in err


def test_probe_length_command_names_a_missing_results_file(tmp_path, capsys):
    from cwlidar_sim.cli import main

    assert main(["probe-length", str(tmp_path / "none.nc")]) == 2
    assert "no results file" in capsys.readouterr().err
    assert main(["probe-length", str(tmp_path)]) == 2
    assert "holds 0 results files" in capsys.readouterr().err


def test_twin_checks_the_disk_before_reading_records(tmp_path, capsys, monkeypatch):
    """A disk without room for a period's file is a one-line error before any record is read."""
    import collections
    import shutil
    from pathlib import Path

    scene = Path(cli.__file__).parent / "campaign" / "data" / "examples" / "twin" / "twin.toml"
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 10**5, 10**5))
    # the records (mast_sonic.csv) are missing too: the disk is named first, so it was checked first
    assert cli.main(["twin", str(scene), "--out", str(tmp_path / "tw"), "--twins", "4"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not enough disk space" in err[0] and "tw" in err[0], err


def test_box_names_what_it_wrote_and_refuses_a_netcdf_file_not_named_nc(tmp_path, capsys):
    args = ["box", "--alpha-eps", "1", "--length-scale", "20", "--gamma", "3", "--shape", "16", "4", "4",
            "--spacing", "1", "1", "1", "--seed", "1", "--no-progress"]
    assert cli.main([*args, "--out", str(tmp_path / "b3.txt")]) == 2
    err = capsys.readouterr().err
    assert "a NetCDF box is written to a .nc file" in err and "b3.nc" in err
    assert not (tmp_path / "b3.txt").exists()
    assert cli.main([*args, "--out", str(tmp_path / "b3.nc")]) == 0
    assert f"wrote a 16x4x4 box (netcdf): {tmp_path / 'b3.nc'}" in capsys.readouterr().err


BOX = ["box", "--alpha-eps", "1", "--length-scale", "20", "--gamma", "3", "--shape", "16", "4", "4",
       "--spacing", "2", "1", "1.5", "--seed", "5", "--no-progress"]


def test_box_formats_by_extension_and_orientation_options(tmp_path, capsys):
    """One seed through every format and orientation: the same field, laid out as each says."""
    from cwlidar_sim.turbulence import read_bladed, read_hawc2, read_netcdf, read_turbsim

    assert cli.main([*BOX, "--out", str(tmp_path / "ref.nc")]) == 0
    ref = read_netcdf(tmp_path / "ref.nc")
    assert cli.main([*BOX, "--format", "hawc2", "--reverse-x", "--out", str(tmp_path / "rev")]) == 0
    assert cli.main([*BOX, "--format", "hawc2", "--convention", "openfast", "--out", str(tmp_path / "of")]) == 0
    for c in "uvw":
        rev = np.fromfile(tmp_path / f"rev_{c}.bin", dtype="<f4").reshape(16, 4, 4)
        np.testing.assert_array_equal(rev, ref[c].values[::-1])  # file plane j = our plane Nx-1-j
        of = np.fromfile(tmp_path / f"of_{c}.bin", dtype="<f4").reshape(16, 4, 4)
        np.testing.assert_array_equal(of, ref[c].values[::-1, ::-1])  # and y reversed, as InflowWind reads
    assert json.loads((tmp_path / "rev.json").read_text())["reverse_x"] is True
    np.testing.assert_array_equal(read_hawc2(tmp_path / "of").u.values, ref.u.values)  # the sidecar says how
    err = capsys.readouterr().err
    assert all(f"{tmp_path / 'rev'}{s}" in err for s in ("_u.bin", "_v.bin", "_w.bin", ".json", ".htc"))
    assert cli.main([*BOX, "--out", str(tmp_path / "t.bts"), "--mean-speed", "9", "--hub-height", "30"]) == 0
    assert f"box (turbsim): {tmp_path / 't.bts'}" in capsys.readouterr().err
    bts = read_turbsim(tmp_path / "t.bts")
    assert bts.attrs["hub_height"] == 30 and bts.attrs["mean_speed"] == 9 and bts.attrs["seed"] == 5
    assert cli.main([*BOX, "--out", str(tmp_path / "b.wnd"), "--mean-speed", "9"]) == 0
    assert f"box (bladed): {tmp_path / 'b.wnd'}, {tmp_path / 'b.sum'}" in capsys.readouterr().err
    wnd = read_bladed(tmp_path / "b.wnd")
    for c in "uvw":
        np.testing.assert_allclose(bts[c].values, ref[c].values, atol=float(np.ptp(ref[c].values)) / 65535)
        np.testing.assert_allclose(wnd[c].values, ref[c].values, atol=float(ref[c].values.std()) / 1000)


def test_box_refuses_options_that_do_not_apply_before_generating(tmp_path, capsys):
    cases = [
        (["--out", "@a.nc", "--convention", "openfast"], "--convention applies to HAWC2 boxes only"),
        (["--out", "@a.bts", "--mean-speed", "9", "--reverse-x"], "--reverse-x applies to HAWC2 boxes only"),
        (["--format", "hawc2", "--out", "@h", "--convention", "openfast", "--reverse-x"], "give one of them"),
        (["--out", "@a.nc", "--mean-speed", "9"], "--mean-speed applies to --format turbsim and bladed only"),
        (["--format", "hawc2", "--out", "@h", "--hub-height", "9"], "--hub-height applies to --format turbsim"),
        (["--out", "@a.wnd"], "give --mean-speed U"),
        (["--format", "turbsim", "--out", "@a.nc", "--mean-speed", "9"], "a TurbSim box is written to a .bts file"),
        (["--format", "bladed", "--out", "@a.bts", "--mean-speed", "9"], "a Bladed box is written to a .wnd file"),
        (["--format", "hawc2", "--out", "@a.nc"], "give a base name such as"),
        (["--out", "@a.bts", "--mean-speed", "9", "--hub-height", "1"], "--hub-height=1.0 is out of range"),
        (["--out", "@a.bts", "--mean-speed", "0"], "--mean-speed=0.0 is out of range"),
    ]
    for extra, message in cases:
        args = [*BOX, *[str(tmp_path / a[1:]) if a.startswith("@") else a for a in extra]]  # @: a file
        assert cli.main(args) == 2, extra
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], (extra, err)
    assert list(tmp_path.iterdir()) == []
