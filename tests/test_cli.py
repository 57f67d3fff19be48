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

    scene = Path(cli.__file__).parent / "campaign" / "examples" / "twin" / "twin.toml"
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
