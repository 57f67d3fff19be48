"""``cwlidar-sim doppler``: JSON report of a uniform-target run, errors as one line."""

import json

import pytest

from cwlidar_sim.cli import main
from cwlidar_sim.signal import PROTOTYPE_2003


def _run(capsys, *argv):
    rc = main(["doppler", *argv])
    out = capsys.readouterr()
    return rc, out


def test_los_is_exact(capsys):
    rc, out = _run(capsys, "--speed", "-6.5", "--cnr", "-10", "--tier", "los", "--n", "5", "--json")
    rep = json.loads(out.out)
    assert rc == 0 and rep["mean"] == -6.5 and rep["std"] == 0.0 and rep["availability"] == 1.0
    assert "note" in rep


@pytest.mark.parametrize("tier", ["spectral", "signal"])
def test_spectral_and_signal_report(capsys, tier):
    # a bin-centred speed at CNR -10 dB (per-bin SNR 25.6): every estimate within a bin, and valid unless
    # the speckle (M_eff = 1.96 looks at 200 blocks) fades the line below the 4 sigma threshold (0.28):
    # P(Gamma(1.96) < 0.011) = 3e-4 per estimate, so at most 3 of 200 fail (Poisson, 99.9 %), flagged NO_SIGNAL
    v = 100 * PROTOTYPE_2003.bin_speed
    rc, out = _run(capsys, "--speed", str(-v), "--cnr", "-10", "--tier", tier, "--estimator", "centroid",
                   "--n", "4" if tier == "signal" else "200", "--seed", "3", "--set", "blocks_per_estimate=200",
                   "--json")
    rep = json.loads(out.out)
    assert rc == 0
    assert rep["expected"] == pytest.approx(v)  # homodyne: |V|
    assert rep["n"] - rep["n_valid"] <= 3 and rep["n_valid"] == rep["n_usable"]
    assert rep["flags"]["NO_SIGNAL"] == rep["n"] - rep["n_valid"]
    assert abs(rep["mean"] - v) < 0.1 * rep["bin_speed"]
    assert set(rep["flags"]) == {"NO_SIGNAL", "NEAR_NYQUIST", "NEAR_ZERO", "SECOND_PEAK", "FIT_FAILED", "PAUSED", "BLOCKED"}
    assert rep["instrument"]["blocks_per_estimate"] == 200 and rep["estimator"] == "centroid"


def test_low_cnr_and_threshold_options(capsys):
    rc, out = _run(capsys, "--speed", "9", "--cnr", "-70", "--n", "50", "--threshold", "5",
                   "--threshold-raise", "10", "--json")
    rep = json.loads(out.out)
    assert rc == 0 and rep["availability"] < 0.2
    assert rep["flags"]["NO_SIGNAL"] == rep["n"] - rep["n_valid"]
    assert rep["instrument"]["threshold_raise_percent"] == 10.0


@pytest.mark.parametrize("argv, match", [
    (["--estimator", "mode"], "allowed: 'median'"),
    (["--set", "nfft=3"], "unknown instrument field"),
    (["--n", "0"], "n=0"),
])
def test_errors(capsys, argv, match):
    rc, out = _run(capsys, "--speed", "5", "--cnr", "0", *argv)
    assert rc == 2 and match in out.err


def test_a_negative_speed_says_the_homodyne_sign_is_lost(capsys):
    """--speed -5 through the spectral tier reads +5 (the instrument sees |V|): the report says so, in JSON and
    in text, instead of returning a number of the other sign without a word."""
    rc, out = _run(capsys, "--speed", "-5", "--cnr", "-10", "--n", "20", "--seed", "1", "--json")
    rep = json.loads(out.out)
    assert rc == 0 and rep["mean"] == pytest.approx(5.0, abs=0.1)
    assert "sign is lost" in rep["note"]
    rc, out = _run(capsys, "--speed", "-5", "--cnr", "-10", "--n", "20", "--seed", "1")
    assert rc == 0 and "note: speed -5 m/s: a homodyne cw lidar measures |V|" in out.out


def test_the_report_says_which_sign_it_gives(capsys):
    """--speed is positive away from the lidar; tier los returns it signed, the others its magnitude: the JSON's
    sign_convention and the text line say which, and the numbers agree with what they say."""
    rc, out = _run(capsys, "--speed", "-6.5", "--cnr", "-10", "--tier", "los", "--n", "5", "--json")
    rep = json.loads(out.out)
    assert rc == 0 and rep["mean"] == -6.5
    assert rep["sign_convention"].startswith("speed: positive away from the lidar")
    assert "signed" in rep["sign_convention"]
    rc, out = _run(capsys, "--speed", "-5", "--cnr", "-10", "--n", "20", "--seed", "1", "--json")
    rep = json.loads(out.out)
    assert rep["mean"] == pytest.approx(5.0, abs=0.1) and "|speed|" in rep["sign_convention"]
    rc, out = _run(capsys, "--speed", "-6.5", "--cnr", "-10", "--tier", "los", "--n", "5")
    assert "mean -6.5000 m/s (signed, + away from the lidar)" in out.out
    rc, out = _run(capsys, "--speed", "-5", "--cnr", "-10", "--n", "20", "--seed", "1")
    assert "m/s (|V|, homodyne)" in out.out


def test_a_field_value_of_the_wrong_type_names_the_field(capsys):
    rc, out = _run(capsys, "--speed", "5", "--cnr", "-10", "--set", "focus=abc")
    assert rc == 2
    assert out.err.strip() == "cwlidar-sim doppler: error: --set focus='abc': focus takes a number"


def test_json_on_stdout_is_strict_json_without_nan():
    """Every command prints its JSON through cli._json: a NaN or an infinity (Python's or numpy's, nested
    anywhere) is null, so the output parses with a strict JSON parser (json.dumps alone writes NaN)."""
    import numpy as np

    from cwlidar_sim.cli import _json

    obj = {"mean": float("nan"), "rows": [1.0, float("inf"), {"x": np.float32("nan")}], "n": np.int64(3),
           "ok": np.float64(2.5)}
    text = _json(obj)
    back = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))
    assert back == {"mean": None, "rows": [1.0, None, {"x": None}], "n": 3, "ok": 2.5}
