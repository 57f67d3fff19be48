"""Instrument presets: sampling, block FFT, averaging and processing choices of a cw lidar.

Three presets are provided, each overridable field by field with
:meth:`Instrument.replace` or :meth:`Instrument.from_dict`:

:data:`PROTOTYPE_2003`
    The 2003 ZephIR prototype of A2012 (section II): 50 MHz sampling, DFT of
    512 consecutive samples (bins of 97.66 kHz = 0.0756 m/s, Nyquist 25 MHz =
    19.4 m/s), 50 Hz staring output, so up to
    ``floor(50e6 / 512 / 50) = 1953`` spectra averaged per estimate, median
    estimator, focus 67.5 m, lambda = 1547.615 nm, a0 = 20 mm.
:data:`CS_SERIES`
    The conically scanning series ZephIR of CS: 200 000 spectra per second,
    4000 averaged per estimate (20 ms, 50 estimates per revolution), centroid
    estimator, z_R = 0.0013 r^2.  CS gives neither the sampling rate nor the
    FFT length; we assume 512-point blocks at 102.4 MHz, the pair that gives
    exactly 200 000 spectra per second.  The telescope radius
    ``a0 = sqrt(lambda / (0.0013 pi)) = 19.47 mm`` reproduces z_R = 0.0013 r^2
    through A2012 Eq. 1.  Focus 100 m (CS's example).

:data:`SPINNER_LIDAR`
    DTU's SpinnerLidar (:mod:`cwlidar_sim.sensors.spinner`): 1.56 um, 256
    bins over 50 MHz (0.152 m/s), 492 estimates per second.

Choices the papers do not state, and which are therefore fields with
documented defaults rather than facts: the window of the 512-point block
(rectangular: "DFT of 512 consecutive samples"), the threshold rule and its
factor, the width of the low-frequency blind zone and of the edge guards,
and the noise near 0 Hz.  Both presets carry (class defaults: none)

* relative-intensity noise 10 dB above shot noise at 0 Hz with a 300 kHz
  corner (``rin_level = 10``, ``rin_corner = 3e5``): the order of an
  erbium-fibre master-oscillator power amplifier's RIN (about -145 dB/Hz)
  against the shot noise of a ~1 mW local oscillator (2 h nu / P =
  -156 dB/Hz), rolling off above the amplifier's relaxation frequencies;
* the beat of the internal reflection of a monostatic telescope with the
  local oscillator, 30 dB above shot noise at 0 Hz with a 30 kHz half-width
  (``reflection_level = 1000``, ``reflection_corner = 3e4``; a laser line
  width of tens of kHz).

Together they lift the floor 5-fold at the prototype's 0.5 m/s blind-zone
edge (0.65 MHz), 2.4-fold at 1 m/s; they add 15 % at 3 m/s and 2.4 % at 8 m/s to the
shot noise.  The per-bin signal-to-noise ratio near 0 Hz drops accordingly,
which is the physics behind the blind zone (``blind_zone_speed`` keeps the
flag).

Doppler conversion: ``f = 2 v / lambda`` [Hz], so 1 m/s <-> 1.2923 MHz at
1547.615 nm.

Physical ranges
---------------
Every field is checked against what a cw coherent Doppler lidar can be, and
the message says why, so a value in the wrong unit is refused before any
computation instead of running (``focus = 0.1``, a focus typed in km, used to
give z_R = 1.2e-5 m and a transfer function of 1.000).  The optical ones:
wavelength 0.25-11 um (UV to CO2), telescope radius 1 mm-0.3 m, focus from
:data:`FOCUS_MIN` = 10 m (the near end of a cw lidar's focusing range) to the
collimation distance ``pi a0^2 / lambda`` (812 m for the prototype, 769 m for
CS's series), where ``z_R = lambda r^2 / (pi a0^2)`` reaches r itself: the
focused-beam weighting (A2012 Eq. 1) needs ``z_R << r``.  The sampling rate
is 1 MHz-10 GHz; the block, averaging and output fields must also fit
together (``blocks_per_estimate`` within one output period, the blind zone
below Nyquist).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_keys, check_real

#: Laser wavelength of the ZephIR prototype [m] (A2012).
WAVELENGTH = 1547.615e-9

#: Wavelengths of coherent Doppler lidars [m]: 0.3 um (UV) to 10.6 um (CO2), with margins.
WAVELENGTH_RANGE = (0.25e-6, 11e-6)
#: Telescope (e^-2) radii [m]: 1 mm (pi a0^2 / lambda = 2 m at 1.55 um: nothing farther can be focused) to 0.3 m.
TELESCOPE_RADIUS_RANGE = (1e-3, 0.3)
#: Nearest focus [m]: the near end of a cw lidar's focusing range (ZephIR: 10 m).
FOCUS_MIN = 10.0
#: Detector sampling rates [Hz]: 1 MHz (Nyquist speed 0.39 m/s at 1.55 um) to 10 GHz.
SAMPLE_RATE_RANGE = (1e6, 1e10)

WINDOWS = ("rect", "hann")
THRESHOLD_KINDS = ("sigma", "snr", "peak_fraction")
RAISE_READINGS = ("level", "excess")

__all__ = ["FOCUS_MIN", "Instrument", "PROTOTYPE_2003", "CS_SERIES", "WINDSCANNER", "SPINNER_LIDAR", "PRESETS", "preset",
           "WINDOWS", "THRESHOLD_KINDS"]


@dataclasses.dataclass(frozen=True)
class Instrument:
    """Acquisition and processing settings of a cw coherent Doppler lidar.

    Parameters
    ----------
    name : str
        Free label.
    wavelength : float
        Laser wavelength lambda [m]; in [2.5e-7, 1.1e-5] (coherent Doppler
        lidars: 0.3 um UV to the 10.6 um CO2 laser).
    telescope_radius : float
        Effective telescope radius a0 at e^-2 intensity [m]; in [1e-3, 0.3].
    focus : float
        Focus distance r [m]; in [10, pi a0^2 / lambda): the near end of a cw
        lidar's focusing range, and the telescope's collimation distance
        (812 m for the prototype), where z_R would reach r and the beam is no
        longer focused (module notes).
    sample_rate : float
        Sampling rate of the real detector signal f_s [Hz]; in [1e6, 1e10].
    n_fft : int
        Samples per block (one DFT) N; even, in [16, 65536].
    blocks_per_estimate : int
        Block periodograms averaged into one spectrum (one estimate) M; >= 1.
    estimate_rate : float
        Output rate of speed estimates [Hz]; > 0.  Must leave room for the
        blocks: ``blocks_per_estimate * n_fft / sample_rate <= 1 / estimate_rate``.
    window : {'rect', 'hann'}
        Taper applied to each block before the DFT.  'rect' (no taper) gives
        the Fejer (periodic sinc^2) line shape.
    estimator : str
        Name of the Doppler estimator, one of
        :data:`cwlidar_sim.signal.processing.ESTIMATORS`.
    threshold_kind : {'sigma', 'snr', 'peak_fraction'}
        Threshold rule on the noise-normalised spectrum ``y = S / B - 1`` (see
        :func:`cwlidar_sim.signal.processing.threshold_levels`):
        'sigma' (the instrument rule): ``t = value * sigma_y``, with
        ``sigma_y = sqrt(1/M + 1/M_bg)`` the standard deviation of ``y`` in a
        signal-free bin; 'snr': ``t = value`` (a per-bin signal-to-noise
        ratio, linear); 'peak_fraction': ``t = value * max(y)`` once the peak
        passes the detection test ``max(y) > peak_detection_sigma * sigma_y``.
    threshold_value : float
        The factor of the rule; >= 0 (<= 1 for 'peak_fraction').
    threshold_raise_percent : float
        A2012's experiment: the threshold raised by this percentage x of its
        original value; in [0, 1000].  How, see ``threshold_raise_reading``.
    threshold_raise_reading : {'level', 'excess'}
        'level': the threshold in raw spectrum units, ``B (1 + t)``, is
        raised, ``t -> (1 + t)(1 + x/100) - 1``; 'excess': its height above
        the removed background, ``t -> t (1 + x/100)``.  The same for every
        threshold kind (:func:`cwlidar_sim.signal.processing.threshold_levels`).
    blind_zone_speed : float
        Speeds below this are never used (relative-intensity noise and the
        homodyne ambiguity live near 0 Hz) [m/s]; >= 0 and below Nyquist.
    edge_guard_speed : float
        An estimate within this distance of the blind-zone edge or of the
        Nyquist speed is flagged [m/s]; >= 0.
    second_peak_fraction : float
        A separate group of thresholded bins carrying at least this fraction of
        the main group's power raises the second-peak (cloud) flag; in (0, 1].
    peak_detection_sigma : float
        Detection test of the 'peak_fraction' threshold: a spectrum whose
        largest excess ``max(y)`` is not above this many ``sigma_y`` has no
        signal (NaN, ``NO_SIGNAL``); in [0, 1000].  Default 4, the 'sigma'
        rule's default level; unused by the other kinds.
    rin_level : float
        Relative-intensity-noise density at 0 Hz relative to the shot-noise
        floor [-]; >= 0 (0: none).
    rin_corner : float
        Corner frequency of the Lorentzian RIN shape ``1 / (1 + (f/f_c)^2)`` [Hz]; > 0.
        The RIN is a real Gaussian process added to the detector signal in
        tier 3 and to the noise floor in both tiers
        (:func:`cwlidar_sim.signal.spectral.noise_correlation`).
    reflection_level : float
        Density at 0 Hz, relative to shot noise, of the beat of the internal
        reflection of a monostatic cw lidar (light returned by the optics,
        not Doppler shifted) with the local oscillator [-]; >= 0 (0: none).
        Same Lorentzian form as the RIN.
    reflection_corner : float
        Half-width of the reflection's 0 Hz peak (laser line width and
        mechanical jitter) [Hz]; > 0.
    background_blocks : int
        Signal-free blocks averaged into the background (noise-floor) spectrum
        M_bg; >= 1.  Default: 10 min of blocks, as the prototype measured every 3 h.
    background_mismatch : float
        Relative gain of the receiver during the measurement over its gain
        when the background was measured, just after a calibration [-]; in
        [-0.5, 1] (0: none).  Multiplies signal and noise alike, so a
        signal-free bin's ``y = S/B - 1`` has mean ``delta`` (the gain minus
        1) instead of 0 (:func:`cwlidar_sim.signal.processing.background_gain`).
    background_drift : float
        Further relative gain change accrued linearly between two calibrations
        (over ``background_interval - background_duration``) [-]; in [-0.5, 1].
    background_interval : float
        Time from one background calibration to the next [s]; > 0.  A2012:
        3 h (10800 s).
    background_duration : float
        Length of a calibration (no estimates: the campaign's PAUSED flag)
        [s]; in [0, background_interval).  A2012: 10 min (600 s).
    """

    name: str = "custom"
    wavelength: float = WAVELENGTH
    telescope_radius: float = 0.020
    focus: float = 67.5
    sample_rate: float = 50e6
    n_fft: int = 512
    blocks_per_estimate: int = 1953
    estimate_rate: float = 50.0
    window: str = "rect"
    estimator: str = "median"
    threshold_kind: str = "sigma"
    threshold_value: float = 4.0
    threshold_raise_percent: float = 0.0
    threshold_raise_reading: str = "level"
    blind_zone_speed: float = 0.5
    edge_guard_speed: float = 0.5
    second_peak_fraction: float = 0.2
    peak_detection_sigma: float = 4.0
    rin_level: float = 0.0
    rin_corner: float = 1e6
    reflection_level: float = 0.0
    reflection_corner: float = 3e4
    background_blocks: int = 58_593_750
    background_mismatch: float = 0.0
    background_drift: float = 0.0
    background_interval: float = 10800.0
    background_duration: float = 600.0

    def __post_init__(self):
        def put(k, v):
            object.__setattr__(self, k, v)

        if not isinstance(self.name, str):
            raise TypeError(f"name must be a str, got {type(self.name).__name__}")
        put("wavelength", _check_physical("wavelength", self.wavelength, WAVELENGTH_RANGE, "m",
                                          "the band of coherent Doppler lidars, 0.3 um (UV) to 10.6 um (CO2 laser); "
                                          "the prototype's is 1.55e-06 m", "nm or um"))
        put("telescope_radius", _check_physical("telescope_radius", self.telescope_radius, TELESCOPE_RADIUS_RANGE,
                                                "m", "the e^-2 radius of a cw lidar's telescope (the prototype's: "
                                                "0.020 m); a smaller one focuses nothing past a few metres",
                                                "mm or cm"))
        put("focus", self._checked_focus())
        put("sample_rate", _check_physical("sample_rate", self.sample_rate, SAMPLE_RATE_RANGE, "Hz",
                                           "a detector digitiser's rate (the prototype's: 5e+07 Hz); below 1 MHz "
                                           "the Nyquist speed lambda f_s / 4 is under 0.4 m/s", "MHz or GHz"))
        n = check_int("n_fft", self.n_fft, lo=16, hi=65536)
        if n % 2:
            raise ValueError(f"n_fft={n} must be even; allowed: even integers in [16, 65536]")
        put("n_fft", n)
        put("blocks_per_estimate", check_int("blocks_per_estimate", self.blocks_per_estimate, lo=1, hi=10**8))
        put("estimate_rate", check_real("estimate_rate", self.estimate_rate, lo=0.0, lo_open=True))
        fit = self.sample_rate / self.n_fft / self.estimate_rate
        if self.blocks_per_estimate > fit * (1 + 1e-9):
            raise ValueError(
                f"blocks_per_estimate={self.blocks_per_estimate} does not fit in one output period "
                f"(1/estimate_rate = {1 / self.estimate_rate:g} s holds {fit:.6g} blocks of "
                f"{self.n_fft / self.sample_rate:g} s); allowed: <= {math.floor(fit * (1 + 1e-9))}"
            )
        check_choice("window", self.window, WINDOWS)
        from .processing import ESTIMATORS  # plain Python, no numba

        check_choice("estimator", self.estimator, tuple(ESTIMATORS))
        check_choice("threshold_kind", self.threshold_kind, THRESHOLD_KINDS)
        hi = 1.0 if self.threshold_kind == "peak_fraction" else 1e6
        put("threshold_value", check_real("threshold_value", self.threshold_value, lo=0.0, hi=hi))
        put("threshold_raise_percent",
            check_real("threshold_raise_percent", self.threshold_raise_percent, lo=0.0, hi=1000.0))
        check_choice("threshold_raise_reading", self.threshold_raise_reading, RAISE_READINGS)
        nyq = self.nyquist_speed
        put("blind_zone_speed", check_real("blind_zone_speed", self.blind_zone_speed, lo=0.0, hi=nyq, hi_open=True))
        put("edge_guard_speed", check_real("edge_guard_speed", self.edge_guard_speed, lo=0.0, hi=nyq))
        put("second_peak_fraction",
            check_real("second_peak_fraction", self.second_peak_fraction, lo=0.0, hi=1.0, lo_open=True))
        put("peak_detection_sigma", check_real("peak_detection_sigma", self.peak_detection_sigma, lo=0.0, hi=1000.0))
        put("rin_level", check_real("rin_level", self.rin_level, lo=0.0, hi=1e12))
        put("rin_corner", check_real("rin_corner", self.rin_corner, lo=0.0, hi=self.sample_rate, lo_open=True))
        put("reflection_level", check_real("reflection_level", self.reflection_level, lo=0.0, hi=1e12))
        put("reflection_corner",
            check_real("reflection_corner", self.reflection_corner, lo=1e-6 * self.sample_rate, hi=self.sample_rate))
        put("background_blocks", check_int("background_blocks", self.background_blocks, lo=1, hi=10**15))
        put("background_mismatch", check_real("background_mismatch", self.background_mismatch, lo=-0.5, hi=1.0))
        put("background_drift", check_real("background_drift", self.background_drift, lo=-0.5, hi=1.0))
        put("background_interval",
            check_real("background_interval", self.background_interval, lo=0.0, hi=1e9, lo_open=True))
        put("background_duration", check_real("background_duration", self.background_duration, lo=0.0,
                                              hi=self.background_interval, hi_open=True))
        if self.first_bin >= self.n_fft // 2 - 1:
            raise ValueError(
                f"blind_zone_speed={self.blind_zone_speed} leaves no usable bin below Nyquist; "
                f"allowed: < {(self.n_fft // 2 - 2) * self.bin_speed:g} m/s"
            )

    def _checked_focus(self) -> float:
        """The focus distance [m], within a cw lidar's focusing range (module notes); wavelength and a0 checked."""
        r = check_real("focus", self.focus, lo=0.0, lo_open=True)
        zr = self.wavelength * r**2 / (math.pi * self.telescope_radius**2)
        far = math.pi * self.telescope_radius**2 / self.wavelength
        allowed = f"allowed: [{FOCUS_MIN:g}, {far:.4g}) m"
        if r < FOCUS_MIN:
            raise ValueError(f"focus={self.focus!r} m is below the {FOCUS_MIN:g} m minimum of a cw lidar's "
                             f"focusing range (zR would be {zr:.2g} m); did you give km? {allowed}")
        if r >= far:
            raise ValueError(f"focus={self.focus!r} m is at or beyond the telescope's collimation distance "
                             f"pi a0^2 / lambda = {far:.4g} m (a0 = {self.telescope_radius:g} m): the beam cannot "
                             f"be focused there, zR would be {zr:.3g} m, not shorter than the focus distance; "
                             f"did you give mm or cm? {allowed}")
        return r

    # -- interchange -----------------------------------------------------
    def as_dict(self) -> dict:
        """Plain dict of the fields (round-trips through :meth:`from_dict`)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict, base: "Instrument | None" = None) -> "Instrument":
        """Build from a mapping; unknown keys are rejected by name.

        Fields missing from ``d`` are taken from ``base`` (a preset), or from
        the class defaults (the prototype) when ``base`` is None.
        """
        _check_keys(d)
        start = {} if base is None else base.as_dict()
        start.update(d)
        return cls(**start)

    def replace(self, **changes) -> "Instrument":
        """Copy with some fields changed (validated); unknown names are rejected."""
        _check_keys(changes)
        return dataclasses.replace(self, **changes)

    # -- derived quantities ------------------------------------------------
    @property
    def n_bins(self) -> int:
        """Bins of the one-sided block spectrum (rfft output), N/2 + 1."""
        return self.n_fft // 2 + 1

    @property
    def block_duration(self) -> float:
        """Duration of one block, N / f_s [s] (10.24 us for the prototype)."""
        return self.n_fft / self.sample_rate

    @property
    def estimate_duration(self) -> float:
        """Signal time averaged into one estimate, M N / f_s [s]."""
        return self.blocks_per_estimate * self.block_duration

    @property
    def bin_width(self) -> float:
        """Frequency bin width f_s / N [Hz] (97.66 kHz for the prototype)."""
        return self.sample_rate / self.n_fft

    @property
    def speed_per_hz(self) -> float:
        """Radial speed per Doppler frequency, lambda / 2 [m/s per Hz]."""
        return 0.5 * self.wavelength

    @property
    def bin_speed(self) -> float:
        """Speed width of one bin, lambda f_s / (2 N) [m/s] (0.0756 m/s for the prototype)."""
        return self.bin_width * self.speed_per_hz

    @property
    def nyquist(self) -> float:
        """Nyquist frequency f_s / 2 [Hz]."""
        return 0.5 * self.sample_rate

    @property
    def nyquist_speed(self) -> float:
        """Speed at the Nyquist frequency, lambda f_s / 4 [m/s] (19.35 m/s for the prototype)."""
        return self.nyquist * self.speed_per_hz

    @property
    def first_bin(self) -> int:
        """First bin outside the blind zone: the smallest k with k * bin_speed >= blind_zone_speed."""
        return int(math.ceil(self.blind_zone_speed / self.bin_speed - 1e-9))

    @property
    def frequencies_f(self) -> np.ndarray:
        """Centre frequency of each one-sided bin, k f_s / N [Hz], k = 0..N/2."""
        return np.arange(self.n_bins) * self.bin_width

    @property
    def speeds_f(self) -> np.ndarray:
        """Speed of each one-sided bin, k lambda f_s / (2 N) [m/s]."""
        return np.arange(self.n_bins) * self.bin_speed

    @property
    def waist_radius(self) -> float:
        """e^-2 beam radius at the focus, lambda r / (pi a0) [m] (1.66 mm for the prototype)."""
        return self.wavelength * self.focus / (math.pi * self.telescope_radius)

    @property
    def rayleigh_length(self) -> float:
        """Rayleigh length lambda r^2 / (pi a0^2) [m] (A2012 Eq. 1)."""
        return self.wavelength * self.focus**2 / (math.pi * self.telescope_radius**2)

    def optics(self):
        """The beam optics as a :class:`cwlidar_sim.beam.BeamOptics`."""
        from ..beam.optics import BeamOptics

        return BeamOptics(focus=self.focus, wavelength=self.wavelength, radius=self.telescope_radius)

    def doppler_frequency(self, speed):
        """Doppler shift 2 v / lambda [Hz] of a radial speed v [m/s] (signed)."""
        return np.asarray(speed, dtype=np.float64) / self.speed_per_hz

    def speed_of_frequency(self, freq):
        """Radial speed lambda f / 2 [m/s] of a Doppler frequency f [Hz]."""
        return np.asarray(freq, dtype=np.float64) * self.speed_per_hz

    def speckle_time(self, transverse_speed: float) -> float:
        """Speckle correlation time: transit time of aerosols across the beam waist [s].

        ``tau_c = w0 / v_perp`` with ``w0 = lambda r / (pi a0)``; infinite for
        ``v_perp = 0`` (the speckle pattern then never renews during an estimate).

        Parameters
        ----------
        transverse_speed : float
            Speed of the aerosols across the beam [m/s]; >= 0.
        """
        v = check_real("transverse_speed", transverse_speed, lo=0.0, hi=1e3)
        return math.inf if v == 0.0 else self.waist_radius / v


def _check_keys(d):
    check_keys(Instrument, d)


def _check_physical(name, value, rng, unit, reason, unit_hint):
    """``value`` as a float in the physical range ``rng`` = (lo, hi), else a ValueError with the reason."""
    v = check_real(name, value, lo=0.0, lo_open=True)
    lo, hi = rng
    if not lo <= v <= hi:
        raise ValueError(f"{name}={value!r} {unit} is outside {reason}: a value in {unit_hint}? "
                         f"allowed: [{lo:g}, {hi:g}] {unit}")
    return v


#: Noise near 0 Hz of both presets (module notes).
_LOW_F_NOISE = dict(rin_level=10.0, rin_corner=3e5, reflection_level=1000.0, reflection_corner=3e4)

#: The 2003 ZephIR prototype of A2012 (staring mode).
PROTOTYPE_2003 = Instrument(name="zephir-prototype-2003", **_LOW_F_NOISE)

#: The conically scanning series ZephIR of CS (assumed 512-point blocks at 102.4 MHz).
CS_SERIES = Instrument(
    name="zephir-cs-series",
    telescope_radius=math.sqrt(WAVELENGTH / (0.0013 * math.pi)),
    focus=100.0,
    sample_rate=102.4e6,
    n_fft=512,
    blocks_per_estimate=4000,
    estimate_rate=50.0,
    estimator="centroid",
    background_blocks=120_000_000,
    **_LOW_F_NOISE,
)

#: A unit of DTU's short-range WindScanner (Mikkelsen et al. 2012): 512-point spectra, an estimate every
#: 3.1 ms (~323 Hz); 100 MHz sampling, the prototype's optics and median estimator assumed
#: (cwlidar_sim.sensors.windscanner, docs/windscanner.md).
WINDSCANNER = Instrument(
    name="dtu-short-range-windscanner",
    focus=125.0,
    sample_rate=100e6,
    n_fft=512,
    blocks_per_estimate=605,
    estimate_rate=1.0 / 3.1e-3,
    background_blocks=117_187_500,
    **_LOW_F_NOISE,
)

#: DTU's SpinnerLidar (Mikkelsen et al. 2013; Peña et al. 2019): lambda = 1.56 um, 512-point blocks at 100 MHz
#: (256 bins over 0-50 MHz, 0.152 m/s each), 492 estimates per second (984 per 2-s rosette), as many blocks as
#: fit in one (396).  Assumed, not from those papers: the ZephIR optics of the CS series (a0 = 19.5 mm), the
#: centroid estimator, 10 min of background blocks (:mod:`cwlidar_sim.sensors.spinner`).
SPINNER_LIDAR = Instrument(
    name="dtu-spinnerlidar",
    wavelength=1.56e-6,
    telescope_radius=math.sqrt(WAVELENGTH / (0.0013 * math.pi)),
    focus=80.0,
    sample_rate=100e6,
    n_fft=512,
    blocks_per_estimate=396,
    estimate_rate=492.0,
    estimator="centroid",
    background_blocks=117_187_500,
    **_LOW_F_NOISE,
)

PRESETS = {"prototype": PROTOTYPE_2003, "cs": CS_SERIES, "windscanner": WINDSCANNER, "spinner": SPINNER_LIDAR}


def preset(name: str) -> Instrument:
    """Instrument preset by name: 'prototype' (A2012), 'cs' (CS series), 'windscanner' or 'spinner' (DTU's)."""
    check_choice("preset", name, tuple(PRESETS))
    return PRESETS[name]
