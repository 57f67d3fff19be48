"""The registry of scene kinds: what a kind provides, how it is found, how a scene finds its kind.

A *scene kind* (``kind = "staring"`` in a scene file) is one object that
offers, under one name per concept, everything the package does with a scene
of that kind: its scene class (the parser), its units of work, their seeds,
their size and cost estimates, the results' assembly, the command line's
summary, the figures, the quick rule of ``reproduce --quick`` and, where it
makes sense, the virtual twin.  :class:`SceneKind` is that written protocol;
:func:`register` checks a kind against it (every member missing is named) and
:func:`get_kind` / :func:`kind_of` are how the runner, the sweeps, the
reports and the command line find it.  Nothing else in the package dispatches
on a kind's name.

Kinds are found in two ways, both as ``"module:attribute"`` references loaded
on the first lookup (xarray's backend entry points are the model):

* the built-in kinds, listed once in :data:`BUILTIN_KINDS`;
* the entry-point group ``cwlidar_sim.scene_kinds`` (:data:`ENTRY_POINT_GROUP`)
  of any installed distribution: a package outside this one adds a kind with
  one line in its ``pyproject.toml``::

      [project.entry-points."cwlidar_sim.scene_kinds"]
      mast = "mast_kind:KIND"

  (``examples/mast_kind`` is a worked example; docs/architecture.md walks
  through it).

This module sits at the bottom of the campaign layer and imports nothing of
it: the kinds are loaded by name, as plugins are, so the scene parsers below
the runners reach the runners' kinds without an import running up the layers.
"""

from __future__ import annotations

import importlib
import importlib.metadata
from typing import Protocol, runtime_checkable

from .._validation import did_you_mean

__all__ = ["ENTRY_POINT_GROUP", "BUILTIN_KINDS", "KIND_MEMBERS", "OPTIONAL_MEMBERS", "SCENE_MEMBERS", "SceneKind",
           "KindBase", "default_statistics", "statistics_of", "side_files_of", "check_kind", "register", "unregister", "get_kind", "kind_of", "kind_names", "refresh"]

#: The entry-point group through which installed distributions add scene kinds.
ENTRY_POINT_GROUP = "cwlidar_sim.scene_kinds"
#: The kinds of this package: name -> ``"module:attribute"`` of its :class:`SceneKind` object.
BUILTIN_KINDS = {
    "staring": "cwlidar_sim.campaign.kinds.builtin:STARING",
    "conical": "cwlidar_sim.campaign.kinds.builtin:CONICAL",
    "nacelle": "cwlidar_sim.campaign.kinds.builtin:NACELLE",
    "windscanner": "cwlidar_sim.campaign.kinds.windscanner:WINDSCANNER",
    "spinner": "cwlidar_sim.campaign.kinds.spinner:SPINNER",
}
#: Members every kind provides (:class:`SceneKind`); ``name`` and ``scene_class`` are attributes, ``twin`` an
#: attribute that may be None, the rest callables.
KIND_MEMBERS = ("name", "scene_class", "resolve", "scene_params", "run_unit", "estimate_bytes", "estimate_unit",
                "summarise", "summary", "figures", "quick", "twin")
_ATTRIBUTES = ("name", "scene_class", "twin")
#: Members a kind may provide; the runner uses a generic default where it does not (:class:`SceneKind`).
OPTIONAL_MEMBERS = ("statistics", "side_files")
#: Members every kind's scene class provides (the runner, the store, the sweeps and the folder call them).
SCENE_MEMBERS = ("kind", "from_dict", "schema", "as_dict", "replace", "with_values", "unit_names", "unit_seed",
                 "simulated_hours")


