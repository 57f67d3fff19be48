"""A results folder: one owner (manifest, --overwrite), one run at a time (lock), no orphans, safe names."""

import json
import os
import subprocess
import sys
import time

import pytest
import xarray as xr

from cwlidar_sim.campaign import PreflightError, ResultsWriteError, loads_scene, read_results, run_scene
from cwlidar_sim.campaign.execution import folder
from cwlidar_sim.campaign.periods import staring
from cwlidar_sim.campaign.execution import store

TEXT = """
name = "{name}"
seed = 1
duration = 40.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "los"
[field]
dx = 1.0
[analysis]
segment_duration = 20.0
fit = false
k_min = 0.05
k_max = 1.0
per_decade = 2
[[period]]
name = "{p}"
mean_speed = 8.0
[[period]]
name = "{q}"
mean_speed = 7.0
"""


def scene(name="one", p="P", q="Q", seed=1):
    return loads_scene(TEXT.format(name=name, p=p, q=q).replace("seed = 1", f"seed = {seed}"))


class Stop(Exception):
    pass


def counting(monkeypatch):
    calls = []
    real = staring.run_unit

    def run_unit(scene, index, params, **kw):
        calls.append(index)
        return real(scene, index, params, **kw)

    monkeypatch.setattr(staring, "run_unit", run_unit)
    return calls


def fake_figure(out, name="spectra.png"):
    (out / name).write_bytes(b"png")
    folder.record_figures(out, [out / name])


def test_another_scene_is_refused_and_overwrite_removes_the_old_run(tmp_path, monkeypatch):
    out = tmp_path / "o"
    run_scene(scene("one"), out, progress=False)
    fake_figure(out)
    calls = counting(monkeypatch)
    with pytest.raises(PreflightError, match=r"holds the results of staring scene 'one', not of the staring "
                                             r"scene 'two'.*--overwrite"):
        run_scene(scene("two"), out, progress=False)
    assert calls == []  # refused before compute
    assert (out / "one.nc").exists() and (out / "spectra.png").exists()

    # an overwrite that fails mid-run: the old run's period files and figures are gone, its results survive
    def stop(index, ds):
        raise Stop

    with pytest.raises(Stop):
        run_scene(scene("two"), out, progress=False, on_period=stop, overwrite=True)
    assert read_results(out / "one.nc").attrs["scene"]
    assert not (out / "one.periods").exists() and not (out / "spectra.png").exists()
    assert folder.read_manifest(out)["name"] == "two"
    # resuming the new scene needs no --overwrite; once its results are written the old ones are removed
    calls.clear()
    run_scene(scene("two"), out, progress=False)
    assert calls == [1]
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "cwlidar-run.json", "two.nc", "two.periods", "two.stats.csv"]  # the old run's one.stats.csv removed
    m = folder.read_manifest(out)
    assert m["results"] == "two.nc" and m["remove_after"] == []


def test_overwrite_of_the_same_scene_computes_everything_again(tmp_path, monkeypatch):
    run_scene(scene(), tmp_path, progress=False)
    calls = counting(monkeypatch)
    run_scene(scene(), tmp_path, progress=False)
    assert calls == []
    run_scene(scene(), tmp_path, progress=False, overwrite=True)
    assert calls == [0, 1]


def test_a_legacy_folder_with_another_scene_is_refused(tmp_path, monkeypatch):
    run_scene(scene("one"), tmp_path, progress=False)
    os.unlink(tmp_path / folder.MANIFEST_NAME)  # as written before manifests existed
    calls = counting(monkeypatch)
    with pytest.raises(PreflightError, match="one.nc"):
        run_scene(scene("two"), tmp_path, progress=False)
    assert calls == []
    run_scene(scene("one"), tmp_path, progress=False)  # the same scene adopts the folder and resumes
    assert calls == [] and folder.read_manifest(tmp_path)["name"] == "one"


def test_a_changed_scene_removes_what_it_no_longer_uses(tmp_path, monkeypatch):
    run_scene(scene(), tmp_path, progress=False)
    fake_figure(tmp_path)
    calls = counting(monkeypatch)
    run_scene(scene(), tmp_path, progress=False)  # unchanged: the figures stay
    assert calls == [] and (tmp_path / "spectra.png").exists()
    lines = []
    ds = run_scene(scene(q="R"), tmp_path, progress=False, log=lines.append)  # period Q renamed R
    assert calls == [0, 1]
    assert list(ds.period.values) == ["P", "R"]
    assert sorted(os.listdir(tmp_path / "one.periods")) == ["000_P.nc", "001_R.nc"]
    assert not (tmp_path / "spectra.png").exists()
    assert any("changed since its results" in line for line in lines)
    assert folder.read_manifest(tmp_path)["figures"] == []


