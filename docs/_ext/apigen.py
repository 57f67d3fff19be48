"""Generate the API reference's sources from the package's ``__all__`` lists.

Nothing here is a hand list: every subpackage of :mod:`cwlidar_sim` (found with
``pkgutil``), every name in its ``__all__``, and every public module inside it
(with the names of its own ``__all__`` that the subpackage does not re-export)
gets an entry, so a new module or a new public name appears in the reference
on the next build.  Functions, classes and exceptions get one page each
(``autosummary :toctree:``, rendered by autodoc + numpydoc, so with their
parameters and units); constants are described in place with their value and
the ``#:`` comment at their definition.

Used by ``docs/conf.py`` at build time and by ``tests/test_docs.py`` (without
Sphinx: :func:`public_names`).  Writes only files whose text changed, so
Sphinx's incremental builds stay incremental.
"""

from __future__ import annotations

import importlib
import inspect
import os
import pkgutil

PACKAGE = "cwlidar_sim"

# Order of the sections of a page, and what each kind of name is called there.
KINDS = (("class", "Classes"), ("exception", "Exceptions"), ("function", "Functions"), ("data", "Constants"),
         ("module", "Modules"))


def subpackages(package: str = PACKAGE) -> list[str]:
    """The public subpackages of ``package`` (dotted names), in the order of the pipeline where known."""
    pkg = importlib.import_module(package)
    found = [f"{package}.{m.name}" for m in pkgutil.iter_modules(pkg.__path__) if m.ispkg and not m.name.startswith("_")]
    order = ["turbulence", "beam", "signal", "sensors", "analysis", "campaign"]
    rank = {f"{package}.{n}": i for i, n in enumerate(order)}
    return sorted(found, key=lambda n: (rank.get(n, len(order)), n))


def public_modules(subpackage: str) -> list[str]:
    """The public (not underscore) modules of a subpackage, its sub-packages' too, dotted names."""
    pkg = importlib.import_module(subpackage)
    out = []
    for m in pkgutil.iter_modules(pkg.__path__):
        if not m.name.startswith("_"):
            out.append(f"{subpackage}.{m.name}")
            if m.ispkg:
                out += public_modules(f"{subpackage}.{m.name}")
    return out


def kind_of(obj) -> str:
    if inspect.ismodule(obj):
        return "module"
    if inspect.isclass(obj):
        return "exception" if issubclass(obj, BaseException) else "class"
    if callable(obj):
        return "function"
    return "data"


def module_names(modname: str) -> list[str]:
    """A module's public names: its ``__all__``, or (without one) what it defines that has no underscore."""
    mod = importlib.import_module(modname)
    if hasattr(mod, "__all__"):
        return list(mod.__all__)
    return [n for n, o in vars(mod).items() if not n.startswith("_") and getattr(o, "__module__", None) == modname
            and (inspect.isclass(o) or inspect.isfunction(o))]


def root_names(package: str = PACKAGE) -> list[str]:
    """The package root's public names (its ``__all__`` but the dunders): the high-level API."""
    return [n for n in importlib.import_module(package).__all__ if not n.startswith("__")]


def public_names(package: str = PACKAGE) -> dict[str, list[str]]:
    """``{subpackage: __all__}`` for every public subpackage: the names the reference must hold."""
    return {sub: list(importlib.import_module(sub).__all__) for sub in subpackages(package)}


def _attr_doc(obj, name: str, modules: list[str]) -> str:
    """The ``#:`` comment at the definition of constant ``name`` (searched in ``modules``), or ''."""
    try:
        from sphinx.pycode import ModuleAnalyzer
    except ImportError:  # the test calls this module without Sphinx
        return ""
    for modname in modules:
        mod = importlib.import_module(modname)
        if getattr(mod, name, None) is not obj:
            continue
        try:
            docs = ModuleAnalyzer.for_module(modname).find_attr_docs()
        except Exception:  # a module the analyzer cannot parse: no comment, not a failure
            continue
        lines = docs.get(("", name))
        if lines:
            return " ".join(line.strip() for line in lines if line.strip())
    return ""


