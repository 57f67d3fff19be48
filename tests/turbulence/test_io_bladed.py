"""Bladed-style .wnd files (TurbSim's variant, with the .sum InflowWind reads): bytes, peers, round trips.

The layout is checked against ``tests/reference.py: bladed_wnd_bytes`` (value by value from TurbSim's
``WrBinBLADED``), with the field given by formulas in the file's order: time step j is our plane Nx-1-j,
file y is our y, v stored along -y (the left-hand rule TurbSim writes and declares in the .sum).  The
peer hipersim writes and reads the same header (without the left-hand rule, and with its x plane 0
first in time): both directions are checked against it.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from field_boxes import ATTRS, DX, DY, DZ, NX, NY, NZ, U, asymmetric_box, random_box
import reference
from cwlidar_sim.turbulence import read_bladed, write_bladed



def turbsim_rule_ti(box, mean_speed):
    """TurbSim's TI [%] (float32): sigma = max(std, |value|max / 20, 0.01 m/s) over the component."""
    out = []
    for c in "uvw":
        a = box[c].values.astype(np.float64)
        out.append(float(np.float32(100 * max(a.std(), 0.05 * np.abs(a).max(), 0.01) / np.float32(mean_speed))))
    return out


def test_bytes_match_the_specification_for_a_known_asymmetric_field(tmp_path):
    box = asymmetric_box()
    wnd, summary = write_bladed(box, tmp_path / "a.wnd", mean_speed=U, hub_height=20.0)
    assert summary == tmp_path / "a.sum"
    # the field in the file's order, from the formulas: time step t is our plane NX-1-t; u is the whole wind
    xs = [(NX - 1 - t) * DX for t in range(NX)]
    u = [[[xs[t] + U for j in range(NY)] for k in range(NZ)] for t in range(NX)]
    v = [[[(j * DY) ** 2 for j in range(NY)] for k in range(NZ)] for t in range(NX)]
    w = [[[float(np.float32(k * DZ + xs[t] * j * DY)) for j in range(NY)] for k in range(NZ)] for t in range(NX)]
    z_centre = 20.0  # the grid centred on the hub
    expected = reference.bladed_wnd_bytes(u, v, w, DZ, DY, DX, U, z_centre, turbsim_rule_ti(box, U), 7)
    got = wnd.read_bytes()
    assert len(got) == len(expected) == 104 + 6 * NX * NY * NZ
    assert got[:104] == expected[:104]  # the header
    assert got == expected


def test_asymmetric_field_round_trip_within_the_quantisation_step(tmp_path):
    box = asymmetric_box()
    back = read_bladed(write_bladed(box, tmp_path / "a.wnd", mean_speed=U)[0])
    for c, ti in zip("uvw", back.attrs["bladed_ti"]):
        step = U * ti / 1e5  # U TI / 100 / 1000
        err = np.abs(back[c].values - box[c].values.astype(np.float64)).max()
        assert err <= 0.5 * step * (1 + 1e-5) + 2e-6, (c, err, step)
    np.testing.assert_array_equal(back.y.values, box.y.values)


def test_summary_holds_what_inflowwind_looks_for_in_its_order(tmp_path):
    _, summary = write_bladed(random_box(), tmp_path / "a.wnd", mean_speed=U, hub_height=90.0)
    lines = [s.upper() for s in summary.read_text().splitlines()]

    def at(key):
        return next(i for i, s in enumerate(lines) if key in s)

    assert at("HUB HEIGHT") < at("UBAR") < at("HEIGHT OFFSET") < at("PERIODIC") < at("BLADED LEFT-HAND RULE")
    assert float(lines[at("HUB HEIGHT")].split()[0]) == 90.0
    assert [s.split("=")[0].strip() for s in lines[at("UBAR") + 1: at("UBAR") + 4]] == ["TI(U)", "TI(V)", "TI(W)"]
    assert not any("CLOCKWISE" in s for s in lines)
    assert lines.index(next(s for s in lines if s.startswith("CWLIDAR_SIM ATTRS"))) > at("BLADED LEFT-HAND RULE")


