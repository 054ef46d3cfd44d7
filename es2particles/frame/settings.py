"""The frame settings: what a run asks of the frame beside the scene's own parameters.

:class:`FrameSettings` holds them, each left as :data:`DEFAULT` (the scene's default, in its
:class:`Defaults`, or the framework's) or given; :func:`check_settings` checks them for a scene
with no context, so bad input fails in one line before one is opened. The frame plan resolves
them once, against the context's limits (``plan.py``).
"""

from dataclasses import dataclass, fields, replace

from ..errors import CapabilityError, ParameterError, check_range
from ..params import Param
from .state import FORMATS

ROUNDINGS = ("nearest", "dither", "jitter")
AUTO_ORDER = ("rgba32f", "rgba16f", "rgba8")  # most precise first
MAX_STEPS = 10 ** 7


@dataclass(frozen=True)
class Defaults:
    """A scene's defaults of the frame settings, used where a run leaves them as DEFAULT."""

    particles: int = 2 ** 20
    point_size: float = 1.0
    steps: int = 1  # simulation steps before the first frame
    rounding: str = "nearest"
    gradient: str = "inferno"  # the gradient map's ramp


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
           "bloom": "--no-bloom/--bloom-*", "accumulate": "--accumulate", "seed": "--seed",
           "vertex_fetch": "--vertex-fetch", "trails": "--trails"}


