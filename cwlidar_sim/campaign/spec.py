"""Scene-spec machinery shared by every scene kind: TOML interchange, key checks, identity constants.

Every table of a scene file maps onto a frozen dataclass deriving from
:class:`Spec`: :meth:`Spec.as_dict` gives the TOML-shaped mapping (None
values dropped, TOML has no null; nested specs as tables, tuples as lists)
and :meth:`Spec.from_dict` rebuilds the spec from it, rejecting unknown keys
by name (``cwlidar_sim._validation.check_keys``).  The scene classes
themselves (:class:`cwlidar_sim.campaign.scene.Scene`,
:class:`cwlidar_sim.campaign.conical_scene.ConicalScene`) use the scene-level
checks here (name, top-level keys, periods), so a staring and a conical
scene file report the same mistake in the same words.

This module sits at the bottom of :mod:`cwlidar_sim.campaign`: it imports
nothing of the campaign, and every scene, store and runner module may import it.
"""

from __future__ import annotations

import dataclasses
import os

from .._validation import check_keys, check_real, check_str, did_you_mean

__all__ = ["RESULTS_VERSION", "SCENE_KINDS", "Spec", "SceneSpec", "set_path", "select_periods", "spec_as_dict", "set_field", "check_scene_name",
           "check_scene_keys", "periods_from_dict", "check_periods", "check_condition_on", "read_text_file",
           "parse_toml", "open_regular_file", "toml_depth", "MAX_TOML_BYTES", "MAX_TOML_DEPTH", "check_distinct_reals",
           "resolve_path"]

#: Version of the results layout (part of a stored period's identity, :func:`cwlidar_sim.campaign.store.scene_key`);
#: raised whenever stored periods would differ from what the code now computes (3: the gridded
#: tier-2 cosine sums, the nacelle coherence theory as the estimate sees it; 4: the fused gridded
#: tasks, 2048-point grids for A2012, whose tier-2 numbers differ at the rounding level, and the
#: one-point quadrature with edges about the shear peak, whose fits move by ~1e-5; 5: tier 3's
#: tones from per-estimate tables summed in float32, other bits of the same law; 6: the
#: misaligned-beam theory on the one-point quadrature's k3 nodes, its spectra moved by <= 3e-5; 7: one
#: availability, the usable fraction, NEAR_ZERO / NEAR_NYQUIST estimates left out of it and of the averaged
#: series: a conical period's ``availability`` drops by its zero-crossing loss).
RESULTS_VERSION = 7
#: Scene kinds: ``kind`` in a scene file (default 'staring').
SCENE_KINDS = ("staring", "conical", "nacelle")


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


class SceneSpec(Spec):
    """Base of the scene kinds (staring, conical, nacelle): a copy with dotted keys changed."""

    def with_values(self, values: dict):
        """A copy of the scene with the dotted keys of ``values`` set, validated like a scene file.

        Parameters
        ----------
        values : dict
            Dotted key of the scene's TOML tree -> new value, e.g.
            ``{"lidar.instrument.focus": 80.0, "duration": 1200.0,
            "period.0.mean_speed": 9.0}`` (the keys of a campaign file's
            ``[set]`` table, :mod:`cwlidar_sim.campaign.sweep`).

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


def check_scene_keys(d, allowed, required, what: str) -> None:
    """A scene mapping: a table, no key outside ``allowed``, every key of ``required``."""
    if not isinstance(d, dict):
        raise TypeError(f"a scene must be a table, got {type(d).__name__}")
    unknown = sorted(set(d) - set(allowed))
    if unknown:
        raise ValueError(f"unknown key(s) in {what}: {unknown}{did_you_mean(unknown, allowed)}; "
                         f"allowed: {sorted(allowed)}")
    for key in required:
        if key not in d:
            raise ValueError(f"{what} is missing the required key {key!r}")


def periods_from_dict(periods, cls) -> tuple:
    """The ``[[period]]`` array of a scene mapping as a tuple of ``cls`` specs."""
    if not isinstance(periods, (list, tuple)):
        raise TypeError("period must be an array of tables ([[period]])")
    return tuple(cls.from_dict(p) for p in periods)


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
    from ..analysis.records import RecordSpec

    if isinstance(entries, (dict, str, bytes)) or not isinstance(entries, (list, tuple)):
        raise TypeError(f"turbulence.condition_on must be an array of tables (one per record), got "
                        f"{type(entries).__name__}")
    out = []
    for i, e in enumerate(entries):
        if isinstance(e, RecordSpec):
            out.append(e)
            continue
        if not isinstance(e, dict):
            raise TypeError(f"turbulence.condition_on[{i}] must be a table of record keys, got {type(e).__name__}")
        try:
            out.append(RecordSpec.from_dict(dict(e)))
        except (TypeError, ValueError) as err:
            raise type(err)(f"turbulence.condition_on[{i}]: {err}") from None
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