def test_round_trip_arrays_and_attributes_and_a_rewrite_is_bit_identical(tmp_path):
    box = random_box()
    wnd, summary = write_bladed(box, tmp_path / "a.wnd", mean_speed=11.4, hub_height=90.0)
    back = read_bladed(wnd)
    for c, ti in zip("uvw", back.attrs["bladed_ti"]):
        step = np.float32(11.4) * ti / 1e5  # U TI / 100 / 1000
        err = np.abs(back[c].values - box[c].values.astype(np.float64)).max()
        assert err <= 0.5 * step * (1 + 1e-5) + 1e-6, (c, err, step)
    for key, value in box.attrs.items():
        assert back.attrs[key] == value, key
    assert back.attrs["hub_height"] == 90.0 and back.attrs["z_bottom"] == 90.0 - 1.5 * DZ
    assert back.attrs["bladed_left_hand_rule"] == 1 and back.attrs["periodic"] == 1
    again, again_sum = write_bladed(back, tmp_path / "b.wnd")
    assert again.read_bytes() == wnd.read_bytes()
    assert again_sum.read_bytes() == summary.read_bytes()


def test_an_odd_number_of_time_steps(tmp_path):
    box = random_box(shape=(7, 3, 2))
    wnd, _ = write_bladed(box, tmp_path / "odd.wnd", mean_speed=10.0)
    assert struct.unpack("<i", wnd.read_bytes()[44:48])[0] == 3  # nt // 2, as TurbSim writes
    back = read_bladed(wnd)
    assert back.u.shape == (7, 3, 2)
    np.testing.assert_allclose(back.w.values, box.w.values, atol=0.01)


def test_summary_flags_and_arguments(tmp_path):
    box = asymmetric_box()
    wnd, summary = write_bladed(box, tmp_path / "a.wnd", mean_speed=U)
    text = summary.read_text()
    # without the left-hand rule line v is read with the stored sign: the mirror image
    summary.write_text(text.replace("Creating a BLADED LEFT-HAND RULE output file.\n", ""))
    plain = read_bladed(wnd)
    np.testing.assert_allclose(plain.v.values, -box.v.values, atol=0.01)
    with pytest.raises(ValueError, match=r"left_hand_rule=True contradicts the summary .*a\.sum.*False"):
        read_bladed(wnd, left_hand_rule=True)
    # an old TurbSim summary saying CLOCKWISE before the hub height: y stored reversed
    summary.write_text("    T     Clockwise rotation looking downwind?\n" + text)
    cw = read_bladed(wnd)
    np.testing.assert_allclose(cw.w.values, box.w.values[:, ::-1], atol=0.01)
    assert cw.attrs["bladed_clockwise"] == 1
    summary.write_text(text.replace(f"UBar  = {U!r}", "UBar  = 12.0"))
    with pytest.raises(ValueError, match="not written together"):
        read_bladed(wnd)
    summary.write_text(text.replace("Hub height", "Hub"))
    with pytest.raises(ValueError, match=r"a\.sum.* lacks the hub height line"):
        read_bladed(wnd)
    summary.unlink()
    with pytest.raises(ValueError, match=r"no summary file .*a\.sum.*left_hand_rule"):
        read_bladed(wnd)
    np.testing.assert_allclose(read_bladed(wnd, left_hand_rule=True).v.values, box.v.values, atol=0.01)


