"""Time columns kept exactly (cwlidar_sim._times): integer ns from the digits, the unit from the header, the rate."""

import numpy as np
import pytest

from cwlidar_sim import _times as T


def test_unix_seconds_at_20_hz_are_exact_and_give_20_hz():
    # float64 seconds near 1.7e9 step in 2.4e-7 s: the median step of the floats gives 20.0000191 Hz
    cells = [f"{1_700_000_000 + i / 20:.3f}" for i in range(12000)]
    floats = np.array([float(c) for c in cells])
    assert 1.0 / np.median(np.diff(floats)) != 20.0  # the trap the exact parse avoids
    tc = T.parse_time_cells(cells, "s", "m.csv: time column 'time'")
    assert tc.ns[0] == 1_700_000_000 * 10**9 and np.all(np.diff(tc.ns) == 50_000_000)
    fs, idx = T.infer_grid(tc, "m.csv")
    assert fs == 20.0 and np.array_equal(idx, np.arange(12000))
    # the same times as NetCDF floats: the floats' own resolution, still 20 Hz
    fs, _ = T.infer_grid(T.float_times(floats, "s", "m.nc"), "m.nc")
    assert fs == 20.0


@pytest.mark.parametrize("fs, fmt", [(30.0, "{:.6f}"), (12.5, "{:.4f}"), (32.0, "{!r}"), (1.0, "{:.0f}")])
def test_rates_written_with_finite_digits_snap_to_the_logged_rate(fs, fmt):
    cells = [fmt.format(0.0333 + i / fs) for i in range(int(120 * fs))]
    rate, idx = T.infer_grid(T.parse_time_cells(cells, "s", "w"), "w")
    assert rate == fs and idx[-1] == len(cells) - 1


def test_a_rate_that_is_not_round_is_kept_as_measured():
    cells = [f"{i * 0.0301:.4f}" for i in range(2000)]  # 33.2226 Hz: no coarser decimal within the resolution
    rate, _ = T.infer_grid(T.parse_time_cells(cells, "s", "w"), "w")
    assert rate == pytest.approx(1 / 0.0301, rel=1e-5) and rate != round(rate, 3)


@pytest.mark.parametrize("header, base, unit", [("time_ms", "time", "ms"), ("time [us]", "time", "us"),
                                                ("time (ns)", "time", "ns"), ("time/h", "time", "h"),
                                                ("time", "time", None), ("sonic_time", "sonic_time", None),
                                                ("time_x", "time_x", None)])
def test_header_units(header, base, unit):
    assert T.split_unit(header) == (base, unit)


def test_units_scale_exactly_and_must_agree_with_the_header():
    tc = T.parse_time_cells(["0", "50", "100.5"], T.column_unit("time_ms", None, "w"), "w")
    assert tc.ns.tolist() == [0, 50_000_000, 100_500_000] and tc.unit == "ms"
    assert T.parse_time_cells(["1", "2"], "us", "w").ns.tolist() == [1000, 2000]
    assert T.column_unit("time", None, "w") == "s" and T.column_unit("time_ms", "ms", "w") == "ms"
    with pytest.raises(ValueError, match="header says 'ms' but the declared unit is 's'"):
        T.column_unit("time_ms", "s", "m.csv: time column 'time_ms'")
    with pytest.raises(ValueError, match="several time columns"):
        T.find_time_column(["time", "time_ms", "u"], "m.csv")
    assert T.find_time_column(["u", "time [ms]"], "m.csv") == "time [ms]"


def test_a_step_implausible_for_the_unit_names_the_column_and_the_likely_unit():
    ms = T.parse_time_cells([str(50 * i) for i in range(100)], "s", "w")  # 20 Hz in ms, read as s
    with pytest.raises(ValueError, match=r"m.csv: time column 'time': read in s, the times step by 50 s "
                                         r"\(0.02 Hz\); allowed: a wind record at 0.1-1000 Hz; read in ms it "
                                         r"would be 20 Hz"):
        T.infer_grid(ms, "m.csv: time column 'time'", rate_range=(0.1, 1000.0), unit="s", what="wind record")
    hours = T.parse_time_cells([f"{i / 72000:.9f}" for i in range(200)], "s", "w")  # 20 Hz in h, read as s
    with pytest.raises(ValueError, match=r"\(71999.4 Hz\).*read in h it would be 20 Hz"):
        T.infer_grid(hours, "w", rate_range=(0.1, 1000.0))
    assert T.infer_grid(T.parse_time_cells([f"{i / 72000:.9f}" for i in range(200)], "h", "w"), "w",
                        rate_range=(0.1, 1000.0))[0] == 20.0


