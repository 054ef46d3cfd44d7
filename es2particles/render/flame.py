"""A flame as a volume: emission and absorption along each pixel's ray through the flame's box,
the article's last repository demo (its author sphere-traces a noise-displaced distance field and
calls the steps taken its glow; here the same kind of field is a density, and the march
integrates it).

What a pixel gets is defined once::

    L = integral over t in [t0, t1] of T(t) (E / K) B(temp(t)) K rho(t) dt + T(t1) background
    T(t) = exp(-integral over [t0, t] of K rho(s) ds),     picture = 1 - exp(-L)

along the ray from the eye through the pixel, where it crosses the box [lo, hi]: ``rho`` the
density, ``temp`` the temperature in [0, 1], ``K`` the extinction (1/m at density 1), ``E`` the
emission (light a metre at density 1) and ``B`` the blackbody colour of the temperature
(:func:`blackbody_ramp`); the tone curve takes a hot core towards white. The march (``flame/march.frag``) cuts [t0, t1] into ``steps`` equal
segments, takes the field at one point of each (the midpoint, or a place dithered by a 4x4
Bayer pattern and the frame number: banding becomes noise that frames average) and integrates
each segment exactly for a field constant over it: a segment of opacity a = 1 - exp(-K rho h)
adds T (E / K) B a. A uniform field is therefore exact at any step count.

Sources of the field: ``noise``, a stretched sphere's distance displaced by two octaves of
simplex noise rising with time (the author's flame, made a density with a soft edge, hotter at
its core and base); ``grid``, a grid of cells (``cells`` a side over the box, kept as an atlas
of ``cells`` tiles, one a z slice) that the scene's particles are splatted into each frame
(``flame/splat.vert``): a cell's density is its particles' count times ``per_particle``, its
temperature their mean heat (1 at birth, 0 at the end of life), read trilinearly; ``state``, a
quantity of the scene's state on a 3D grid over the box, (density, temperature) (``quantity``:
the wind flame's ``fire``, which its air carries), read by its generated trilinear sample.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import CapabilityError, ParameterError, check_range
from ..frame.plan import Ref, Rendering, Resource, Stage
from ..frame.settings import setting
from ..gl.bindings import generated_values, stage_interface
from ..gl.device import DrawState

SOURCES = ("noise", "grid", "state")
MAX_STEPS = 1024
RAMP_KELVIN = (1000.0, 3000.0)  # the ramp's temperatures 0 and 1
RAMP_SIZE = 256
WAVELENGTHS = (610e-9, 550e-9, 465e-9)  # red, green, blue (m)
# The splat's accumulation formats, in order: two channels (count, heat) that do not saturate.
SPLAT_FORMATS = ("rgba32f", "rgba16f", "rgba8")
# The temporal accumulation's sum of K pictures, each weighed 1/K: float where it blends.
SUM_FORMATS = ("rgba32f", "rgba16f", "rgba8")


def planck(wavelength, kelvin):
    """Planck's spectral radiance (W sr^-1 m^-3) at ``wavelength`` (m) and ``kelvin``."""
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    return 2 * h * c ** 2 / wavelength ** 5 / np.expm1(h * c / (wavelength * k * kelvin))


def blackbody_ramp(size=RAMP_SIZE, kelvin=RAMP_KELVIN):
    """(size, 3) float64: a blackbody's colour from ``kelvin[0]`` to ``kelvin[1]`` evenly: the
    hue of Planck's law at the three wavelengths (its brightest channel 1) times the brightness
    of Stefan-Boltzmann's law, (T / kelvin[1])^4: dim red when cool, yellow-white when hot."""
    t = np.linspace(*kelvin, size)
    rgb = np.stack([planck(w, t) for w in WAVELENGTHS], axis=1)
    return rgb / rgb.max(axis=1, keepdims=True) * (t / kelvin[1])[:, None] ** 4


def ramp_image(size=RAMP_SIZE):
    """The ramp as the (1, size, 4) uint8 image the march samples, rounded to the nearest code."""
    image = np.full((1, size, 4), 255, np.uint8)
    image[0, :, :3] = np.round(blackbody_ramp(size) * 255)
    return image