def _value_option(obj) -> str:
    """A short ``:value:`` for scalars and short containers, else the type."""
    if isinstance(obj, (bool, int, float, str)) or (isinstance(obj, tuple) and len(repr(obj)) <= 120):
        return f"   :value: {obj!r}\n"
    return f"   :type: {type(obj).__module__}.{type(obj).__qualname__}\n"


def _title(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n\n"


def _section(modname: str, names: list[str], objects: dict, search: list[str]) -> str:
    """The autosummary tables (one per kind) and the constants of ``names`` under ``modname``."""
    out = f".. currentmodule:: {modname}\n\n"
    for kind, heading in KINDS:
        group = [n for n in names if kind_of(objects[n]) == kind]
        if not group:
            continue
        out += _title(heading, "-")
        if kind == "module":
            out += "".join(f"* :mod:`{objects[n].__name__}`\n" for n in group) + "\n"
        elif kind == "data":
            for n in group:
                doc = _attr_doc(objects[n], n, search)
                out += f".. data:: {n}\n{_value_option(objects[n])}\n"
                out += f"   {doc}\n\n" if doc else "\n"
        else:
            out += ".. autosummary::\n   :toctree: generated\n   :nosignatures:\n\n"
            out += "".join(f"   {n}\n" for n in group) + "\n"
    return out


def _write(path: str, text: str) -> None:
    try:
        with open(path, encoding="utf-8") as fh:
            if fh.read() == text:
                return
    except FileNotFoundError:
        pass
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)


def generate(outdir: str, package: str = PACKAGE) -> list[str]:
    """Write ``outdir/index.rst`` and one page per subpackage and public module; returns the page names."""
    os.makedirs(outdir, exist_ok=True)
    pages = [package]
    root = importlib.import_module(package)
    top = root_names(package)
    _write(os.path.join(outdir, f"{package}.rst"),
           _title(package) + f".. automodule:: {package}\n\n"
           + _section(package, top, {n: getattr(root, n) for n in top}, [package]))
    for sub in subpackages(package):
        mod = importlib.import_module(sub)
        names = list(mod.__all__)
        objects = {n: getattr(mod, n) for n in names}
        modules = public_modules(sub)
        text = _title(sub) + f".. automodule:: {sub}\n\n"
        text += _section(sub, names, objects, modules)
        text += _title("Modules", "-")
        text += ("Each module's notes, and the names it adds to the ones above.\n\n"
                 ".. toctree::\n   :maxdepth: 1\n\n" + "".join(f"   {m}\n" for m in modules) + "\n")
        _write(os.path.join(outdir, f"{sub}.rst"), text)
        pages.append(sub)
        for modname in modules:
            m = importlib.import_module(modname)
            own = module_names(modname)
            mobjects = {n: getattr(m, n) for n in own}
            # a name the subpackage re-exports (the same object under the same name) is documented there
            shared = [n for n in own if n in objects and objects[n] is mobjects[n]]
            extra = [n for n in own if n not in shared]
            mtext = _title(modname) + f".. automodule:: {modname}\n\n"
            if shared:
                mtext += (f"Documented with :mod:`{sub}`: "
                          + ", ".join(f":obj:`~{sub}.{n}`" for n in shared) + ".\n\n")
            if extra:
                mtext += _section(modname, extra, mobjects, [modname])
            _write(os.path.join(outdir, f"{modname}.rst"), mtext)
            pages.append(modname)
    index = _title("API reference")
    index += ("Generated at build time from each subpackage's ``__all__``: every public name, with its\n"
              "parameters and units from its numpydoc docstring.  The package's conventions (SI units,\n"
              "one-sided spectra, array names that carry their dimensions) are on the first page.\n\n")
    index += ".. toctree::\n   :maxdepth: 1\n\n" + "".join(f"   {p}\n" for p in [package, *subpackages(package)]) + "\n"
    _write(os.path.join(outdir, "index.rst"), index)
    return pages