@runtime_checkable
class SceneKind(Protocol):
    """What a scene kind provides: one name per concept, the same for every kind.

    Attributes
    ----------
    name : str
        The scene file's ``kind = "..."`` and the results' ``sensor`` attribute.
    scene_class : type
        The scene: a frozen dataclass with ``kind`` (= ``name``),
        ``from_dict(d, *, base_dir)``, ``schema()``, ``as_dict()``,
        ``replace(**fields)``, ``with_values(dotted)``, ``unit_names()``
        (the units of work in run order), ``unit_seed(index)`` (each unit's
        seed, distinct across units, stable when units are added) and
        ``simulated_hours()`` (:data:`SCENE_MEMBERS`;
        :class:`cwlidar_sim.campaign.scenes.spec.SceneSpec` gives ``with_values``).
    twin : object or None
        The virtual twin's hooks (:mod:`cwlidar_sim.campaign.twin.run`), or None:
        a scene of this kind that names ``[turbulence] condition_on`` is
        refused with a message naming the kind.
    """

    name: str
    scene_class: type
    twin: object

    def resolve(self, scene):
        """The scene with its automatic settings chosen, and why: ``(scene, {key: reason})``."""

    def scene_params(self, scene, log):
        """The tensor shared by every unit (or None: each unit has its own) and the fit's summary (or None).

        Called once per run, before any unit; ``log`` receives one line per decision.
        """

    def run_unit(self, scene, index: int, params=None, *, status=None):
        """Unit ``index`` as an xarray.Dataset on ``period`` (one row per result row of the unit).

        Seeded from ``scene.unit_seed(index)`` alone, so a unit gives the same
        bits here, on a Dask worker, or in a resumed run; ``status`` receives
        short progress texts.  The Dataset's attributes include ``sensor``
        (= ``name``), ``scene`` (the scene's JSON) and ``results_version``.
        """

    def estimate_bytes(self, scene) -> float:
        """Size of the scene's results on disk [bytes] (checked against the free space before a run)."""

    def estimate_unit(self, scene, index: int, params=None) -> dict:
        """``{"seconds": wall time on one core, "memory_bytes": peak memory}`` of unit ``index``.

        ``scene`` and ``params`` are :meth:`resolve`'s and :meth:`scene_params`'.
        """

    def summarise(self, ds):
        """The scene's results from its units joined along ``period`` (e.g. averages per height)."""

    def summary(self, scene, ds) -> dict:
        """The command line's short report of the results (JSON-able)."""

    def figures(self, ds, out_dir) -> list:
        """Write the results' figures as PNG into ``out_dir``; the paths."""

    def quick(self, scene):
        """The scene made quick for ``reproduce --quick``: less data, the same physics and seeds."""

    # optional members (OPTIONAL_MEMBERS): a kind without them gets the defaults named

    def statistics(self, ds) -> dict:
        """Optional: which results variables are per-period statistics, and of which instrument.

        ``{variable: instrument}`` for the variables of the tidy statistics
        table (:mod:`cwlidar_sim.campaign.execution.tidy`): each on ``period``,
        either a statistic per period (further dimensions such as ``scan_s``
        or ``focus`` become columns) or a series on a time dimension (its
        coordinate in ``s``), which the table turns into 10-minute statistics.
        Default (:func:`default_statistics`): every numeric variable on
        ``period`` alone, its instrument from its ``instrument`` attribute.
        """

    def side_files(self, ds, stem) -> list:
        """Optional: write the kind's own files beside the results file ``<stem>.nc``, atomically; their paths.

        Default: none.  The nacelle kind writes its preview signal (``<stem>.preview.csv``).
        """


def default_statistics(ds) -> dict:
    """The tidy table's variables of a kind that does not say: every numeric variable on ``period`` alone.

    Each one's instrument is its ``instrument`` attribute, else ``""``.
    """
    return {str(n): str(v.attrs.get("instrument", "")) for n, v in ds.data_vars.items()
            if v.dims == ("period",) and v.dtype.kind in "fiub"}


def statistics_of(kind, ds) -> dict:
    """``kind.statistics(ds)`` where the kind provides it, else :func:`default_statistics`."""
    member = getattr(kind, "statistics", None)
    return dict(member(ds)) if callable(member) else default_statistics(ds)


def side_files_of(kind, ds, stem) -> list:
    """``kind.side_files(ds, stem)`` where the kind provides it, else no file."""
    member = getattr(kind, "side_files", None)
    return list(member(ds, stem)) if callable(member) else []


class KindBase:
    """A convenient base of a kind: the members most kinds share, for a subclass to override.

    Nothing automatic (``resolve`` returns the scene as it is), no shared
    tensor (``scene_params``: None, each unit takes its own), the units
    joined as they are (``summarise``), no figures, no quick rule (a
    ValueError naming the kind), no twin, the default tidy statistics
    (:func:`default_statistics`) and no side files.  A subclass sets ``name`` and
    ``scene_class`` and defines ``run_unit``, ``estimate_bytes``,
    ``estimate_unit`` and ``summary`` (:class:`SceneKind`).
    """

    twin = None

    def resolve(self, scene):
        return scene, {}

    def scene_params(self, scene, log):
        return None, None

    def summarise(self, ds):
        return ds

    def figures(self, ds, out_dir) -> list:
        return []

    def quick(self, scene):
        raise ValueError(f"a {self.name} scene has no quick rule (reproduce --quick)")

    def statistics(self, ds) -> dict:
        return default_statistics(ds)

    def side_files(self, ds, stem) -> list:
        return []

    def __repr__(self):
        return f"<scene kind {getattr(self, 'name', '?')!r} ({type(self).__module__}.{type(self).__qualname__})>"


