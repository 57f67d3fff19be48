"""The signal chain: one entry point that every lidar feeds.

A sensor is geometry: where its beam points and focuses, when (its schedule,
the sweep within a dwell), which range cells with which weights.  It samples
the field into the structure below and hands it to :func:`run_chain`, which
does everything else, the same way for every sensor.

What a sensor hands over
------------------------
Estimates come in :class:`FocusGroup` s: the estimates that share one focus
(one instrument, one set of cells; a staring lidar has one group, a lidar
cycling through heights or focus distances one per focus).  For each
estimate ``e`` of a group the chain asks the sensor, a chunk at a time, for

* ``vlos_els[e, l, s]``: the signed line-of-sight speed [m/s] of aerosol
  cell ``s`` in look ``l`` (looks are equal sub-intervals of the estimate's
  dwell, e.g. a scanning beam's sweep; one look for a staring beam), the
  cells' weights ``weight_s`` summing to 1; the weight beyond the simulated
  span is the last cell (``tail = True``), which sees the mean wind
  (:mod:`cwlidar_sim.beam.cells`);
* ``vlos_e[e]``: the ideal, the mean over looks of the weighted sum (tier 1,
  A2012 Eq. 2);
* optionally ``cloud_el[e, l]``: the radial speed of a cloud layer in each
  look [m/s], carrying ``cloud_weight`` relative to the aerosol's unit weight.

Tiers
-----
``los`` (1)
    ``speed_e = |mix_e|`` with ``mix_e = (vlos_e + w_c cloud_e) / (1 + w_c)``
    the power-weighted mean of aerosol and cloud (signed), and the
    instrument's folding rules as flags: below ``blind_zone_speed`` NaN
    flagged ``NO_SIGNAL | NEAR_ZERO``, within ``edge_guard_speed`` above it
    ``NEAR_ZERO``, near Nyquist ``NEAR_NYQUIST`` (:func:`homodyne_flags`).
``spectral`` (2)
    The expected averaged periodogram of every estimate from all its looks
    and cells, its speckle and noise statistics, a measured background and
    :func:`cwlidar_sim.signal.estimate`.  Speckle models: 'continuum' (cells
    are continua of scatterers with the sub-cell speed spread: each look's
    bins' exact mean and variance, :func:`cwlidar_sim.signal.spectral.continuum_moments`,
    the looks' M / n_looks-block averages combined as independent; falls back to
    'independent' without a spread), 'independent' (one Gamma(M_eff) gain per
    bin, :func:`cwlidar_sim.signal.sample_spectra`) and 'coherent' (one per
    estimate); the looks' cells enter the point-cell models with weight
    ``w_s / n_looks`` each.
``signal`` (3)
    The heterodyne signal (:func:`cwlidar_sim.signal.simulate_signal_spectra`)
    of each look in turn (``blocks_per_estimate / n_looks`` blocks per look,
    speckle and Doppler phase continuous from look to look), the looks'
    periodograms averaged; then the same processing.  At most
    :data:`SIGNAL_MAX_ESTIMATES` estimates (200 s at 50 Hz).

The tail cell in the spectrum
-----------------------------
The weight beyond the span lies far from the focus, in air decorrelated
from the probe volume's core: it sees the mean wind *on average* (tier 1
adds ``tail_weight * n . U``), and its Doppler spectrum is the turbulence's
whole distribution of line-of-sight speeds about the mean, a pedestal
``~ 6 sigma_los`` wide carrying ``tail_weight`` of the power, far below the
threshold of any bin.  Tiers 2 and 3 therefore leave it out of the spectrum
(the other cells keep their weights, so the lines' power is the core's);
modelling it as one cell at the mean wind would put a narrow line of
``tail_weight`` of the power at the mean speed and pull every estimate
toward it.  The pedestal's own power, left out, is below
``tail_weight CNR N / (2 n_bins)`` per bin (0.04 of the noise floor for the
CS lidar at 40 m with span 5, 0.002 for A2012's prototype at span 20).

The speckle correlation time is the transit time across the waist,
``w0 / v_perp`` (:meth:`Instrument.speckle_time`), ``v_perp`` the speed of
the focal spot relative to the aerosols (a sensor's ``transverse_speed``:
the wind across a staring beam, the spot's own speed for a scanning one).

Instrument effects, every tier where they apply: a cloud (its power added to
the CNR, ``cnr_db + 10 log10(1 + w_c)``, ``cnr_db`` staying the aerosol's),
the CNR varying over a record (a Gauss-Markov process in dB,
:func:`cnr_series`; tiers 1 and 2), the background's gain mismatch and drift
on the calibration clock (:func:`cwlidar_sim.signal.processing.background_gain`),
the pauses for the background measurement (NaN flagged ``PAUSED``), and
processing variants (other thresholds or estimators applied to the same
spectra: :data:`VARIANT_KEYS`).

Randomness (one rule for every sensor)
--------------------------------------
A group draws from one ``SeedSequence``, by one rule for every sensor
(``cwlidar_sim._seeding.focus_seeds``): a sensor with a focus list (the
conical lidar's heights, the nacelle lidar's focus distances, a list of one
included) passes the record root's children in list order; a sensor with
one fixed focus (the staring lidar) passes the root.  It spawns the background measurement and the simulation, then
(with a CNR variation) the variation's stream.  Tier 2's speckle gains come
in fixed blocks of :data:`DRAW_BLOCK` estimates, block ``b`` from the child
``SeedSequence`` with spawn key ``(..., b)``, the per-bin normals from the
counter-based stream of the estimate's index within the group; tier 3 draws
from the simulation stream.  Every kernel sums in a fixed order, so the
result is the same, bit for bit, for any ``chunk`` and any thread count.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from .._lidar_fields import LidarFields
from .._repr import summary_repr
from .._validation import check_bool, check_choice, check_int, check_memory, check_real
from .instrument import Instrument
from .processing import FAIL_FLAGS, Flag, background_gain, background_spectrum, estimate_variants, usable_fraction
from .spectral import _draw_rows, _speckle_draws, continuum_moments, line_shape_table, sample_moments, speckle_looks
from .exact import ar1_rho, signal_rows
from .noise import lag_coefficients, noise_floor

__all__ = [
    "ChainSettings",
    "FocusGroup",
    "ChainRecord",
    "run_chain",
    "homodyne_flags",
    "variant_instruments",
    "cnr_series",
    "pause_mask",
    "TIERS",
    "SPECKLE_MODELS",
    "VARIANT_KEYS",
    "SIGNAL_MAX_ESTIMATES",
    "DRAW_BLOCK",
    "CNR_DB_RANGE",
]

#: Fidelity tiers (module notes).
TIERS = ("los", "spectral", "signal")
#: Speckle models of tiers 2 and 3 (module notes).
SPECKLE_MODELS = ("continuum", "independent", "coherent")
#: Instrument fields a processing variant may override: they act on the spectra only.
VARIANT_KEYS = ("estimator", "threshold_kind", "threshold_value", "threshold_raise_percent",
                "threshold_raise_reading", "blind_zone_speed", "edge_guard_speed", "second_peak_fraction")
#: Longest record of tier 'signal' [estimates] (200 s at 50 Hz: a guard against hours of 50 MHz synthesis).
SIGNAL_MAX_ESTIMATES = 10_000
#: Estimates per block of speckle gains (fixed, so the draws do not depend on any chunking).
DRAW_BLOCK = 4096
#: Allowed wideband carrier-to-noise ratio [dB], for every sensor and scene.
CNR_DB_RANGE = (-100.0, 100.0)


@dataclasses.dataclass(frozen=True)
class ChainSettings:
    """What a lidar's signal chain does, the same for every sensor.

    Its fields are a lidar's (their defaults declared once, in
    ``cwlidar_sim._lidar_fields.LidarFields``); this class validates them for the chain.

    Parameters
    ----------
    tier : {'los', 'spectral', 'signal'}
        Fidelity tier (module notes).
    cnr_db : float
        Wideband carrier-to-noise ratio of the aerosol [dB] (signal over
        noise power in 0..f_s/2, :mod:`cwlidar_sim.signal.spectral`); in
        :data:`CNR_DB_RANGE`.
    speckle : {'continuum', 'independent', 'coherent'}
        Speckle model of tiers 2 and 3.
    exact_background : bool
        Use the exact noise floor instead of a background measured over
        ``instrument.background_blocks`` signal-free blocks.
    cnr_variation_db : float
        Standard deviation of the CNR over a record [dB], in [0, 20] (0:
        constant); tiers 'los' (no effect) and 'spectral'.
    cnr_time_scale : float
        Correlation time of that variation [s]; in (0, 1e6].
    background_pause : bool
        Stop for the background measurement on the instrument's calibration
        schedule (``background_interval``, ``background_duration``; A2012:
        10 min every 3 h): estimates inside a pause are NaN flagged ``PAUSED``.
    line_broadening : float
        Instrument broadening of the Doppler line (laser line width, phase
        noise) as the standard deviation of a Gaussian in frequency [Hz]; in
        [0, 5e6].  It acts exactly like a sub-cell speed spread of
        ``lambda / 2`` times it, added in quadrature to the cells' (continuum
        speckle, tiers 2 and 3).
    """

    tier: str = LidarFields.tier
    cnr_db: float = LidarFields.cnr_db
    speckle: str = LidarFields.speckle
    exact_background: bool = LidarFields.exact_background
    cnr_variation_db: float = LidarFields.cnr_variation_db
    cnr_time_scale: float = LidarFields.cnr_time_scale
    background_pause: bool = LidarFields.background_pause
    line_broadening: float = LidarFields.line_broadening

    def __post_init__(self):
        put = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        check_choice("tier", self.tier, TIERS)
        put("cnr_db", check_real("cnr_db", self.cnr_db, lo=CNR_DB_RANGE[0], hi=CNR_DB_RANGE[1]))
        check_choice("speckle", self.speckle, SPECKLE_MODELS)
        put("exact_background", check_bool("exact_background", self.exact_background))
        put("cnr_variation_db", check_real("cnr_variation_db", self.cnr_variation_db, lo=0.0, hi=20.0))
        put("cnr_time_scale", check_real("cnr_time_scale", self.cnr_time_scale, lo=0.0, hi=1e6, lo_open=True))
        put("background_pause", check_bool("background_pause", self.background_pause))
        put("line_broadening", check_real("line_broadening", self.line_broadening, lo=0.0, hi=5e6))
        if self.cnr_variation_db > 0.0 and self.tier == "signal":
            raise ValueError("cnr_variation_db > 0 is available in tiers 'los' and 'spectral'; allowed with "
                             "tier 'signal': 0")


@dataclasses.dataclass
class FocusGroup:
    """The estimates of one focus, as a sensor hands them to the chain (module notes).

    Parameters
    ----------
    instrument : Instrument
        The instrument focused for this group.
    index_e : ndarray of int, shape (n_e,)
        Positions of the group's estimates in the record.
    time_e : ndarray, shape (n_e,)
        Their mid-times [s] (CNR variation, background drift and pauses).
    weight_s : ndarray, shape (n_s,)
        Weights of the aerosol cells [-], >= 0, summing to 1.
    n_looks : int
        Looks per estimate.
    sample : callable
        ``sample(lo, hi) -> (vlos_els, vlos_e, cloud_el)`` for the group's
        estimates ``lo .. hi - 1``: shapes ``(hi - lo, n_looks, n_s)``,
        ``(hi - lo,)`` and ``(hi - lo, n_looks)`` or None [m/s].
    tail : bool
        The last aerosol cell is the mean-wind tail (left out of the
        spectrum: module notes).
    seed : numpy.random.SeedSequence or None
        The group's stream (None only for tier 'los').
    transverse_speed : float
        Speed of the focal spot relative to the aerosols [m/s] (speckle time).
    subcell_spread : float
        Sub-cell speed spread [m/s] of the 'continuum' speckle (0: none).
    cloud_weight : float
        A cloud's weight relative to the aerosol probe volume [-] (0: none).
    calibration_time : float
        Time of ``time_e = 0`` on the background-calibration clock [s].
    """

    __repr__ = summary_repr

    instrument: Instrument
    index_e: np.ndarray
    time_e: np.ndarray
    weight_s: np.ndarray
    n_looks: int
    sample: Callable
    tail: bool = False
    seed: object = None
    transverse_speed: float = 0.0
    subcell_spread: float = 0.0
    cloud_weight: float = 0.0
    calibration_time: float = 0.0


@dataclasses.dataclass(frozen=True)
class ChainRecord:
    """Output of :func:`run_chain`, one entry per estimate of the record.

    Attributes
    ----------
    vlos_e : ndarray, shape (n_e,)
        The ideal (tier 1) weighted line-of-sight speed of the aerosol [m/s], signed.
    speed_e : ndarray, shape (n_e,)
        The instrument's estimate |v| [m/s]; NaN where it failed.
    flags_e : ndarray, uint8, shape (n_e,)
        :class:`cwlidar_sim.signal.Flag` bits.
    variants : dict
        Variant name -> ``(speed_e, flags_e)``, the same spectra processed otherwise.
    availability : float
        Fraction of finite ``speed_e`` [-].
    groups : list of dict
        Per group: correlation time, looks, speckle model used, sub-cell
        spread, background, CNR and background-gain ranges.
    info : dict
        ``flag_counts``, ``n_failed``, ``variant_availability``, ``tier``, ``estimator``.
    """

    __repr__ = summary_repr

    vlos_e: np.ndarray
    speed_e: np.ndarray
    flags_e: np.ndarray
    variants: dict
    availability: float
    groups: list
    info: dict


def homodyne_flags(instrument, v_e):
    """Tier 1's folding and low-frequency cut (module notes): ``(speed_e, flags_e)``."""
    speed = np.abs(v_e)
    flags = np.zeros(np.shape(v_e), dtype=np.uint8)
    low = speed < instrument.blind_zone_speed
    near = speed < instrument.blind_zone_speed + instrument.edge_guard_speed
    nyq = speed > instrument.nyquist_speed - instrument.edge_guard_speed
    flags[near] |= np.uint8(Flag.NEAR_ZERO)
    flags[low] |= np.uint8(Flag.NO_SIGNAL)
    flags[nyq] |= np.uint8(Flag.NEAR_NYQUIST)
    return np.where(low, np.nan, speed), flags


