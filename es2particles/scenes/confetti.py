"""The ARM chapter's confetti: the 3D collision scene's particles (its voxel field, response and
moving objects, ``collision3d.py``) drawn as paper quads that tumble in flight and lie flat on
whatever they last touched. A fourth quantity, ``normal`` (an octahedral unit vector, two 16-bit
values), is set by the passes (``collision3d.frag`` with ``ORIENTED``) to the normal of the
last surface touched, and turns at ``--tumble`` in flight; the quads (``render/quads.py``) face
it."""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.settings import Defaults
from ..params import param
from ..render.quads import SHAPES, Quads
from ..render.shafts import ShaftParams, backlight
from .collision3d import Collision3D, Collision3DPhysics
from .emitter import time_step


@dataclass(frozen=True)
class ConfettiParams(ShaftParams, Collision3DPhysics):
    """The 3D collision's physics, object and camera, and the paper's: quads cut and lit, so
    none of the sprites' look (texture, blend, size law, softness, buffer, lamp); the light
    shafts, which the quads occlude."""

    dt: float = time_step(1 / 60, 0.1)
    tumble: float = param(540.0, 0.0, 3600.0, unit="degrees/s",
                          help="how fast a quad turns end over end in flight")
    paper_size: float = param(0.06, 0.001, 1.0, unit="m", help="a confetti's side")
    shapes: str = param("disc,square,star", text=True, metavar="SHAPE[,SHAPE...]",
                        help=f"the shapes cut from the quads: {', '.join(SHAPES)}")
    launch_spread: float = param(1.2, 0.0, 100.0, unit="m/s", option=False,
                                 help="the launch velocity's random spread")

    def check(self):
        super().check()
        shapes = self.shape_list
        if not shapes or any(s not in SHAPES for s in shapes) or len(set(shapes)) != len(shapes):
            raise ParameterError(f"--shapes: confetti shapes are one to three of "
                                 f"{', '.join(SHAPES)}, each once; got {self.shapes!r}")

    @property
    def shape_list(self):
        return tuple(s.strip() for s in self.shapes.split(",") if s.strip())


class Confetti(Collision3D):
    """Paper confetti falling on an object, tumbling, and lying flat where it lands."""

    name, Params, renders = "confetti", ConfettiParams, Quads
    writes = ("position", "velocity", "normal")
    defaults = Defaults(particles=2 ** 13, point_size=9.0, rounding="dither")

    def declare(self, g, caps):
        super().declare(g, caps)
        # octahedral: two numbers in [-1, 1], on its edges wherever a normal is on an axis
        g.quantity("normal", -1.0, 1.0, clamps="none")

    def uniforms(self, caps):
        return {**super().uniforms(caps), "u_tumble": float(np.radians(self.params.tumble))}

    def defines(self, caps):
        return {**super().defines(caps), "ORIENTED": None}

    def begin(self, count, rng):
        return {**super().begin(count, rng), "normal": np.tile([0.0, 1.0], (count, 1))}

    def rendering(self):
        p = self.params
        return Quads(half_size=p.paper_size / 2, shapes=p.shape_list,
                     light=(-1.5, 6.0, 3.0), meshes=tuple(self.meshes()),
                     shafts=p.shafts_declared(backlight(p.eye, p.target)))