def test_truncated_foreign_and_corrupt_files_are_one_line_errors_naming_the_file(tmp_path):
    wnd, _ = write_bladed(random_box(), tmp_path / "ok.wnd", mean_speed=10.0)
    raw = wnd.read_bytes()
    cases = {
        "cut": (raw[:-4], r"cut\.wnd.* holds \d+ bytes, but its header .*truncated"),
        "stub": (raw[:50], r"stub\.wnd.* is truncated: its header needs 104 bytes"),
        "bts": (struct.pack("<h", 8) + raw[2:], r"bts\.wnd.* not a Bladed-style wind file.*read_turbsim"),
        "type8": (raw[:2] + struct.pack("<h", 8) + raw[4:], r"another turbulence type"),
        "huge": (raw[:76] + struct.pack("<i", 2**30) + raw[80:], r"huge\.wnd.* holds \d+ bytes, but its header"),
        "ti": (raw[:20] + struct.pack("<f", float("nan")) + raw[24:], r"ti\.wnd.*TI\(u\) = nan"),
    }
    for name, (content, match) in cases.items():
        path = tmp_path / f"{name}.wnd"
        path.write_bytes(content)
        with pytest.raises(ValueError, match=match) as err:
            read_bladed(path, left_hand_rule=True)
        assert "\n" not in str(err.value), name
    bad = tmp_path / "j.sum"
    write_bladed(random_box(), tmp_path / "j.wnd", mean_speed=10.0)
    bad.write_text(bad.read_text().replace('{"alpha_eps"', '{alpha_eps'))
    with pytest.raises(ValueError, match=r"j\.sum.*line \d+: the attributes are not valid JSON"):
        read_bladed(tmp_path / "j.wnd")


def test_writer_refuses_bad_input_before_writing(tmp_path):
    with pytest.raises(ValueError, match="mean_speed is needed"):
        write_bladed(random_box(), tmp_path / "a.wnd")
    with pytest.raises(ValueError, match="ends in .sum"):
        write_bladed(random_box(), tmp_path / "a.sum", mean_speed=10.0)
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------
# the peer: hipersim writes and reads the same header
# ---------------------------------------------------------------------------
def test_hipersim_reads_our_file_as_the_time_series_at_the_rotor(tmp_path):
    hipersim = pytest.importorskip("hipersim", reason="peer hipersim not installed (pip install '.[test]')")
    box = random_box(seed=3)
    wnd, _ = write_bladed(box, tmp_path / "a.wnd", mean_speed=U)
    peer = hipersim.TurbulenceField.from_bladed(str(wnd))
    uvw = np.asarray(peer.uvw)  # (3, time step, y, z); hipersim applies no left-hand rule
    assert uvw.shape == (3, 16, 5, 4) and (peer.dx, peer.dy, peer.dz) == (DX, DY, DZ)
    step = max(np.float32(U) * t / 1e5 for t in read_bladed(wnd).attrs["bladed_ti"])
    np.testing.assert_allclose(uvw[0] - U, box.u.values[::-1], atol=step)  # time step j = our plane NX-1-j
    np.testing.assert_allclose(uvw[1], -box.v.values[::-1], atol=step)  # v stored along -y
    np.testing.assert_allclose(uvw[2], box.w.values[::-1], atol=step)


def test_we_read_hipersims_file(tmp_path):
    hipersim = pytest.importorskip("hipersim", reason="peer hipersim not installed (pip install '.[test]')")
    rng = np.random.default_rng(5)
    uvw = rng.standard_normal((3, 8, 3, 4)).astype(np.float32)
    hipersim.TurbulenceField(uvw, (8, 3, 4), (DX, DY, DZ), seed=5).to_bladed(U, folder=str(tmp_path), basename="hs")
    ds = read_bladed(tmp_path / "hs_1.wnd", left_hand_rule=False)  # hipersim writes no .sum, v along +y
    assert ds.attrs["seed"] == 0 and ds.attrs["mean_speed"] == U and ds.attrs["dx"] == DX
    for c, a in zip("uvw", uvw):
        # hipersim writes its plane j as time step j, about the component's mean, truncating to the step
        np.testing.assert_allclose(ds[c].values, (a - a.mean())[::-1], atol=0.01 * U / 10 + 1e-6)


def test_our_attributes_line_is_json(tmp_path):
    _, summary = write_bladed(random_box(), tmp_path / "a.wnd", mean_speed=U)
    line = next(s for s in summary.read_text().splitlines() if s.startswith("cwlidar_sim attrs: "))
    assert json.loads(line.partition(": ")[2]) == ATTRS
