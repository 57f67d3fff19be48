"""What every lidar shares: its probe volume, its signal chain, a cloud layer, and sampling the field for the chain.

A lidar sensor is geometry (where the beam points and focuses, when, which
cells); everything else is the same for every lidar and lives here and in
:mod:`cwlidar_sim.signal.chain`:

* :class:`LidarBase`, the fields every lidar has, with one set of names and
  ranges: the instrument, the chain's tier and speckle model, the CNR and its
  variation, the background, the probe volume's weighting, span, cells and
  tail rule (:mod:`cwlidar_sim.beam.cells`), the sub-cell spread, the
  speckle's transverse speed, and a cloud layer;
* :class:`BeamSampler`, which samples a field along a lidar's looks into the
  chain's ``(estimates, looks, cells)`` structure with the one line-of-sight
  kernel of :mod:`cwlidar_sim.beam` (Taylor advection at U along +x,
  trilinear interpolation);
* the cloud's geometry: a layer ``cloud_base`` above the telescope,
  ``cloud_depth`` deep, is crossed by a beam of vertical component ``n_z > 0``
  between ranges ``cloud_base / n_z`` and ``(cloud_base + cloud_depth) / n_z``,
  where the weighting integrates to ``I_c``; the cloud carries
  ``w_c = cloud_strength * I_c`` of the aerosol's unit weight and moves at
  ``(V_c cos psi, V_c sin psi, 0)`` (``V_c = cloud_speed``, by default the
  mean wind; ``psi = cloud_direction_deg``; no turbulence).  A beam that
  does not rise never reaches it (``w_c = 0``).  Not modelled, all small
  beside the effect: the aerosol weight inside and beyond the cloud (the
  beam is not extinguished), the cloud's own speckle time and any spread of
  speeds within it.  Inside the simulated span the cells would count the
  cloud twice, so the cloud must lie beyond it (validated).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._lidar_fields import LidarFields
from .._validation import check_choice, check_keys, check_real, check_str
from ..beam.cells import TAIL_RULES, ProbeCells, interval_weight, probe_cells
from ..beam.probe import get_weighting
from ..beam.sampling import _check_extent, _prepare_field, is_time_resolved, time_weights
from ..signal.chain import ChainSettings
from ..signal.instrument import PRESETS, PROTOTYPE_2003, Instrument

__all__ = ["LidarBase", "BeamSampler", "instrument_from_spec", "field_subcell_spread",
           "CLOUD_BASE_MAX", "CLOUD_STRENGTH_MAX"]

#: Highest cloud base [m] (the troposphere).
CLOUD_BASE_MAX = 20000.0
#: Largest cloud backscatter relative to the aerosol's [-].
CLOUD_STRENGTH_MAX = 1e9

_PRESET_ALIASES = {"prototype": "prototype", "prototype_2003": "prototype", "cs": "cs", "cs_series": "cs"}


def instrument_from_spec(spec) -> Instrument:
    """An :class:`~cwlidar_sim.signal.Instrument` from an instance or a dict.

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


