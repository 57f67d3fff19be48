"""The ``[turbulence]`` table of every scene kind: one set of keys, one rule for defaults.

A staring, a conical and a nacelle scene describe their turbulence with the
same keys, checked by the same class (:class:`TurbulenceSpec`; the kinds'
subclasses :class:`cwlidar_sim.campaign.scenes.conical.SurfaceTurbulenceSpec`
and :class:`cwlidar_sim.campaign.scenes.nacelle.NacelleTurbulenceSpec` differ
only in their default table and in what the kind can run).  The keys given
pick one of four ways to set the Mann (1994) tensor:

* **explicit**: ``alpha_eps`` [m^(4/3) s^-2], ``length_scale`` [m], ``gamma`` [-],
  one tensor for every period (A2012's and the bundled nacelle scene's);
  ``source = "fixed"`` is an older spelling of the same;
* **what a user knows**: one of ``ti`` (turbulence intensity sigma_u / U
  [-], U the period's mean speed), ``sigma_u`` [m/s] or ``iec_class``
  (IEC 61400-1 ed. 4 normal turbulence model, below), optionally
  ``length_scale`` (default IEC 61400-1 Annex C at ``height``:
  ``L = 0.8 Lambda_1``, ``Lambda_1 = 0.7 z`` up to 60 m and 42 m above,
  as :meth:`cwlidar_sim.turbulence.MannParameters.iec`) and ``gamma``
  (default 3.9).  ``alpha_eps`` is then set so that the tensor's own
  longitudinal variance (over all wave vectors,
  :func:`cwlidar_sim.turbulence.limits.longitudinal_std`) is sigma_u^2
  exactly; :meth:`~cwlidar_sim.turbulence.MannParameters.iec` instead sets the
  isotropic standard deviation to 0.55 sigma_u, which gives the Gamma = 3.9
  tensor a sigma_u 1.7 % low;
* **surface layer**: ``source = "mann1994"`` or ``"iec"`` with ``z0``
  (roughness length [m], default 0.01) and, for 'mann1994', an optional
  ``obukhov_length`` [m] (stability, Monin-Obukhov with Businger-Dyer):
  the tensor at each height from the period's mean speed
  (:func:`cwlidar_sim.turbulence.surface_layer.surface_layer_parameters`);
* **fitted** (staring only): ``fit_to``, a sonic record the three
  parameters are fitted to (:func:`cwlidar_sim.campaign.periods.staring_field.scene_params`).

A field the user already has
----------------------------
``file`` names a turbulence field to fly the instruments through instead of
generating a Mann box, in every kind: ``file = "box.bts"``, or a table
``[turbulence.file]`` with ``path`` and the reader's options: ``format``
('turbsim', 'bladed', 'hawc2', 'netcdf'; default from the suffix),
``convention`` and ``reverse_x`` (HAWC2's orientation), ``shape`` and
``spacing`` (HAWC2 without its JSON sidecar), ``left_hand_rule`` (Bladed
without its ``.sum``), ``dims`` (NetCDF: our names t, x, y, z -> the
file's).  A NetCDF file on (t, x, y, z) is time-resolved (an LES's output).
Relative paths are taken from the scene file's folder; the files must exist
when the scene is loaded.  Frozen fields are advected at each period's mean
speed; a field too small for a period's record is refused, naming the sizes,
before any sampling (:mod:`cwlidar_sim.turbulence.io_source`).  The tensor
keys keep their meaning and their kind's defaults: the tensor is the theory
the results are compared with (and the staring lidar's transverse speed),
no longer the field's source.  ``file`` is its own key, not a value of
``source``: ``source`` picks a tensor (a model), a file is a realisation,
and a scene can want both (``source = "mann1994"`` as the theory of an LES's
field).  Not with ``condition_on`` (the twin conditions the boxes it
generates).

A table giving none of the keys that pick a way (``alpha_eps``,
``length_scale``, ``gamma``, ``ti``, ``sigma_u``, ``iec_class``,
``source``, ``fit_to``) is the kind's default: a staring scene has none
(its table must pick one), a conical scene's is ``source = "mann1994"``, a
nacelle scene's ``alpha_eps = 0.1, length_scale = 33.6, gamma = 3.9``
(also the values an explicit nacelle table leaves out).

``height`` [m] is where ``ti`` / ``sigma_u`` / ``iec_class`` and the IEC
length scale, or the surface layer, are taken.  Default: the unit's
measurement height where the scene has one (a conical scene: each height
of ``scan.heights``, in cycle mode the box's reference height).  A staring
and a nacelle scene have no measurement height (their fields are one
homogeneous tensor), so they need ``height`` whenever the tensor depends on
it: the surface layer, and ``ti`` / ``sigma_u`` / ``iec_class`` without
``length_scale``.

``ti``, ``iec_class`` and the surface layer make the tensor depend on the
period's mean speed, so each period (and each height of a conical scene)
gets its own; ``sigma_u`` with ``length_scale`` or ``height`` is one
tensor for every period.  ``condition_on`` (the virtual twin) is taken by
staring and conical scenes; a staring twin needs one tensor for the scene
(its periods are the records').

Every resolved tensor keeps the model's ranges (``length_scale`` <=
:data:`cwlidar_sim.turbulence.parameters.LENGTH_SCALE_MAX`, ``gamma`` <=
:data:`~cwlidar_sim.turbulence.parameters.GAMMA_MAX`) and Taylor's limit
sigma_u / U <= 0.5 in every period (:mod:`cwlidar_sim.turbulence.limits`).

IEC 61400-1 ed. 4 (2019) normal turbulence model
------------------------------------------------
``sigma_1 = I_ref (0.75 V_hub + b)``, ``b = 5.6 m/s``, the 90 % quantile of
sigma_u at the hub-height mean speed V_hub (here the period's mean speed),
with ``I_ref`` = 0.18 (category A+, new in ed. 4), 0.16 (A), 0.14 (B), 0.12
(C).  The standard itself was not at hand; the formula and the I_ref values
are as quoted by NREL's answer on the IEC 61400-1:2019 NTM
(https://forums.nrel.gov/t/iec-61400-1-2019-for-turbulence-intensity-in-turbsim/2588)
and the theory page of pyIECWind (https://pyiecwind.readthedocs.io/en/stable/theory.html),
which also gives Lambda_1.
"""

