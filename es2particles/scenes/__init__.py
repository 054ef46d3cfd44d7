"""Scenes: each module declares one simulation (its graph, start, view, defaults).

:func:`installed_scenes` maps a scene's command-line name to its class: the built-in ones and
every scene another package registers under the entry-point group ``es2particles.scenes``.
"""

import sys
from importlib.metadata import entry_points

from .attractor import Attractor
from .base import Defaults, Fill, Scene
from .clifford import Clifford
from .collision import Collision
from .collision3d import Collision3D
from .dejong import DeJong
from .fountain import Fountain
from .smoke import Smoke

ENTRY_POINT_GROUP = "es2particles.scenes"
BUILT_IN = (DeJong, Clifford, Collision, Fountain, Collision3D, Smoke)

__all__ = ["Attractor", "Clifford", "Collision", "Collision3D", "DeJong", "Defaults", "Fill",
           "Fountain", "Scene", "Smoke", "installed_scenes", "ENTRY_POINT_GROUP"]


def _entry_points():
    found = entry_points()
    if hasattr(found, "select"):
        return found.select(group=ENTRY_POINT_GROUP)
    return found.get(ENTRY_POINT_GROUP, [])  # Python 3.9


def installed_scenes():
    """name -> Scene class, built-in scenes first. A registered scene that fails to load, or is
    not a Scene of the name it is registered under, is left out with one line on stderr naming
    its entry point (one broken plug-in must not take the command line down)."""
    scenes = {cls.name: cls for cls in BUILT_IN}
    for point in _entry_points():
        if point.name in scenes and point.value == _path(scenes[point.name]):
            continue  # a built-in scene, registered by our own package metadata
        try:
            cls = point.load()
        except Exception as error:  # a plug-in's import error, whatever it is
            print(f"es2particles: scene {point.name!r} ({point.value}) could not be loaded: "
                  f"{type(error).__name__}: {error}", file=sys.stderr)
            continue
        problem = None
        if not (isinstance(cls, type) and issubclass(cls, Scene)):
            problem = "it is not a subclass of es2particles.scenes.Scene"
        elif cls.name != point.name:
            problem = f"its name attribute is {cls.name!r}"
        elif point.name in scenes:
            problem = "another scene has that name"
        if problem:
            print(f"es2particles: scene {point.name!r} ({point.value}) is left out: {problem}",
                  file=sys.stderr)
            continue
        scenes[point.name] = cls
    return scenes


def _path(cls):
    return f"{cls.__module__}:{cls.__name__}"