@dataclasses.dataclass(frozen=True, kw_only=True)
class LidarBase(LidarFields):
    """The fields every lidar has (module notes); sensors add their geometry.

    The shared fields and their defaults are declared once, in
    ``cwlidar_sim._lidar_fields.LidarFields`` (the scenes' ``[lidar]`` tables
    read the same declaration); this class documents and validates them.

    Parameters
    ----------
    instrument : Instrument
        Acquisition and processing settings (a dict of overrides on a preset
        is accepted by ``from_dict``).
    tier : {'los', 'spectral', 'signal'}
        Signal-chain tier (:mod:`cwlidar_sim.signal.chain`).
    weighting : str
        Probe-volume weighting, a name of the registry
        :data:`cwlidar_sim.beam.WEIGHTINGS`: 'exact' (A2012 Eq. 3 as
        corrected in :mod:`cwlidar_sim.beam.optics`), 'lorentzian' (Eq. 4, cut at the telescope),
        'aperture', 'point' or one registered by the user.
    span : float
        Half-width of the simulated span [z_R]; in (0, 10000].
    cell_length : float
        Range-cell length and sub-point spacing [m]; in (0, 1000].
    cell_growth : float
        Tail cells grow to ``cell_growth |s|`` at distance ``|s|`` from the
        focus (:func:`cwlidar_sim.beam.cells.probe_cells`); in [0, 1].
    tail : {'mean_wind', 'renormalise'}
        What the weight beyond the span sees (:mod:`cwlidar_sim.beam.cells`).
    cnr_db : float
        Wideband carrier-to-noise ratio of the aerosol [dB]; in
        :data:`cwlidar_sim.signal.chain.CNR_DB_RANGE`.
    speckle : {'continuum', 'independent', 'coherent'}
        Speckle model (:mod:`cwlidar_sim.signal.chain`).
    exact_background : bool
        Exact noise floor instead of a measured background.
    transverse_speed : float or None
        Speed of the focal spot relative to the aerosols [m/s], in [0, 1000],
        setting the speckle time; None: the sensor's own (the wind across a
        staring beam, the spot's speed for a scanning one).
    subcell_spread : float or None
        Sub-cell speed spread [m/s], in [0, 100]; None: from the field's tensor
        (:func:`field_subcell_spread`, 0 without one).
    cnr_variation_db, cnr_time_scale : float
        CNR variation over a record [dB] and its time scale [s].
    background_pause : bool
        Pause for the background measurement (NaN flagged PAUSED).
    line_broadening : float
        Instrument broadening of the Doppler line [Hz] (:class:`cwlidar_sim.signal.chain.ChainSettings`).
    cloud_base : float or None
        Height of a cloud layer's base above the telescope [m], in
        (0, :data:`CLOUD_BASE_MAX`]; None: no cloud.
    cloud_strength : float
        beta_cloud / beta_aerosol [-]; in [0, :data:`CLOUD_STRENGTH_MAX`]
        (water clouds 1e3-1e5); > 0 needs ``cloud_base``.
    cloud_depth : float
        Depth of the backscattering layer [m] (~ 1 / (2 extinction), 10-50 m
        for water clouds); in (0, 10000].
    cloud_speed : float or None
        Horizontal speed of the cloud [m/s], in [0, 200]; None: the mean wind U.
    cloud_direction_deg : float
        Direction the cloud moves toward [deg], from +x (the mean wind) toward +y.
    """

    instrument: Instrument = PROTOTYPE_2003

    def _put(self, k, v):
        object.__setattr__(self, k, v)

    def __post_init__(self):
        put = self._put
        if not isinstance(self.instrument, Instrument):
            raise TypeError(f"instrument must be an Instrument, got {type(self.instrument).__name__} "
                            f"(use {type(self).__name__}.from_dict for a dict)")
        self.chain_settings()  # the chain's own checks, named by field
        put("cnr_db", float(self.cnr_db))
        put("cnr_variation_db", float(self.cnr_variation_db))
        put("cnr_time_scale", float(self.cnr_time_scale))
        put("line_broadening", float(self.line_broadening))
        get_weighting(check_str("weighting", self.weighting))  # a registered name
        put("span", check_real("span", self.span, lo=0.0, hi=1e4, lo_open=True))
        put("cell_length", check_real("cell_length", self.cell_length, lo=0.0, hi=1000.0, lo_open=True))
        put("cell_growth", check_real("cell_growth", self.cell_growth, lo=0.0, hi=1.0))
        check_choice("tail", self.tail, TAIL_RULES)
        if self.transverse_speed is not None:
            put("transverse_speed", check_real("transverse_speed", self.transverse_speed, lo=0.0, hi=1000.0))
        if self.subcell_spread is not None:
            put("subcell_spread", check_real("subcell_spread", self.subcell_spread, lo=0.0, hi=100.0))
        put("exact_background", bool(self.exact_background))
        put("background_pause", bool(self.background_pause))
        put("cloud_strength", check_real("cloud_strength", self.cloud_strength, lo=0.0, hi=CLOUD_STRENGTH_MAX))
        put("cloud_depth", check_real("cloud_depth", self.cloud_depth, lo=0.0, hi=1e4, lo_open=True))
        if self.cloud_speed is not None:
            put("cloud_speed", check_real("cloud_speed", self.cloud_speed, lo=0.0, hi=200.0))
        put("cloud_direction_deg", check_real("cloud_direction_deg", self.cloud_direction_deg))
        if self.cloud_base is None:
            if self.cloud_strength > 0.0:
                raise ValueError(f"cloud_strength={self.cloud_strength!r} > 0 needs cloud_base [m] (the height of "
                                 f"the cloud layer); allowed: cloud_strength=0 without a cloud_base")
        else:
            put("cloud_base", check_real("cloud_base", self.cloud_base, lo=0.0, hi=CLOUD_BASE_MAX, lo_open=True))

    # -- interchange -----------------------------------------------------
    def as_dict(self) -> dict:
        """Plain dict of the fields, the instrument as its full field dict (round-trips through :meth:`from_dict`)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["instrument"] = self.instrument.as_dict()
        for k, v in d.items():
            if isinstance(v, (list, tuple)):
                d[k] = tuple(v)
        return d

    @classmethod
    def from_dict(cls, d: dict):
        """Build from a mapping; unknown keys are rejected by name.

        ``instrument`` may be an :class:`~cwlidar_sim.signal.Instrument`, a full field dict, or a
        dict of overrides on a preset, e.g. ``{'preset': 'cs', 'estimator': 'median'}``.
        """
        check_keys(cls, d)
        d = dict(d)
        if "instrument" in d:
            d["instrument"] = instrument_from_spec(d["instrument"])
        return cls(**d)

    def replace(self, **changes):
        """Copy with some fields changed (validated); unknown names are rejected."""
        check_keys(type(self), changes)
        return dataclasses.replace(self, **changes)

    # -- the chain and the probe volume ------------------------------------
    def chain_settings(self) -> ChainSettings:
        """The signal chain's settings (:class:`cwlidar_sim.signal.chain.ChainSettings`)."""
        return ChainSettings(**{f.name: getattr(self, f.name) for f in dataclasses.fields(ChainSettings)})

    def subcell_spread_in(self, field) -> tuple:
        """``(spread, source)``: the sub-cell speed spread [m/s] the chain uses in ``field``, and where it comes from.

        The one rule of every lidar: 0 in tier 'los' (source None) and for a
        speckle model other than 'continuum'; else ``subcell_spread`` if set,
        else the field's tensor (:func:`field_subcell_spread`), else 0.
        """
        if self.tier == "los":
            return 0.0, None
        if self.speckle != "continuum":
            return 0.0, f"not used by speckle {self.speckle!r}"
        if self.subcell_spread is not None:
            return self.subcell_spread, "lidar"
        spread = field_subcell_spread(field)
        if spread is None:
            return 0.0, "none (field has no Mann parameters)"
        return spread, "field tensor"

    def probe_cells(self, instrument: Instrument) -> ProbeCells:
        """Range cells of the probe volume of ``instrument`` (focused) with this lidar's span, cells and tail rule."""
        return probe_cells(instrument.optics(), self.weighting, self.span, self.cell_length, growth=self.cell_growth,
                           tail=self.tail)

    def cloud_velocity(self, U: float) -> np.ndarray:
        """The cloud's velocity (x, y, z) [m/s]."""
        v = U if self.cloud_speed is None else self.cloud_speed
        psi = math.radians(self.cloud_direction_deg)
        return np.array([v * math.cos(psi), v * math.sin(psi), 0.0])

    def cloud_weight_at(self, instrument: Instrument, n_z: float) -> float:
        """The cloud's weight ``w_c`` for a beam of vertical component ``n_z`` focused as ``instrument`` [-]."""
        if self.cloud_base is None or n_z <= 0.0:
            return 0.0
        a = self.cloud_base / n_z - instrument.focus
        b = (self.cloud_base + self.cloud_depth) / n_z - instrument.focus
        return self.cloud_strength * interval_weight(instrument.optics(), self.weighting, a, b)

    def check_cloud_beyond(self, instrument: Instrument, cells: ProbeCells, n_z: float) -> None:
        """A cloud inside the simulated span would be counted twice: refuse it, naming the allowed bases."""
        if self.cloud_base is None or n_z <= 0.0:
            return
        lo = (instrument.focus + cells.edges[-1]) * n_z
        if self.cloud_base <= lo:
            raise ValueError(f"cloud_base={self.cloud_base!r} m is inside the simulated span of the beam (its far end "
                             f"reaches {lo:.4g} m); allowed: ({lo:.4g}, {CLOUD_BASE_MAX:g}] m")


