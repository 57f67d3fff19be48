"""Virtual staring cw lidar: a record of speed estimates from a turbulence field, through any tier.

Geometry and cells
------------------
The lidar at ``position`` stares along ``n`` (:func:`cwlidar_sim.beam.direction_from_angles`:
azimuth from +x toward +y, elevation up from the horizontal; azimuth 0 stares
along the mean wind, so a positive radial speed is away from the lidar).
The probe volume is cut into cells of about ``cell_length`` over
``[max(-span z_R, -r), span z_R]`` around the focus ``r = instrument.focus``
(:func:`cwlidar_sim.beam.weight_truncated`, weights renormalised to sum to
1, the missing tail reported as ``info['truncated_fraction']``).  For each
estimate time ``t_e`` the line-of-sight speed of every cell,
``vlos_es[e, s] = n . (U + u, v, w)`` at ``position + (r + s_s) n`` and
``t_e`` (Taylor advection at U along +x, trilinear interpolation as in
:func:`cwlidar_sim.beam.sample_los`), is held over the estimate
(``t_e`` is the estimate's mid-time; at 50 Hz the wind moves ``U / 50``,
0.2 m at 10 m/s, during one estimate: less than a cell).

Tiers
-----
``los`` (tier 1)
    ``vlos_e = sum_s w_s vlos_es`` (A2012 Eq. 2), signed; the instrument's
    ``speed_e = |vlos_e|`` (a homodyne lidar loses the sign), no flags.
``spectral`` (tier 2)
    The expected averaged periodogram of each estimate from all its cells
    (below), the speckle and noise draw of
    :func:`cwlidar_sim.signal.sample_spectra`, a background spectrum
    (:func:`cwlidar_sim.signal.background_spectrum`, one per record, or the
    exact floor) and :func:`cwlidar_sim.signal.estimate`.
``signal`` (tier 3)
    :func:`cwlidar_sim.signal.simulate_signal_spectra` (the 50 MHz heterodyne
    signal) with the cell speeds held over each estimate, then the same
    processing; costs about ``n_cells`` multiply-adds per signal sample, so
    it is limited to short records (:data:`SIGNAL_MAX_ESTIMATES`).

Exact expected spectrum (tier 2, derived)
-----------------------------------------
With the line shape ``G(u) = sum_{|d|<N} a_d exp(i 2 pi u d / N)``,
``a_d = R_w(d) rho^|d| / R_w(0)`` (:mod:`cwlidar_sim.signal.spectral`), the
expected signal periodogram of an estimate is

``S(k) = sum_s A_s [G(k - x_s) + G(k + x_s)] = sum_{|d|<N} a_d C(d) exp(i 2 pi k d / N)``,
``C(d) = sum_s A_s 2 cos(2 pi x_s d / N)``,

``A_s = CNR w_s / 2`` and ``x_s = vlos_es / bin_speed`` the cell's Doppler
frequency in bins (signed; the homodyne mirror is the ``+x_s`` term, and a
speed beyond Nyquist aliases through the periodicity of the cosine).  On
integer bins the lags ``d`` and ``d - N`` coincide, so ``S`` is the real DFT
of the folded sequence ``b_0 = a_0 C(0)``, ``b_d = a_d C(d) + a_{N-d} C(N-d)``.
``C(d)`` for ``d = 0..N-1`` comes from the Chebyshev recurrence
``cos((d+1) t) = 2 cos t cos(d t) - cos((d-1) t)`` (about 3 flops per cell
and lag), then one length-N real FFT per estimate
(:func:`cwlidar_sim._fft.rfft_rows`).  No table and no interpolation: the
result equals the defining sum to rounding (~1e-13 relative), whereas
:func:`cwlidar_sim.signal.expected_spectrum` interpolates a tabulated ``G``
(error <= 1.3e-5 of the peak for the prototype).  Tiny negative rounding
residues (~1e-14 of the peak) are clipped to 0.

Randomness and chunks
---------------------
``seed`` spawns two streams (numpy ``SeedSequence``): the background
measurement and the simulation.  Tier 2 draws its speckle gains in fixed
blocks of :data:`DRAW_BLOCK` estimates, block ``b`` from the child
``SeedSequence`` with spawn key ``(..., b)``, and the per-bin normals from
the counter-based stream of the estimate's global index.  Estimates are
processed ``chunk`` at a time (memory: about
``chunk * (8 n_cells + 24 N)`` bytes, plus ``8 DRAW_BLOCK (N/2 + 1)`` bytes of
gains for 'independent' speckle), and every kernel loops over estimates
with sums in a fixed order, so the result is the same, bit for bit, for any
``chunk`` and any thread count; a shorter record is a prefix of a longer one
with the same settings (same correlation time and background).

Defaults (choices, not facts of the papers)
-------------------------------------------
``cnr_db = -10``: the wideband carrier-to-noise ratio of a shot-noise-limited
1 W cw lidar at 1.55 um, ``CNR ~ eta P beta lambda pi / (h nu B)`` with
efficiency ``eta ~ 0.3``, ``B = 25 MHz`` and a boundary-layer backscatter
``beta ~ 1e-7 .. 1e-6 /m/sr``, is about -13 .. -3 dB.  Neither paper states
a CNR; -10 dB gives a per-bin SNR of ``CNR N / 2`` = 14 dB for a one-bin
line, so the prototype's estimates are essentially always available while
speckle still sets their scatter.
``speckle = 'continuum'``: every cell is a continuum of scatterers whose
speeds spread about the cell's speed by the sub-cell spread (below); given
the cell speeds the signal is a Gaussian process and tier 2 draws each bin
with the mean and variance of its M-block average
(:func:`cwlidar_sim.signal.spectral.continuum_moments`: the bin's
block-to-block decorrelation from the Doppler spread of the scatterers in
it), tier 3 synthesises that process.  Both converge as the beam is cut
finer.  Without a sub-cell spread (``subcell_spread = 0``) the cells are
point-like and the model falls back to 'independent' (one
Gamma(M_eff) gain per bin, ``M_eff`` from the transit time: the earlier
default, whose tier-3 counterpart depends on the cell count); 'coherent'
(one gain per estimate) is exact for a single speed.
``subcell_spread = None``: from the field's Mann parameters (its attributes
``alpha_eps``, ``length_scale``, ``gamma``, ``dx``): the square root of
:func:`cwlidar_sim.turbulence.subcell_variance`, the along-beam variance
above the field's grid wavenumber (0.095 m/s for A2012's scene at 0.5 m);
0 when the field carries no parameters.
``cell_length = 0.5`` m: the spacing of the fields used here; cells should
not be much longer than the field spacing.
``transverse_speed = None``: the aerosols' speed across the beam is then the
rms, over the record, of the total wind's component perpendicular to ``n``
at the focus (for a beam along the mean wind: the v, w turbulence); it sets
the speckle correlation time ``w0 / v_perp`` and ``M_eff``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_keys, check_memory, check_real, check_seed, check_tuple
from ..signal.instrument import PRESETS, PROTOTYPE_2003, Instrument

__all__ = [
    "StaringLidar",
    "LidarRecord",
    "measure_staring",
    "expected_spectrum_exact",
    "instrument_from_spec",
    "TIERS",
    "VARIANT_KEYS",
    "SIGNAL_MAX_ESTIMATES",
    "DRAW_BLOCK",
    "SPECKLE_MODELS",
    "field_subcell_spread",
    "cnr_series",
]

TIERS = ("los", "spectral", "signal")
#: Instrument fields a processing variant may override: they act on the spectra only.
VARIANT_KEYS = ("estimator", "threshold_kind", "threshold_value", "threshold_raise_percent",
                "threshold_raise_reading", "blind_zone_speed", "edge_guard_speed", "second_peak_fraction")
#: Longest record accepted by tier 'signal' [estimates] (60 s at 50 Hz).
SIGNAL_MAX_ESTIMATES = 3000
#: Estimates per block of speckle gains (fixed, so draws do not depend on ``chunk``).
DRAW_BLOCK = 4096
#: Speckle models of :class:`StaringLidar`.
SPECKLE_MODELS = ("continuum", "independent", "coherent")

_PRESET_ALIASES = {"prototype": "prototype", "prototype_2003": "prototype", "cs": "cs", "cs_series": "cs"}


def _check_bool(name, value):
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__} {value!r}")
    return bool(value)


def instrument_from_spec(spec) -> Instrument:
    """An :class:`Instrument` from an instance or a dict.

    A dict with a ``'preset'`` key (``'prototype'`` / ``'prototype_2003'`` or
    ``'cs'`` / ``'cs_series'``) starts from that preset and overrides the
    other keys; a dict without it is a full :meth:`Instrument.from_dict`
    (class defaults, i.e. the prototype, fill missing fields).
    """
    if isinstance(spec, Instrument):
        return spec
    if not isinstance(spec, dict):
        raise TypeError(f"instrument must be an Instrument or a dict, got {type(spec).__name__}")
    d = dict(spec)
    if "preset" in d:
        name = d.pop("preset")
        check_choice("instrument preset", name, tuple(_PRESET_ALIASES))
        return Instrument.from_dict(d, base=PRESETS[_PRESET_ALIASES[name]])
    return Instrument.from_dict(d)


@dataclasses.dataclass(frozen=True)
class StaringLidar:
    """A cw lidar staring in a fixed direction (A2012's prototype by default).

    Parameters
    ----------
    instrument : Instrument
        Acquisition and processing settings; ``instrument.focus`` is the focus
        distance r [m].  Default :data:`cwlidar_sim.signal.PROTOTYPE_2003`.
    position : tuple of 3 floats
        Telescope position (x, y, z) [m] in the field's frame.
    azimuth_deg : float
        Beam azimuth [deg] from +x (the mean wind) toward +y; finite.
    elevation_deg : float
        Beam elevation above the horizontal [deg]; in [-90, 90].
    tier : {'los', 'spectral', 'signal'}
        Simulation tier (module notes).
    weighting : {'exact', 'lorentzian'}
        Probe-volume weighting (A2012 Eq. 3 as corrected in
        :mod:`cwlidar_sim.beam.optics`, or Eq. 4).
    span : float
        Half-width of the kept span in Rayleigh lengths [-]; in (0, 1000].
    cell_length : float
        Target length of a range cell [m]; in (0, 1000].  The span is cut into
        ``ceil(span length / cell_length)`` equal cells.
    cnr_db : float
        Wideband carrier-to-noise ratio [dB] (signal over noise power in
        0..f_s/2, :mod:`cwlidar_sim.signal.spectral`); in [-200, 200].
        Default -10 dB (module notes).
    transverse_speed : float or None
        Aerosol speed across the beam [m/s], in [0, 1000]; sets the speckle
        correlation time ``w0 / v_perp``.  None: from the field (module notes).
    speckle : {'continuum', 'independent', 'coherent'}
        Speckle model (module notes): 'continuum' (cells are continua of
        scatterers with the sub-cell spread, both tiers), or tier 2's gain
        per bin ('independent') or per estimate ('coherent') of point cells.
    exact_background : bool
        Use the exact noise floor instead of a background measured over
        ``instrument.background_blocks`` signal-free blocks.
    subcell_spread : float or None
        Standard deviation of the scatterers' speeds about their cell's speed
        [m/s], in [0, 100]; None: from the field's tensor (module notes).
    cnr_variation_db : float
        Standard deviation of the CNR over a record [dB], in [0, 20] (0:
        constant): the aerosol load varies as a stationary Gauss-Markov
        process in dB (:func:`cnr_series`).  Tier 2 only.
    cnr_time_scale : float
        Correlation time of that variation [s]; in (0, 1e6].
    """

    instrument: Instrument = PROTOTYPE_2003
    position: tuple = (0.0, 0.0, 0.0)
    azimuth_deg: float = 0.0
    elevation_deg: float = 0.0
    tier: str = "spectral"
    weighting: str = "exact"
    span: float = 20.0
    cell_length: float = 0.5
    cnr_db: float = -10.0
    transverse_speed: float | None = None
    speckle: str = "continuum"
    exact_background: bool = False
    subcell_spread: float | None = None
    cnr_variation_db: float = 0.0
    cnr_time_scale: float = 600.0

    def __post_init__(self):
        def put(k, v):
            object.__setattr__(self, k, v)

        if not isinstance(self.instrument, Instrument):
            raise TypeError(f"instrument must be an Instrument, got {type(self.instrument).__name__} "
                            "(use StaringLidar.from_dict for a dict)")
        put("position", check_tuple("position", self.position, 3, check_real))
        put("azimuth_deg", check_real("azimuth_deg", self.azimuth_deg))
        put("elevation_deg", check_real("elevation_deg", self.elevation_deg, lo=-90.0, hi=90.0))
        check_choice("tier", self.tier, TIERS)
        check_choice("weighting", self.weighting, ("exact", "lorentzian"))
        put("span", check_real("span", self.span, lo=0.0, hi=1000.0, lo_open=True))
        put("cell_length", check_real("cell_length", self.cell_length, lo=0.0, hi=1000.0, lo_open=True))
        put("cnr_db", check_real("cnr_db", self.cnr_db, lo=-200.0, hi=200.0))
        if self.transverse_speed is not None:
            put("transverse_speed", check_real("transverse_speed", self.transverse_speed, lo=0.0, hi=1000.0))
        check_choice("speckle", self.speckle, SPECKLE_MODELS)
        put("exact_background", _check_bool("exact_background", self.exact_background))
        if self.subcell_spread is not None:
            put("subcell_spread", check_real("subcell_spread", self.subcell_spread, lo=0.0, hi=100.0))
        put("cnr_variation_db", check_real("cnr_variation_db", self.cnr_variation_db, lo=0.0, hi=20.0))
        put("cnr_time_scale", check_real("cnr_time_scale", self.cnr_time_scale, lo=0.0, hi=1e6, lo_open=True))
        if self.cnr_variation_db > 0.0 and self.tier == "signal":
            raise ValueError("cnr_variation_db > 0 is available in tiers 'los' and 'spectral'; allowed with "
                             "tier 'signal': 0")
        check_int("number of range cells", self.n_cells, lo=1, hi=100_000)

    # -- interchange -----------------------------------------------------
    def as_dict(self) -> dict:
        """Plain dict of the fields, the instrument as its full field dict (round-trips through :meth:`from_dict`)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["instrument"] = self.instrument.as_dict()
        d["position"] = tuple(self.position)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "StaringLidar":
        """Build from a mapping; unknown keys are rejected by name.

        ``instrument`` may be an :class:`Instrument`, a full field dict, or a
        dict of overrides on a preset, e.g.
        ``{'preset': 'prototype_2003', 'threshold_raise_percent': 10}``.
        """
        check_keys(cls, d)
        d = dict(d)
        if "instrument" in d:
            d["instrument"] = instrument_from_spec(d["instrument"])
        return cls(**d)

    def replace(self, **changes) -> "StaringLidar":
        """Copy with some fields changed (validated); unknown names are rejected."""
        check_keys(type(self), changes)
        return dataclasses.replace(self, **changes)

    # -- derived ---------------------------------------------------------
    @property
    def direction(self) -> np.ndarray:
        """Unit beam direction n, shape (3,) [-]."""
        from ..beam.sampling import direction_from_angles

        return direction_from_angles(self.azimuth_deg, self.elevation_deg)

    def _span_limits(self):
        zr = self.instrument.rayleigh_length
        half = self.span * zr
        return max(-half, -self.instrument.focus), half

    @property
    def n_cells(self) -> int:
        """Number of range cells, ``ceil(span length / cell_length)``."""
        lo, hi = self._span_limits()
        return max(1, int(math.ceil((hi - lo) / self.cell_length - 1e-9)))

    def cells(self):
        """Range cells and renormalised weights (:class:`cwlidar_sim.beam.RangeCells`)."""
        from ..beam.optics import weight_truncated

        return weight_truncated(self.instrument.optics(), self.weighting, span=self.span, n_cells=self.n_cells,
                                renormalise=True)


@dataclasses.dataclass(frozen=True)
class LidarRecord:
    """Output of :func:`measure_staring`.

    Attributes
    ----------
    time_e : ndarray, float64, shape (n_e,)
        Estimate (mid-)times [s].
    vlos_e : ndarray, float64, shape (n_e,)
        Tier-1 probe-volume weighted line-of-sight speed of the total wind
        [m/s], signed (positive away from the lidar): the ideal.
    speed_e : ndarray, float64, shape (n_e,)
        The instrument's speed estimate |v| [m/s] (>= 0); NaN where the
        processing failed.
    flags_e : ndarray, uint8, shape (n_e,)
        :class:`cwlidar_sim.signal.Flag` bit fields.
    variants : dict
        Variant name -> ``(speed_e, flags_e)`` from the same spectra processed
        with that variant's overrides.
    availability : float
        Fraction of finite ``speed_e`` [-].
    info : dict
        Run information: ``tier``, ``n_estimates``, ``n_cells``,
        ``cell_length`` [m], ``span``, ``weighting``, ``kept_fraction``,
        ``truncated_fraction``, ``rayleigh_length`` [m], ``focus`` [m],
        ``direction``, ``cnr_db``, ``transverse_speed`` [m/s] and its
        ``transverse_speed_source``, ``correlation_time`` [s], ``m_eff``,
        ``speckle`` (the model used), ``subcell_spread`` [m/s] and its
        ``subcell_spread_source``, ``background``, ``estimator``, ``flag_counts``,
        ``variant_availability``.
    """

    time_e: np.ndarray
    vlos_e: np.ndarray
    speed_e: np.ndarray
    flags_e: np.ndarray
    variants: dict
    availability: float
    info: dict


# ---------------------------------------------------------------------------
# tier-2 expected spectrum
# ---------------------------------------------------------------------------
def _lag_coefficients(n_fft: int, window: str, rho: float) -> np.ndarray:
    """a_d = R_w(d) rho^d / R_w(0), d = 0..N-1 (read-only; :func:`cwlidar_sim.signal.spectral.lag_coefficients`)."""
    from ..signal.spectral import lag_coefficients

    return lag_coefficients(n_fft, window, rho)


def _rho(instrument, correlation_time):
    return 1.0 if math.isinf(correlation_time) else math.exp(-1.0 / (instrument.sample_rate * correlation_time))


def _signal_rows(instrument, vlos_es, amp_s, a_d):
    """Expected signal periodogram rows (exact) from cell speeds [m/s] and amplitudes CNR w_s / 2."""
    from . import _kernels as K
    from .._config import apply_numba_threads
    from .._fft import rfft_rows

    x = np.ascontiguousarray(vlos_es / instrument.bin_speed)
    lags = np.empty((x.shape[0], instrument.n_fft))
    apply_numba_threads()
    K.lag_sequence_kernel(x, amp_s, a_d, lags)
    sig = np.ascontiguousarray(rfft_rows(lags).real)
    np.maximum(sig, 0.0, out=sig)
    return sig


def expected_spectrum_exact(instrument, vlos_es, weight_s, cnr_db: float, *, correlation_time: float = math.inf):
    """Expected averaged spectrum of each estimate, exact (no line-shape table).

    Same model, arguments and returns as
    :func:`cwlidar_sim.signal.expected_spectrum`, computed by the lag sum of
    the module notes: ``O(N n_cells + N log N)`` per estimate.

    Parameters
    ----------
    instrument : Instrument
    vlos_es : array_like, shape (n_estimates, n_cells) or (n_cells,)
        Radial speed of each cell during each estimate [m/s] (signed).
    weight_s : array_like, shape (n_cells,)
        Beam weights [-], >= 0, summing to a value in (0, 1].
    cnr_db : float
        Wideband carrier-to-noise ratio [dB].
    correlation_time : float
        Speckle correlation time tau_c [s]; > 0 or inf (frozen).

    Returns
    -------
    signal_ef : ndarray, shape (n_estimates, N/2 + 1)
        Expected signal part of the averaged periodogram, one-sided bins
        k = 0..N/2, each ``|X_k|^2 / sum w_n^2`` (module convention of
        :mod:`cwlidar_sim.signal.processing`) [units of the noise floor].
    noise_f : ndarray, shape (N/2 + 1,)
        Expected noise floor [-].
    """
    from ..signal.processing import noise_floor
    from ..signal.spectral import _as_2d, _weights, cnr_linear

    if not isinstance(instrument, Instrument):
        raise TypeError(f"instrument must be an Instrument, got {type(instrument).__name__}")
    v = _as_2d("vlos_es", vlos_es)
    w = _weights(weight_s, v.shape[1])
    cnr = cnr_linear(cnr_db)
    tau = _check_tau(correlation_time)
    a_d = _lag_coefficients(instrument.n_fft, instrument.window, _rho(instrument, tau))
    return _signal_rows(instrument, v, 0.5 * cnr * w, a_d), noise_floor(instrument)


def _check_tau(correlation_time):
    if isinstance(correlation_time, float) and math.isinf(correlation_time) and correlation_time > 0:
        return math.inf
    return check_real("correlation_time", correlation_time, lo=0.0, lo_open=True)


class _SpeckleBlocks:
    """Speckle gains and normal-stream keys of tier 2 in fixed blocks of DRAW_BLOCK estimates."""

    def __init__(self, seq: np.random.SeedSequence, nf: int, m_eff: float, speckle: str):
        self.seq, self.nf, self.m_eff, self.speckle = seq, nf, m_eff, speckle
        self._b = -1
        self._cached = None

    def _block(self, b):
        if b != self._b:
            from ..signal.spectral import _speckle_draws

            child = np.random.SeedSequence(self.seq.entropy, spawn_key=tuple(self.seq.spawn_key) + (b,))
            # always a whole block: the draws do not depend on the record length
            self._cached = _speckle_draws(np.random.default_rng(child), DRAW_BLOCK, self.nf, self.m_eff, self.speckle)
            self._b = b
        return self._cached

    def pieces(self, e0, e1):
        """(lo, hi, key, gain rows lo..hi-1) covering estimates e0..e1-1."""
        for b in range(e0 // DRAW_BLOCK, (e1 - 1) // DRAW_BLOCK + 1):
            key, gain = self._block(b)
            lo, hi = max(e0, b * DRAW_BLOCK), min(e1, (b + 1) * DRAW_BLOCK)
            yield lo, hi, key, gain[lo - b * DRAW_BLOCK: hi - b * DRAW_BLOCK]


# ---------------------------------------------------------------------------
# measurement
# ---------------------------------------------------------------------------
def _variant_instruments(instrument, variants):
    if variants is None:
        return []
    if not isinstance(variants, (list, tuple)):
        raise TypeError(f"variants must be a list of dicts, got {type(variants).__name__}")
    out, names = [], set()
    for i, v in enumerate(variants):
        if not isinstance(v, dict):
            raise TypeError(f"variants[{i}] must be a dict, got {type(v).__name__}")
        name = v.get("name")
        if not isinstance(name, str) or not name:
            raise ValueError(f"variants[{i}] needs a non-empty str 'name', got {name!r}")
        if name in names:
            raise ValueError(f"variants[{i}]: duplicate name {name!r}")
        names.add(name)
        over = {k: val for k, val in v.items() if k != "name"}
        bad = sorted(set(over) - set(VARIANT_KEYS))
        if bad:
            raise ValueError(f"variants[{i}] ({name!r}): key(s) {bad} would change the spectra; "
                             f"allowed: {list(VARIANT_KEYS)}")
        out.append((name, instrument.replace(**over)))
    return out


def field_subcell_spread(field):
    """Sub-cell speed spread [m/s] from a field's Mann parameters and spacing (attributes), or None.

    ``sqrt(subcell_variance(params, dx))`` (:func:`cwlidar_sim.turbulence.subcell_variance`)
    with the field's ``dx`` (or its x spacing); None when the field does not
    carry ``alpha_eps``, ``length_scale`` and ``gamma``.
    """
    attrs = getattr(field, "attrs", {}) or {}
    if not all(k in attrs for k in ("alpha_eps", "length_scale", "gamma")):
        return None
    from ..turbulence import MannParameters, subcell_variance

    params = MannParameters(float(attrs["alpha_eps"]), float(attrs["length_scale"]), float(attrs["gamma"]))
    if "dx" in attrs:
        dx = float(attrs["dx"])
    else:
        x = np.asarray(field["x"].values, dtype=np.float64)
        dx = float(x[1] - x[0])
    return math.sqrt(subcell_variance(params, dx))


def cnr_series(time_e, std_db: float, time_scale: float, seed) -> np.ndarray:
    """CNR offsets [dB] at the estimate times: a stationary Gauss-Markov process.

    ``x_0 ~ N(0, std^2)``, ``x_{e+1} = r x_e + sqrt(1 - r^2) std z``,
    ``r = exp(-(t_{e+1} - t_e) / time_scale)``: correlation
    ``exp(-|dt| / time_scale)`` at any spacing of the times (sorted).
    """
    t = np.asarray(time_e, dtype=np.float64)
    std = check_real("std_db", std_db, lo=0.0, hi=20.0)
    ts = check_real("time_scale", time_scale, lo=0.0, hi=1e6, lo_open=True)
    if t.ndim != 1 or np.any(np.diff(t) < 0):
        raise ValueError("time_e must be 1-D and sorted")
    rng = np.random.default_rng(seed)
    z = rng.standard_normal(t.size)
    x = np.empty(t.size)
    if t.size:
        x[0] = std * z[0]
        r = np.exp(-np.diff(t) / ts)
        q = np.sqrt(1.0 - r * r) * std
        for e in range(1, t.size):
            x[e] = r[e - 1] * x[e - 1] + q[e - 1] * z[e]
    return x


def _seed_sequence(seed):
    if isinstance(seed, np.random.Generator):
        return np.random.SeedSequence(int(seed.integers(0, 2**63 - 1)))
    return np.random.SeedSequence(check_seed("seed", seed))


def _transverse_rms(fld, origin, n3, focus, time_e, U, wrap):
    """rms over the record of the total wind's component across the beam at the focus [m/s]."""
    from ..beam import _kernels as BK

    n_tc = np.ascontiguousarray(np.broadcast_to(n3, (time_e.size, 3)))
    vel_tsc, vlos_ts = BK.empty_outputs(time_e.size, 1)
    BK.sample_points_kernel(fld.u, fld.v, fld.w, fld.grid, wrap, wrap, origin, n_tc, np.array([focus]), time_e,
                            U, True, vel_tsc, vlos_ts)
    perp = vel_tsc[:, 0, :] - vlos_ts[:, :1] * n3[None, :]
    return float(np.sqrt(np.mean(np.sum(perp * perp, axis=1))))


def measure_staring(field, lidar: StaringLidar, times_e, U: float, seed, *, variants=None, chunk: int = 4096,
                    transverse_speed: float | None = None, wrap: bool = False,
                    calibration_time: float = 0.0) -> LidarRecord:
    """Simulate a staring lidar's record of speed estimates in a turbulence field.

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line field (see :func:`cwlidar_sim.beam.sample_los`);
        u, v, w are fluctuations [m/s], the mean ``U`` is added to u.
    lidar : StaringLidar
    times_e : array_like, shape (n_e,)
        Estimate mid-times [s] (e.g. ``arange(n) / instrument.estimate_rate``).
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u).
    seed : int or numpy.random.Generator
        Randomness of tiers 'spectral' and 'signal' (background and
        speckle/noise); ignored (may be None) for tier 'los'.
    variants : list of dict, optional
        Extra processing of the same spectra: each dict has a ``'name'`` and
        overrides of :data:`VARIANT_KEYS`, e.g.
        ``{'name': 'raise10', 'threshold_raise_percent': 10}`` or
        ``{'name': 'peak', 'estimator': 'peak'}``.  Tier 'los' has no
        processing: every variant equals the base.
    chunk : int
        Estimates processed at a time (memory only; the result does not
        depend on it); in [1, 10**6].
    transverse_speed : float, optional
        Overrides ``lidar.transverse_speed`` [m/s].
    wrap : bool
        Treat y and z as periodic (see :func:`cwlidar_sim.beam.sample_los`).
    calibration_time : float
        Time of ``times_e = 0`` on the background-calibration clock [s]
        (:func:`cwlidar_sim.signal.processing.background_gain`: the gain
        mismatch and drift of ``instrument.background_*``); e.g. a campaign
        period's start.

    Returns
    -------
    LidarRecord
    """
    from .._config import apply_numba_threads
    from ..beam.sampling import _check_extent, _check_flag, _prepare_beam, _prepare_field
    from ..signal.processing import FAIL_FLAGS, Flag, background_gain, background_spectrum, estimate, noise_floor
    from ..signal.spectral import line_shape_table, speckle_looks
    from . import _kernels as K

    if not isinstance(lidar, StaringLidar):
        raise TypeError(f"lidar must be a StaringLidar, got {type(lidar).__name__}")
    inst = lidar.instrument
    U = check_real("U", U)
    chunk = check_int("chunk", chunk, lo=1, hi=10**6)
    wrap = _check_flag("wrap", wrap)
    procs = [("", inst)] + _variant_instruments(inst, variants)
    cells = lidar.cells()
    w_s = np.ascontiguousarray(cells.weight_s, dtype=np.float64)
    range_s = np.maximum(inst.focus + cells.s_s, 0.0)
    n3 = np.ascontiguousarray(lidar.direction, dtype=np.float64)
    origin, _, time_e, range_s = _prepare_beam(lidar.position, n3, times_e, range_s)
    time_e = np.ascontiguousarray(time_e, dtype=np.float64)
    fld = _prepare_field(field, origin)
    _check_extent(fld, origin, n3[None, :], range_s, wrap, 1e-6)
    ne, ns = time_e.size, w_s.size
    if lidar.tier == "signal" and ne > SIGNAL_MAX_ESTIMATES:
        raise ValueError(f"tier 'signal' synthesises the {inst.sample_rate:g} Hz signal of every cell: "
                         f"n_e={ne} estimates is too many; allowed: <= {SIGNAL_MAX_ESTIMATES} "
                         "(use tier 'spectral' for long records)")
    if lidar.tier != "los":
        ss = _seed_sequence(seed)
    rows = ne if lidar.tier == "signal" else min(ne, chunk)
    check_memory("measure_staring buffers", rows * (8 * ns + 48 * inst.n_fft) + 64 * ne)
    info = {
        "tier": lidar.tier, "n_estimates": ne, "n_cells": ns,
        "cell_length": float(cells.edges[1] - cells.edges[0]), "span": lidar.span, "weighting": lidar.weighting,
        "kept_fraction": cells.kept_fraction, "truncated_fraction": cells.truncated_fraction,
        "rayleigh_length": inst.rayleigh_length, "focus": inst.focus, "direction": tuple(float(c) for c in n3),
        "cnr_db": lidar.cnr_db, "estimator": inst.estimator if lidar.tier != "los" else "los",
    }
    apply_numba_threads()

    def sample_cells(e0, e1, buf):
        vl = np.empty(e1 - e0)
        K.los_cells_kernel(fld.u, fld.v, fld.w, fld.grid, wrap, wrap, origin, n3, range_s, w_s, time_e[e0:e1], U,
                           True, buf[: e1 - e0], vl)
        return buf[: e1 - e0], vl

    vlos_e = np.empty(ne)
    if lidar.tier == "los":
        buf = np.empty((min(ne, chunk), ns))
        for e0 in range(0, ne, chunk):
            e1 = min(ne, e0 + chunk)
            _, vlos_e[e0:e1] = sample_cells(e0, e1, buf)
        speed = np.abs(vlos_e)
        flags = np.zeros(ne, dtype=np.uint8)
        var = {name: (speed.copy(), flags.copy()) for name, _ in procs[1:]}
        info.update(transverse_speed=None, transverse_speed_source=None, correlation_time=None, m_eff=None,
                    speckle=None, subcell_spread=None, subcell_spread_source=None, background=None,
                    flag_counts={f.name: 0 for f in Flag},
                    variant_availability={name: 1.0 for name in var},
                    note="tier 'los' is the ideal weighted line-of-sight average; speed_e = |vlos_e|")
        return LidarRecord(time_e=time_e, vlos_e=vlos_e, speed_e=speed, flags_e=flags, variants=var,
                           availability=1.0, info=info)

    # speckle correlation time from the aerosols' speed across the beam
    if transverse_speed is not None:
        vt, src = check_real("transverse_speed", transverse_speed, lo=0.0, hi=1000.0), "argument"
    elif lidar.transverse_speed is not None:
        vt, src = lidar.transverse_speed, "lidar"
    else:
        vt, src = _transverse_rms(fld, origin, n3, inst.focus, time_e, U, wrap), "field rms at the focus"
    tau = inst.speckle_time(vt)
    m_eff = speckle_looks(inst.blocks_per_estimate, inst.block_duration, tau)
    if lidar.subcell_spread is not None:
        spread, spread_src = lidar.subcell_spread, "lidar"
    else:
        spread = field_subcell_spread(field)
        spread_src = "field tensor" if spread is not None else "none (field has no Mann parameters)"
        spread = spread or 0.0
    speckle = lidar.speckle
    if speckle != "continuum":
        spread, spread_src = 0.0, f"not used by speckle {speckle!r}"
    elif spread == 0.0:
        speckle = "independent"
    s_bg, s_sim = ss.spawn(2)
    cnr_gain_e = None
    if lidar.cnr_variation_db > 0.0:
        (s_cnr,) = ss.spawn(1)
        cnr_gain_e = 10.0 ** (cnr_series(time_e, lidar.cnr_variation_db, lidar.cnr_time_scale, s_cnr) / 10.0)
    bg = None if lidar.exact_background else background_spectrum(inst, np.random.default_rng(s_bg))
    table = line_shape_table(inst.n_fft, inst.window)
    cnr = 10.0 ** (lidar.cnr_db / 10.0)
    amp_s = 0.5 * cnr * w_s
    out = {name: (np.empty(ne), np.empty(ne, dtype=np.uint8)) for name, _ in procs}

    gain_e = None
    if inst.background_mismatch != 0.0 or inst.background_drift != 0.0:
        gain_e = background_gain(inst, time_e + check_real("calibration_time", calibration_time))

    def process(e0, e1, spec):
        if gain_e is not None:
            spec = spec * gain_e[e0:e1, None]
        for name, pinst in procs:
            est = estimate(spec, pinst, bg, line_table=table)
            out[name][0][e0:e1] = est.speed_e
            out[name][1][e0:e1] = est.flags_e

    if lidar.tier == "spectral" and speckle == "continuum":
        from ..signal.spectral import continuum_moments, sample_moments

        key = np.uint64(int(np.random.default_rng(s_sim).integers(0, 2**63, dtype=np.int64)))
        buf = np.empty((min(ne, chunk), ns))
        for c0 in range(0, ne, chunk):
            c1 = min(ne, c0 + chunk)
            vlos_es, vlos_e[c0:c1] = sample_cells(c0, c1, buf)
            mean, var, _ = continuum_moments(inst, vlos_es, w_s, lidar.cnr_db, spread, correlation_time=tau,
                                             cnr_gain_e=None if cnr_gain_e is None else cnr_gain_e[c0:c1])
            process(c0, c1, sample_moments(mean, var, key, e0=c0))
    elif lidar.tier == "spectral":
        a_d = _lag_coefficients(inst.n_fft, inst.window, _rho(inst, tau))
        noise = noise_floor(inst)
        draws = _SpeckleBlocks(s_sim, inst.n_bins, m_eff, speckle)
        from ..signal.spectral import _draw_rows

        buf = np.empty((min(ne, chunk), ns))
        spec_buf = np.empty((min(ne, chunk), inst.n_bins))
        for c0 in range(0, ne, chunk):
            c1 = min(ne, c0 + chunk)
            vlos_es, vlos_e[c0:c1] = sample_cells(c0, c1, buf)
            sig = _signal_rows(inst, vlos_es, amp_s, a_d)
            if cnr_gain_e is not None:
                sig *= cnr_gain_e[c0:c1, None]
            spec = spec_buf[: c1 - c0]
            for lo, hi, key, gain in draws.pieces(c0, c1):
                _draw_rows(sig[lo - c0: hi - c0], noise, inst.blocks_per_estimate, gain, key, lo,
                           spec[lo - c0: hi - c0])
            process(c0, c1, spec)
    else:
        from ..signal.heterodyne import simulate_signal_spectra

        vlos_es, vlos_e[:] = sample_cells(0, ne, np.empty((ne, ns)))
        spec = simulate_signal_spectra(inst, vlos_es, w_s, lidar.cnr_db, np.random.default_rng(s_sim),
                                       correlation_time=tau, speed_spread=spread if speckle == "continuum" else 0.0)
        process(0, ne, spec)

    speed, flags = out.pop("")
    avail = float(np.mean(np.isfinite(speed)))
    info.update(transverse_speed=vt, transverse_speed_source=src, correlation_time=tau, m_eff=m_eff,
                speckle=(speckle if lidar.tier == "spectral" or speckle == "continuum"
                         else "tier 3 (AR(1) per cell)"),
                subcell_spread=spread, subcell_spread_source=spread_src,
                background_gain=None if gain_e is None else (float(gain_e.min()), float(gain_e.max())),
                cnr_db_range=None if cnr_gain_e is None else (lidar.cnr_db + 10 * math.log10(cnr_gain_e.min()),
                                                             lidar.cnr_db + 10 * math.log10(cnr_gain_e.max())),
                background="exact" if lidar.exact_background else f"measured ({inst.background_blocks} blocks)",
                flag_counts={f.name: int(np.count_nonzero(flags & f.value)) for f in Flag},
                n_failed=int(np.count_nonzero(flags & int(FAIL_FLAGS))),
                variant_availability={name: float(np.mean(np.isfinite(s))) for name, (s, _) in out.items()})
    return LidarRecord(time_e=time_e, vlos_e=vlos_e, speed_e=speed, flags_e=flags, variants=out,
                       availability=avail, info=info)