def check_kind(kind, name: str | None = None):
    """Raise TypeError unless ``kind`` provides every member of :class:`SceneKind`, naming those it lacks.

    ``name``: the name it is registered under (its ``name`` must equal it).
    Returns ``kind``.
    """
    where = f"scene kind {name!r}" if name is not None else f"scene kind {kind!r}"
    missing = [m for m in KIND_MEMBERS if not hasattr(kind, m)]
    if missing:
        raise TypeError(f"{where} lacks {', '.join(missing)}: a scene kind provides {', '.join(KIND_MEMBERS)} "
                        f"(cwlidar_sim.campaign.registry.SceneKind)")
    not_callable = [m for m in KIND_MEMBERS if m not in _ATTRIBUTES and not callable(getattr(kind, m))]
    if not_callable:
        raise TypeError(f"{where}: {', '.join(not_callable)} must be callable (cwlidar_sim.campaign.registry.SceneKind)")
    if not isinstance(kind.name, str) or not kind.name.isidentifier():
        raise TypeError(f"{where}: its name must be an identifier string, got {kind.name!r}")
    if name is not None and kind.name != name:
        raise TypeError(f"{where}: registered as {name!r} but its name is {kind.name!r}")
    cls = kind.scene_class
    if not isinstance(cls, type):
        raise TypeError(f"{where}: scene_class must be a class, got {cls!r}")
    lacking = [m for m in SCENE_MEMBERS if not hasattr(cls, m)]
    if lacking:
        raise TypeError(f"{where}: its scene class {cls.__name__} lacks {', '.join(lacking)}: a scene provides "
                        f"{', '.join(SCENE_MEMBERS)} (cwlidar_sim.campaign.registry.SceneKind)")
    if cls.kind != kind.name:
        raise TypeError(f"{where}: its scene class {cls.__name__} has kind = {cls.kind!r}, not {kind.name!r}")
    return kind


#: name -> kind object (registered), or "module:attribute" (found, not loaded yet).
_KINDS: dict = {}
#: Names found through entry points (forgotten by :func:`refresh`).
_FOUND: set = set()
_discovered = False


def _load_reference(name: str, ref: str, origin: str):
    module, _, attr = ref.partition(":")
    try:
        obj = importlib.import_module(module)
        for part in attr.split(".") if attr else ():
            obj = getattr(obj, part)
    except Exception as e:  # a broken plugin is named, with what failed
        raise ImportError(f"scene kind {name!r} ({origin} {ref!r}) cannot be loaded: {type(e).__name__}: {e}") from e
    return obj


def _discover() -> None:
    """Fill the table with the built-in kinds and the entry points' (references, loaded on lookup)."""
    global _discovered
    if _discovered:
        return
    for name, ref in BUILTIN_KINDS.items():
        _KINDS.setdefault(name, ref)
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        if ep.name in BUILTIN_KINDS:
            continue  # a built-in name is the package's own: an installed copy of an older build declares it too
        if ep.name not in _KINDS:
            _KINDS[ep.name] = ("entry point", ep)
            _FOUND.add(ep.name)
    _discovered = True


def refresh() -> None:
    """Forget the kinds found through entry points and look again (after a distribution was installed)."""
    global _discovered
    importlib.invalidate_caches()
    for name in _FOUND:
        _KINDS.pop(name, None)
    _FOUND.clear()
    _discovered = False


def register(kind, *, replace: bool = False):
    """Register a scene kind under ``kind.name`` after checking it (:func:`check_kind`); returns it.

    A name taken by another kind is refused unless ``replace``.
    """
    _discover()
    check_kind(kind)
    old = _KINDS.get(kind.name)
    if old is not None and old is not kind and not replace and not isinstance(old, (str, tuple)):
        raise ValueError(f"scene kind {kind.name!r} is registered already ({old!r}); pass replace=True to replace it")
    _KINDS[kind.name] = kind
    _FOUND.discard(kind.name)
    return kind


def unregister(name: str) -> None:
    """Remove a kind registered with :func:`register` (a test's); a built-in kind is loaded again on lookup."""
    _KINDS.pop(name, None)
    if name in BUILTIN_KINDS:
        _KINDS[name] = BUILTIN_KINDS[name]


def kind_names() -> tuple:
    """Names of every kind known: the built-in ones, then those registered or found through entry points."""
    _discover()
    return tuple(BUILTIN_KINDS) + tuple(sorted(n for n in _KINDS if n not in BUILTIN_KINDS))


def get_kind(name, *, where: str = "kind"):
    """The scene kind registered as ``name``; a ValueError naming ``where``, the closest names and all of them."""
    _discover()
    entry = _KINDS.get(name) if isinstance(name, str) else None
    if entry is None:
        names = kind_names()
        raise ValueError(f"{where} = {name!r} is not a scene kind{did_you_mean([str(name)], names)}; allowed: "
                         f"{list(names)} (a package adds one through the entry-point group {ENTRY_POINT_GROUP!r})")
    if isinstance(entry, str):
        kind = check_kind(_load_reference(name, entry, "built-in"), name)
    elif isinstance(entry, tuple):
        ep = entry[1]
        try:
            loaded = ep.load()
        except Exception as e:
            raise ImportError(f"scene kind {name!r} (entry point {ep.value!r} of group {ENTRY_POINT_GROUP!r}) "
                              f"cannot be loaded: {type(e).__name__}: {e}") from e
        kind = check_kind(loaded, name)
    else:
        return entry
    _KINDS[name] = kind
    return kind


def kind_of(scene):
    """The kind of a scene object (by its ``kind``); a TypeError for an object that is no kind's scene."""
    name = getattr(scene, "kind", None)
    if not isinstance(name, str):
        raise TypeError(f"expected a scene ({', '.join(kind_names())}), got {type(scene).__name__}")
    kind = get_kind(name)
    if not isinstance(scene, kind.scene_class):
        raise TypeError(f"a {name} scene must be a {kind.scene_class.__name__}, got {type(scene).__name__}")
    return kind
