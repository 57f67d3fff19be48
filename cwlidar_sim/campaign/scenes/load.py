"""Reading a scene file of any kind: the kind named by its ``kind`` key, found in the registry.

The scene classes themselves (:mod:`~cwlidar_sim.campaign.scenes.staring`,
:mod:`~cwlidar_sim.campaign.scenes.conical`, :mod:`~cwlidar_sim.campaign.scenes.nacelle`, a
plugin's) parse their own tables; these functions pick the class by
:func:`cwlidar_sim.campaign.registry.get_kind`.
"""

from __future__ import annotations

from ..registry import get_kind
from .spec import parse_toml, read_text_file

__all__ = ["load_scene", "loads_scene", "scene_from_dict"]


def loads_scene(text: str, *, base_dir: str = "."):
    """Parse a scene from TOML text: the scene class of its ``kind`` (:func:`~cwlidar_sim.campaign.scenes.load.scene_from_dict`)."""
    return scene_from_dict(parse_toml(text, "scene"), base_dir=base_dir)


def scene_from_dict(d: dict, *, base_dir: str = "."):
    """A scene of any registered kind from a TOML-shaped mapping, by ``d['kind']`` (default ``'staring'``).

    The kind is looked up in :mod:`cwlidar_sim.campaign.registry`: an unknown
    one is a ValueError naming the closest kinds and every registered one.
    The files the scene's ``[turbulence]`` table names (``file``) must exist
    (relative paths from ``base_dir``): a FileNotFoundError names the key.
    """
    name = d.get("kind", "staring") if isinstance(d, dict) else "staring"
    scene = get_kind(name).scene_class.from_dict(d, base_dir=base_dir)
    check = getattr(getattr(scene, "turbulence", None), "check_files", None)
    if check is not None:  # the files a scene names (turbulence.file) exist, relative to its folder
        check(base_dir)
    return scene


def load_scene(path):
    """Read a scene TOML file (of any registered kind)."""
    text, folder = read_text_file(path, "scene")
    return loads_scene(text, base_dir=folder)