def variant_instruments(instrument, variants):
    """``[(name, instrument with the variant's overrides)]``; only :data:`VARIANT_KEYS` may change."""
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


def pause_mask(instrument, time_e, calibration_time: float = 0.0) -> np.ndarray:
    """True for estimates inside the background measurement's pauses (the instrument's calibration schedule)."""
    t = calibration_time + np.asarray(time_e, dtype=np.float64)
    return np.mod(t, instrument.background_interval) < instrument.background_duration


class SpeckleBlocks:
    """Speckle gains and normal-stream keys of tier 2 in fixed blocks of :data:`DRAW_BLOCK` estimates."""

    def __init__(self, seq: np.random.SeedSequence, nf: int, m_eff: float, speckle: str):
        self.seq, self.nf, self.m_eff, self.speckle = seq, nf, m_eff, speckle
        self._b = -1
        self._cached = None

    def _block(self, b):
        if b != self._b:
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


def _with_cloud(vlos_els, cloud_el, weight_s, wc, tail):
    """The spectrum's cells: the tail left out (module notes), the cloud one more cell of every look.

    With a cloud, the weights are divided by ``1 + w_c`` and the CNR raised by ``10 log10(1 + w_c)``.
    """
    if tail:
        vlos_els, weight_s = vlos_els[:, :, :-1], weight_s[:-1]
    if cloud_el is None or wc == 0.0:
        return vlos_els, weight_s
    v = np.concatenate([vlos_els, cloud_el[:, :, None]], axis=2)
    return np.ascontiguousarray(v), np.append(weight_s, wc) / (1.0 + wc)


