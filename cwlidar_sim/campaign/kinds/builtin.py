"""The built-in scene kinds: staring (A2012), conical (CS) and nacelle, as :class:`~cwlidar_sim.campaign.registry.SceneKind` objects.

Each kind names its scene class and hands every member of the protocol to
the modules that do the work: its unit of work, estimates, summary and
summarise in :mod:`~cwlidar_sim.campaign.periods.staring`,
:mod:`~cwlidar_sim.campaign.periods.conical` or :mod:`~cwlidar_sim.campaign.periods.nacelle`
(looked up there at call time: a test that replaces ``staring.run_unit`` is
obeyed), its figures in :mod:`~cwlidar_sim.campaign.figures.staring`,
:mod:`~cwlidar_sim.campaign.figures.conical` or
:mod:`~cwlidar_sim.campaign.figures.nacelle`, its twin in
:mod:`~cwlidar_sim.campaign.twin.run`.  The registry
(:data:`cwlidar_sim.campaign.registry.BUILTIN_KINDS`) finds them here by name.
"""

from __future__ import annotations

import dataclasses

from ..figures import conical as conical_figures, nacelle as nacelle_figures, staring as staring_figures
from ..periods import conical, nacelle, staring
from ..periods.staring_auto import resolve as resolve_auto
from ..periods.staring_field import choose_field, scene_params as staring_params
from ..registry import KindBase
from ..scenes.conical import ConicalScene
from ..scenes.nacelle import NacelleScene
from ..scenes.staring import Scene
from ..twin.run import ConicalTwin, StaringTwin

__all__ = ["UnitModuleKind", "StaringKind", "ConicalKind", "NacelleKind", "STARING", "CONICAL", "NACELLE"]


class UnitModuleKind(KindBase):
    """A kind whose unit of work, estimates, summarise and summary are the functions of one module (``module``)."""

    module = None

    def run_unit(self, scene, index, params=None, *, status=None):
        return self.module.run_unit(scene, index, params, status=status)

    def estimate_bytes(self, scene) -> float:
        return self.module.estimate_bytes(scene)

    def estimate_unit(self, scene, index, params=None) -> dict:
        return self.module.estimate_unit(scene, index, params)

    def summarise(self, ds):
        return self.module.summarise(ds)

    def summary(self, scene, ds) -> dict:
        return self.module.summary(scene, ds)


class StaringKind(UnitModuleKind):
    """``kind = "staring"``: a staring lidar against a sonic, one unit per period (A2012)."""

    name = "staring"
    scene_class = Scene
    module = staring
    twin = StaringTwin()
    #: reproduce --quick: every period this long [s].
    quick_duration = 1200.0

    def resolve(self, scene):
        """The ``"auto"`` tier, ``field.dx`` and ``cell_length``: the cheapest sufficient settings."""
        return resolve_auto(scene)

    def scene_params(self, scene, log):
        """The scene's tensor (given, or fitted to ``turbulence.fit_to``), and each period's field choice logged."""
        say = log or (lambda s: None)
        params, fit_info = staring_params(scene)
        if fit_info is not None:
            say(f"turbulence fitted to {fit_info['path']}: {params}")
        for p in scene.periods:
            kind, why = choose_field(scene, p)
            say(f"period {p.name}: {kind} field ({why})")
        return params, fit_info

    def figures(self, ds, out_dir) -> list:
        return staring_figures.make_staring_figures(ds, out_dir)

    #: The tidy table's variables and their instruments: the 10 Hz series (10-minute statistics), the 50 Hz
    #: ideal, the per-period quality numbers and the scene's wind.
    statistics_vars = {"lidar_10hz": "lidar", "sonic_10hz": "sonic", "lidar_ideal": "lidar_tier1",
                       "availability": "lidar", "availability_10hz": "lidar", "flag_count": "lidar",
                       "correlation_time": "lidar", "mean_speed": "scene", "misalignment": "scene"}

    def statistics(self, ds) -> dict:
        return {k: v for k, v in self.statistics_vars.items() if k in ds.data_vars}

    def quick(self, scene):
        return scene.replace(duration=self.quick_duration,
                             periods=tuple(dataclasses.replace(p, duration=None) for p in scene.periods))


class ConicalKind(UnitModuleKind):
    """``kind = "conical"``: a conically scanning lidar against a cup and a sonic, one unit per period x height (CS)."""

    name = "conical"
    scene_class = ConicalScene
    module = conical
    twin = ConicalTwin()
    #: reproduce --quick: the first templates kept, at every height.
    quick_periods = 2

    def resolve(self, scene):
        """``scan.theory = "auto"``: the theory alone where it answers the scene, else beside the simulation."""
        if scene.scan.theory != "auto":
            return scene, {}
        choice, why = scene.resolve_theory()
        return scene.replace(scan=dataclasses.replace(scene.scan, theory=choice)), {"scan.theory": f"{choice}: {why}"}

    def figures(self, ds, out_dir) -> list:
        return conical_figures.make_cs_figures(ds, out_dir)

    #: The tidy table's instruments by the units' variable names' prefixes (the rest: the lidar's).
    statistics_prefixes = (("cup_", "cup"), ("sonic_", "sonic"), ("in_situ_", "mast"), ("mann_", "scene"),
                           ("mean_speed_unit", "scene"), ("u_star_", "scene"))

    def statistics(self, ds) -> dict:
        """Every unit's numbers (``*_unit``, ``*_variant_unit``: one row per period x height), by instrument."""
        out = {}
        for name, var in ds.data_vars.items():
            if var.dims[:1] == ("period",) and str(name).endswith("_unit") and var.dtype.kind in "fiub":
                out[str(name)] = next((who for pre, who in self.statistics_prefixes if str(name).startswith(pre)),
                                      "lidar")
        return out

    def quick(self, scene):
        """The first templates at every height: the full run's first units, seeds and bits alike."""
        return scene.replace(periods=scene.periods[:self.quick_periods],
                             scan=dataclasses.replace(scene.scan, periods_per_height=()))


class NacelleKind(UnitModuleKind):
    """``kind = "nacelle"``: a nacelle lidar's preview of the rotor-effective wind speed, one unit per period."""

    name = "nacelle"
    scene_class = NacelleScene
    module = nacelle
    #: reproduce --quick: every period this long [s].
    quick_duration = 300.0

    def figures(self, ds, out_dir) -> list:
        return nacelle_figures.make_nacelle_figures(ds, out_dir)

    def statistics(self, ds) -> dict:
        return self.module.statistics(ds)

    def side_files(self, ds, stem) -> list:
        """The preview signal, ``<stem>.preview.csv`` (:func:`cwlidar_sim.campaign.periods.nacelle.write_preview`)."""
        return [self.module.write_preview(ds, f"{stem}.preview.csv")] if "preview_estimate" in ds else []

    def quick(self, scene):
        return scene.replace(duration=self.quick_duration,
                             periods=tuple(dataclasses.replace(p, duration=None) for p in scene.periods))


STARING = StaringKind()
CONICAL = ConicalKind()
NACELLE = NacelleKind()
