"""The frame settings: what a run asks of the frame beside the scene's own parameters.

:class:`FrameSettings` holds them, each left as :data:`DEFAULT` (the scene's default, in its
:class:`Defaults`, or the framework's) or given; :func:`check_settings` checks them for a scene
with no context, so bad input fails in one line before one is opened. The frame plan resolves
them once, against the context's limits (``plan.py``).
"""

from dataclasses import dataclass, fields

from ..errors import CapabilityError, ParameterError, check_range
from .state import FORMATS

ROUNDINGS = ("nearest", "dither")
AUTO_ORDER = ("rgba32f", "rgba16f", "rgba8")  # most precise first
MAX_STEPS = 10 ** 7


@dataclass(frozen=True)
class Defaults:
    """A scene's defaults of the frame settings, used where a run leaves them as DEFAULT."""

    particles: int = 2 ** 20
    point_size: float = 1.0
    steps: int = 1  # simulation steps before the first frame
    rounding: str = "nearest"


class _Default:
    """A setting left to the scene or the framework (``FrameSettings``)."""

    def __repr__(self):
        return "DEFAULT"

    def __reduce__(self):
        return "DEFAULT"


DEFAULT = _Default()
# A setting's command-line form, for messages that name what the user typed.
OPTIONS = {"particles": "--particles", "size": "--size", "format": "--format",
           "rounding": "--rounding", "steps": "--steps", "point_size": "--point-size",
           "intensity": "--intensity", "exposure": "--exposure", "gradient": "--gradient",
           "bloom": "--no-bloom/--bloom-*", "accumulate": "--accumulate", "seed": "--seed"}


@dataclass(frozen=True)
class FrameSettings:
    """What a run asks of the frame, beside the scene's own parameters. A setting left as
    ``DEFAULT`` takes the scene's default (particles, point size, steps, rounding) or the
    framework's; one given that the scene's frame does not use (a gradient map for 3D sprites) is
    an error naming it, never silently ignored.

    ``gradient``: a ramp (see ``render.ramps``) or None (grey); ``bloom``: a
    :class:`~es2particles.render.post.Bloom` or None (off). ``share``: which share of a larger
    still this is (``cluster/shares.py``)."""

    particles: object = DEFAULT
    size: object = DEFAULT
    format: object = DEFAULT
    rounding: object = DEFAULT
    steps: object = DEFAULT
    point_size: object = DEFAULT
    intensity: object = DEFAULT
    exposure: object = DEFAULT
    gradient: object = DEFAULT
    bloom: object = DEFAULT
    accumulate: object = DEFAULT
    seed: object = DEFAULT
    share: int = 0

    def given(self):
        """The names of the settings given (not left as DEFAULT)."""
        return [f.name for f in fields(self)
                if f.name != "share" and getattr(self, f.name) is not DEFAULT]

    def get(self, name, default):
        value = getattr(self, name)
        return default if value is DEFAULT else value


def parse_size(text, max_size):
    """'WxH' (or an int pair) to (w, h), each in [1, max_size]."""
    if isinstance(text, str):
        parts = text.lower().split("x")
        if len(parts) != 2:
            raise ParameterError(f"size must be WxH, e.g. 1024x1024, got {text!r}")
        try:
            text = tuple(int(p) for p in parts)
        except ValueError:
            raise ParameterError(f"size must be WxH with whole numbers, got {text!r}") from None
    try:
        w, h = text
    except (TypeError, ValueError):
        raise ParameterError(f"size must be WxH or a (w, h) pair, got {text!r}") from None
    return (int(check_range("size width", w, 1, max_size, integer=True)),
            int(check_range("size height", h, 1, max_size, integer=True)))


def resolve_format(caps, fmt):
    """The storage format to use and a note saying why: ``auto`` takes the most precise format
    the context can render to; a named one must be renderable (else CapabilityError)."""
    if fmt == "auto":
        for candidate in AUTO_ORDER:
            if caps.renderable.get(candidate):
                return candidate, f"{candidate} (auto: the most precise renderable format)"
    if fmt not in FORMATS:
        raise ParameterError(f"format must be one of {sorted(FORMATS)} or 'auto', got {fmt!r}")
    if caps is not None and not caps.renderable.get(fmt):
        raise CapabilityError(f"format {fmt!r} cannot be rendered to on {caps.renderer}")
    return fmt, fmt


def check_rounding(rounding):
    if rounding not in ROUNDINGS:
        raise ParameterError(f"rounding must be one of {ROUNDINGS}, got {rounding!r}")
    return rounding


# Settings every frame uses; a rendering declares the others it uses (``Rendering.settings``).
COMMON_SETTINGS = ("particles", "size", "format", "rounding", "steps", "seed")
MAX_SIZE = 2 ** 16  # no context's textures are wider: the bound of a check made before one


def check_settings(settings, scene, rendering=None):
    """Check ``settings`` for ``scene`` without a context (what does not depend on one): every
    setting given is one the scene's frame uses, and each is of its kind and in its range (the
    size, particle count and point size against the context's own limits come when the frame is
    planned). Raises :class:`ParameterError` naming the setting."""
    if not isinstance(settings, FrameSettings):
        raise ParameterError(f"settings must be a FrameSettings, got {type(settings).__name__}")
    rendering = scene.rendering() if rendering is None else rendering
    used = set(COMMON_SETTINGS) | set(rendering.settings)
    unused = [name for name in settings.given() if name not in used]
    if unused:
        raise ParameterError(f"{', '.join(OPTIONS.get(n, n) for n in unused)}: scene "
                             f"{scene.name!r} does not use "
                             f"{'this setting' if len(unused) == 1 else 'these settings'} "
                             f"({rendering.kind})")
    given = {name: getattr(settings, name) for name in settings.given()}
    checks = {"size": lambda v: parse_size(v, MAX_SIZE),
              "particles": lambda v: check_range("particles", v, 1, None, integer=True),
              "steps": lambda v: check_range("steps", v, 0, MAX_STEPS, integer=True),
              "seed": lambda v: check_range("seed", v, 0, 2 ** 63 - 1, integer=True),
              "format": lambda v: v == "auto" or v in FORMATS or resolve_format(None, v),
              "rounding": check_rounding,
              "point_size": lambda v: check_range("point_size", v, 0.0, None)}
    for name, value in given.items():
        if name in checks:
            checks[name](value)
    rendering.check_settings({n: v for n, v in given.items() if n in rendering.settings})
    check_range("share", settings.share, 0, 2 ** 40, integer=True)