from __future__ import annotations

import dataclasses
import math

from ..._validation import check_choice, check_real, check_str
from ...turbulence.limits import MAX_TURBULENCE_INTENSITY, check_frozen_turbulence, longitudinal_std
from ...turbulence.io_source import FieldFile
from ...turbulence.parameters import MannParameters
from ...turbulence.surface_layer import surface_layer_parameters
from .spec import Spec, Table, at_path, check_condition_on, check_scene_keys, entry_label, set_field, spec_table

__all__ = ["TurbulenceSpec", "IEC_REFERENCE_INTENSITY", "IEC_NTM_B", "IEC_GAMMA", "iec_sigma_u", "iec_length_scale"]

#: I_ref of the IEC 61400-1 ed. 4 turbulence categories [-] (module notes).
IEC_REFERENCE_INTENSITY = {"A+": 0.18, "A": 0.16, "B": 0.14, "C": 0.12}
#: b of the normal turbulence model sigma_1 = I_ref (0.75 V_hub + b) [m/s].
IEC_NTM_B = 5.6
#: Gamma of IEC 61400-1 Annex C (and Mann's fit to Kaimal's spectra) [-]: the default ``gamma``.
IEC_GAMMA = 3.9
#: sigma_u / u* of the surface-layer sources, the larger of the two (IEC's 2.4; Mann's fit to Kaimal: 2.24), for
#: the closed-form turbulence intensity of the neutral surface layer's frozen-turbulence check.
SURFACE_SIGMA_U_OVER_USTAR = 2.4
#: The keys that pick how the tensor is set (module notes); a table with none of them is the kind's default.
MODE_KEYS = ("alpha_eps", "length_scale", "gamma", "ti", "sigma_u", "iec_class", "source", "fit_to")
KNOWN_KEYS = ("ti", "sigma_u", "iec_class")
SOURCES = ("mann1994", "iec", "fixed")
#: The record-file options ``turbulence.fit_to_options`` passes to the fit's reader
#: (:class:`cwlidar_sim.analysis.records.RecordSpec`: how the file is written, not how the fit treats it).
FIT_TO_OPTIONS = ("columns", "units", "sample_rate", "sep", "decimal", "skiprows", "comment", "na_values", "timezone",
                  "max_gap", "max_filled_fraction")


