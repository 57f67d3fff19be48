"""Bundled reproductions: ``cwlidar-sim reproduce NAME`` for a2012, cs, nacelle, spinner and windscanner.

The scenes ship with the package (``cwlidar_sim/campaign/data/scenes/*.toml``).
Quick mode keeps the physics and the geometry and does less, by the scene
kind's quick rule (:meth:`cwlidar_sim.campaign.registry.SceneKind.quick`):
a staring scene (a2012) shortens every period (the low-wavenumber end is
noisier), a conical one (cs) keeps the first two periods at every height
instead of its plan of periods per height (the full run's first eight units,
seeds and bits alike; the ratios' standard errors are larger), a nacelle one
shortens every period to 5 minutes, a spinner one to 20 s (ten rosettes), a
windscanner one to 30 s with 10-s segments; the full run is the reproduction.
"""

from __future__ import annotations

from importlib import resources

from ..registry import kind_of
from ..scenes.load import loads_scene

__all__ = ["BUNDLED", "bundled_scene", "bundled_text"]

#: Bundled scenes: name -> file.
BUNDLED = {"a2012": "a2012.toml", "cs": "cs.toml", "nacelle": "nacelle.toml", "spinner": "spinner.toml",
           "windscanner": "windscanner.toml"}


def bundled_text(name: str) -> str:
    """TOML text of a bundled scene."""
    from ..._validation import check_choice

    check_choice("scene", name, tuple(BUNDLED))
    return resources.files("cwlidar_sim.campaign").joinpath("data", "scenes", BUNDLED[name]).read_text(encoding="utf-8")


def bundled_scene(name: str, *, quick: bool = False):
    """A bundled scene; ``quick``: its kind's quick rule (module notes; same seeds and geometry)."""
    scene = loads_scene(bundled_text(name))
    return kind_of(scene).quick(scene) if quick else scene
