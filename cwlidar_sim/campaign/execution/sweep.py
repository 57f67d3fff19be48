"""Campaign files: a base scene swept over any of its fields, expanded into independent tasks.

A campaign file (TOML) names a base scene and the fields to sweep:

.. code-block:: toml

    name = "thresholds"
    seed = 7                      # campaign seed: every task's seed derives from it
    base = "a2012"                # a bundled scene, or a scene file (relative to this file)
    periods = ["C"]               # optional: keep only these periods of the base scene
    replicas = 2                  # independent turbulence realisations of every sweep point
    paired = true                 # same turbulence for every sweep point of a replica (default)

    [set]                         # dotted scene keys applied to every task
    duration = 600.0
    "analysis.fit" = false

    [[sweep]]                     # keys in one [[sweep]] table are zipped (equal lengths) ...
    "lidar.instrument.threshold_raise_percent" = [0.0, 10.0, 20.0]

    [[sweep]]                     # ... and the tables are crossed with each other
    "lidar.instrument.estimator" = ["median", "centroid"]
    "lidar.cnr_db" = { start = -20.0, stop = -10.0, num = 2 }   # or { start, stop, step }

A dotted key addresses the scene's TOML tree (``lidar.cnr_db``,
``lidar.instrument.estimator``, ``period.0.mean_speed`` for the first period);
every task's scene is validated like a scene file, so a key or value that a
scene would reject is rejected here by name, before anything runs.

Identity and seeds
------------------
A task is identified by its swept values and its replica (``task_id``, a hash
of them), never by its position in the sweep: adding values to a sweep later
leaves the other tasks' identities, seeds and results unchanged.  The task's
scene seed is drawn from the campaign seed and, with ``paired = true``, the
replica alone (every sweep point of a replica sees the same turbulence, so
differences between sweep points come from the swept setting, not from
sampling), or, with ``paired = false``, the whole identity.  The base scene's
own period seeds are cleared so replicas differ.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import itertools
import json
import math
import os

from ..._seeding import seed_int
from ..._validation import check_bool, check_int, check_seed, did_you_mean
from ..registry import kind_of
from .reproduce import BUNDLED, bundled_scene
from ..scenes.load import load_scene, scene_from_dict
from ..scenes.staring import Scene
from ..scenes.spec import at_path, check_dotted_key, parse_toml, read_text_file, select_periods, set_path, table_fields

__all__ = ["CampaignSpec", "Task", "load_campaign", "loads_campaign", "expand", "estimate_task", "TASK_OVERHEAD_S",
           "INTERPRETER_BYTES"]

#: Fixed cost of a task [s]: imports, turbulence set-up, analysis, writing.
TASK_OVERHEAD_S = 3.0
#: Memory of the interpreter and the libraries a task holds besides its largest unit [bytes].
INTERPRETER_BYTES = 250e6


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def _expand_values(key, spec):
    """The list of values of one swept key: a list, or a range table {start, stop, num | step}."""
    if isinstance(spec, (list, tuple)):
        if not spec:
            raise ValueError(f"sweep key {key!r}: the list of values is empty")
        return list(spec)
    if isinstance(spec, dict):
        import numpy as np

        check_keys_plain(f"sweep key {key!r}", spec, ("start", "stop", "num", "step"))
        if "start" not in spec or "stop" not in spec or ("num" in spec) == ("step" in spec):
            raise ValueError(f"sweep key {key!r}: a range needs start, stop and exactly one of num or step, got {spec}")
        start, stop = float(spec["start"]), float(spec["stop"])
        if "num" in spec:
            num = check_int(f"sweep key {key!r}: num", spec["num"], lo=1, hi=100000)
            return [float(x) for x in np.linspace(start, stop, num)]
        step = float(spec["step"])
        if not step != 0 or (stop - start) / step < 0:
            raise ValueError(f"sweep key {key!r}: step {step} does not lead from {start} to {stop}")
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        if n > 100000:
            raise ValueError(f"sweep key {key!r}: {n} values, allowed: <= 100000")
        return [start + i * step for i in range(n)]
    raise TypeError(f"sweep key {key!r}: values must be a list or a range table {{start, stop, num|step}}, "
                    f"got {type(spec).__name__}")


def check_keys_plain(where, d, allowed):
    """No key of the table ``d`` outside ``allowed``; else a ValueError naming ``where``, the closest keys and
    the allowed ones."""
    unknown = sorted(set(d) - set(allowed))
    if unknown:
        raise ValueError(f"unknown key(s) in {where}: {unknown}{did_you_mean(unknown, allowed)}; "
                         f"allowed: {sorted(allowed)}")


@dataclasses.dataclass(frozen=True)
class Task:
    """One scene of a campaign.

    Attributes
    ----------
    task_id : str
        Hash of the swept values and the replica (16 hex digits).
    values : dict
        Swept key -> value of this task.
    replica : int
        Replica index.
    seed : int
        The task scene's seed.
    scene : Scene
        The task's validated scene.
    """

    task_id: str
    values: dict
    replica: int
    seed: int
    scene: Scene

    def label(self) -> str:
        """Short human-readable description."""
        parts = [f"{k.rsplit('.', 1)[-1]}={v}" for k, v in self.values.items()]
        return ", ".join(parts + [f"replica {self.replica}"])


@dataclasses.dataclass(frozen=True)
class CampaignSpec:
    """A campaign: a base scene, fixed settings, sweeps and replicas (see the module docstring).

    Parameters
    ----------
    name : str
        Letters, digits, '-' and '_'.
    base : str
        A bundled scene name (e.g. 'a2012') or a scene TOML path.
    seed : int
        Campaign seed.
    periods : tuple of str
        Periods of the base scene to keep (empty: all).
    replicas : int
        Realisations per sweep point; in [1, 10000].
    paired : bool
        Share the turbulence of a replica between sweep points.
    set : dict
        Dotted scene key -> value, applied to every task.
    sweep : tuple of dict
        Each dict maps dotted keys to value lists/ranges; keys of one dict are
        zipped, the dicts are crossed.
    base_dir : str
        Folder relative paths are taken from (not stored).
    """

    name: str
    base: str
    seed: int = 0
    periods: tuple = ()
    replicas: int = 1
    paired: bool = True
    set: dict = dataclasses.field(default_factory=dict)
    sweep: tuple = ()
    description: str = ""
    base_dir: str = dataclasses.field(default=".", compare=False)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name or not all(c.isalnum() or c in "-_" for c in self.name):
            raise ValueError(f"campaign name {self.name!r} may hold only letters, digits, '-' and '_'")
        if not isinstance(self.base, str) or not self.base:
            raise ValueError(f"campaign base must name a bundled scene or a scene file, got {self.base!r}")
        object.__setattr__(self, "seed", check_seed("seed", self.seed))
        object.__setattr__(self, "replicas", check_int("replicas", self.replicas, lo=1, hi=10000))
        check_bool("paired", self.paired)
        if not isinstance(self.set, dict):
            raise TypeError("set must be a table of dotted scene keys")
        periods = tuple(self.periods)
        if not all(isinstance(p, str) for p in periods):
            raise TypeError(f"periods must be a list of period names, got {self.periods!r}")
        object.__setattr__(self, "periods", periods)
        sweep = tuple(dict(s) for s in self.sweep)
        seen = set(self.set)
        for i, group in enumerate(sweep):
            if not group:
                raise ValueError(f"sweep[{i}] is empty")
            lens = {k: len(_expand_values(k, v)) for k, v in group.items()}
            if len(set(lens.values())) > 1:
                raise ValueError(f"sweep[{i}] zips its keys, so their value lists need equal lengths; got {lens}")
            dup = seen & set(group)
            if dup:
                raise ValueError(f"sweep[{i}]: key(s) {sorted(dup)} are set or swept twice")
            seen |= set(group)
        object.__setattr__(self, "sweep", sweep)

    def as_dict(self) -> dict:
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "base_dir"}
        d["periods"], d["sweep"] = list(d["periods"]), [dict(s) for s in d["sweep"]]
        return d

    @classmethod
    def from_dict(cls, d: dict, *, base_dir: str = ".") -> "CampaignSpec":
        if not isinstance(d, dict):
            raise TypeError(f"a campaign must be a table, got {type(d).__name__}")
        check_keys_plain("campaign", d, table_fields(cls))
        missing = [k for k in ("name", "base") if k not in d]
        if missing:
            raise ValueError(f"campaign is missing the required key(s) {missing}")
        d = dict(d)
        d.pop("base_dir", None)
        if "sweep" in d:
            if not isinstance(d["sweep"], (list, tuple)):
                raise TypeError("sweep must be an array of tables ([[sweep]])")
            d["sweep"] = tuple(d["sweep"])
        return cls(base_dir=base_dir, **d)

    def base_scene(self) -> Scene:
        """The base scene with ``periods`` selected (not yet ``set``)."""
        if self.base in BUNDLED:
            scene = bundled_scene(self.base)
        else:
            path = self.base if os.path.isabs(self.base) else os.path.join(self.base_dir, self.base)
            if not os.path.isfile(path):
                raise ValueError(f"campaign base {self.base!r}: neither a bundled scene {sorted(BUNDLED)} "
                                 f"nor a scene file ({path!r} does not exist)")
            scene = load_scene(path)
        if self.periods:
            scene = select_periods(scene, list(self.periods))
        return scene


def loads_campaign(text: str, *, base_dir: str = ".") -> CampaignSpec:
    """Parse a campaign from TOML text."""
    return CampaignSpec.from_dict(parse_toml(text, "campaign"), base_dir=base_dir)


def load_campaign(path) -> CampaignSpec:
    """Read a campaign TOML file."""
    text, folder = read_text_file(path, "campaign")
    return loads_campaign(text, base_dir=folder)


def _task_seed(campaign_seed: int, identity) -> int:
    import numpy as np

    words = [int(_digest(identity)[i:i + 8], 16) for i in range(0, 32, 8)]
    ss = np.random.SeedSequence([campaign_seed, *words])
    return seed_int(ss)


def expand(spec: CampaignSpec) -> list[Task]:
    """All tasks of a campaign, each with its validated scene (sweep order: first group slowest)."""
    base = spec.base_scene()
    schema = type(base).schema()
    for where, keys in [("[set]", spec.set)] + [(f"sweep[{i}]", g) for i, g in enumerate(spec.sweep)]:
        for key in keys:  # every dotted key names a key of the base scene's tables, before any task is built
            with at_path(f"campaign {where}"):
                check_dotted_key(key, schema, type(base)._what)
    tree = base.as_dict()
    for p in tree["period"]:
        p.pop("seed", None)
    for key, value in spec.set.items():
        set_path(tree, key, value)
    groups = []
    for group in spec.sweep:
        vals = {k: _expand_values(k, v) for k, v in group.items()}
        n = len(next(iter(vals.values())))
        groups.append([{k: vals[k][i] for k in vals} for i in range(n)])
    tasks = []
    for combo in itertools.product(*groups) if groups else [()]:
        values = {}
        for part in combo:
            values.update(part)
        for r in range(spec.replicas):
            identity = {"values": values, "replica": r}
            task_id = _digest(identity)[:16]
            seed = _task_seed(spec.seed, {"replica": r} if spec.paired else identity)
            t = copy.deepcopy(tree)
            for key, value in values.items():
                set_path(t, key, value)
            t["seed"] = seed
            t["name"] = base.name
            try:
                scene = scene_from_dict(t, base_dir=base.base_dir)
            except (ValueError, TypeError) as e:
                raise type(e)(f"campaign task {values} (replica {r}): {e}") from None
            tasks.append(Task(task_id, dict(values), r, seed, scene))
    ids = [t.task_id for t in tasks]
    if len(set(ids)) != len(ids):
        raise ValueError("two tasks of the sweep have the same values; remove the duplicate values")
    return tasks


def estimate_task(scene) -> dict:
    """Estimated wall time [s] on one core and peak memory [bytes] of one task.

    The scene's kind estimates each unit (:meth:`cwlidar_sim.campaign.registry.SceneKind.estimate_unit`,
    with the scene's automatic settings resolved and its shared tensor, e.g.
    :func:`cwlidar_sim.campaign.periods.staring.estimate_unit`); the task's time is
    their sum plus :data:`TASK_OVERHEAD_S` (imports, set-up, writing), its
    memory the largest unit's plus :data:`INTERPRETER_BYTES`.
    """
    kind = kind_of(scene)
    scene = kind.resolve(scene)[0]
    params, _ = kind.scene_params(scene, None)
    per = [kind.estimate_unit(scene, i, params) for i in range(len(scene.unit_names()))]
    return {"seconds": TASK_OVERHEAD_S + sum(e["seconds"] for e in per),
            "memory_bytes": max(e["memory_bytes"] for e in per) + INTERPRETER_BYTES}
