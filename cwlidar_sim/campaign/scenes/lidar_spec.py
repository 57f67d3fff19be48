"""The ``[lidar]`` table of every scene kind: the instrument, the signal chain, the probe volume, a cloud.

One set of keys, names and ranges for every lidar, whatever its geometry:
they are the fields of :class:`cwlidar_sim.sensors.LidarBase` (and through
it of :class:`cwlidar_sim.signal.chain.ChainSettings`), checked by building
that class, so a staring and a conical scene accept the same values and
refuse the same mistakes in the same words (prefixed ``lidar.``).  A scene
kind adds its geometry elsewhere (the staring lidar's ``elevation_deg``
here, the conical scan's cone and schedule in ``[scan]``) and its own
defaults (:class:`ConicalLidarSpec`: the CS series instrument).

Example
-------
.. code-block:: toml

    [lidar]
    preset = "prototype"          # or "cs"
    instrument = { focus = 67.5, estimator = "median" }
    tier = "spectral"             # los | spectral | signal (| auto, staring)
    cnr_db = -10.0
    cnr_variation_db = 2.0        # the aerosol load over a record
    speckle = "continuum"         # continuum | independent | coherent
    span = 20.0                   # z_R, with the tail rule and growing cells
    tail = "mean_wind"
    cloud_base = 1500.0           # m above the telescope, with cloud_strength
    cloud_strength = 1e4
    variants = [{ name = "raise10", threshold_raise_percent = 10.0 }]
"""

from __future__ import annotations

import dataclasses

from ..._lidar_fields import LIDAR_KEYS, LidarFields
from ..._validation import check_choice, check_keys
from ...signal.chain import TIERS
from .spec import Spec, Table, at_path, entry_label, set_field, spec_table

__all__ = ["LidarSpecBase", "ConicalLidarSpec", "SENSOR_KEYS", "lidar_schema"]

#: Keys of the table that are :class:`cwlidar_sim.sensors.LidarBase` fields (the rest: preset, instrument,
#: variants, and the kind's geometry): the one declaration of a lidar's shared fields.
SENSOR_KEYS = LIDAR_KEYS