def test_a_second_run_is_refused_naming_the_holder(tmp_path, monkeypatch):
    tmp_path.mkdir(exist_ok=True)
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, sys, time\n"
        f"fd = os.open({str(tmp_path / folder.LOCK_NAME)!r}, os.O_RDWR | os.O_CREAT)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\n"
        "os.write(fd, str(os.getpid()).encode())\n"
        "print('locked', flush=True)\n"
        "time.sleep(60)\n")], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        calls = counting(monkeypatch)
        with pytest.raises(PreflightError, match=rf"in use by another run \(pid {holder.pid}\)"):
            run_scene(scene(), tmp_path, progress=False)
        assert calls == []
    finally:
        holder.kill()
        holder.wait()
    run_scene(scene(), tmp_path, progress=False)  # the lock died with its holder
    assert (tmp_path / "one.nc").exists()


def test_orphaned_temporaries_are_removed_at_the_next_start(tmp_path):
    run_scene(scene(), tmp_path, progress=False)
    orphans = [tmp_path / ".tmp-abc123.nc", tmp_path / "one.periods" / ".tmp-x9.nc"]
    for p in orphans:
        p.write_bytes(b"half a file")
    lines = []
    run_scene(scene(), tmp_path, progress=False, log=lines.append)
    assert not any(p.exists() for p in orphans)
    assert sum("temporary file of an interrupted run" in line for line in lines) == 2


def _data_offset(path, ds):
    """Where the stored bytes of ``ds``'s largest float variable start in the file at ``path``."""
    name = max((n for n in ds.data_vars if ds[n].dtype.kind == "f"), key=lambda n: ds[n].size)
    raw = path.read_bytes()
    for dtype in ("<f8", "<f4"):
        needle = ds[name].values.astype(dtype).tobytes()[64:96]
        at = raw.find(needle)
        if at >= 0:
            return at + 8
    raise AssertionError(f"the bytes of {name} were not found in {path}")


def _attribute_offset(path):
    """Where a letter of the stored ``scene`` attribute (the scene's TOML as JSON) lies in the file."""
    at = path.read_bytes().find(b'"name": "one"')
    assert at >= 0
    return at + 10


@pytest.mark.parametrize("where", ["metadata", "numbers", "attribute"])
def test_a_damaged_period_file_is_computed_again_with_a_warning(tmp_path, monkeypatch, where):
    """A flipped bit in the file's metadata makes it unreadable; one in its numbers reads back without an
    error (HDF5 keeps no checksum) and is caught by the digest stored with the period."""
    whole = run_scene(scene(), tmp_path, progress=False)
    p = tmp_path / "one.periods" / "000_P.nc"
    data = bytearray(p.read_bytes())
    at = {"metadata": lambda: 100, "numbers": lambda: _data_offset(p, read_results(p)),
          "attribute": lambda: _attribute_offset(p)}[where]()
    data[at] ^= 0x10
    p.write_bytes(bytes(data))
    calls = counting(monkeypatch)
    with pytest.warns(RuntimeWarning, match="000_P.nc is damaged"):
        again = run_scene(scene(), tmp_path, progress=False)
    assert calls == [0]
    xr.testing.assert_identical(again.drop_attrs(), whole.drop_attrs())
    read_results(p)  # replaced by a whole file


BAD_PERIOD_NAMES = ["../../../../victim/escaped", "/tmp/abs", "a/b", "a\\b", "a\x00b", ".hidden", "..", "a..b",
                    "tab\there", "x" * 250]


@pytest.mark.parametrize("bad", BAD_PERIOD_NAMES)
def test_unsafe_period_names_are_refused_before_compute(tmp_path, monkeypatch, bad):
    calls = counting(monkeypatch)
    out = tmp_path / "a" / "b" / "c" / "d" / "out"
    out.parent.mkdir(parents=True)
    with pytest.raises(ValueError, match="period name"):
        run_scene(scene(q=bad.replace("\\", "\\\\").replace("\x00", "\\u0000").replace("\t", "\\t")), out,
                  progress=False)
    assert calls == []
    assert not out.exists()  # nothing written, inside or outside the folder
    assert sorted(tmp_path.rglob("*")) == [tmp_path / "a", tmp_path / "a" / "b", tmp_path / "a" / "b" / "c",
                                           tmp_path / "a" / "b" / "c" / "d"]


