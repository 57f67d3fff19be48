"""An example scene kind outside cwlidar_sim: a met mast of sonics and cups at several heights in a Mann box.

Installed (``pip install examples/mast_kind``), its entry point in the group
``cwlidar_sim.scene_kinds`` registers :data:`KIND`; a scene file with
``kind = "mast"`` then runs through ``cwlidar-sim run``, ``campaign``
sweeps (local or on Dask), resume, ``report`` and the figures like the
built-in kinds.  docs/architecture.md walks through it.
"""

from .kind import KIND, MastKind
from .scene import MastPeriodSpec, MastScene, MastSpec, MastTurbulenceSpec

__all__ = ["KIND", "MastKind", "MastScene", "MastSpec", "MastTurbulenceSpec", "MastPeriodSpec"]