@pytest.mark.parametrize("cells, match", [
    (["0", "0.05", "0.05", "0.15"], r"not strictly increasing: sample 2 at t = 0.050000000 s repeats"),
    (["0", "0.1", "0.05", "0.15"], r"not strictly increasing: sample 2 .* goes back"),
    (["0", "nan", "0.1"], r"time is missing at sample 1"),
    (["0", "", "0.1"], r"time is missing at sample 1"),
    (["0", "0.1", "0.2", "0.37", "0.4"], r"sample 3 .* 0.30 steps off"),
    (["0", "soon"], r"neither numbers nor ISO 8601 times \(sample 1: 'soon'\)$"),
    (["0", "0.1", "x" * 100 + "\x07"], r"neither numbers nor ISO 8601 times \(sample 2: 'x{32}\.\.\.'\)$"),
    (["0", "2023-11-14T22:13:20", "0.2"], r"w: mixes numbers and ISO 8601 times; allowed: one or the other$"),
])
def test_bad_times_are_named(cells, match):
    with pytest.raises(ValueError, match=match):
        T.infer_grid(T.parse_time_cells(cells, "s", "w"), "w")


def test_negative_times_and_iso_times_are_exact():
    tc = T.parse_time_cells([f"{-300 + i / 32:.6f}" for i in range(64)], "s", "w")
    assert tc.ns[0] == -300 * 10**9 and T.infer_grid(tc, "w")[0] == 32.0
    assert T.ns_text(-1) == "-0.000000001" and T.ns_text(1_700_000_000_525_000_000) == "1700000000.525000000"
    iso = T.parse_time_cells(["2023-11-14T22:13:20.525", "2023-11-14T22:13:20.575", "2023-11-14T22:13:20.625"],
                             "s", "w")
    assert iso.iso and iso.ns[0] == 1_700_000_000_525_000_000 and T.infer_grid(iso, "w")[0] == 20.0


def _oracle_ns(cell, per):
    """A cell's ns by decimal arithmetic alone (the definition the fast path must meet)."""
    from decimal import ROUND_HALF_EVEN, Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = 60
        return int((Decimal(cell) * per).to_integral_value(rounding=ROUND_HALF_EVEN))


@pytest.mark.parametrize("unit", ["ns", "us", "ms", "s", "min", "h"])
def test_every_written_form_of_a_time_gives_its_exact_ns(unit):
    """Plain decimals (read vectorised), and exponents, rounding, 19 digits (read by decimal): one answer."""
    rng = np.random.default_rng(len(unit))
    per = T.unit_ns(unit, "w")
    cells = []
    for _ in range(3000):
        whole = str(int(rng.integers(0, 10 ** int(rng.integers(0, 11)))) % (2**62 // per))  # within int64 ns
        frac = "".join(map(str, rng.integers(0, 10, int(rng.integers(0, 13)))))
        c = rng.choice(["", "-", "+"]) + rng.choice(["", "00"]) + whole + ("." + frac if rng.random() < 0.8 else "")
        cells.append(c)
    cells += ["-0", "+0.0", ".5", "-.25", "5.", "007.500", "1e3", "-2.5E-1", "-5", "5_0"]
    if unit == "s":
        cells += ["9223372036.854775807", "-9223372036.85477580", "1700000000.525"]  # 19 digits: to the last ns
    k = len(str(per)) - 1 if unit not in ("min", "h") else -1
    plain = [c for c in cells if "e" not in c.lower() and "_" not in c and len(c.partition(".")[2]) <= k
             and "922" not in c]
    assert len(plain) > 500 or k < 0
    if hasattr(getattr(np, "strings", None), "partition"):  # numpy >= 2.3
        assert (T._plain_decimal_ns(plain, per) is not None) == (k >= 0)  # these take the vectorised path
    for block in (cells, plain or cells[:9], cells[:50]):
        tc = T.parse_time_cells(block, unit, "w")
        assert tc.ns.tolist() == [_oracle_ns(c, per) for c in block]
        places = max(len(c.split(".")[1]) if "." in c and "e" not in c.lower() else 0 for c in block)
        assert tc.quantum_ns == max(1.0, per * 10.0 ** -places)
    if unit == "s":  # one ns past int64, in 19 digits: refused, not wrapped around
        with pytest.raises(ValueError, match=r"w: times beyond \+-292 years in ns"):
            T.parse_time_cells(["9223372036.854775808", "9223372036.854775809"], unit, "w")
        with pytest.raises(ValueError, match=r"w: holds neither numbers nor ISO 8601 times"):  # a NUL is no digit
            T.parse_time_cells(["5\x00", "6"], unit, "w")


def test_a_plain_column_of_times_costs_no_decimal_per_cell(monkeypatch):
    cells = [f"{1_700_000_000 + i / 20:.3f}" for i in range(2000)] + ["-0.125", "+3", ".5"]
    expect = [_oracle_ns(c, 10**9) for c in cells]

    def no_decimal(*a, **k):
        raise AssertionError("a Decimal per cell for a plain column")

    if not hasattr(getattr(np, "strings", None), "partition"):
        pytest.skip("numpy < 2.3: every column takes the decimal path")
    monkeypatch.setattr(T.decimal, "Decimal", no_decimal)
    assert T.parse_time_cells(cells, "s", "w").ns.tolist() == expect
    assert T.parse_time_cells([f"{i / 20:.2f}" for i in range(100)], "ms", "w").ns[-1] == 4_950_000