def test_a_long_scene_name_is_refused_before_compute(tmp_path, monkeypatch):
    calls = counting(monkeypatch)
    with pytest.raises(ValueError, match="scene name .* 256 bytes, over the file system's limit of 255"):
        run_scene(scene(name="s" * 242), tmp_path / "o", progress=False)
    assert calls == [] and not (tmp_path / "o").exists()
    run_scene(scene(name="s" * 241), tmp_path / "o", progress=False)  # 241 + '.stats.parquet' = 255 bytes fits
    assert (tmp_path / "o" / ("s" * 241 + ".nc")).exists()
    assert (tmp_path / "o" / ("s" * 241 + ".stats.csv")).exists()


def test_combine_refuses_periods_of_two_runs(tmp_path):
    a = run_scene(scene(seed=7), tmp_path / "a", progress=False)
    b = run_scene(scene(seed=8), tmp_path / "b", progress=False)
    pa = read_results(tmp_path / "a" / "one.periods" / "000_P.nc")
    pb = read_results(tmp_path / "b" / "one.periods" / "001_Q.nc")
    with pytest.raises(ValueError, match="'P' and 'Q' come from different runs: their attribute 'scene' differs"):
        store.combine_periods([pa, pb])
    assert a.attrs["scene"] != b.attrs["scene"]
    qa = read_results(tmp_path / "a" / "one.periods" / "001_Q.nc")
    store.combine_periods([pa, qa])  # the same run's periods combine


def test_combine_refuses_periods_with_different_variables(tmp_path):
    # a period stored before a variable was added must not be NaN-filled beside one that has it
    run_scene(scene(), tmp_path / "a", progress=False)
    pa = read_results(tmp_path / "a" / "one.periods" / "000_P.nc")
    qa = read_results(tmp_path / "a" / "one.periods" / "001_Q.nc")
    name = next(n for n, v in qa.data_vars.items() if "period" in v.dims)
    with pytest.raises(ValueError, match=rf"'P' and 'Q' hold different variables \(only in 'P': \['{name}'\]"):
        store.combine_periods([pa, qa.drop_vars(name)])


def test_save_checks_the_key_read_back(tmp_path, monkeypatch):
    run_scene(scene(), tmp_path / "r", progress=False)
    ds = read_results(tmp_path / "r" / "one.periods" / "000_P.nc")
    st = store.PeriodStore(tmp_path, scene(), None)
    real = store.read_results

    def replaced_meanwhile(path):
        back = real(path)
        return back.assign_attrs(scene_key="another run's")

    monkeypatch.setattr(store, "read_results", replaced_meanwhile)
    with pytest.raises(ResultsWriteError, match="replaced by another run"):
        st.save(0, ds)


def test_campaign_and_scene_folders_do_not_mix(tmp_path, monkeypatch):
    from cwlidar_sim.campaign.execution import batch
    from cwlidar_sim.campaign.execution.sweep import loads_campaign

    (tmp_path / "base.toml").write_text(TEXT.format(name="base", p="P", q="Q"))
    spec = loads_campaign('name = "c"\nseed = 3\nbase = "base.toml"\n[[sweep]]\n"lidar.span" = [10.0]\n',
                          base_dir=str(tmp_path))
    out = tmp_path / "o"
    run_scene(scene(), out, progress=False)
    with pytest.raises(PreflightError, match="staring scene 'one', not of the campaign 'c'"):
        batch.run_campaign(spec, out, local=True, progress=False)
    assert not (out / "tasks").exists()
    batch.run_campaign(spec, out, local=True, progress=False, overwrite=True)
    assert not (out / "one.nc").exists() and not (out / "one.periods").exists()
    assert json.loads((out / "index.json").read_text())["tasks"]
    with pytest.raises(PreflightError, match="campaign 'c', not of the staring scene 'one'"):
        run_scene(scene(), out, progress=False)


def hold_lock(folder_path):
    """A child process holding the folder's lock (as a live run would); returns it once it holds it."""
    folder_path.mkdir(parents=True, exist_ok=True)
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, time\n"
        f"fd = os.open({str(folder_path / folder.LOCK_NAME)!r}, os.O_RDWR | os.O_CREAT)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\n"
        "os.write(fd, str(os.getpid()).encode())\n"
        "print('locked', flush=True)\n"
        "time.sleep(60)\n")], stdout=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "locked"
    return holder


