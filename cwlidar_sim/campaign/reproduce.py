"""Bundled reproductions: ``cwlidar-sim reproduce a2012`` and ``reproduce cs``.

The scenes ship with the package (``cwlidar_sim/campaign/scenes/*.toml``).
Quick mode keeps the physics and the geometry and does less: a2012 shortens
every period (the low-wavenumber end is noisier), cs keeps the first two
periods at every height instead of its plan of periods per height (the
full run's first eight units, seeds and bits alike; the ratios' standard
errors are larger); the full run is the reproduction.
"""

from __future__ import annotations

from importlib import resources

from .scene import Scene, loads_scene

__all__ = ["BUNDLED", "bundled_scene", "bundled_text"]

#: Bundled scenes: name -> (file, quick mode: period duration [s] (staring) or periods kept (conical)).
BUNDLED = {"a2012": ("a2012.toml", 1200.0), "cs": ("cs.toml", 2), "nacelle": ("nacelle.toml", 300.0)}


def bundled_text(name: str) -> str:
    """TOML text of a bundled scene."""
    from .._validation import check_choice

    check_choice("scene", name, tuple(BUNDLED))
    return resources.files("cwlidar_sim.campaign").joinpath("scenes", BUNDLED[name][0]).read_text(encoding="utf-8")


def bundled_scene(name: str, *, quick: bool = False) -> Scene:
    """A bundled scene; ``quick`` shortens it (module notes; same seeds and geometry)."""
    import dataclasses

    scene = loads_scene(bundled_text(name))
    if quick:
        q = BUNDLED[name][1]
        if scene.kind == "conical":  # the first q templates at every height: the full run's first units
            scene = scene.replace(periods=scene.periods[:q],
                                  scan=dataclasses.replace(scene.scan, periods_per_height=()))
        elif scene.kind == "nacelle":
            scene = scene.replace(duration=q, periods=tuple(dataclasses.replace(p, duration=None)
                                                            for p in scene.periods))
        else:
            scene = scene.replace(duration=q,
                                  periods=tuple(dataclasses.replace(p, duration=None) for p in scene.periods))
    return scene