def _flat(vlos_els, w_s):
    """The looks' cells as one set of cells of weight ``w_s / n_looks``."""
    ne, nl, ns = vlos_els.shape
    if nl == 1:
        return np.ascontiguousarray(vlos_els[:, 0, :]), w_s
    return np.ascontiguousarray(vlos_els.reshape(ne, nl * ns)), np.tile(w_s, nl) / nl


class _Group:
    """One group's run through tiers 2 and 3."""

    def __init__(self, settings: ChainSettings, g: FocusGroup, procs, out, speckle_used, spread):
        self.s, self.g, self.procs, self.out = settings, g, procs, out
        inst = g.instrument
        self.inst = inst
        self.tau = inst.speckle_time(g.transverse_speed)
        self.m_eff = speckle_looks(inst.blocks_per_estimate, inst.block_duration, self.tau)
        self.speckle = speckle_used
        self.spread = spread if speckle_used == "continuum" else 0.0
        s_bg, self.s_sim = g.seed.spawn(2)
        self.cnr_gain_e = None
        if settings.cnr_variation_db > 0.0:
            (s_cnr,) = g.seed.spawn(1)
            self.cnr_gain_e = 10.0 ** (cnr_series(g.time_e, settings.cnr_variation_db, settings.cnr_time_scale,
                                                  s_cnr) / 10.0)
        self.bg = None if settings.exact_background else background_spectrum(inst, np.random.default_rng(s_bg))
        self.table = line_shape_table(inst.n_fft, inst.window)
        self.gain_e = None
        if inst.background_mismatch != 0.0 or inst.background_drift != 0.0:
            self.gain_e = background_gain(inst, g.time_e + g.calibration_time)
        self.cnr_db = settings.cnr_db
        if g.cloud_weight > 0.0:
            self.cnr_db = settings.cnr_db + 10.0 * math.log10(1.0 + g.cloud_weight)

    def process(self, e0, e1, spec):
        if self.gain_e is not None:
            spec = spec * self.gain_e[e0:e1, None]
        sel = self.g.index_e[e0:e1]
        ests = estimate_variants(spec, [pinst for _, pinst in self.procs], self.bg, line_table=self.table)
        for (name, _), est in zip(self.procs, ests):
            self.out[name][0][sel] = est.speed_e
            self.out[name][1][sel] = est.flags_e

    def continuum(self, vlos_els, w_s, e0, e1, key):
        inst, nl = self.inst, vlos_els.shape[1]
        gain = None if self.cnr_gain_e is None else self.cnr_gain_e[e0:e1]
        if nl == 1:
            mean, var, _ = continuum_moments(inst, vlos_els[:, 0, :], w_s, self.cnr_db, self.spread,
                                             correlation_time=self.tau, cnr_gain_e=gain)
        else:
            # disjoint sets of M / n_looks blocks: their averages are independent
            look = inst.replace(blocks_per_estimate=inst.blocks_per_estimate // nl)
            mean = var = 0.0
            for j in range(nl):
                m_l, v_l, _ = continuum_moments(look, vlos_els[:, j, :], w_s, self.cnr_db, self.spread,
                                                correlation_time=self.tau, cnr_gain_e=gain)
                mean = mean + m_l
                var = var + v_l
            mean, var = mean / nl, var / (nl * nl)
        self.process(e0, e1, sample_moments(mean, var, key, e0=e0))

    def point_cells(self, vlos_els, w_s, e0, e1, draws, buf):
        inst = self.inst
        v, w = _flat(vlos_els, w_s)
        a_d = lag_coefficients(inst.n_fft, inst.window, ar1_rho(inst, self.tau))
        sig = signal_rows(inst, v, 0.5 * (10.0 ** (self.cnr_db / 10.0)) * w, a_d)
        if self.cnr_gain_e is not None:
            sig *= self.cnr_gain_e[e0:e1, None]
        spec = buf[: e1 - e0]
        noise = noise_floor(inst)
        for lo, hi, key, gain in draws.pieces(e0, e1):
            _draw_rows(sig[lo - e0: hi - e0], noise, inst.blocks_per_estimate, gain, key, lo, spec[lo - e0: hi - e0])
        self.process(e0, e1, spec)

    def signal(self, vlos_els, w_s):
        from .heterodyne import simulate_signal_spectra

        inst = self.inst
        ne, nl, ns = vlos_els.shape
        rng = np.random.default_rng(self.s_sim)
        if nl == 1:
            spec = simulate_signal_spectra(inst, np.ascontiguousarray(vlos_els[:, 0, :]), w_s, self.cnr_db, rng,
                                           correlation_time=self.tau, speed_spread=self.spread)
        else:
            look = inst.replace(blocks_per_estimate=inst.blocks_per_estimate // nl,
                                estimate_rate=inst.estimate_rate * nl)
            spec_l = simulate_signal_spectra(look, np.ascontiguousarray(vlos_els.reshape(ne * nl, ns)), w_s,
                                             self.cnr_db, rng, correlation_time=self.tau, speed_spread=self.spread)
            spec = spec_l.reshape(ne, nl, -1).mean(axis=1)
        self.process(0, ne, spec)


def _spread(settings, g):
    """The continuum's speed spread [m/s]: the cells' sub-cell spread and the instrument's line broadening."""
    if settings.line_broadening == 0.0:
        return g.subcell_spread
    dv = 0.5 * g.instrument.wavelength * settings.line_broadening
    return math.sqrt(g.subcell_spread * g.subcell_spread + dv * dv)


def _speckle_used(settings, spread):
    if settings.speckle != "continuum":
        return settings.speckle
    return "continuum" if spread > 0.0 else "independent"


def run_chain(settings: ChainSettings, groups, n_estimates: int, *, variants=None, chunk: int = 4096) -> ChainRecord:
    """Run the signal chain over a record's focus groups (module notes).

    Parameters
    ----------
    settings : ChainSettings
    groups : list of FocusGroup
        Together they cover the record's estimates once.
    n_estimates : int
        Record length; in [0, 10**9].
    variants : list of dict, optional
        Extra processings of the same spectra: each a ``'name'`` and
        overrides of :data:`VARIANT_KEYS` (e.g. ``{'name': 'raise10',
        'threshold_raise_percent': 10}``).  Tier 'los' has no processing:
        every variant equals the base.
    chunk : int
        Estimates processed at a time (memory only; the result does not
        depend on it); in [1, 10**6].

    Returns
    -------
    ChainRecord
    """
    if not isinstance(settings, ChainSettings):
        raise TypeError(f"settings must be a ChainSettings, got {type(settings).__name__}")
    ne = check_int("n_estimates", n_estimates, lo=0, hi=10**9)
    chunk = check_int("chunk", chunk, lo=1, hi=10**6)
    tier = settings.tier
    if not groups:
        raise ValueError("run_chain needs at least one FocusGroup")
    base = groups[0].instrument
    vnames = [n for n, _ in variant_instruments(base, variants)]
    if tier == "signal":
        big = max(g.index_e.size for g in groups)
        if big > SIGNAL_MAX_ESTIMATES:
            raise ValueError(f"tier 'signal' synthesises the {base.sample_rate:g} Hz signal of every cell: "
                             f"{big} estimates is too many; allowed: <= {SIGNAL_MAX_ESTIMATES} (200 s at 50 Hz; "
                             "use tier 'spectral' for long records)")
    vlos_e = np.empty(ne)
    out = {name: (np.full(ne, np.nan), np.zeros(ne, dtype=np.uint8)) for name in [""] + vnames}
    ginfo = []
    from .._config import apply_numba_threads

    apply_numba_threads()
    for g in groups:
        inst = g.instrument
        n_group = g.index_e.size
        procs = [("", inst)] + variant_instruments(inst, variants)
        w_s = np.ascontiguousarray(g.weight_s, dtype=np.float64)
        nl = check_int("n_looks", g.n_looks, lo=1, hi=4096)
        info = {"n_estimates": int(n_group), "n_looks": nl, "n_cells": int(w_s.size), "cnr_db": settings.cnr_db}
        if g.cloud_weight > 0.0:
            info.update(cloud_weight=g.cloud_weight, cloud_fraction=g.cloud_weight / (1.0 + g.cloud_weight))
        ginfo.append(info)
        if n_group == 0:
            continue
        if tier == "los":
            for c0 in range(0, n_group, chunk):
                c1 = min(n_group, c0 + chunk)
                _, v, cloud = g.sample(c0, c1)
                sel = g.index_e[c0:c1]
                vlos_e[sel] = v
                mix = v if cloud is None or g.cloud_weight == 0.0 else \
                    (v + g.cloud_weight * cloud.mean(axis=1)) / (1.0 + g.cloud_weight)
                sp, fl = homodyne_flags(inst, mix)
                for name in out:
                    out[name][0][sel], out[name][1][sel] = sp, fl
            info.update(correlation_time=None, m_eff=None, speckle=None, subcell_spread=None, background=None)
            continue
        if g.seed is None:
            raise ValueError(f"seed is required for tier {tier!r}; allowed: an int or a numpy Generator")
        spread = _spread(settings, g)
        speckle = _speckle_used(settings, spread)
        if nl > 1 and (speckle == "continuum" or tier == "signal") and inst.blocks_per_estimate % nl:
            raise ValueError(f"{n_group and nl} looks per estimate with speckle {speckle!r} / tier {tier!r} need "
                             f"n_looks to divide instrument.blocks_per_estimate={inst.blocks_per_estimate}; "
                             "allowed: its divisors")
        run = _Group(settings, g, procs, out, speckle, spread)
        rows = n_group if tier == "signal" else min(n_group, chunk)
        check_memory("signal chain buffers", rows * (8 * nl * (w_s.size + 1) + 48 * inst.n_fft) + 64 * n_group)
        if tier == "signal":
            vlos_els, v, cloud = g.sample(0, n_group)
            vlos_e[g.index_e] = v
            run.signal(*_with_cloud(vlos_els, cloud, w_s, g.cloud_weight, g.tail))
        elif speckle == "continuum":
            key = np.uint64(int(np.random.default_rng(run.s_sim).integers(0, 2**63, dtype=np.int64)))
            for c0 in range(0, n_group, chunk):
                c1 = min(n_group, c0 + chunk)
                vlos_els, v, cloud = g.sample(c0, c1)
                vlos_e[g.index_e[c0:c1]] = v
                run.continuum(*_with_cloud(vlos_els, cloud, w_s, g.cloud_weight, g.tail), c0, c1, key)
        else:
            draws = SpeckleBlocks(run.s_sim, inst.n_bins, run.m_eff, speckle)
            buf = np.empty((min(n_group, chunk), inst.n_bins))
            for c0 in range(0, n_group, chunk):
                c1 = min(n_group, c0 + chunk)
                vlos_els, v, cloud = g.sample(c0, c1)
                vlos_e[g.index_e[c0:c1]] = v
                run.point_cells(*_with_cloud(vlos_els, cloud, w_s, g.cloud_weight, g.tail), c0, c1, draws, buf)
        cnr_range = None
        if run.cnr_gain_e is not None:
            cnr_range = (settings.cnr_db + 10 * math.log10(run.cnr_gain_e.min()),
                         settings.cnr_db + 10 * math.log10(run.cnr_gain_e.max()))
        info.update(correlation_time=run.tau, m_eff=run.m_eff,
                    speckle=(speckle if tier == "spectral" or speckle == "continuum" else "tier 3 (AR(1) per cell)"),
                    subcell_spread=run.spread,
                    background="exact" if settings.exact_background else f"measured ({inst.background_blocks} blocks)",
                    background_gain=None if run.gain_e is None else (float(run.gain_e.min()), float(run.gain_e.max())),
                    cnr_db_range=cnr_range)
    if settings.background_pause:
        for g in groups:
            paused = g.index_e[pause_mask(g.instrument, g.time_e, g.calibration_time)]
            for sp, fl in out.values():
                sp[paused] = np.nan
                fl[paused] |= np.uint8(Flag.PAUSED)
    speed, flags = out.pop("")
    est = "los" if tier == "los" else base.estimator
    info = {"tier": tier, "estimator": est,
            "flag_counts": {f.name: int(np.count_nonzero(flags & f.value)) for f in Flag},
            "n_failed": int(np.count_nonzero(flags & int(FAIL_FLAGS))),
            "variant_availability": {n: usable_fraction(s, f) for n, (s, f) in out.items()}}
    avail = usable_fraction(speed, flags)  # one definition (processing module notes)
    return ChainRecord(vlos_e=vlos_e, speed_e=speed, flags_e=flags, variants=out, availability=avail,
                       groups=ginfo, info=info)