def test_a_campaign_folder_is_locked_and_its_orphans_cleaned(tmp_path, monkeypatch):
    from cwlidar_sim.campaign.execution import batch
    from cwlidar_sim.campaign.execution.sweep import loads_campaign

    (tmp_path / "base.toml").write_text(TEXT.format(name="base", p="P", q="Q"))
    spec = loads_campaign('name = "c"\nseed = 3\nbase = "base.toml"\n[[sweep]]\n"lidar.span" = [10.0]\n',
                          base_dir=str(tmp_path))
    out = tmp_path / "o"
    calls = []
    real = batch._run_unit
    monkeypatch.setattr(batch, "_run_unit", lambda *a: calls.append(a[1]) or real(*a))
    holder = hold_lock(out)
    try:
        with pytest.raises(PreflightError, match=rf"in use by another run \(pid {holder.pid}\)"):
            batch.run_campaign(spec, out, local=True, progress=False)
    finally:
        holder.kill()
        holder.wait()
    assert calls == [] and not (out / "tasks").exists()

    def stop(task, index):
        raise Stop

    with pytest.raises(Stop):
        batch.run_campaign(spec, out, local=True, progress=False, on_unit=stop)
    (task_dir,) = [p for p in (out / "tasks").iterdir() if p.is_dir()]
    orphans = [task_dir / "base.periods" / ".tmp-k1.nc", out / "index.json.tmp-4242"]
    for p in orphans:
        p.write_bytes(b"half")
    calls.clear()
    present = []  # seen while the task runs (its folder is removed once it is done)
    s = batch.run_campaign(spec, out, local=True, progress=False,
                           on_unit=lambda task, index: present.append([p.exists() for p in orphans]))
    assert calls == [1] and s["units_reused"] == 1
    assert present == [[False, False]]


def test_the_old_results_survive_a_failed_final_write(tmp_path, monkeypatch):
    import errno

    run_scene(scene("one"), tmp_path, progress=False)
    before = (tmp_path / "one.nc").read_bytes()
    real = xr.Dataset.to_netcdf

    def full_disk(ds, path, **kw):
        if "scene_key" not in ds.attrs:  # the scene's results file, not a period's: the disk fills mid-file
            if hasattr(path, "write"):  # the atomic writer hands to_netcdf an open file object
                path.write(b"partial")
            else:
                with open(path, "wb") as fh:
                    fh.write(b"partial")
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(ds, path, **kw)

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full_disk)
    for sc, kw in ((scene("one", seed=2), {}), (scene("two"), {"overwrite": True})):
        with pytest.raises(ResultsWriteError, match="No space left"):
            run_scene(sc, tmp_path, progress=False, **kw)
        assert (tmp_path / "one.nc").read_bytes() == before
    assert not [p for p in tmp_path.rglob(".tmp-*")] + [p for p in tmp_path.rglob(".*.tmp*")]


def test_a_look_alike_of_a_separator_stays_inside_the_folder(tmp_path):
    """U+2215 (division slash) and U+FF0E (fullwidth full stop) look like '/' and '.' but are plain characters."""
    out = tmp_path / "out"
    ds = run_scene(scene(q="\uff0e\uff0e\u2215x"), out, progress=False)
    assert list(ds.period.values) == ["P", "\uff0e\uff0e\u2215x"]
    assert sorted(os.listdir(out / "one.periods")) == ["000_P.nc", "001_\uff0e\uff0e\u2215x.nc"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_crafted_manifest_never_removes_a_file_outside_the_folder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    victims = [tmp_path / "victim.png", tmp_path / "victim.nc", tmp_path / "x.periods"]
    for v in victims:
        v.write_text("keep me")
    folder.write_manifest(out, {"name": "../x", "kind": "staring", "digest": "0", "results": "../victim.nc",
                                "figures": ["../victim.png", str(tmp_path / "victim.png")],
                                "remove_after": ["../victim.nc"]})
    run_scene(scene("one"), out, progress=False, overwrite=True)
    folder.write_manifest(out, {"name": "one", "kind": "staring", "digest": "changed", "results": "one.nc",
                                "figures": ["../victim.png"], "remove_after": ["../victim.nc"]})
    run_scene(scene("one"), out, progress=False)
    assert all(v.read_text() == "keep me" for v in victims)


def test_a_run_that_left_nothing_does_not_hold_the_folder(tmp_path):
    """A run refused after it claimed the folder (a bad record, say) wrote only the folder's manifest:
    another scene may use the folder without --overwrite, as nothing of the first would be lost."""
    folder.write_manifest(str(tmp_path), {"name": "ghost", "kind": "staring", "digest": None, "figures": [],
                                          "results": None, "remove_after": []})
    run_scene(scene("one"), tmp_path, progress=False)
    assert folder.read_manifest(str(tmp_path))["name"] == "one"
    with pytest.raises(PreflightError, match="holds the results of staring scene 'one'"):
        run_scene(scene("two"), tmp_path, progress=False)  # 'one' left results: protected