@dataclasses.dataclass(frozen=True)
class _LidarTableHead(Spec):
    """The table's first keys: the instrument's preset and overrides."""

    preset: str = "prototype"
    instrument: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class LidarSpecBase(LidarFields, _LidarTableHead):
    """The lidar of a scene (module notes); every key as :class:`cwlidar_sim.sensors.LidarBase`.

    The keys shared with the sensors and their defaults are declared once
    (``cwlidar_sim._lidar_fields.LidarFields``); the table declares its own
    ``preset``, ``instrument`` and ``variants``, and ``cell_length`` again
    (None: the field's spacing).

    Parameters
    ----------
    preset : {'prototype', 'cs'}
        Instrument preset (:func:`cwlidar_sim.signal.instrument.preset`).
    instrument : dict
        Field-by-field overrides of the preset (e.g. ``focus``, ``estimator``,
        ``threshold_raise_percent``); validated by :class:`~cwlidar_sim.signal.Instrument`.
    tier : {'los', 'spectral', 'signal'}
        Signal-chain tier (:mod:`cwlidar_sim.signal.chain`).
    cnr_db, cnr_variation_db, cnr_time_scale : float
        The aerosol's wideband CNR [dB] and its variation over a record [dB, s].
    weighting, span, cell_length, cell_growth, tail
        The probe volume's cells (:func:`cwlidar_sim.beam.cells.probe_cells`);
        ``cell_length`` None: the field's spacing.
    transverse_speed, speckle, subcell_spread
        The speckle's transverse speed [m/s] (None: the sensor's own), model
        and sub-cell spread [m/s] (None: from the field's tensor).
    exact_background, background_pause : bool
        Exact noise floor; pauses for the background measurement.
    line_broadening : float
        Instrument broadening of the Doppler line as a Gaussian's standard
        deviation [Hz] (laser line width, phase noise); in [0, 5e6].  It acts
        like a sub-cell speed spread of ``lambda / 2`` times it, added in
        quadrature (continuum speckle, tiers 2 and 3).
    cloud_base, cloud_strength, cloud_depth, cloud_speed, cloud_direction_deg
        A cloud layer (:mod:`cwlidar_sim.sensors.base`).
    variants : list of dict
        Extra processings of the same spectra, each a ``name`` and overrides
        of :data:`cwlidar_sim.signal.chain.VARIANT_KEYS` (e.g. ``{name =
        "raise10", threshold_raise_percent = 10}``, ``{name = "peak",
        estimator = "peak"}``).
    """

    cell_length: float | None = None
    variants: tuple = ()

    #: Tiers this kind of scene accepts.
    _tiers = TIERS

    def __post_init__(self):
        from ...sensors.base import LidarBase
        from ...signal.chain import VARIANT_KEYS, variant_instruments
        from ...signal.instrument import PRESETS, Instrument

        check_choice("lidar.preset", self.preset, tuple(PRESETS))
        if not isinstance(self.instrument, dict):
            raise TypeError(f"lidar.instrument must be a table of overrides, got {type(self.instrument).__name__}")
        with at_path("lidar.instrument", tuple(f.name for f in dataclasses.fields(Instrument))):
            inst = self.build_instrument()  # named as the scene file names it
        check_choice("lidar.tier", self.tier, self._tiers)
        kw = self.sensor_kwargs(0.5)
        with at_path("lidar", SENSOR_KEYS):
            base = LidarBase(instrument=inst, **kw)
        for k in SENSOR_KEYS:
            if k not in ("tier", "cell_length"):
                set_field(self, k, getattr(base, k))
        if self.cell_length is not None and self.cell_length != "auto":
            set_field(self, "cell_length", base.cell_length)
        variants = tuple(self.variants)
        for i, v in enumerate(variants):
            if not isinstance(v, dict):
                continue
            where = entry_label("lidar.variants", i, v.get("name"))
            if v.get("name") == "main":
                raise ValueError(f"{where}.name 'main' is reserved for the lidar's own processing")
            over = {k: x for k, x in v.items() if k != "name"}
            if set(over) <= set(VARIANT_KEYS):
                with at_path(where, VARIANT_KEYS):
                    inst.replace(**over)  # each variant's values, named by its entry
        # the chain's own check: names, and only the processing fields (the spectra stay the same)
        with at_path("lidar", ("variants",)):
            variant_instruments(inst, [dict(v) if isinstance(v, dict) else v for v in variants])
        set_field(self, "variants", tuple(dict(v) for v in variants))

    def build_instrument(self, extra=None):
        """The Instrument: the preset with ``instrument`` and then ``extra`` overrides applied."""
        from ...signal.instrument import Instrument, preset

        d = dict(self.instrument)
        d.update(extra or {})
        return Instrument.from_dict(d, base=preset(self.preset))

    def sensor_kwargs(self, cell_length: float) -> dict:
        """The :class:`cwlidar_sim.sensors.LidarBase` fields (not the instrument) of this table.

        ``cell_length`` is used where the table leaves it to the field (None)
        or to the runner ('auto'); a tier 'auto' stands for 'spectral' (what
        it resolves to whenever the chain's settings matter).
        """
        kw = {k: getattr(self, k) for k in SENSOR_KEYS}
        if kw["cell_length"] is None or kw["cell_length"] == "auto":
            kw["cell_length"] = cell_length
        if kw["tier"] == "auto":
            kw["tier"] = "spectral"
        return kw

    @property
    def variant_list(self) -> list:
        """The variants as a list of dicts (the chain's argument), or None."""
        return [dict(v) for v in self.variants] or None

    @classmethod
    def from_dict(cls, d: dict):
        check_keys(cls, d)
        d = dict(d)
        if "variants" in d:
            if not isinstance(d["variants"], (list, tuple)):
                raise TypeError("lidar.variants must be a list of tables")
            d["variants"] = tuple(d["variants"])
        return cls(**d)


@dataclasses.dataclass(frozen=True)
class ConicalLidarSpec(LidarSpecBase):
    """The ``[lidar]`` table of a conical scene: the same keys, the scanning instrument's defaults.

    Defaults: ``preset = 'cs'`` (CS's series ZephIR), ``span = 30``
    (the std ratio's convergence in the span, docs/convergence.md: span 5
    left it 0.07 low at 40 m, 30 leaves less than 0.005),
    ``speckle = 'independent'`` (the spot's speed gives every estimate
    thousands of looks); ``cell_length`` defaults to the box spacing
    (``scan.spacing``).  The cone, the scan and the heights are ``[scan]``.
    """

    preset: str = "cs"
    span: float = 30.0
    speckle: str = "independent"


def lidar_schema(cls) -> dict:
    """Schema entries of a ``[lidar]`` table of class ``cls`` (:func:`cwlidar_sim.campaign.scenes.spec.check_scene_keys`):
    the table, its ``instrument`` overrides and each of its ``variants``."""
    from ...signal.chain import VARIANT_KEYS
    from ...signal.instrument import Instrument

    return {"lidar": spec_table(cls), "lidar.instrument": Table(tuple(f.name for f in dataclasses.fields(Instrument))),
            "lidar.variants[]": Table(("name",) + tuple(VARIANT_KEYS))}
