"""Cross-references to a public object through any of its import paths.

A docstring may name an object where it is defined (``cwlidar_sim.signal.chain.run_chain``, or
``run_chain`` inside that module), while the API reference documents it once, where the
subpackage re-exports it (``cwlidar_sim.signal.run_chain``).  Sphinx's Python domain looks only
for the name as written, so such a reference would be dead under ``-n`` (nitpicky).  This
extension handles Sphinx's ``missing-reference`` event: it imports what the reference names (as
written, or relative to the module and class it appears in), finds the documented entry that is
the same object (by identity) and resolves the reference to it.  ``Class.attribute`` resolves
through its class the same way.  A reference to something not documented anywhere stays
unresolved, and ``-n -W`` fails the build on it, as it should: a dead link is a defect.

External names (``builtins.dict``, ``enum.IntFlag``, scipy's) cannot be resolved without
intersphinx inventories, which are not fetched (the build downloads nothing); they are listed in
``conf.py``'s ``nitpick_ignore_regex`` by module, so a typo inside the package is still caught.
"""

from __future__ import annotations

import importlib

__all__ = ["setup"]

PACKAGE = "cwlidar_sim"


def _import(dotted: str):
    """The object at ``dotted`` (module, then attributes), or a sentinel when there is none."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return _MISSING
        return obj
    return _MISSING


_MISSING = object()


def _documented_by_id(env) -> dict:
    """id(object) -> the dotted name under which the py domain documents it (first found)."""
    cache = getattr(env, "_xref_by_id", None)
    if cache is None:
        cache = {}
        objects = env.get_domain("py").objects
        for name in sorted(objects, key=len):  # the shortest path (the re-export) wins
            if not name.startswith(PACKAGE):
                continue
            obj = _import(name)
            if obj is not _MISSING and not isinstance(obj, (int, float, str, bytes, bool, type(None))):
                cache.setdefault(id(obj), name)
        env._xref_by_id = cache
    return cache


def _defining_modules(source: str | None) -> list[str]:
    """Modules where the docstring holding a reference was written (``...:docstring of X``): X's own
    module, or, for what has none (a property), the module of the nearest enclosing object that has one."""
    if not source or "docstring of " not in source:
        return []
    dotted = source.rsplit("docstring of ", 1)[1].split(":")[0].strip()
    mods = []
    while dotted:
        obj = _import(dotted)
        if obj is not _MISSING:
            if isinstance(obj, type(importlib)):
                mods.append(obj.__name__)
            mod = getattr(obj, "__module__", None)
            if isinstance(mod, str):
                mods.append(mod)
            if mods:
                break
        dotted = dotted.rpartition(".")[0]
    return [m for m in mods if m.startswith(PACKAGE)]


def _candidates(target: str, module: str | None, cls: str | None, source: str | None = None) -> list[str]:
    target = target.lstrip("~.")
    out = [target] if target.startswith(PACKAGE) else []
    for mod in _defining_modules(source):
        out.append(f"{mod}.{target}")
    if module:
        if cls:
            out.append(f"{module}.{cls}.{target}")
        out.append(f"{module}.{target}")
        pkg = module.rsplit(".", 1)[0]
        out.append(f"{pkg}.{target}")
    return out


def _resolve(env, dotted: str) -> str | None:
    """The documented name of the object at ``dotted`` (also via its class for an attribute)."""
    objects = env.get_domain("py").objects
    if dotted in objects:
        return dotted
    by_id = _documented_by_id(env)
    obj = _import(dotted)
    if obj is not _MISSING and not isinstance(obj, (int, float, str, bytes, bool, type(None))):
        found = by_id.get(id(obj))
        if found:
            return found
    head, _, attr = dotted.rpartition(".")
    if head:
        owner = _import(head)
        if owner is not _MISSING and isinstance(owner, type) and id(owner) in by_id:
            full = f"{by_id[id(owner)]}.{attr}"
            if full in objects:
                return full
    return None


def missing_reference(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    for dotted in _candidates(node["reftarget"], node.get("py:module"), node.get("py:class"), node.source):
        found = _resolve(env, dotted)
        if found is None:
            continue
        domain = env.get_domain("py")
        ref = domain.resolve_any_xref(env, node["refdoc"], app.builder, found, node, contnode)
        if ref:
            return ref[0][1]
    return None


def setup(app):
    app.connect("missing-reference", missing_reference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
