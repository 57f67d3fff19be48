"""Instrument presets: A2012 / CS numbers, conversions, overrides and validation."""

import math

import pytest

from cwlidar_sim.signal import CS_SERIES, PROTOTYPE_2003, Instrument, preset


def test_prototype_bins_and_nyquist():
    p = PROTOTYPE_2003
    # A2012 section II: 50 MHz / 512 = 97.66 kHz bins; 1 m/s <-> 2/lambda = 1.2923 MHz
    assert p.bin_width == pytest.approx(50e6 / 512)
    assert 1.0 / p.speed_per_hz == pytest.approx(1.2923e6, rel=1e-4)
    assert p.bin_speed == pytest.approx(0.0756, abs=5e-5)
    assert p.nyquist == 25e6
    assert p.nyquist_speed == pytest.approx(19.35, abs=0.01)
    assert p.block_duration == pytest.approx(10.24e-6)
    # 50 Hz output leaves room for floor(97656.25 / 50) = 1953 blocks
    assert p.blocks_per_estimate == 1953 == math.floor(p.sample_rate / p.n_fft / p.estimate_rate)
    assert p.estimator == "median" and p.focus == 67.5
    assert p.waist_radius == pytest.approx(1.66e-3, abs=0.01e-3)
    assert p.rayleigh_length == pytest.approx(5.61, abs=0.01)
    assert p.speeds_f[10] == pytest.approx(10 * p.bin_speed)
    assert p.doppler_frequency(1.0) == pytest.approx(2 / p.wavelength)
    assert p.speed_of_frequency(p.doppler_frequency(-3.2)) == pytest.approx(-3.2)


def test_cs_series():
    c = CS_SERIES
    assert c.sample_rate / c.n_fft == pytest.approx(200_000)  # CS: 200 000 spectra per second
    assert c.blocks_per_estimate == 4000
    assert c.estimate_duration == pytest.approx(0.020)
    assert c.estimator == "centroid"
    assert c.rayleigh_length / c.focus**2 == pytest.approx(0.0013)
    assert preset("cs") is c and preset("prototype") is PROTOTYPE_2003


def test_overrides_and_round_trip():
    p = PROTOTYPE_2003.replace(blocks_per_estimate=100, estimator="centroid")
    assert p.blocks_per_estimate == 100 and p.estimator == "centroid" and p.focus == 67.5
    assert Instrument.from_dict(p.as_dict()) == p
    assert Instrument.from_dict({"focus": 100.0}, base=CS_SERIES).estimator == "centroid"
    with pytest.raises(ValueError, match="unknown key.*'bogus'"):
        PROTOTYPE_2003.replace(bogus=1)
    with pytest.raises(ValueError, match="unknown key"):
        Instrument.from_dict({"n_fft": 512, "nfft": 3})


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"n_fft": 511}, "n_fft=511 must be even"),
        ({"blocks_per_estimate": 1954}, "blocks_per_estimate=1954 does not fit"),
        ({"estimator": "mode"}, "estimator='mode' is not allowed; allowed: 'median'"),
        ({"window": "kaiser"}, "window"),
        ({"threshold_kind": "peak_fraction", "threshold_value": 1.5}, "threshold_value"),
        ({"blind_zone_speed": 25.0}, "blind_zone_speed"),
        ({"focus": -1.0}, "focus"),
        ({"sample_rate": float("nan")}, "sample_rate"),
    ],
)
def test_bad_fields(kw, match):
    with pytest.raises(ValueError, match=match):
        PROTOTYPE_2003.replace(**kw)


def test_speckle_time():
    p = PROTOTYPE_2003
    assert p.speckle_time(1.0) == pytest.approx(p.waist_radius)
    assert math.isinf(p.speckle_time(0.0))
    with pytest.raises(ValueError, match="transverse_speed"):
        p.speckle_time(-1.0)


@pytest.mark.parametrize(
    "kw, words",
    [
        # a focus typed in km: refused with its z_R (1.2e-5 m), not run with a transfer function of 1.000
        ({"focus": 0.1}, ["focus=0.1", "10 m minimum", "zR would be 1.2e-05 m", "km"]),
        ({"focus": 9.99}, ["focus=9.99", "10 m minimum"]),
        # at pi a0^2 / lambda = 812 m the prototype's z_R reaches the focus distance itself
        ({"focus": 812.0}, ["focus=812.0", "collimation distance", "812"]),
        ({"focus": 67500.0}, ["focus=67500.0", "collimation distance"]),
        ({"wavelength": 1547.615}, ["wavelength=1547.615", "coherent Doppler lidars", "nm or um"]),
        ({"wavelength": 1.547615e-3}, ["wavelength=0.001547615", "[2.5e-07, 1.1e-05]"]),
        ({"telescope_radius": 20.0}, ["telescope_radius=20.0", "mm or cm", "[0.001, 0.3]"]),
        ({"telescope_radius": 5e-4}, ["telescope_radius=0.0005"]),
        ({"sample_rate": 50.0, "blocks_per_estimate": 1}, ["sample_rate=50.0", "MHz", "[1e+06, 1e+10]"]),
    ],
)
def test_physical_ranges_say_why(kw, words):
    with pytest.raises(ValueError) as e:
        PROTOTYPE_2003.replace(**kw)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_physical_range_edges_are_accepted():
    p = PROTOTYPE_2003
    far = math.pi * p.telescope_radius**2 / p.wavelength  # 812.0 m
    assert 811.9 < far < 812.0
    assert p.replace(focus=10.0).rayleigh_length == pytest.approx(0.1232, abs=1e-4)
    assert p.replace(focus=811.9).rayleigh_length < 811.9
    for kw in ({"wavelength": 0.25e-6}, {"wavelength": 11e-6}, {"telescope_radius": 0.3}, {"sample_rate": 1e10}):
        assert p.replace(**kw) is not None
    # CS's series: z_R = 0.0013 r^2, collimation at 1 / 0.0013 = 769 m
    assert CS_SERIES.replace(focus=769.0).focus == 769.0
    with pytest.raises(ValueError, match="collimation distance"):
        CS_SERIES.replace(focus=770.0)
