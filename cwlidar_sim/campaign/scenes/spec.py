"""Scene-spec machinery shared by every scene kind: TOML interchange, key checks, identity constants.

Every table of a scene file maps onto a frozen dataclass deriving from
:class:`Spec`: :meth:`Spec.as_dict` gives the TOML-shaped mapping (None
values dropped, TOML has no null; nested specs as tables, tuples as lists)
and :meth:`Spec.from_dict` rebuilds the spec from it, rejecting unknown keys
by name (``cwlidar_sim._validation.check_keys``).  The scene classes
themselves (:class:`cwlidar_sim.campaign.scenes.staring.Scene`,
:class:`cwlidar_sim.campaign.scenes.conical.ConicalScene`) use the scene-level
checks here (name, top-level keys, periods), so a staring and a conical
scene file report the same mistake in the same words.

This module sits at the bottom of :mod:`cwlidar_sim.campaign`: it imports
nothing of the campaign, and every scene, store and runner module may import it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re

import numpy as np

from ..._seeding import seed_int
from ..._validation import check_keys, check_real, check_str, closest_key
from .start_time import check_start_time

__all__ = ["RESULTS_VERSION", "Spec", "SceneSpec", "set_path", "select_periods", "spec_as_dict", "set_field", "check_scene_name",
           "check_scene_keys", "periods_from_dict", "check_periods", "check_condition_on", "read_text_file",
           "parse_toml", "open_regular_file", "toml_depth", "MAX_TOML_BYTES", "MAX_TOML_DEPTH", "check_distinct_reals",
           "resolve_path", "Table", "spec_table", "table_fields", "turbulence_schema", "entry_label", "prefix_path",
           "at_path", "table_from_dict", "unknown_keys_message", "check_dotted_key"]

#: Version of the results layout (part of a stored period's identity, :func:`cwlidar_sim.campaign.execution.store.scene_key`);
#: raised whenever stored periods would differ from what the code now computes (3: the gridded
#: tier-2 cosine sums, the nacelle coherence theory as the estimate sees it; 4: the fused gridded
#: tasks, 2048-point grids for A2012, whose tier-2 numbers differ at the rounding level, and the
#: one-point quadrature with edges about the shear peak, whose fits move by ~1e-5; 5: tier 3's
#: tones from per-estimate tables summed in float32, other bits of the same law; 6: the
#: misaligned-beam theory on the one-point quadrature's k3 nodes, its spectra moved by <= 3e-5; 7: one
#: availability, the usable fraction, NEAR_ZERO / NEAR_NYQUIST estimates left out of it and of the averaged
#: series: a conical period's ``availability`` drops by its zero-crossing loss; 8: a nacelle period keeps its
#: preview series, ``preview_estimate``, ``preview_rews`` and ``preview_delay``, for the preview file; 9: a conical
#: scene carries the continuum theory by default and ``scan.theory = "continuum"`` no longer the lattice (now
#: ``"lattice"``): a period stored before would mix units with and without the theory's variables; in the same
#: landing the nacelle ``*_theory`` values moved to the adaptive k1 grid (correlation by up to 0.007), staring and
#: nacelle periods gained ``*_theory_lattice``, WindScanner periods ``std_ratio*``, and boxes generated with
#: ``hf_compensation`` a corrected Nyquist-row gain).
RESULTS_VERSION = 9


def set_field(obj, name: str, value) -> None:
    """Set a field of a frozen dataclass (its validated, converted value) from ``__post_init__``."""
    object.__setattr__(obj, name, value)


def spec_as_dict(obj) -> dict:
    """Plain TOML-shaped dict of a spec: None values dropped, specs as tables, tuples as lists."""
    out = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if v is None:
            continue
        if dataclasses.is_dataclass(v):
            v = v.as_dict()
        elif f.name == "condition_on":
            if not v:
                continue  # an unconditioned scene keeps its key (and its stored results)
            v = condition_on_as_dicts(v)
        elif isinstance(v, tuple) and v and dataclasses.is_dataclass(v[0]):
            v = [x.as_dict() for x in v]
        elif isinstance(v, tuple):
            v = [dict(x) if isinstance(x, dict) else x for x in v]
        elif isinstance(v, dict):
            v = dict(v)
        out[f.name] = v
    return out


class Spec:
    """Base of the scene's frozen dataclasses: ``as_dict`` / ``from_dict`` round-trip.

    Subclasses are frozen dataclasses that validate in ``__post_init__``;
    ``_required`` names the keys :meth:`from_dict` needs.
    """

    _required: tuple = ()

    def as_dict(self) -> dict:
        """Plain TOML-shaped dict (round-trips through :meth:`from_dict`)."""
        return spec_as_dict(self)

    @classmethod
    def from_dict(cls, d: dict):
        """Build from a TOML-shaped mapping; unknown keys are rejected by name."""
        check_keys(cls, d, required=cls._required)
        return cls(**d)


def set_path(tree: dict, key: str, value) -> None:
    """Set the value at a dotted ``key`` of a scene's tree: 'a.b.c' is ``tree["a"]["b"]["c"]`` (numbers index lists).

    The key addresses a scene's TOML tree (:meth:`SceneSpec.as_dict`):
    ``lidar.cnr_db``, ``lidar.instrument.focus``, ``period.0.mean_speed`` for
    the first period.  A missing table on the way is created (the scene's
    checks then name a key that does not belong there).
    """
    if not isinstance(key, str):
        raise TypeError(f"scene key {key!r} must be a dotted string like 'lidar.cnr_db'")
    parts = key.split(".")
    if not all(parts):
        raise ValueError(f"scene key {key!r} is not a dotted path like 'lidar.cnr_db'")
    node = tree
    for i, part in enumerate(parts[:-1]):
        nxt = parts[i + 1]
        if isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ValueError(f"scene key {key!r}: {part!r} is not an index of a list of {len(node)}")
            node = node[int(part)]
            continue
        if part not in node or node[part] is None:
            node[part] = [] if nxt.isdigit() else {}
        node = node[part]
        if not isinstance(node, (dict, list)):
            raise ValueError(f"scene key {key!r}: {'.'.join(parts[:i + 1])!r} is a value, not a table")
    last = parts[-1]
    if isinstance(node, list):
        if not last.isdigit() or int(last) >= len(node):
            raise ValueError(f"scene key {key!r}: {last!r} is not an index of a list of {len(node)}")
        node[int(last)] = value
    else:
        node[last] = value


def select_periods(scene, names, what: str = "periods"):
    """``scene`` with only the periods named in ``names`` (in the scene's order), validated.

    The periods kept are numbered afresh, so a period without its own
    ``seed`` draws another realisation than in the whole scene (its seed
    derives from its position).  An unknown name is a ValueError listing
    the scene's periods.
    """
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise TypeError(f"{what} must be a list of period names, got {names!r}")
    have = [p.name for p in scene.periods]
    missing = [n for n in names if n not in have]
    if missing:
        raise ValueError(f"{what}: {missing} are not periods of scene {scene.name!r}; allowed: {have}")
    if not names:
        raise ValueError(f"{what} is empty; allowed: a list of some of {have}")
    return scene.replace(periods=tuple(p for p in scene.periods if p.name in names))


@dataclasses.dataclass(frozen=True)
class SceneSpec(Spec):
    """Base of the scene kinds (staring, conical, nacelle): parsing from TOML, a copy with dotted keys changed.

    A kind declares ``_tables`` (TOML table -> its spec class), ``_period_spec``
    (the ``[[period]]`` class), ``_required`` (keys a file must have) and
    ``_what`` (the noun in messages), and its ``schema()``.

    Every kind's scene file may name ``start_time``, the instant its first
    period starts (ISO 8601 with a time zone, kept as UTC text,
    :func:`~cwlidar_sim.campaign.scenes.start_time.check_start_time`); the periods follow one another from there
    (:mod:`cwlidar_sim.campaign.execution.cf`).  It gives the results an
    absolute time axis and changes no number; None (default): none.
    """

    start_time: str | None = dataclasses.field(default=None, kw_only=True)

    _required = ("name", "period")
    _what = "scene"

    @classmethod
    def _check_kind(cls, d: dict) -> None:
        """Refuse a mapping of another kind (a kind whose files may omit ``kind`` overrides this)."""

    @classmethod
    def from_dict(cls, d: dict, *, base_dir: str = "."):
        """Build from a TOML-shaped mapping; unknown keys are rejected by name, every error names its TOML path."""
        start = check_start_time(d.get("start_time")) if isinstance(d, dict) else None  # every kind's key
        if isinstance(d, dict) and "start_time" in d:
            d = {k: v for k, v in d.items() if k != "start_time"}
        check_scene_keys(d, cls.schema(), cls._required, cls._what)
        cls._check_kind(d)
        kw = {k: d[k] for k in ("name", "description", "seed", "duration") if k in d}
        if start is not None:
            kw["start_time"] = start
        for key, spec in cls._tables.items():
            if key in d:
                kw[key] = table_from_dict(spec, d[key], key)
        kw["periods"] = periods_from_dict(d["period"], cls._period_spec)
        return cls(base_dir=base_dir, **kw)

    def replace(self, **changes):
        """Copy with fields changed (validated)."""
        return dataclasses.replace(self, **changes)

    # -- units of work: one per period (a kind whose units differ overrides these) --
    def period_duration(self, period) -> float:
        """Length of a period [s]: its own, or the scene's ``duration``."""
        return self.duration if period.duration is None else period.duration

    def units(self) -> list:
        """The units in run order: the periods."""
        return list(self.periods)

    def unit_names(self) -> list:
        """Names of the units of work, in run order: the periods'."""
        return [p.name for p in self.periods]

    def row_names(self, index: int) -> list:
        """Names of the result rows of unit ``index``: its period's."""
        return [self.periods[index].name]

    def simulated_hours(self) -> float:
        """Simulated time of all units [h]."""
        return sum(self.period_duration(p) for p in self.periods) / 3600.0

    def unit_seed(self, index: int) -> int:
        """Seed of unit (period) ``index``: the period's own, or a child of the scene's (distinct across units)."""
        p = self.periods[index]
        if p.seed is not None:
            return p.seed
        return seed_int(np.random.SeedSequence(self.seed, spawn_key=(index,)))

    def with_values(self, values: dict):
        """A copy of the scene with the dotted keys of ``values`` set, validated like a scene file.

        Parameters
        ----------
        values : dict
            Dotted key of the scene's TOML tree -> new value, e.g.
            ``{"lidar.instrument.focus": 80.0, "duration": 1200.0,
            "period.0.mean_speed": 9.0}`` (the keys of a campaign file's
            ``[set]`` table, :mod:`cwlidar_sim.campaign.execution.sweep`).

        Returns
        -------
        scene
            A new scene of the same kind; this one is unchanged.

        Raises
        ------
        ValueError, TypeError
            A key the scene does not have, or a value its checks reject,
            named with the keys given.
        """
        if not isinstance(values, dict):
            raise TypeError(f"values must be a dict of dotted scene keys, got {type(values).__name__}")
        tree = self.as_dict()
        for key, value in values.items():
            set_path(tree, key, value)
        try:
            return type(self).from_dict(tree, base_dir=self.base_dir)
        except (ValueError, TypeError) as e:
            raise type(e)(f"scene {self.name!r} with {values}: {e}") from None


def resolve_path(base_dir: str, path: str) -> str:
    """A path named in a scene file: absolute as given, else relative to the scene file's folder ``base_dir``."""
    return path if os.path.isabs(path) else os.path.join(base_dir, path)


def check_distinct_reals(name: str, values, *, count: tuple, noun: str, lo: float, hi: float) -> tuple:
    """A scene's list of distinct reals (heights, focus distances) as a checked tuple.

    ``count`` is the (min, max) number of items, each ``name[i]`` in [lo, hi]; a wrong count, an
    item out of range or a repeated value is a ValueError naming the field.
    """
    v = tuple(values)
    if not count[0] <= len(v) <= count[1]:
        raise ValueError(f"{name} needs {count[0]} to {count[1]} {noun}, got {len(v)}")
    v = tuple(check_real(f"{name}[{i}]", x, lo=lo, hi=hi) for i, x in enumerate(v))
    if len(set(v)) != len(v):
        raise ValueError(f"{name} must be distinct, got {v}")
    return v


def check_scene_name(name) -> str:
    """A scene name (the results file's name): letters, digits, '-' and '_'."""
    check_str("name", name)
    if not all(c.isalnum() or c in "-_" for c in name):
        raise ValueError(f"name {name!r} may hold only letters, digits, '-' and '_'")
    return name


# -- the TOML path in every message ---------------------------------------------------------------
# A scene is read table by table; each table is parsed "at" its TOML path (``lidar``, ``lidar.instrument``,
# ``period[0] ('A')``), and an error raised inside is re-raised naming that path once (:func:`at_path`).
# Unknown keys are found before any table is parsed, for the whole file at once (:func:`check_scene_keys`),
# against the scene kind's schema: the TOML path of every table -> its keys, so that a key written in the
# wrong table is pointed to the one that has it.


@dataclasses.dataclass(frozen=True)
class Table:
    """The keys of one table of a scene's schema.

    Parameters
    ----------
    keys : tuple of str
        The keys the table takes.
    explained : tuple of str
        Keys the table's parser refuses with its own message (a key that moved
        elsewhere); not reported as unknown, never suggested.
    """

    keys: tuple
    explained: tuple = ()


def table_fields(cls) -> tuple:
    """The keys of a spec dataclass's table: its fields (not ``base_dir``)."""
    return tuple(f.name for f in dataclasses.fields(cls) if f.name != "base_dir")


def spec_table(cls) -> Table:
    """The :class:`Table` of a spec class: its fields, and the keys its ``from_dict`` explains (``_explained_keys``)."""
    return Table(table_fields(cls), tuple(getattr(cls, "_explained_keys", ())))


def turbulence_schema(cls) -> dict:
    """Schema entries of a ``[turbulence]`` table of class ``cls``, with its ``condition_on`` records if it has them."""
    out = {"turbulence": spec_table(cls)}
    if "condition_on" in table_fields(cls):
        from ...analysis.records import RecordSpec

        out["turbulence.condition_on[]"] = spec_table(RecordSpec)
    for key, table in getattr(cls, "_sub_tables", {}).items():  # [turbulence.file], [turbulence.fit_to_options]
        out[f"turbulence.{key}"] = table
    return out


def entry_label(array: str, index: int, name=None) -> str:
    """How messages name entry ``index`` of the array of tables ``array``: ``period[0] ('A')``, ``period[2]``."""
    return f"{array}[{index}]" + (f" ({name!r})" if isinstance(name, str) and name else "")


def prefix_path(path: str, message: str, keys=(), owner: str | None = None) -> str:
    """``message`` naming the TOML ``path`` once.

    A message that already starts with ``path`` is kept; one that starts
    with a key of the table (``gamma=30 is ...``) becomes ``path.gamma=30
    is ...``; a leading ``owner.`` (a class name some checks write) is
    replaced by ``path.``; any other becomes ``path: message``.
    """
    if message == path or (message.startswith(path) and message[len(path)] in ".[ :=("):
        return message
    if owner and message.startswith(owner + "."):
        return f"{path}.{message[len(owner) + 1:]}"
    m = re.match(r"[A-Za-z_]\w*", message)
    if m and m.group() in keys and message[m.end():m.end() + 1] in ("", ".", "[", "=", " ", ":"):
        return f"{path}.{message}"
    return f"{path}: {message}"


@contextlib.contextmanager
def at_path(path: str, keys=(), owner: str | None = None):
    """Re-raise a ValueError or TypeError raised inside naming ``path`` once (:func:`prefix_path`)."""
    try:
        yield
    except (ValueError, TypeError) as e:
        raise type(e)(prefix_path(path, str(e), keys, owner)) from None


def table_from_dict(cls, d, path: str):
    """``cls.from_dict(d)`` for the table at TOML ``path``; every error names the path once.

    ``d`` must be a table holding ``cls._required``; the keys themselves are
    checked beforehand, for the whole scene (:func:`check_scene_keys`).
    """
    if not isinstance(d, dict):
        raise TypeError(f"{path} must be a table, got {type(d).__name__} {d!r}")
    missing = [k for k in getattr(cls, "_required", ()) if k not in d]
    if missing:
        raise ValueError(f"{path} is missing the required key(s) {missing}")
    with at_path(path, table_fields(cls)):
        return cls.from_dict(d)


def _below(pattern: str, table: str) -> bool:
    """Whether the schema table ``pattern`` lies inside ``table`` (every table lies inside the top, '')."""
    return pattern != table and (table == "" or pattern.startswith(table + ".") or pattern.startswith(table + "["))


def _place(key: str, pattern: str, table: str) -> str:
    """Where ``key`` of the schema table ``pattern`` is written, said from inside ``table``."""
    if pattern.endswith("[]"):
        array = pattern[:-2]
        where = f"{array}[i].{key}"
        if table and array.startswith(table + ".") and "." not in array[len(table) + 1:]:
            return f"{where}, i.e. {array[len(table) + 1:]} = [{{ ..., {key} = ... }}]"
        return f"{where}, i.e. {key} in each [[{array}]]" if "[" not in array else where
    where = f"{pattern}.{key}"
    rel = pattern[len(table) + 1:] if table and pattern.startswith(table + ".") else None
    if rel and not re.search(r"[.\[]", rel):
        return f"{where}, i.e. {rel} = {{ {key} = ... }}"
    return where


def _hint(key: str, table: str, schema: dict) -> str | None:
    """Where an unknown ``key`` of ``table`` probably belongs: the table (nested first) that has it, else
    this table's closest key, else the closest key of a table right inside it."""
    key = str(key)
    others = [p for p, t in schema.items() if p != table and key in t.keys]
    if others:
        others.sort(key=lambda p: not _below(p, table))
        return _place(key, others[0], table)
    near = closest_key(key, schema[table].keys) if table in schema else None
    if near:
        return repr(near)
    for p, t in schema.items():  # a misspelt key of a table right inside this one (not across the scene: too loose)
        if table and _below(p, table) and not re.search(r"[.\[]", p[len(table) + 1:].removesuffix("[]")):
            near = closest_key(key, t.keys)
            if near:
                return _place(near, p, table)
    return None


def unknown_keys_message(where: str, unknown, table: str, schema: dict) -> str:
    """One line: the unknown keys of the table named ``where`` (pattern ``table`` of ``schema``), where each
    probably belongs (a table that has it, else the closest key), and the table's keys."""
    pairs = []
    for k in unknown:
        h = _hint(k, table, schema)
        if h:
            pairs.append(h.replace(", i.e.", f" for {k!r}, i.e.", 1) if ", i.e." in h else f"{h} for {k!r}")
    hint = f" (did you mean {'; '.join(pairs)}?)" if pairs else ""
    return f"unknown key(s) in {where}: {sorted(unknown)}{hint}; allowed: {sorted(schema[table].keys)}"


def _as_schema(schema) -> dict:
    """A schema with a :class:`Table` for every path (a plain collection of keys: the top level alone)."""
    if not isinstance(schema, dict):
        schema = {"": schema}
    return {p: t if isinstance(t, Table) else Table(tuple(t)) for p, t in schema.items()}


def _tables(d: dict, pattern: str):
    """(table, label) of every table of the scene mapping ``d`` at the schema ``pattern`` (those present)."""
    nodes = [(d, "")]
    for part in pattern.split("."):
        array = part.endswith("[]")
        name = part[:-2] if array else part
        nxt = []
        for node, label in nodes:
            v = node.get(name) if isinstance(node, dict) else None
            path = f"{label}.{name}" if label else name
            if array and isinstance(v, (list, tuple)):
                nxt.extend((e, entry_label(path, i, e.get("name"))) for i, e in enumerate(v) if isinstance(e, dict))
            elif not array and isinstance(v, dict):
                nxt.append((v, path))
        nodes = nxt
    return nodes


def check_scene_keys(d, schema, required, what: str) -> None:
    """A scene mapping: a table, every key of ``required``, and no unknown key in any of its tables.

    Parameters
    ----------
    d : dict
        The scene's parsed TOML.
    schema : dict
        TOML path of each table -> its :class:`Table` (or its keys): ``''``
        the top level, ``'lidar.instrument'`` a nested table, ``'period[]'``
        each entry of an array of tables.  An unknown key is reported with
        the table's path and a hint where it belongs (a table that has it,
        nested ones first, else the closest key by spelling); a plain set of
        keys stands for the top level alone.
    required : iterable of str
        Top-level keys that must be present.
    what : str
        How the messages name the top level ('scene', 'conical scene').
    """
    schema = _as_schema(schema)
    if not isinstance(d, dict):
        raise TypeError(f"a scene must be a table, got {type(d).__name__}")
    for pattern, table in schema.items():
        for node, label in ([(d, what)] if pattern == "" else _tables(d, pattern)):
            unknown = sorted(set(node) - set(table.keys) - set(table.explained))
            if unknown:
                raise ValueError(unknown_keys_message(label, unknown, pattern, schema))
        if pattern == "":
            for key in required:
                if key not in d:
                    raise ValueError(f"{what} is missing the required key {key!r}")


def check_dotted_key(key: str, schema: dict, what: str = "scene") -> None:
    """A dotted scene key (``lidar.instrument.estimator``, ``period.0.mean_speed``) that names a key of
    ``schema``'s tables (:func:`check_scene_keys`), else a ValueError naming the unknown part, where it
    probably belongs and the table's keys.  What lies below a key that is no table of the schema (a
    value, ``platform.phase_deg.surge``) is left to the scene's own checks."""
    schema = _as_schema(schema)
    parts = key.split(".")
    pattern, label, i = "", what, 0
    while i < len(parts):
        part, table = parts[i], schema[pattern]
        if part not in table.keys and part not in table.explained:
            raise ValueError(f"scene key {key!r}: {unknown_keys_message(label, [part], pattern, schema)}")
        child = f"{pattern}.{part}" if pattern else part
        path = f"{label}.{part}" if pattern else part
        if f"{child}[]" in schema and i + 1 < len(parts):
            if not parts[i + 1].isdigit():
                raise ValueError(f"scene key {key!r}: {path} is an array of tables, its entries are "
                                 f"{'.'.join(parts[:i + 1])}.0, .1, ...; allowed: e.g. "
                                 f"{'.'.join(parts[:i + 1])}.0.{parts[i + 1]}")
            pattern, label, i = f"{child}[]", f"{path}[{parts[i + 1]}]", i + 2
        elif child in schema:
            pattern, label, i = child, path, i + 1
        else:
            return


def periods_from_dict(periods, cls) -> tuple:
    """The ``[[period]]`` array of a scene mapping as a tuple of ``cls`` specs (errors name ``period[i] ('A')``)."""
    if not isinstance(periods, (list, tuple)):
        raise TypeError("period must be an array of tables ([[period]])")
    return tuple(table_from_dict(cls, p, entry_label("period", i, p.get("name") if isinstance(p, dict) else None))
                 for i, p in enumerate(periods))


def check_periods(periods, cls, what: str) -> tuple:
    """At least one period, every one a ``cls``, names unique."""
    periods = tuple(periods)
    if not periods:
        raise ValueError(f"a {what} needs at least one [[period]]")
    if not all(isinstance(p, cls) for p in periods):
        raise TypeError(f"periods must be {cls.__name__} instances, got "
                        f"{sorted({type(p).__name__ for p in periods})}")
    names = [p.name for p in periods]
    if len(set(names)) != len(names):
        raise ValueError(f"period names must be unique, got {names}")
    return periods


def check_condition_on(entries) -> tuple:
    """``[turbulence] condition_on``: a tuple of :class:`~cwlidar_sim.analysis.records.RecordSpec`, names unique.

    Each entry is a RecordSpec or its table (unknown keys rejected by name,
    every value checked by the spec); an error names the entry's index.
    """
    from ...analysis.records import RecordSpec

    if isinstance(entries, (dict, str, bytes)) or not isinstance(entries, (list, tuple)):
        raise TypeError(f"turbulence.condition_on must be an array of tables (one per record), got "
                        f"{type(entries).__name__}")
    out = []
    for i, e in enumerate(entries):
        if isinstance(e, RecordSpec):
            out.append(e)
            continue
        where = entry_label("turbulence.condition_on", i, e.get("name") if isinstance(e, dict) else None)
        if not isinstance(e, dict):
            raise TypeError(f"{where} must be a table of record keys, got {type(e).__name__}")
        schema = {"turbulence.condition_on[]": spec_table(RecordSpec)}
        unknown = sorted(set(e) - set(table_fields(RecordSpec)))
        if unknown:
            raise ValueError(unknown_keys_message(where, unknown, "turbulence.condition_on[]", schema))
        if "path" not in e:
            raise ValueError(f"{where} is missing the required key(s) ['path']")
        with at_path(where, table_fields(RecordSpec), owner="RecordSpec"):
            out.append(RecordSpec.from_dict(dict(e)))
    names = [r.name for r in out]
    if len(set(names)) != len(names):
        raise ValueError(f"turbulence.condition_on: record names must be unique, got {names} (set name = ...)")
    return tuple(out)


def condition_on_as_dicts(entries) -> list:
    """The records of ``condition_on`` as TOML-shaped tables (None and empty values dropped)."""
    return [{k: v for k, v in r.as_dict().items() if v is not None and v != {}} for r in entries]


#: Largest TOML file read [bytes]: the biggest scene or campaign file is a few kB; a file far
#: larger is not one (a log, a data file named by mistake) and is refused before it is read.
MAX_TOML_BYTES = 1 << 20
#: Deepest nesting of tables and arrays accepted in a TOML file: a scene goes 4 levels deep
#: ([[turbulence.condition_on]] with its inline tables); Python's parser recurses once per level
#: and fails with a RecursionError near a thousand.
MAX_TOML_DEPTH = 32


def open_regular_file(path, what: str):
    """A binary file object for ``path`` after checking it is a regular file (never blocks).

    The file is opened non-blocking and checked with ``fstat`` on the open
    descriptor, so a FIFO, a socket, a device or a directory named like a
    data file is refused at once instead of blocking the reader forever.

    Raises
    ------
    ValueError
        Naming ``what``, the path and what it is instead.
    """
    import stat

    path = os.fspath(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except IsADirectoryError:
        raise ValueError(f"{what} {path!r} is a directory, not a file") from None
    except OSError as e:
        raise ValueError(f"cannot read {what} {path!r}: {e.strerror or e}") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        kind = ("a directory" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
                else "a socket" if stat.S_ISSOCK(mode) else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
                else "not a regular file")
        why = "" if stat.S_ISDIR(mode) else " (reading it could block forever)"
        raise ValueError(f"{what} {path!r} is {kind}, not a regular file; refused{why}")
    if hasattr(os, "set_blocking"):
        os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def read_text_file(path, what: str) -> tuple[str, str]:
    """(text, folder) of a TOML file; an unreadable, oversized or non-UTF-8 one: a ValueError naming ``what`` and it.

    The file must be a regular file (:func:`open_regular_file`) of at most
    :data:`MAX_TOML_BYTES`, checked before it is read.
    """
    path = os.fspath(path)
    with open_regular_file(path, f"{what} file") as fh:
        size = os.fstat(fh.fileno()).st_size
        if size > MAX_TOML_BYTES:
            raise ValueError(f"{what} file {path!r} is {size} bytes, more than the {MAX_TOML_BYTES} bytes a "
                             f"{what} file may have (a scene or campaign file is a few kB); refused before reading")
        try:
            data = fh.read(MAX_TOML_BYTES + 1)
        except OSError as e:
            raise ValueError(f"cannot read {what} file {path!r}: {e.strerror or e}") from None
    if len(data) > MAX_TOML_BYTES:  # grew while read
        raise ValueError(f"{what} file {path!r} is more than {MAX_TOML_BYTES} bytes; refused")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ValueError(f"{what} file {path!r} is not UTF-8 text (byte {e.start}: {e.reason}); "
                         f"a TOML file must be UTF-8") from None
    return text, os.path.dirname(os.path.abspath(path))


def toml_depth(obj) -> int:
    """Nesting depth of parsed TOML (tables and arrays; a scalar is 0), walked without recursion."""
    deepest, stack = 0, [(obj, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            children = node.values()
        elif isinstance(node, list):
            children = node
        else:
            continue
        deepest = max(deepest, depth + 1)
        stack.extend((c, depth + 1) for c in children)
    return deepest


def parse_toml(text: str, what: str) -> dict:
    """TOML text as a dict; invalid or too deeply nested TOML is a ValueError naming ``what``.

    Nesting deeper than :data:`MAX_TOML_DEPTH` levels is refused: no scene
    needs it, and the parser (recursive) or the code reading the tables
    would otherwise end in a RecursionError traceback.
    """
    import tomllib

    if not isinstance(text, str):
        raise TypeError(f"{what} text must be a str, got {type(text).__name__}")
    if len(text) > MAX_TOML_BYTES:
        raise ValueError(f"{what} is {len(text)} characters, more than the {MAX_TOML_BYTES} a {what} file may have")
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{what} is not valid TOML: {e}") from None
    except RecursionError:
        raise ValueError(f"{what}: TOML nested deeper than {MAX_TOML_DEPTH} levels (tables or arrays); "
                         f"refused") from None
    depth = toml_depth(d)
    if depth > MAX_TOML_DEPTH:
        raise ValueError(f"{what}: TOML nested deeper than {MAX_TOML_DEPTH} levels ({depth} levels of tables or "
                         f"arrays); refused")
    return d