def iec_sigma_u(iec_class: str, speed: float) -> float:
    """sigma_1 = I_ref (0.75 V_hub + 5.6 m/s) of IEC 61400-1 ed. 4's normal turbulence model [m/s].

    Parameters
    ----------
    iec_class : {'A+', 'A', 'B', 'C'}
        Turbulence category.
    speed : float
        Hub-height mean speed V_hub [m/s]; > 0.
    """
    check_choice("iec_class", iec_class, tuple(IEC_REFERENCE_INTENSITY))
    U = check_real("speed", speed, lo=0.0, lo_open=True)
    return IEC_REFERENCE_INTENSITY[iec_class] * (0.75 * U + IEC_NTM_B)


def iec_length_scale(height: float) -> float:
    """Mann length scale L = 0.8 Lambda_1 of IEC 61400-1 Annex C at ``height`` [m], in m.

    Lambda_1 = 0.7 z up to 60 m, 42 m above.
    """
    z = check_real("height", height, lo=0.0, lo_open=True)
    return 0.8 * (0.7 * z if z <= 60.0 else 42.0)


def _prefixed(fn, *args, **kw):
    """``fn(*args, **kw)`` with its ValueError / TypeError prefixed ``turbulence.`` (the key's TOML path)."""
    try:
        return fn(*args, **kw)
    except (ValueError, TypeError) as e:
        msg = str(e)
        raise type(e)(msg if msg.startswith("turbulence") else f"turbulence.{msg}") from None