@dataclass(frozen=True)
class FrameSettings:
    """What a run asks of the frame, beside the scene's own parameters. A setting left as
    ``DEFAULT`` takes the scene's default (particles, point size, steps, rounding) or the
    framework's; one given that the scene's frame does not use (an exposure for 3D sprites) is
    an error naming it, never silently ignored.

    ``gradient``: a ramp (see ``io.ramps``) or None (a density grey, any other picture as
    drawn); ``bloom``: a
    :class:`Bloom` or None (off). ``share``: which share of a larger
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
    vertex_fetch: object = DEFAULT
    trails: object = DEFAULT
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
    return (int(check_range("--size width", w, 1, max_size, integer=True)),
            int(check_range("--size height", h, 1, max_size, integer=True)))


def resolve_format(caps, fmt):
    """The storage format to use and a note saying why: ``auto`` takes the most precise format
    the context can render to; a named one must be renderable (else CapabilityError)."""
    packs = caps is None or caps.fragment_highp
    if fmt == "auto":
        for candidate in AUTO_ORDER:
            if caps.renderable.get(candidate) and (packs or candidate != "rgba8"):
                return candidate, f"{candidate} (auto: the most precise renderable format)"
        raise CapabilityError(f"--format auto: {caps.renderer} renders to no state format "
                              f"{'' if packs else 'it can unpack '}(of {', '.join(AUTO_ORDER)})")
    if fmt not in FORMATS:
        raise ParameterError(f"format must be one of {sorted(FORMATS)} or 'auto', got {fmt!r}")
    if caps is not None and not caps.renderable.get(fmt):
        raise CapabilityError(f"format {fmt!r} cannot be rendered to on {caps.renderer}")
    if fmt == "rgba8" and not packs:
        bits = caps.precision["fragment"]["medium float"][2]
        raise CapabilityError(f"format 'rgba8' packs each value in 16 bits, which fragment "
                              f"shaders without highp float cannot unpack (this context's best "
                              f"is mediump, {bits} bits): use --format auto")
    return fmt, fmt


def check_rounding(rounding):
    if rounding not in ROUNDINGS:
        raise ParameterError(f"rounding must be one of {ROUNDINGS}, got {rounding!r}")
    return rounding


# Settings every frame uses; a rendering declares the others it uses (``Rendering.settings``).
# The post chain every rendering's picture takes (a gradient map where the rendering makes none
# of its own, bloom: frame/plan.py's plan_picture), and trails after it.
POST_SETTINGS = ("gradient", "bloom", "trails")
COMMON_SETTINGS = ("particles", "size", "format", "rounding", "steps", "seed") + POST_SETTINGS
MAX_SIZE = 2 ** 16  # no context's textures are wider: the bound of a check made before one
MAX_ACCUMULATE = 10 ** 6
# Above ~1e6 per particle the tone curve maps every lit pixel to its top: a one-colour image
# with exit 0 (--intensity 1e39 did that).
MAX_INTENSITY = 1e6
MAX_POINT_SIZE = 1e4  # a sprite 10 images across at 1024 high: beyond any scene's use


def _setting(name, default, lo=None, hi=None, **kwargs):
    return Param(default, lo, hi, name=name, **kwargs)


# The frame settings declared once: the command line's options and help, a run file's values.
# A default of None is the scene's (its Defaults); bloom is declared by its parts.
SETTINGS = {d.name: d for d in (
    # 0 is taken here and refused by check_settings for a scene that needs particles (all but
    # those whose grids run alone: Scene.runs_alone); particles_setting words each scene's range.
    _setting("particles", None, 0, None, integer=True, help="particle count"),
    _setting("size", "1024x1024", text=True, metavar="WxH", help="image size in pixels"),
    _setting("format", "rgba8", choices=("rgba8", "rgba16f", "rgba32f", "auto"),
             help="state storage format (rgba8: 16-bit packed; auto: the most precise one the "
                  "context can render to)"),
    _setting("rounding", None, choices=ROUNDINGS,
             help="rounding of packed state (dither: stochastic on write, unbiased; jitter: "
                  "nearest on write, each read offset within its code)"),
    _setting("steps", None, 0, MAX_STEPS, integer=True,
             help="simulation steps before the (first) frame"),
    _setting("seed", 0, 0, 2 ** 63 - 1, integer=True, help="seed of the starting state"),
    # At least a pixel for points and sprites alike (a size of 0 drew nothing, and a sprite
    # below a pixel is drawn as one anyway); the context's own range bounds a point's further.
    _setting("point_size", None, 1.0, MAX_POINT_SIZE, unit="pixels",
             help="point or sprite diameter (a sprite's at the camera distance where its "
                  "attenuation is 1, in an image 1024 high)"),
    _setting("intensity", 1.0, 0.0, MAX_INTENSITY,
             help="density each particle adds: brightens the tone-mapped picture"),
    _setting("exposure", 4.0, 1e-3, 1e3, help="tone curve brightness"),
    _setting("gradient", "inferno", text=True, metavar="RAMP",
             help="gradient map, colouring the picture by its brightness: a ramp name (inferno, "
                  "ice, viridis, gold, grey, spectral), colours '#000,#f80,#fff', a PNG path, or "
                  "'none' (a density grey, any other picture as drawn)"),
    _setting("accumulate", 1, 1, MAX_ACCUMULATE, integer=True,
             help="samples in each image: this step's and the next K-1 steps' (a density sums "
                  "them, and reseeded attractors shift their grid for each; a flame averages "
                  "its marches, whose dither moves each step); 1/sqrt(K) the noise"),
    _setting("vertex_fetch", "auto", choices=("auto", "on", "off"),
             help="how the points and sprites read the state: on, vertex texture fetch (the "
                  "article's way); off, the state read back into a vertex buffer each frame (for "
                  "devices without it; sprites then take no depth sort, shadow map, lamp or "
                  "shafts); auto, on where the context has vertex texture units"),
    _setting("trails", "off", text=True, metavar="off|fade:OPACITY|ribbons:K",
             help="trails over an animation's frames: fade:OPACITY keeps the brighter of the new "
                  "picture and the last frame's times OPACITY (0 to 1), less 0.6 of a code, so a "
                  "trail fades out fully (webgl-wind's screen-space fade); ribbons:K draws each "
                  "particle's positions of the last K frames (2 to 64) as a strip, fading with "
                  "age"),
    _setting("bloom_threshold", 0.2, 0.0, 1.0, help="bloom luminance threshold"),
    _setting("bloom_radius", 3.0, 0.5, 4.0, help="bloom blur sigma, texels of the half level"),
    _setting("bloom_intensity", 0.8, 0.0, 10.0, help="bloom strength"),
)}
BLOOM_PARTS = ("bloom_threshold", "bloom_radius", "bloom_intensity")


@dataclass(frozen=True)
class Bloom:
    """The bloom setting's value: luminance threshold in [0, 1], blur radius (sigma in [0.5, 4]
    texels of the half-resolution level; the quarter level doubles it), and how much glow is
    added; each part's default and range is its declaration's in :data:`SETTINGS`."""

    # 0.2: the article's glow shows (21% of the de Jong still's pixels change, 0.6% saturate);
    # at 0.6, above 99.9% of the pixels, bloom changed 0.04% and the glow was invisible.
    threshold: float = SETTINGS["bloom_threshold"].default
    radius: float = SETTINGS["bloom_radius"].default
    intensity: float = SETTINGS["bloom_intensity"].default

    def __post_init__(self):  # radius at most 4: the 12 taps of blur.frag cover 3 sigma
        for part in ("threshold", "radius", "intensity"):
            object.__setattr__(self, part, SETTINGS[f"bloom_{part}"].convert(
                getattr(self, part), f"bloom {part}"))


MAX_RIBBON = 64  # positions a ribbon keeps, at most


def check_bloom(value):
    """Refuse a bloom setting that is neither a :class:`Bloom`, None (off) nor left as
    DEFAULT."""
    if not (value is DEFAULT or value is None or isinstance(value, Bloom)):
        raise ParameterError(f"bloom must be a Bloom or None (off), got {type(value).__name__}")
    return value


def parse_trails(text):
    """``--trails`` as (kind, value): ("off", None), ("fade", the opacity a frame keeps, in
    (0, 1)) or ("ribbons", K positions each particle's ribbon keeps, 2 to MAX_RIBBON); anything
    else is refused in one line (K against the context's texture size: when the frame is
    planned)."""
    if not isinstance(text, str):
        raise ParameterError(f"--trails must be off, fade:OPACITY or ribbons:K, got {text!r}")
    kind, _, value = text.partition(":")
    if kind == "off" and not value:
        return "off", None
    if kind == "fade":
        try:
            opacity = float(value)
        except ValueError:
            raise ParameterError(f"--trails fade:OPACITY takes a number, got {value!r}") from None
        if not 0.0 < opacity < 1.0:
            raise ParameterError(f"--trails fade:OPACITY must be in (0, 1), got {value}")
        return "fade", opacity
    if kind == "ribbons":
        if not value.strip().isdigit() or not 2 <= int(value) <= MAX_RIBBON:
            raise ParameterError(f"--trails ribbons:K takes a whole number K in [2, "
                                 f"{MAX_RIBBON}] (positions a ribbon keeps), got {value!r}")
        return "ribbons", int(value)
    raise ParameterError(f"--trails must be off, fade:OPACITY or ribbons:K, got {text!r}")


# The settings of a frame's state: a frame that keeps none (an empty pass graph) uses none.
STATE_SETTINGS = ("particles", "format", "rounding", "seed")


def state_quantities(scene):
    """The quantities ``scene``'s step keeps (none: a scene that keeps no state here, such as
    the flame's noise, which the state settings cannot act on)."""
    from .graph import scene_graph

    return list(scene_graph(scene, None).quantities.values())


def keeps_state(scene, rendering):
    """Whether the state settings (STATE_SETTINGS) act on ``scene`` drawn by ``rendering``:
    its renderer reads particles, or its step keeps quantities."""
    return bool(rendering.reads) or bool(state_quantities(scene))


def keeps_particles(scene):
    """Whether ``--particles`` counts anything for ``scene``: its step keeps a quantity on the
    particles (a state of grids alone, the wind flame's, counts none)."""
    return any(q.domain is None for q in state_quantities(scene))


def _inert_state_setting(scene, settings, quantities):
    """(setting, why) of a state setting given that changes nothing for ``scene``'s state, the
    formats its ``quantities`` (its pass graph's, with no context) take in the format given
    (``Quantity.format_in``); None if each acts. A quantity declared 32-bit is kept so in rgba8
    and rgba16f alike, and 32-bit packed or float state is always rounded to the nearest value."""
    given, fmt = settings.given(), resolve(settings, None, "format")
    if fmt not in FORMATS:  # auto: known with a context
        return None
    if not quantities:
        return None
    stored = sorted({q.format_in(fmt) for q in quantities})
    if "format" in given and fmt != "rgba8" and stored == sorted(
            {q.format_in("rgba8") for q in quantities}):
        return "format", (f"scene {scene.name!r} keeps its state in {', '.join(stored)} with "
                          f"--format rgba8 too (its quantities ask for more bits than {fmt} "
                          "holds, or are pinned): it would change nothing")
    if "rounding" in given and settings.rounding != "nearest" and "rgba8" not in stored:
        return "rounding", (f"scene {scene.name!r} keeps its state in {', '.join(stored)} "
                            f"here, always rounded to the nearest value: {settings.rounding} "
                            "rounding applies to 16-bit packed state (rgba8)")
    return None


def acting_state_settings(scene, values):
    """``values`` (the resolved settings a run file writes, by name) with each state setting
    that would change nothing for ``scene`` written as the value that acts: the rounding of
    float or 32-bit state is the nearest, a format its quantities ignore is rgba8. A file naming
    the other value is refused on reading (--format rgba16f wrote the SPH's default dither)."""
    values = dict(values)
    quantities = state_quantities(scene)
    for _ in range(2):  # the format, then the rounding in that format
        given = FrameSettings(**{n: values[n] for n in ("format", "rounding") if n in values})
        inert = _inert_state_setting(scene, given, quantities)
        if inert is None:
            break
        values[inert[0]] = "nearest" if inert[0] == "rounding" else "rgba8"
    return values


def frames_independent(scene, settings):
    """Whether a frame of ``scene`` needs nothing drawn before it: a stateless (reseeded) scene
    without trails (a trail is the frames before)."""
    return bool(scene.stateless) and resolve(settings, None, "trails") == "off"


def particles_setting(scene):
    """The ``particles`` setting as ``scene`` takes it: from 1, or from 0 where its grids run
    alone (``Scene.runs_alone``: the picture is then its :meth:`rendering_alone`)."""
    if getattr(scene, "runs_alone", False):
        return replace(SETTINGS["particles"], help="particle count (0: the grids alone)")
    return replace(SETTINGS["particles"], lo=1)


def typed_setting(name, value, label, scene=None):
    """Frame setting ``name`` as typed, on the command line (text) or in a run file (TOML's
    types), converted once for both to the value a :class:`FrameSettings` holds: checked
    against its declaration (the particle count against ``scene``'s range), the gradient
    'none' as None (off), a run file's size [w, h] as a pair. ``label`` names it in a refusal."""
    declared = SETTINGS[name]
    if name == "particles" and scene is not None:
        declared = particles_setting(scene)
    if name == "size" and not isinstance(value, str):
        if isinstance(value, list) and len(value) == 2 and all(type(v) is int for v in value):
            return tuple(value)
        raise ParameterError(f'{label} must be "WxH" or [w, h], got {value!r}')
    if not declared.text:
        return declared.convert(value, label)
    if not isinstance(value, str):
        raise ParameterError(f"{label} must be text, got {value!r}")
    return None if name == "gradient" and value == "none" else value


def scene_rendering(scene, particles=DEFAULT):
    """What ``scene`` draws with ``particles``: its :meth:`rendering`, or where its grids run
    alone and ``particles`` is 0, its :meth:`rendering_alone`."""
    if particles == 0 and getattr(scene, "runs_alone", False):
        return scene.rendering_alone()
    return scene.rendering()


def _refuse_particle_params(scene):
    """With ``--particles 0`` (the grids alone), a parameter only the particles use (the scene's
    ``particle_params``) set to other than its default is refused in one line."""
    params = getattr(scene, "params", None)
    if params is None:
        return
    declared = params.declarations()
    for name in getattr(scene, "particle_params", ()):
        d = declared[name]
        if getattr(params, name) != d.convert(type(params).__dataclass_fields__[name].default):
            raise ParameterError(f"{d.flag_name}: only the particles use it, and --particles 0 "
                                 f"runs the grids alone: it does nothing here")


def check_settings(settings, scene, rendering=None):
    """Check ``settings`` for ``scene`` without a context (what does not depend on one): every
    setting given is one the scene's frame uses, and each is of its kind and in its range (the
    size, particle count and point size against the context's own limits come when the frame is
    planned). Raises :class:`ParameterError` naming the setting."""
    if not isinstance(settings, FrameSettings):
        raise ParameterError(f"settings must be a FrameSettings, got {type(settings).__name__}")
    if "particles" in settings.given():
        particles_setting(scene).convert(settings.particles, "--particles")
    rendering = scene_rendering(scene, settings.particles) if rendering is None else rendering
    if settings.particles == 0 and getattr(scene, "runs_alone", False):
        _refuse_particle_params(scene)
    used = set(COMMON_SETTINGS) | set(rendering.settings)
    unused = [name for name in settings.given() if name not in used]
    if unused:
        raise ParameterError(f"{', '.join(OPTIONS.get(n, n) for n in unused)}: scene "
                             f"{scene.name!r} does not use "
                             f"{'this setting' if len(unused) == 1 else 'these settings'} "
                             f"({rendering.kind})")
    stateful = [n for n in STATE_SETTINGS if n in settings.given()]
    quantities = state_quantities(scene) if stateful else []
    if stateful and not rendering.reads and not quantities:
        raise ParameterError(f"{OPTIONS.get(stateful[0], stateful[0])}: scene {scene.name!r} "
                             "keeps no state here (no particles, no grid): nothing to count, "
                             "store, round or seed")
    if "particles" in stateful and quantities and not keeps_particles(scene):
        raise ParameterError(f"--particles: scene {scene.name!r} keeps grids here, no "
                             "particles: there is nothing to count")
    given = {name: getattr(settings, name) for name in settings.given()}
    if "format" in given:
        SETTINGS["format"].convert(given["format"], "format")
    if "rounding" in given:
        SETTINGS["rounding"].convert(given["rounding"], "rounding")
    inert = _inert_state_setting(scene, settings, quantities) if stateful else None
    if inert:
        name, why = inert
        raise ParameterError(f"{OPTIONS[name]} {given[name]}: {why}")
    for name, value in given.items():
        if name == "size":
            parse_size(value, MAX_SIZE)
        elif name == "bloom":
            check_bloom(value)
        elif name == "gradient" and value is not None:
            from ..io.ramps import load_ramp

            load_ramp(value)
        elif name == "trails" and parse_trails(value)[0] == "ribbons" and scene.stateless:
            raise ParameterError(f"--trails {value}: scene {scene.name!r} places its particles "
                                 "afresh each step, so their positions make no path; use "
                                 "--trails fade:OPACITY")
        elif name in SETTINGS and not SETTINGS[name].text:
            SETTINGS[name].convert(value, name)
    rendering.check_settings({n: v for n, v in given.items() if n in rendering.settings})
    check_range("share", settings.share, 0, 2 ** 40, integer=True)


def setting(name, value):
    """``value`` of setting ``name`` checked against its declaration (kind and range)."""
    return SETTINGS[name].convert(value, name)


def resolve(settings, defaults, name, rendering=None):
    """Frame setting ``name`` as a run takes it, resolved in one place: given in ``settings``
    (a :class:`FrameSettings`, or None), else the scene's own default (its ``defaults``, a
    :class:`Defaults`, where it has that field), else the framework's declaration's
    (:data:`SETTINGS`; bloom: the ``rendering``'s ``default_bloom``, on for the density's
    tone-mapped picture and off for the others, whose look it would change; the gradient map:
    the scene's where the rendering maps one of its own, a density's or a field's, else off)."""
    value = DEFAULT if settings is None else getattr(settings, name)
    if value is not DEFAULT:
        return value
    if name == "gradient" and not getattr(rendering, "own_gradient", True):
        return None  # a picture drawn in colour keeps them unless a ramp is asked for
    if defaults is not None and name in {f.name for f in fields(defaults)}:
        return getattr(defaults, name)
    if name == "bloom":
        return getattr(rendering, "default_bloom", None)
    return SETTINGS[name].default