def flame_light(lo, hi):
    """Where the light shafts the flame lights stream from: the middle of its box's lower part
    (a 0.3 of the way up), where the flame is brightest."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = (lo + hi) / 2
    centre[1] = lo[1] + 0.3 * (hi[1] - lo[1])
    return tuple(float(v) for v in centre)


def atlas_shape(cells):
    """(tiles across, tiles down) of the atlas of ``cells`` z slices of ``cells``^2 texels."""
    across = int(np.ceil(np.sqrt(cells)))
    return across, int(np.ceil(cells / across))


@dataclass(frozen=True)
class Flame(Rendering):
    """A flame marched through the box ``lo``..``hi`` seen by the scene's camera (see the
    module's docstring). ``source``: noise (``shape``: radius, height, flicker, frequency (1/m);
    ``rise``: the noise's upward speed, m/s; ``dt``: seconds a step) or grid (``cells`` a side,
    ``per_particle``: a particle's density in its cell; reads position and life).
    Or state: ``quantity``, a state quantity of two components (density, temperature) on a 3D
    grid over the box. ``extinction``, ``emission``: K and E. ``steps`` segments a ray,
    ``jitter`` their sample's place dithered. ``up``, ``fov``: the camera's up and vertical
    field of view (degrees), for the rays."""

    source: str = "noise"
    lo: tuple = (-1.0, 0.0, -1.0)
    hi: tuple = (1.0, 2.5, 1.0)
    steps: int = 64
    jitter: bool = True
    extinction: float = 4.0
    emission: float = 6.0
    background: tuple = (0.02, 0.02, 0.03)
    shape: tuple = (0.45, 2.0, 0.35, 1.6)
    rise: float = 1.5
    dt: float = 1 / 30
    cells: int = 48
    per_particle: float = 0.125
    quantity: str = "fire"
    up: tuple = (0.0, 1.0, 0.0)
    fov: float = 45.0
    shafts: object = None

    settings = ("accumulate",)
    has_camera = True
    kind = "it marches a flame through a volume: no point size or tone map"

    def __post_init__(self):
        if self.source not in SOURCES:
            raise ParameterError(f"flame source must be one of {', '.join(SOURCES)}, got "
                                 f"{self.source!r}")
        check_range("march steps", self.steps, 1, MAX_STEPS, integer=True)
        check_range("flame extinction", self.extinction, 1e-3, 1e3)
        check_range("flame emission", self.emission, 0.0, 1e3)
        check_range("flame cells", self.cells, 2, 128, integer=True)
        if not np.all(np.greater(self.hi, self.lo)):
            raise ParameterError(f"the flame's box must have hi > lo, got {self.lo}, {self.hi}")

    @property
    def reads(self):
        return {"grid": ("position", "life"), "state": (self.quantity,)}.get(self.source, ())

    def uniforms(self, size):
        """The march's uniforms for a picture of ``size``."""
        w, h = size
        lens = float(np.tan(np.radians(self.fov) / 2))
        out = {"u_lo": tuple(map(float, self.lo)), "u_hi": tuple(map(float, self.hi)),
               "u_up": tuple(map(float, self.up)), "u_lens": (lens * w / h, lens),
               "u_medium": (float(self.extinction), float(self.emission / self.extinction)),
               "u_background": tuple(map(float, self.background))}
        if self.source == "noise":
            out.update(u_shape=tuple(map(float, self.shape)), u_rise=float(self.rise * self.dt))
        else:
            across, down = atlas_shape(self.cells)
            out["u_atlas"] = (float(self.cells), float(across), float(across * self.cells),
                              float(down * self.cells))
        return out

    def plan(self, b, defaults):
        """The splat (grid source), the march and, where asked, the light shafts the flame
        lights; returns the picture."""
        from .shafts import plan_shafts

        # The flame is the shafts' light: their source is the flame's own picture (nothing in
        # front of it), streaming from where it burns brightest.
        return plan_shafts(b, self.shafts, self._plan_march(b), flame_light(self.lo, self.hi), (),
                           lambda target, clear: b.stage(Stage(
                               "shaft source: the flame", "shafts", "post/present.frag",
                               inputs={"u_source": Ref("flame")}, target=Ref(target),
                               what="the flame's light, nothing in front of it")))

    def _plan_march(self, b):
        """The splat (grid source) and the march: the flame over the background."""
        w, h = b.size
        inputs = {}
        b.resource(Resource("flame ramp", "image", (RAMP_SIZE, 1), "rgba8", data=ramp_image(),
                            linear=True, what="the blackbody colour by temperature"))
        inputs["u_ramp"] = Ref("flame ramp")
        scale, interface, generated = 1.0, None, {}
        defines = {"STEPS": self.steps, f"SOURCE_{self.source.upper()}": None}
        if self.source == "grid":
            scale = self._plan_splat(b)
            inputs["u_grid"] = Ref("flame grid")
        elif self.source == "state":
            interface, generated = self._state_interface(b)
            inputs.update(b.state_inputs(interface))
            defines["field_sample"] = f"sample_{self.quantity}"
        uniforms = self.uniforms((w, h))
        if self.source == "grid":
            uniforms["u_density"] = float(self.per_particle / scale)
        if self.jitter:
            defines["JITTER"] = None
        b.resource(Resource("flame", "target", (w, h), "rgba8", linear=True,
                            what="the flame over the background"))
        frame = {"u_eye": ("eye",), "u_forward": ("forward",)}
        if self.source == "noise" or self.jitter:  # the noise's clock, the dither's frame
            frame["u_step"] = ("step",)
        # Temporal accumulation: the marches of this step and the next K-1 steps' (the dither's
        # phase moves each step, and the field with it), each weighed 1/K into a sum.
        samples = b.accumulate = setting("accumulate", b.setting("accumulate"))
        what = (f"{self.steps} segments a ray through the {self.source} field"
                + (", their samples dithered" if self.jitter else ", midpoints"))
        if samples == 1:
            b.stage(Stage("flame", "flame", "flame/march.frag", defines=defines,
                          interface=interface, inputs=inputs, target=Ref("flame"),
                          uniforms=uniforms, generated=generated, frame_uniforms=frame,
                          what=what))
            return "flame"
        fmt = next(f for f in SUM_FORMATS if f == "rgba8" or b.caps.blendable.get(f))
        b.resource(Resource("flame sum", "target", (w, h), fmt, linear=True,
                            what=f"{samples} marches, each weighed 1/{samples}"))
        b.stage(Stage("flame", "flame", "flame/march.frag",
                      defines={**defines, "ACCUMULATE": None}, interface=interface,
                      inputs=inputs, target=Ref("flame sum"),
                      uniforms={**uniforms, "u_weight": 1 / samples}, generated=generated,
                      frame_uniforms=frame, state=DrawState(blend="add"),
                      clear=(0.0, 0.0, 0.0, 0.0), samples=samples,
                      what=f"{what}; {samples} steps' marches averaged in {fmt}"))
        b.stage(Stage("flame average", "post", "post/present.frag",
                      inputs={"u_source": Ref("flame sum")}, target=Ref("flame"),
                      what="the average, in RGBA8"))
        return "flame"

    def _state_interface(self, b):
        """The march's generated reads of the state quantity (source state): its interface and
        the values it declares. The quantity must be (density, temperature) on a 3D grid."""
        q = b.graph_plan.quantities.get(self.quantity)
        if q is None or q.domain is None or q.domain.dimensions != 3 or q.components != 2:
            where = ("not in the scene's state" if q is None else "on the particles"
                     if q.domain is None else f"of {q.components} components on a "
                     f"{q.domain.dimensions}D grid")
            raise ParameterError(f"the flame's state source marches quantity "
                                 f"{self.quantity!r}, (density, temperature) on a 3D grid; it "
                                 f"is {where}")
        interface = stage_interface((self.quantity,), {self.quantity: q}, b.format)
        return interface, generated_values(interface, q.domain.layout(b.caps.max_texture_size))

    def _plan_splat(self, b):
        """The grid's atlas and the stage adding each live particle's count and heat into its
        cell. Returns a count's value in the atlas (1, or 1/255 in RGBA8)."""
        caps, layout = b.caps, b.layout
        fmt = next((f for f in SPLAT_FORMATS if caps.blendable.get(f)), None)
        if fmt is None:
            raise CapabilityError(f"no format can be blended into on {caps.renderer}")
        if caps.max_vertex_texture_units < 1:
            raise CapabilityError("the flame's grid source splats particles by vertex texture "
                                  "fetch; this context has no vertex texture units")
        scale = 1.0 if fmt != "rgba8" else 1.0 / 255.0
        across, down = atlas_shape(self.cells)
        size = (across * self.cells, down * self.cells)
        quantities = {q: b.graph_plan.quantities[q] for q in self.reads}
        own = {"u_lo": tuple(map(float, self.lo)), "u_hi": tuple(map(float, self.hi)),
               "u_atlas": (float(self.cells), float(across), float(size[0]), float(size[1]))}
        interface = stage_interface(tuple(quantities), quantities, b.format, own)
        b.resource(Resource("flame grid", "target", size, fmt, linear=True,
                            what=f"{self.cells}^3 cells, {self.cells} z slices as tiles: "
                                 f"count and heat of the particles in each"))
        b.stage(Stage("flame splat", "splat", "flame/splat.frag", "flame/splat.vert",
                      vertex_interface=interface, inputs=b.state_inputs(interface),
                      target=Ref("flame grid"), vertices=b.particle_texels(),
                      primitive="points", count=layout.count,
                      state=DrawState(blend="add", point_size=True),
                      uniforms={**own, "u_scale": scale},
                      generated=generated_values(interface, layout), clear=(0.0,) * 4,
                      what=f"{layout.count} particles into their cells"))
        return scale