@dataclasses.dataclass(frozen=True)
class TurbulenceSpec(Spec):
    """The ``[turbulence]`` table of a scene (module notes: the four ways, the defaults, ``height``).

    This class is a staring scene's table; a conical and a nacelle scene use
    its subclasses (same keys, their own default table and refusals).

    Parameters
    ----------
    source : {'mann1994', 'iec', 'fixed'}, optional
        The surface layer ('mann1994': Mann's fit to Kaimal's neutral spectra
        at each height, extended by stability; 'iec': IEC 61400-1 Annex C at
        each height, neutral); 'fixed': the explicit ``alpha_eps``,
        ``length_scale``, ``gamma`` (older spelling).
    z0 : float, optional
        Roughness length of the surface layer [m]; in (0, 2]; default 0.01
        with ``source``.
    obukhov_length : float, optional
        Obukhov length L_MO of the surface layer [m] (negative unstable,
        positive stable, inf neutral); |L_MO| >= height / 2; 'mann1994' only.
        Default: neutral.
    alpha_eps : float, optional
        alpha eps^(2/3) [m^(4/3) s^-2]; > 0.
    length_scale : float, optional
        Mann length scale L [m]; in (0, 5000].
    gamma : float, optional
        Anisotropy Gamma [-]; in [0, 8]; default 3.9 with ``ti`` / ``sigma_u`` / ``iec_class``.
    ti : float, optional
        Turbulence intensity sigma_u / U [-], U the period's mean speed; in (0, 0.5].
    sigma_u : float, optional
        Longitudinal standard deviation [m/s]; in (0, 20]; sigma_u / U <= 0.5 in every period.
    iec_class : {'A+', 'A', 'B', 'C'}, optional
        IEC 61400-1 ed. 4 turbulence category: sigma_u = I_ref (0.75 U + 5.6 m/s).
    height : float, optional
        Height the turbulence is given at [m]; in [1, 1000]; default: the
        scene's measurement height (conical), none for staring and nacelle scenes.
    fit_to : str, optional
        Staring scenes: path of a sonic record (NetCDF: variables ``u``,
        ``v``, ``w`` with their ``units``, m s-1 when absent, on a ``time``
        coordinate; or CSV with columns time, u, v, w in m/s, the time in s
        or in the unit its header names, ``time_ms``; u along the mean wind)
        to fit the three parameters to (relative paths are taken from the
        scene file's folder), read by the twin's reader
        (:mod:`cwlidar_sim.analysis.record_files`).  Every period's
        ``mean_speed`` must lie within 30 % of the record's mean; a fit on a
        bound is warned about and flagged (see
        :func:`cwlidar_sim.campaign.periods.staring_field.scene_params`).  Exclusive with
        every other way.
    fit_to_options : dict, optional
        With ``fit_to``: how the record file is written, passed to its reader
        (:class:`cwlidar_sim.analysis.records.RecordSpec`): ``sep``,
        ``decimal``, ``skiprows``, ``comment``, ``na_values``, ``timezone``,
        ``columns``, ``units``, ``sample_rate``, ``max_gap``,
        ``max_filled_fraction`` (``FIT_TO_OPTIONS``); other keys are
        refused by name.  Default: the reader's.
    file : FieldFile, optional
        A turbulence field file to sample instead of a generated box (module
        notes: ``file = "box.bts"`` or a ``[turbulence.file]`` table of
        :class:`cwlidar_sim.turbulence.io_source.FieldFile` keys).
    condition_on : tuple of RecordSpec
        Staring and conical scenes: measured records the field is
        conditioned on (the virtual twin, :mod:`cwlidar_sim.campaign.twin.run`):
        tables of :class:`cwlidar_sim.analysis.records.RecordSpec` keys
        (``path``, ``kind`` 'sonic' or 'cup', ``position`` [m], ``noise_std``
        [m/s], columns, units, cleaning); ``position`` is relative to the
        lidar's focus in the field's frame (staring) or to the lidar, the
        cone's apex, in the lidar's frame (conical: x toward its azimuth 0, y
        toward azimuth 90 deg, z up; a mast at the circle's centre at 40 m is
        ``[0, 0, 40]``; each box is conditioned on the records inside it).
        Relative paths are taken from the scene file's folder.  Default: none.
    """

    source: str | None = None
    z0: float | None = None
    obukhov_length: float | None = None
    alpha_eps: float | None = None
    length_scale: float | None = None
    gamma: float | None = None
    ti: float | None = None
    sigma_u: float | None = None
    iec_class: str | None = None
    height: float | None = None
    fit_to: str | None = None
    condition_on: tuple = ()
    fit_to_options: dict | None = None
    file: FieldFile | None = None

    #: The scene kind whose table this is (its defaults and refusals).
    _kind = "staring"
    #: The kind's default table (a table giving no key of MODE_KEYS); None: the table must pick a way.
    _default = None
    #: The kind's measurement height is each unit's (conical); False: the scene has none.
    _has_height = False
    #: The kind fits its tensor to a sonic record (``fit_to``).
    _takes_fit_to = True
    #: The kind can be a virtual twin conditioned on records (``condition_on``).
    _takes_condition_on = True
    #: The kind's twin needs one tensor for the whole scene (its periods are the records').
    _twin_needs_one_tensor = True

    #: The sub-tables of ``[turbulence]`` (the scene files' schema).
    _sub_tables = {"file": spec_table(FieldFile), "fit_to_options": Table(FIT_TO_OPTIONS)}

    def __post_init__(self):
        set_field(self, "condition_on", check_condition_on(self.condition_on))
        self._check_file()
        given = {k for k in MODE_KEYS + ("z0", "obukhov_length", "height") if getattr(self, k) is not None}
        if not given & set(MODE_KEYS):
            if self._default is None:
                raise ValueError("turbulence needs one of: alpha_eps, length_scale and gamma (the Mann tensor); "
                                 "ti, sigma_u or iec_class (what you know, with height); source = 'mann1994' or "
                                 "'iec' (the surface layer, with height); fit_to (a sonic record)")
            for k, v in self._default.items():
                set_field(self, k, v)
            given |= set(self._default)
        self._check_values()
        mode = self.mode
        explicit = [k for k in ("alpha_eps", "length_scale", "gamma") if getattr(self, k) is not None]
        known = [k for k in KNOWN_KEYS if getattr(self, k) is not None]
        if self.fit_to is not None:
            others = sorted(given - {"fit_to"})
            if others:
                raise ValueError(f"turbulence: fit_to fits the tensor to a record; give either fit_to or "
                                 f"{', '.join(others)}, not both")
            if not self._takes_fit_to:
                raise ValueError(f"turbulence.fit_to = {self.fit_to!r}: only a staring scene fits its tensor to a "
                                 f"sonic record (kinds that take fit_to: staring); give the tensor's keys here")
        elif mode == "known":
            if len(known) > 1:
                raise ValueError(f"turbulence: {' and '.join(known)} each set sigma_u; keep one of them")
            for k in ("alpha_eps", "source", "z0", "obukhov_length"):
                if getattr(self, k) is not None:
                    raise ValueError(f"turbulence: {known[0]} sets sigma_u (and with it alpha_eps); {k} belongs to "
                                     f"another way; keep {known[0]} or {k}")
        elif mode == "surface":
            for k in explicit + [k for k in KNOWN_KEYS if getattr(self, k) is not None]:
                raise ValueError(f"turbulence: source = {self.source!r} sets the tensor from the surface layer; "
                                 f"{k} belongs to another way; keep source or {k} (source = 'fixed' takes "
                                 f"alpha_eps, length_scale, gamma)")
            if self.z0 is None:
                set_field(self, "z0", 0.01)
            if self.source == "iec" and self.obukhov_length is not None:
                raise ValueError(f"turbulence.obukhov_length = {self.obukhov_length!r}: source = 'iec' is the neutral "
                                 f"surface layer; use source = 'mann1994' for stability, or drop obukhov_length")
        else:  # explicit
            if self.obukhov_length is not None:
                raise ValueError("turbulence.obukhov_length sets the surface layer's stability; it needs source = "
                                 "'mann1994' (not the explicit alpha_eps, length_scale, gamma)")
            if self.source is None and self.z0 is not None:
                raise ValueError("turbulence.z0 is the surface layer's roughness; it needs source = 'mann1994' or "
                                 "'iec' (not the explicit alpha_eps, length_scale, gamma)")
            if self.height is not None:
                raise ValueError("turbulence.height is where ti / sigma_u / iec_class or the surface layer are "
                                 "taken; the explicit alpha_eps, length_scale, gamma hold at every height: drop height")
            if self.source == "fixed" and self.z0 is None:
                set_field(self, "z0", 0.01)  # the older spelling's stored default (a scene's identity)
            for k in ("alpha_eps", "length_scale", "gamma"):  # the kind's default tensor fills what is left out
                if getattr(self, k) is None and k in (self._default or {}):
                    set_field(self, k, self._default[k])
            missing = [k for k in ("alpha_eps", "length_scale", "gamma") if getattr(self, k) is None]
            if missing:
                what = "source = 'fixed'" if self.source == "fixed" else "the explicit Mann tensor"
                raise ValueError(f"turbulence: {what} needs alpha_eps, length_scale and gamma; missing "
                                 f"{', '.join(missing)} (or give ti, sigma_u or iec_class for alpha_eps)")
            p = _prefixed(MannParameters, self.alpha_eps, self.length_scale, self.gamma)
            set_field(self, "alpha_eps", p.alpha_eps)
            set_field(self, "length_scale", p.length_scale)
            set_field(self, "gamma", p.gamma)
        if self.condition_on:
            if not self._takes_condition_on:
                raise ValueError("turbulence.condition_on: the virtual twin conditions staring and conical scenes "
                                 "(kinds that take condition_on: staring, conical), not a nacelle scene")
            if self._twin_needs_one_tensor and self.depends_on_speed:
                raise ValueError(f"turbulence.condition_on: a staring twin needs one tensor for the scene (its "
                                 f"periods are the records'), but {self._speed_key()} makes it depend on the "
                                 f"period's mean speed; give alpha_eps, length_scale, gamma (or sigma_u) instead")
        if not self._has_height and self.height is None and self.depends_on_height:
            why = ("the surface layer is taken at a height" if mode == "surface"
                   else f"{known[0]} without length_scale takes IEC's length scale at a height")
            raise ValueError(f"turbulence.height: a {self._kind} scene has no measurement height of its own and "
                             f"{why}; give height [m]" + ("" if mode == "surface" else " or length_scale [m]"))
        if self.height is not None and self.obukhov_length is not None:
            self.resolve(self.height, 10.0)  # |L_MO| >= height / 2, named

    def _check_file(self):
        """``file`` as a :class:`FieldFile` and ``fit_to_options`` checked (each error names its TOML path)."""
        f = self.file
        if f is not None and not isinstance(f, FieldFile):
            if isinstance(f, str):
                f = {"path": f}
            if not isinstance(f, dict):
                raise TypeError(f"turbulence.file must be a path or a table (path, format, ...), got "
                                f"{type(f).__name__} {f!r}")
            keys = [x.name for x in dataclasses.fields(FieldFile)]
            unknown = sorted(set(f) - set(keys))
            if unknown:
                raise ValueError(f"turbulence.file: unknown keys {unknown}; allowed: {keys}")
            if "path" not in f:
                raise ValueError("turbulence.file is missing the required key 'path'")
            with at_path("turbulence.file", keys, owner="FieldFile"):
                f = FieldFile(**f)
            set_field(self, "file", f)
        if f is not None and self.condition_on:
            raise ValueError("turbulence.file: the virtual twin conditions the boxes it generates "
                             "(turbulence.condition_on); give file or condition_on, not both")
        opts = self.fit_to_options
        if opts is not None:
            if not isinstance(opts, dict):
                raise TypeError(f"turbulence.fit_to_options must be a table of record-file options, got {opts!r}")
            unknown = sorted(set(opts) - set(FIT_TO_OPTIONS))
            if unknown:
                raise ValueError(f"turbulence.fit_to_options: unknown keys {unknown}; allowed: {list(FIT_TO_OPTIONS)}")
            if self.fit_to is None:
                raise ValueError("turbulence.fit_to_options says how the fit_to record is written; it needs fit_to")
            from ...analysis.records import RecordSpec

            with at_path("turbulence.fit_to_options", FIT_TO_OPTIONS, owner="RecordSpec"):
                RecordSpec("record.csv", **opts)  # the values, checked by the reader's own rules
            set_field(self, "fit_to_options", dict(opts))

    def check_files(self, base_dir: str = ".") -> None:
        """The files the table names exist (``file``; relative paths from ``base_dir``, the scene file's folder)."""
        if self.file is not None:
            self.file.check_files(base_dir, "turbulence.file")

    def field_source(self, base_dir: str = "."):
        """``source(region, U, duration) -> Dataset`` of ``file``, read and placed, or None (a generated box).

        The one place every kind gets its field file from
        (:meth:`cwlidar_sim.turbulence.io_source.FieldFile.place`, through
        :func:`cwlidar_sim.turbulence.cover.cover_box`'s ``source``).
        """
        if self.file is None:
            return None
        import functools

        return functools.partial(self.file.place, base_dir=base_dir, label="turbulence.file")

    def _check_values(self):
        """Types and ranges of the keys given (each error names ``turbulence.<key>``, the value and the range)."""
        if self.source is not None:
            check_choice("turbulence.source", self.source, SOURCES)
        if self.z0 is not None:
            set_field(self, "z0", check_real("turbulence.z0", self.z0, lo=0.0, hi=2.0, lo_open=True))
        if self.obukhov_length is not None:
            L = self.obukhov_length
            if isinstance(L, bool) or not isinstance(L, (int, float)) or math.isnan(L) or L == 0:
                raise ValueError(f"turbulence.obukhov_length={L!r} is out of range; allowed: a non-zero length [m] "
                                 f"(negative unstable, positive stable, inf neutral), |L| >= height / 2")
            set_field(self, "obukhov_length", float(L))
        if self.ti is not None:
            set_field(self, "ti", check_real("turbulence.ti", self.ti, lo=0.0, hi=MAX_TURBULENCE_INTENSITY,
                                             lo_open=True))
        if self.sigma_u is not None:
            set_field(self, "sigma_u", check_real("turbulence.sigma_u", self.sigma_u, lo=0.0, hi=20.0, lo_open=True))
        if self.iec_class is not None:
            check_choice("turbulence.iec_class", self.iec_class, tuple(IEC_REFERENCE_INTENSITY))
        if self.height is not None:
            set_field(self, "height", check_real("turbulence.height", self.height, lo=1.0, hi=1000.0))
        if self.fit_to is not None:
            check_str("turbulence.fit_to", self.fit_to)
        if self.mode == "known":
            # the optional length_scale and gamma, in the model's ranges (named), before any period is resolved
            _prefixed(MannParameters, 1.0, 1.0 if self.length_scale is None else self.length_scale,
                      IEC_GAMMA if self.gamma is None else self.gamma)

    # -- what the table sets ----------------------------------------------
    @property
    def mode(self) -> str:
        """How the tensor is set: 'fit', 'known', 'surface' or 'explicit' (module notes)."""
        if self.fit_to is not None:
            return "fit"
        if any(getattr(self, k) is not None for k in KNOWN_KEYS):
            return "known"
        if self.source in ("mann1994", "iec"):
            return "surface"
        return "explicit"

    @property
    def depends_on_speed(self) -> bool:
        """Whether the tensor depends on the period's mean speed (``ti``, ``iec_class``, the surface layer)."""
        return self.mode == "surface" or (self.mode == "known" and self.sigma_u is None)

    @property
    def depends_on_height(self) -> bool:
        """Whether the tensor depends on the height it is taken at (absent ``height``: the unit's)."""
        return self.mode == "surface" or (self.mode == "known" and self.length_scale is None)

    def _speed_key(self) -> str:
        return "source" if self.mode == "surface" else next(k for k in KNOWN_KEYS if getattr(self, k) is not None)

    def target_sigma_u(self, speed: float) -> float:
        """The sigma_u [m/s] that ``ti`` / ``sigma_u`` / ``iec_class`` set at mean speed ``speed`` [m/s]."""
        if self.ti is not None:
            return self.ti * speed
        if self.sigma_u is not None:
            return self.sigma_u
        return iec_sigma_u(self.iec_class, speed)

    def resolve(self, height=None, speed=None):
        """(MannParameters, sigma_u target or None, u* or None) at ``height`` [m] and mean ``speed`` [m/s].

        ``height`` is the unit's measurement height (``turbulence.height``
        overrides it); the explicit tensor needs neither, the others need
        what they depend on.  sigma_u target: the surface layer's, or the
        sigma_u of ``ti`` / ``sigma_u`` / ``iec_class`` (which the tensor's
        longitudinal variance equals); u*: the surface layer's.  None for
        ``fit_to`` (the tensor is the fit's).
        """
        mode = self.mode
        if mode == "fit":
            return None, None, None
        if mode == "explicit":
            return MannParameters(self.alpha_eps, self.length_scale, self.gamma), None, None
        z = self.height if self.height is not None else height
        if self.depends_on_height and z is None:
            raise ValueError(f"turbulence: {self._speed_key()} needs the height the tensor is taken at; give "
                             f"turbulence.height [m]")
        if self.depends_on_speed and speed is None:
            raise ValueError(f"turbulence: {self._speed_key()} depends on the period's mean speed; resolve it per "
                             f"period")
        if mode == "surface":
            return _prefixed(surface_layer_parameters, z, speed, z0=self.z0, source=self.source,
                             obukhov_length=self.obukhov_length)
        su = self.target_sigma_u(speed)
        L = self.length_scale if self.length_scale is not None else iec_length_scale(z)
        g = IEC_GAMMA if self.gamma is None else self.gamma
        unit = longitudinal_std(MannParameters(1.0, L, g)) ** 2  # sigma_u^2 of alpha_eps = 1 at this L, Gamma
        return _prefixed(MannParameters, su**2 / unit, L, g), su, None

    def params(self, height=None, speed=None):
        """The :class:`cwlidar_sim.turbulence.MannParameters` at ``height`` and ``speed`` (None for ``fit_to``).

        Without arguments: the one tensor of a table that depends on neither
        (explicit, or ``sigma_u`` with ``height`` or ``length_scale``).
        """
        return self.resolve(height, speed)[0]

    def check_frozen(self, periods, heights=(None,), where="turbulence.height") -> None:
        """Taylor's limit sigma_u / U <= 0.5 for every period (``.name``, ``.mean_speed``) at every height.

        ``heights``: the scene's measurement heights [m] (None: the scene
        has none; ``turbulence.height`` overrides them), named ``where`` in
        the surface layer's message.  Checked from the keys given where that
        is exact (``ti``, ``sigma_u``, ``iec_class``: the tensor's sigma_u is
        theirs; the neutral surface layer: sigma_u / U = c kappa / ln(z / z0)
        whatever U), else on the resolved tensor.  ``fit_to``: checked when
        the fit is known.
        """
        mode = self.mode
        if mode == "fit":
            return
        if self.height is not None:
            heights, where = (self.height,), "turbulence.height"
        if mode == "explicit":
            p = self.params()
            for i, per in enumerate(periods):
                check_frozen_turbulence(p, per.mean_speed, entry_label("period", i, per.name))
        elif mode == "known":
            key = self._speed_key()
            for i, per in enumerate(periods):
                U = per.mean_speed
                su = self.target_sigma_u(U)
                if su / U > MAX_TURBULENCE_INTENSITY * (1 + 1e-12):
                    if key == "sigma_u":
                        allowed = f"sigma_u <= {MAX_TURBULENCE_INTENSITY * U:g} m/s at this U"
                    else:  # iec_class: I_ref (0.75 U + b) <= 0.5 U
                        iref = IEC_REFERENCE_INTENSITY[self.iec_class]
                        umin = iref * IEC_NTM_B / (MAX_TURBULENCE_INTENSITY - 0.75 * iref)
                        allowed = f"mean_speed >= {umin:.3g} m/s for this class, or a lower class"
                    raise ValueError(
                        f"turbulence.{key} = {getattr(self, key)!r} gives sigma_u = {su:.3g} m/s, a turbulence "
                        f"intensity sigma_u/U = {su / U:.2f} in {entry_label('period', i, per.name)} (mean_speed = {U:g} m/s), above "
                        f"the {MAX_TURBULENCE_INTENSITY:g} that Taylor's frozen-turbulence hypothesis carries; "
                        f"allowed: {allowed}")
        else:
            z0 = self.z0
            zmin = min(heights)
            if zmin <= z0:
                raise ValueError(f"{where}: {zmin:g} m is not above turbulence.z0 = {z0:g} m; the surface layer's "
                                 f"log law needs heights above the roughness length")
            if self.obukhov_length is None or math.isinf(self.obukhov_length):
                # the surface layer's sigma_u / U = c kappa / ln(z / z0), whatever U (c = sigma_u / u*: 2.4 for
                # 'iec', 2.24 for Mann's fit): in closed form, without the tensors' quadratures
                ti = SURFACE_SIGMA_U_OVER_USTAR * 0.4 / math.log(zmin / z0)
                if ti > MAX_TURBULENCE_INTENSITY:
                    raise ValueError(
                        f"{where}: {zmin:g} m over turbulence.z0 = {z0:g} m gives a surface-layer turbulence "
                        f"intensity sigma_u/U = {ti:.2f}, above the {MAX_TURBULENCE_INTENSITY:g} that Taylor's "
                        f"frozen-turbulence hypothesis carries; allowed: heights >= "
                        f"{z0 * math.exp(SURFACE_SIGMA_U_OVER_USTAR * 0.4 / MAX_TURBULENCE_INTENSITY):.3g} m, or a "
                        f"smaller z0")
            else:  # stability: each tensor in closed form (one quadrature per Gamma), its range checked by name
                for z in heights:
                    for i, per in enumerate(periods):
                        p, su, _ = self.resolve(z, per.mean_speed)
                        check_frozen_turbulence(p, per.mean_speed, f"{entry_label('period', i, per.name)} at {z:g} m")

    # -- interchange --------------------------------------------------------
    @classmethod
    def from_dict(cls, d: dict):
        """Build from the ``[turbulence]`` table; unknown keys are rejected by name."""
        if not isinstance(d, dict):
            raise TypeError(f"turbulence must be a table, got {type(d).__name__}")
        check_scene_keys(d, [f.name for f in dataclasses.fields(cls)], (), "turbulence")
        return cls(**d)
