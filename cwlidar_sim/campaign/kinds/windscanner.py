"""The WindScanner scene kind (``kind = "windscanner"``): three cw lidars with one common focus against a sonic.

Its scene is :class:`~cwlidar_sim.campaign.scenes.windscanner.WindScannerScene`, its unit of work,
estimates, summary and summarise :mod:`~cwlidar_sim.campaign.periods.windscanner`, its figures
:mod:`~cwlidar_sim.campaign.figures.windscanner`.  The registry
(:data:`cwlidar_sim.campaign.registry.BUILTIN_KINDS`) finds it here by name.
"""

from __future__ import annotations

import dataclasses

from ..figures import windscanner as windscanner_figures
from ..periods import windscanner
from ..registry import KindBase
from ..scenes.windscanner import WindScannerScene

__all__ = ["WindScannerKind", "WINDSCANNER"]


class WindScannerKind(KindBase):
    """``kind = "windscanner"``: the wind vector from three beams meeting at one point, one unit per period."""

    name = "windscanner"
    scene_class = WindScannerScene
    #: quick: every period this long [s], the spectra's segments this long [s].
    quick_duration = 30.0
    quick_segment = 10.0

    def run_unit(self, scene, index, params=None, *, status=None):
        return windscanner.run_unit(scene, index, params, status=status)

    def estimate_bytes(self, scene) -> float:
        return windscanner.estimate_bytes(scene)

    def estimate_unit(self, scene, index, params=None) -> dict:
        return windscanner.estimate_unit(scene, index, params)

    def summarise(self, ds):
        return windscanner.summarise(ds)

    def summary(self, scene, ds) -> dict:
        return windscanner.summary(scene, ds)

    def figures(self, ds, out_dir) -> list:
        return windscanner_figures.make_windscanner_figures(ds, out_dir)

    def quick(self, scene):
        """Short periods and segments: the same geometry, seeds and chain, noisier spectra."""
        return scene.replace(duration=self.quick_duration,
                             scanner=dataclasses.replace(scene.scanner, segment_duration=self.quick_segment),
                             periods=tuple(dataclasses.replace(p, duration=None) for p in scene.periods))


WINDSCANNER = WindScannerKind()
