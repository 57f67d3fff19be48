"""The TOML files that ship with the package: scenes (``campaign/data/scenes``) and campaign examples
(``campaign/data/examples``), found by name for the command line (``cwlidar-sim scenes``, ``run NAME``,
``campaign NAME``).  Imports nothing heavy: the CLI's cold start stays free of compilation."""

from __future__ import annotations

import os

__all__ = ["bundled_files", "bundled_or_path"]

_BUNDLED_DIRS = (("scene", ("campaign", "data", "scenes")), ("campaign", ("campaign", "data", "examples")))


def bundled_files() -> dict:
    """``{name: (kind, file)}`` of the bundled TOML files, ``file`` an importlib.resources Traversable."""
    from importlib import resources

    root = resources.files("cwlidar_sim")
    out = {}
    for kind, parts in _BUNDLED_DIRS:
        folder = root.joinpath(*parts)
        if folder.is_dir():
            for f in sorted(folder.iterdir(), key=lambda f: f.name):
                if f.name.endswith(".toml"):
                    out[f.name[:-len(".toml")]] = (kind, f)
    return out


def bundled_or_path(arg: str, kind: str) -> str:
    """``arg`` if it is a file; else the path of the bundled ``kind`` of that name; else a clear error."""
    if os.path.exists(arg):
        return arg
    found = bundled_files()
    if found.get(arg, (None,))[0] == kind:
        return str(found[arg][1])
    if os.sep in arg or arg.endswith(".toml"):
        return arg  # a path: the loader names it
    names = sorted(n for n, (k, _) in found.items() if k == kind)
    raise ValueError(f"no {kind} file {arg!r} and no bundled {kind} of that name; bundled: {', '.join(names)} "
                     f"('cwlidar-sim scenes' lists them)")