class BeamSampler:
    """Samples a field along a lidar's looks for one focus: the chain's ``vlos_els`` (module notes).

    Parameters
    ----------
    field : xarray.Dataset
        Box, plane or line (:func:`cwlidar_sim.beam.sample_los`); u, v, w
        fluctuations [m/s], the mean U added to u.
    origin : array_like, shape (3,)
        Telescope position [m].
    focus : float
        Focus distance [m].
    cells : ProbeCells
    U : float
        Mean wind along +x [m/s].
    wrap : bool
        Periodic y and z.
    """

    def __init__(self, field, origin, focus, cells: ProbeCells, U, wrap):
        self.origin = np.ascontiguousarray(origin, dtype=np.float64)
        # a time-resolved field (t, x, y, z): its snapshots, sampled unadvected and weighted linearly in t
        self.time_k = np.asarray(field["t"].values, dtype=np.float64) if is_time_resolved(field) else None
        self.snaps = (None if self.time_k is None else
                      [_prepare_field(field.isel(t=k), self.origin) for k in range(self.time_k.size)])
        self.fld = _prepare_field(field, self.origin) if self.snaps is None else self.snaps[0]
        self.cells = cells
        self.range_j = np.ascontiguousarray(np.maximum(focus + cells.sub_j, 0.0))
        self.fraction_j = np.ascontiguousarray(cells.fraction_j, dtype=np.float64)
        self.ptr_s = np.ascontiguousarray(cells.ptr_s, dtype=np.int64)
        self.weight_s = np.ascontiguousarray(cells.weight_s, dtype=np.float64)
        self.tail = float(cells.tail_weight)
        self.n_s = cells.n_cells + (1 if self.tail > 0.0 else 0)
        self.U, self.wrap = float(U), bool(wrap)

    def check_extent(self, n_dc) -> None:
        """The field must hold every sub-point along the directions ``n_dc`` (a ValueError says where not)."""
        _check_extent(self.fld, self.origin, np.atleast_2d(n_dc), self.range_j, self.wrap, 1e-6)

    def sample(self, time_l, n_lc):
        """``(vlos_ls, vlos_l)`` of the looks at times ``time_l`` [s] along directions ``n_lc`` (unit).

        ``vlos_ls[l, s]`` is the line-of-sight speed [m/s] of cell ``s`` (the
        range cells, then the tail cell if any) in look ``l``; ``vlos_l`` their
        weighted sum (tier 1).
        """
        if self.snaps is not None:
            return self._combine(self._sample, time_l, n_lc)
        return self._sample(self.fld, time_l, n_lc)

    def _combine(self, fn, time_l, n_lc, *args):
        """``fn``'s outputs on a time-resolved field: its snapshots at t = 0, weighted linearly in t."""
        k_l, a_l = time_weights(self.time_k, time_l)
        out = None
        for k in np.unique(k_l):
            sel = np.flatnonzero(k_l == k)
            for kk, w in ((k, 1.0 - a_l[sel]), (k + 1, a_l[sel])):
                parts = fn(self.snaps[kk], np.zeros(sel.size), np.ascontiguousarray(n_lc[sel]), *args)
                if out is None:
                    out = tuple(np.zeros((time_l.size,) + p.shape[1:]) for p in parts)
                for o, p in zip(out, parts):
                    o[sel] += w.reshape((-1,) + (1,) * (p.ndim - 1)) * p
        return out

    def _sample(self, f, time_l, n_lc):
        from ..beam._kernels import los_cells_kernel  # lazily: importing the sensors does not import numba

        n_l = time_l.size
        vlos_ls = np.empty((n_l, self.n_s))
        vlos_l = np.empty(n_l)
        los_cells_kernel(f.u, f.v, f.w, f.grid, self.wrap, self.wrap, self.origin, np.ascontiguousarray(n_lc),
                         self.range_j, self.fraction_j, self.ptr_s, self.weight_s, self.tail,
                         np.ascontiguousarray(time_l, dtype=np.float64), self.U, True, True, vlos_ls, vlos_l)
        return vlos_ls, vlos_l

    def velocity_at(self, time_t, n_tc, ranges):
        """(u, v, w) of the total wind at ``ranges`` along ``n_tc`` at ``time_t``, shape (n_t, n_r, 3) [m/s]."""
        r = np.ascontiguousarray(np.atleast_1d(ranges), dtype=np.float64)
        if self.snaps is not None:
            return self._combine(self._velocity, np.asarray(time_t, dtype=np.float64), np.asarray(n_tc), r)
        return self._velocity(self.fld, time_t, n_tc, r)

    def _velocity(self, f, time_t, n_tc, r):
        from ..beam import _kernels as BK

        vel_tsc, vlos_ts = BK.empty_outputs(time_t.size, r.size)
        BK.sample_points_kernel(f.u, f.v, f.w, f.grid, self.wrap, self.wrap, self.origin,
                                np.ascontiguousarray(n_tc), r, np.ascontiguousarray(time_t, dtype=np.float64),
                                self.U, True, vel_tsc, vlos_ts)
        return vel_tsc, vlos_ts
