"""A grid quantity as the picture: what a grid scene draws with no particles (``--particles 0``).

Each pixel takes the quantity at its world point over the rectangle ``view``, sampled as a pass
samples it (``sample_q``: bilinear, by hand or by the hardware as the plan says), and maps its
magnitude (a vector's length, a scalar's absolute value) over [0, ``top``] through the gradient
map, or grey; the scene's background image (its objects) covers it where opaque. One full-screen
stage (``field/field.frag``) writes the picture: no post chain.
"""

from dataclasses import dataclass

from ..errors import ParameterError, check_range
from ..frame.plan import Ref, Rendering, Resource, Stage
from ..gl.bindings import generated_values, stage_interface
from .post import colouring


@dataclass(frozen=True)
class Field(Rendering):
    """Grid quantity ``quantity`` (on a 2D grid) drawn over the world rectangle ``view`` (x0, y0,
    x1, y1), its magnitude from 0 to ``top`` along the gradient map, under ``background``."""

    quantity: str
    view: tuple
    top: float
    background: object = None

    own_gradient = True  # the magnitude is coloured along it
    has_camera = False
    kind = "it draws a grid quantity as an image"

    def __post_init__(self):
        x0, y0, x1, y1 = (float(v) for v in self.view)
        if not (x1 > x0 and y1 > y0):
            raise ParameterError(f"view must have x1 > x0 and y1 > y0, got {self.view}")
        check_range("field top", self.top, 1e-30)

    @property
    def reads(self):
        return (self.quantity,)

    def plan(self, b, defaults):
        q = b.graph_plan.quantities[self.quantity]
        if q.domain is None or q.domain.dimensions != 2:
            raise ParameterError(f"the field rendering draws a quantity of a 2D grid; "
                                 f"{self.quantity!r} lives on "
                                 f"{'the particles' if q.domain is None else 'a 3D grid'}")
        own = {"u_view": tuple(map(float, self.view)), "u_top": float(self.top)}
        interface = stage_interface((self.quantity,), {self.quantity: q}, b.format, own)
        defines, inputs = colouring(b, b.setting("gradient"), self.background,
                                    "the scene's objects, over the field")
        defines["read_field_sample"] = f"sample_{self.quantity}"
        b.resource(Resource("field", "target", b.size, "rgba8", linear=True,
                            what=f"{self.quantity}'s magnitude"))
        w, h = q.domain.shape
        b.stage(Stage("field", "field", "field/field.frag", defines=defines,
                      interface=interface, inputs={**b.state_inputs(interface), **inputs},
                      target=Ref("field"), uniforms=own,
                      generated=generated_values(interface, q.domain.layout(b.caps.max_texture_size)),
                      what=f"{self.quantity} on its {w}x{h} grid, |{self.quantity}| from 0 to "
                           f"{self.top:g} along the gradient map"))
        return "field"
