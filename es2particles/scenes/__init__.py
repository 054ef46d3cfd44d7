"""Scenes: each module declares one simulation (its graph, start, view, defaults).

:func:`installed_scenes` maps a scene's command-line name to its class: the built-in ones and
every scene another package registers under the entry-point group ``es2particles.scenes``.
:func:`scene_class` loads one scene alone: a run imports only the scene it runs (importing every
scene and reading the package metadata cost ~45 ms of a ~0.5 s command).
"""

import importlib
import sys

ENTRY_POINT_GROUP = "es2particles.scenes"
# name -> "module:Class" of the built-in scenes, in the order `--help` lists them.
BUILT_IN = {"dejong": "es2particles.scenes.dejong:DeJong",
            "clifford": "es2particles.scenes.clifford:Clifford",
            "collision": "es2particles.scenes.collision:Collision",
            "fountain": "es2particles.scenes.fountain:Fountain",
            "collision3d": "es2particles.scenes.collision3d:Collision3D",
            "confetti": "es2particles.scenes.confetti:Confetti",
            "smoke": "es2particles.scenes.smoke:Smoke",
            "wind": "es2particles.scenes.wind:Wind",
            "boids": "es2particles.scenes.boids:Boids",
            "liquid": "es2particles.scenes.liquid:Liquid",
            "sph": "es2particles.scenes.sph:Sph",
            "flame": "es2particles.scenes.flame:Flame"}
# What ``from es2particles.scenes import X`` gives (name -> module), imported when first asked for.
_EXPORTS = {"Attractor": "attractor", "Defaults": "base", "Fill": "base", "Scene": "base",
            "DeJong": "dejong", "Clifford": "clifford", "Collision": "collision",
            "Fountain": "fountain", "Collision3D": "collision3d", "Confetti": "confetti",
            "Smoke": "smoke", "Wind": "wind", "Boids": "boids", "Liquid": "liquid", "Sph": "sph",
            "Flame": "flame"}

# The modules (what pdoc documents); the classes above are reached as attributes.
__all__ = ["base", "attractor", "dejong", "clifford", "emitter", "collision", "fountain",
           "collision3d", "confetti", "smoke", "air", "wind", "boids", "liquid", "sph", "flame",
           "field_compression", "installed_scenes", "scene_class", "ENTRY_POINT_GROUP",
           "BUILT_IN"]


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)


def _load(path):
    module, name = path.split(":")
    return getattr(importlib.import_module(module), name)


def scene_class(name):
    """The Scene class registered as ``name`` (a built-in one without reading any package
    metadata), or None where no scene has that name."""
    if name in BUILT_IN:
        return _load(BUILT_IN[name])
    return installed_scenes().get(name)


def _entry_points():
    from importlib.metadata import entry_points

    found = entry_points()
    if hasattr(found, "select"):
        return found.select(group=ENTRY_POINT_GROUP)
    return found.get(ENTRY_POINT_GROUP, [])  # Python 3.9


def installed_scenes():
    """name -> Scene class, built-in scenes first. A registered scene that fails to load, or is
    not a Scene of the name it is registered under, is left out with one line on stderr naming
    its entry point (one broken plug-in must not take the command line down)."""
    from .base import Scene

    scenes = {name: _load(path) for name, path in BUILT_IN.items()}
    for point in _entry_points():
        if BUILT_IN.get(point.name) == point.value:
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

