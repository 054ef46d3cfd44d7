"""Light shafts: the volumetric light scattering post-process of GPU Gems 3, chapter 13 (the
article's "light scattered" demo), as stages any 3D rendering can end with.

What a pixel at ``uv`` gets is defined once, as an integral along its ray towards the light's
point ``L`` on the screen::

    shaft(uv) = exposure * weight * integral over t in [0, 1] of
                SEGMENTS * decay^(SEGMENTS t) * source(L + (uv - L) (1 - RAY)^t) dt

where ``source`` is the light the occluders let through (1 where nothing is in front of the
sky, less through particles, by their opacity, 0 behind an opaque mesh) times the light's glow,
exp(-(d / GLOW)^2) at a distance d from L in picture heights, on the screen, and 0 off it (no
pass could hold what lies there; a ray that leaves the screen does not come back). The ray
runs from the pixel to 1 - RAY of its distance from L; ``decay`` is the light kept, and ``weight`` the light a sample
adds, per 1/SEGMENTS of the ray (so the author's values, 0.95 and 0.45 a tap, keep their sense).

Sampling t geometrically makes passes chain exactly: a pass of T taps whose factors are
(1 - RAY)^(j s) and weights decay^(SEGMENTS j s), j < T, applied to the output of a pass with
a step T times finer, multiplies their factors and weights, so P passes of T taps are one
midpoint sum of T^P samples (:func:`shaft_schedule`). Each pass is normalised (its output stays
in [0, 1] in an RGBA8 or half-float target) and the composite multiplies the gain back.
``reference`` is one pass of 1,024 taps at the picture's resolution.

Stages: the occluders at the picture's resolution (the meshes black, then the particles each
multiplying what passes by one less its opacity), the passes at the shafts' scale (``shafts/scatter.frag``), and the
composite (``shafts/composite.frag``), which adds the shafts to the picture in the light's
colour, faded out as the light turns towards the camera's side (they never flip behind it).
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range
from ..frame.plan import Ref, Resource, Stage
from ..params import Params, param
from .meshes import plan_mesh_passes

MODES = ("off", "on", "reference")
RAY = 0.95  # the ray runs from the pixel to 5% of its distance from the light
SEGMENTS = 16  # decay and weight are per 1/16 of the ray
GLOW = 0.25  # the light's glow, exp(-(d / GLOW)^2), d in picture heights from the light
COLOUR = (1.0, 0.9, 0.72)  # the light's colour
FADE = 0.25  # the shafts fade out as the cosine of the light's angle off the view falls below this
REACH = 0.25  # a light further off the screen (picture heights) is warned of: faint shafts
REFERENCE_TAPS = 1024
MAX_TAPS, MAX_PASSES = 128, 4


@dataclass(frozen=True)
class Shafts:
    """Light shafts over a 3D picture (see the module's docstring): ``passes`` chained passes of
    ``taps`` taps at ``scale`` of the picture's resolution, the first sample's place dithered by a
    4x4 Bayer pattern where ``jitter``; ``light`` the world point they stream from (None: the
    rendering's light). ``reference``: one pass of 1,024 taps at full resolution instead."""

    taps: int = 12
    passes: int = 2
    scale: float = 1.0
    jitter: bool = True
    decay: float = 0.95
    weight: float = 0.45
    exposure: float = 0.2
    light: tuple = None
    reference: bool = False

    what = "light shafts"  # how a refusal names them, as a feature of Sprites
    vertex_textures = 0  # in the sprites' own vertex shader (their occluders draw them again)

    def __post_init__(self):
        check_range("shaft taps", self.taps, 1, MAX_TAPS, integer=True)
        check_range("shaft passes", self.passes, 1, MAX_PASSES, integer=True)
        check_range("shaft scale", self.scale, 0.05, 1.0)
        check_range("shaft decay", self.decay, 0.5, 1.0)
        check_range("shaft weight", self.weight, 0.0, 10.0)
        check_range("shaft exposure", self.exposure, 0.0, 10.0)
        if self.light is not None:
            light = tuple(float(check_range("shaft light", v, -1e4, 1e4)) for v in self.light)
            if len(light) != 3:
                raise ParameterError(f"shaft light must be three numbers, got {self.light}")
            object.__setattr__(self, "light", light)
        if self.reference:
            for name, value in (("taps", REFERENCE_TAPS), ("passes", 1), ("scale", 1.0),
                                ("jitter", False)):
                object.__setattr__(self, name, value)

    @property
    def taps_a_pixel(self):
        return self.taps * self.passes

    def warnings(self, camera, size):
        """One line where the light's point lies more than REACH picture heights off the screen
        seen by ``camera`` (nothing off the screen gives light, and its glow is faint there)."""
        if self.light is None:
            return ()
        w, h = size
        clip = camera.matrix(w / h) @ np.array([*self.light, 1.0])
        if clip[3] <= 0:
            return (f"the shafts' light {_point(self.light)} is behind the camera: no shafts; "
                    "place it in view with --shaft-light X,Y,Z",)
        x, y = (clip[:2] / clip[3] + 1) / 2
        off = max(max(0.0, -x, x - 1) * w / h, max(0.0, -y, y - 1))
        if off <= REACH:
            return ()
        return (f"the shafts' light {_point(self.light)} is {off:.2g} picture heights off the "
                f"screen: its shafts barely show (light comes only from the screen, the glow "
                f"falls off over {GLOW:g}); place it in view with --shaft-light X,Y,Z",)

    def schedule(self):
        """:func:`shaft_schedule` of these shafts."""
        return shaft_schedule(self.taps, self.passes, self.decay, self.weight, self.exposure)


def _point(p):
    return "(" + ", ".join(f"{v:g}" for v in p) + ")"


def shaft_schedule(taps, passes, decay, weight=1.0, exposure=1.0):
    """Each pass's (log2 of its factor's step, log2 of its weight's step, 1 / its weights' sum),
    finest first, and the gain the composite multiplies the last pass by: P passes of T taps
    are the midpoint sum of T^P samples of the shaft integral (the module's docstring)."""
    n = taps ** passes
    rows, gain = [], exposure * weight * SEGMENTS / n
    for p in range(passes):
        step = taps ** p / n
        a, b = step * np.log2(1 - RAY), SEGMENTS * step * np.log2(decay)
        start = 0.5 if p == 0 else 0.0  # the first pass's samples sit mid-step (or jittered)
        total = float(np.sum(np.exp2(b * (np.arange(taps) + start))))
        rows.append((float(a), float(b), 1.0 / total))
        gain *= total
    return rows, float(gain)


@dataclass(frozen=True)
class ShaftParams(Params):
    """The light shafts' options, declared once for every 3D scene that takes them (a base of
    the emitter family's parameters)."""

    shafts: str = param("off", choices=MODES,
                        help="light shafts (GPU Gems 3, ch. 13): off, on, or reference (1,024 "
                             "taps at full resolution)")
    shaft_taps: int = param(12, 1, MAX_TAPS, integer=True, help="taps a pass")
    shaft_passes: int = param(2, 1, MAX_PASSES, integer=True,
                              help="chained passes (P passes of T taps sum T^P samples)")
    shaft_scale: float = param(1.0, 0.05, 1.0,
                               help="the shafts' resolution, a share of the picture's")
    shaft_jitter: str = param("on", choices=("on", "off"),
                              help="dither the first sample's place by a 4x4 Bayer pattern "
                                   "(banding becomes noise)")
    shaft_decay: float = param(0.95, 0.5, 1.0, help="light kept per 1/16 of the ray")
    shaft_weight: float = param(0.45, 0.0, 10.0, help="light a 1/16 of the ray adds")
    shaft_exposure: float = param(0.2, 0.0, 10.0, help="the shafts' brightness")
    shaft_light: tuple = param(None, -1e4, 1e4, count=3, unit="m", optional=True,
                               help="the point the shafts stream from (default: the lamp, or "
                                    "behind the camera's target as far again as the eye, a "
                                    "quarter of that higher)")

    def check(self):
        super().check()
        declared = self.declarations()
        moved = [d for n, d in declared.items() if n.startswith("shaft_") and d.option
                 and getattr(self, n) != d.default]
        if self.shafts == "off" and moved:
            raise ParameterError(f"{moved[0].flag_name}: light shafts are off; give --shafts on "
                                 "with it")
        fixed = [d for d in moved if d.name in ("shaft_taps", "shaft_passes", "shaft_scale",
                                                "shaft_jitter")]
        if self.shafts == "reference" and fixed:
            raise ParameterError(f"{fixed[0].flag_name}: the reference shafts are one pass of "
                                 f"{REFERENCE_TAPS:,} taps at full resolution, unjittered; give "
                                 "--shafts on with it")

    def shafts_declared(self, light):
        """The :class:`Shafts` these options ask for (streaming from ``--shaft-light``, else from
        ``light``: the scene's lamp, or :func:`backlight`), or None."""
        if self.shafts == "off":
            return None
        return Shafts(self.shaft_taps, self.shaft_passes, self.shaft_scale,
                      self.shaft_jitter == "on", self.shaft_decay, self.shaft_weight,
                      self.shaft_exposure, self.shaft_light or light, self.shafts == "reference")


def backlight(eye, target):
    """Where shafts stream from in a scene with no lamp: behind the camera's target as far again
    as the eye is in front of it, and a quarter of that distance higher (a light low in the sky
    behind the scene, on the screen above the target)."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    d = target - eye
    return tuple(float(v) for v in target + d + np.array([0.0, 0.25 * np.linalg.norm(d), 0.0]))


def plan_shafts(b, shafts, picture, light, meshes, occluders):
    """Add the light shafts' stages to plan builder ``b`` over the presented resource
    ``picture``: the occluders at the picture's resolution (``meshes`` drawn black, then
    ``occluders(target, clear)``, which adds the particles' stage multiplying what passes, the
    first to clear the target where there are no meshes), the chained passes at the shafts'
    scale and the composite. ``light``: the rendering's light (where the shafts declare none).
    Returns the new picture; with ``shafts`` None, ``picture`` (the plan says they are off)."""
    if shafts is None:
        b.left_out.append("light shafts (switched off)")
        return picture
    light = tuple(float(v) for v in (shafts.light or light))
    w, h = b.size
    scale = float(shafts.scale)
    size = (max(1, int(round(w * scale))), max(1, int(round(h * scale))))
    b.resource(Resource("shaft occluders", "target", (w, h), "rgba8", depth=bool(meshes),
                        linear=True, what="the light the scene lets through"))
    white = (1.0, 1.0, 1.0, 1.0)
    plan_mesh_passes(b, meshes, "shafts", "shaft occluder", "lamp/occluder.frag",
                     "shaft occluders", white, "black: it stops the light")
    occluders("shaft occluders", None if meshes else white)
    fmt = "rgba16f" if b.caps.renderable.get("rgba16f") else "rgba8"
    rows, gain = shafts.schedule()
    source, frame = "shaft occluders", {"u_view_projection": ("view_projection",)}
    for p, (a, bw, norm) in enumerate(rows, 1):
        name = f"shafts {p} of {len(rows)}" if len(rows) > 1 else "shafts"
        b.resource(Resource(name, "target", size, fmt, linear=True,
                            what="the light scattered towards the camera, normalised"))
        defines = {"TAPS": shafts.taps}
        uniforms = {"u_light": light, "u_pass": (a, bw, norm)}
        if p == 1:
            defines["SOURCE"] = None
            uniforms.update(u_aspect=w / h, u_glow=GLOW)
            if shafts.jitter:
                defines["JITTER"] = None
        b.stage(Stage(name, "shafts", "shafts/scatter.frag", defines=defines,
                      inputs={"u_source": Ref(source)}, target=Ref(name), uniforms=uniforms,
                      frame_uniforms=frame,
                      what=f"{shafts.taps} taps along the ray to the light"
                           + (", the first jittered" if "JITTER" in defines else "")))
        source = name
    b.resource(Resource("picture with shafts", "target", (w, h), "rgba8", linear=True,
                        what="the picture with the light shafts added"))
    colour = tuple(float(c * gain) for c in COLOUR)
    b.stage(Stage("shaft composite", "shafts", "shafts/composite.frag",
                  inputs={"u_image": Ref(picture), "u_shafts": Ref(source)},
                  target=Ref("picture with shafts"),
                  uniforms={"u_colour": colour, "u_light": light, "u_fade": FADE},
                  frame_uniforms={"u_eye": ("eye",), "u_forward": ("forward",)},
                  what=f"{'the reference: ' if shafts.reference else ''}{shafts.passes} x "
                       f"{shafts.taps} taps at {scale:g} of the resolution "
                       f"({shafts.taps ** shafts.passes} samples a ray), added"))
    return "picture with shafts"
