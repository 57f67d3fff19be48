"""The ``spinner`` scene kind: DTU's SpinnerLidar, one unit per period (:class:`~cwlidar_sim.campaign.registry.SceneKind`).

The scene is :class:`~cwlidar_sim.campaign.scenes.spinner.SpinnerScene`; its unit
of work, estimates, summary and summarise are
:mod:`~cwlidar_sim.campaign.periods.spinner`'s (looked up there at call time),
its figures :mod:`~cwlidar_sim.campaign.figures.spinner`'s.  The registry
(:data:`cwlidar_sim.campaign.registry.BUILTIN_KINDS`) finds it here by name.
"""

from __future__ import annotations

import dataclasses

from ..figures import spinner as spinner_figures
from ..periods import spinner
from ..scenes.spinner import SpinnerScene
from ..registry import KindBase

__all__ = ["SpinnerKind", "SPINNER"]


class SpinnerKind(KindBase):
    """``kind = "spinner"``: a SpinnerLidar's inflow over the rotor disc per rosette, one unit per period.

    (A kind imports no other kind: the registry reaches each by name, so the built-in kinds'
    ``UnitModuleKind`` is not reused; these are its five one-line hand-overs.)
    """

    name = "spinner"
    scene_class = SpinnerScene
    #: reproduce --quick: every period this long [s] (ten 2-s rosettes).
    quick_duration = 20.0

    def run_unit(self, scene, index, params=None, *, status=None):
        return spinner.run_unit(scene, index, params, status=status)

    def estimate_bytes(self, scene) -> float:
        return spinner.estimate_bytes(scene)

    def estimate_unit(self, scene, index, params=None) -> dict:
        return spinner.estimate_unit(scene, index, params)

    def summarise(self, ds):
        return spinner.summarise(ds)

    def summary(self, scene, ds) -> dict:
        return spinner.summary(scene, ds)

    def figures(self, ds, out_dir) -> list:
        return spinner_figures.make_spinner_figures(ds, out_dir)

    def quick(self, scene):
        return scene.replace(duration=self.quick_duration,
                             periods=tuple(dataclasses.replace(p, duration=None) for p in scene.periods))


SPINNER = SpinnerKind()
