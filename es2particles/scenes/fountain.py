"""The JOGL chapter's fountain in 3D: fireballs leave emitters on the floor, fly parabolas, fade
with age and die at their lifetime or through the floor, drawn as glowing sprites over a checkered
floor beside the seed's crate. A point-emitting member of the emitter family (``emitter.py``):
its step is ``fountain.frag``, its float64 twin ``twins/fountain.py``. y is up, the floor y = 0;
the position's range, y in [-1, 7], puts the floor on a code of the 16-bit grid, so nothing on
it reads below it."""

from dataclasses import dataclass

from ..errors import ParameterError
from ..frame.settings import Defaults
from ..params import param
from ..render.meshes import box, crate_texture, floor
from .emitter import PointEmitterParams, PointEmitting


@dataclass(frozen=True)
class FountainParams(PointEmitterParams):
    """The seed's: gravity 9.81, particles die at 2.5 s or through the floor."""

    gravity: tuple = param((0.0, -9.81, 0.0), -100.0, 100.0, count=3, unit="m/s^2",
                           help="the acceleration of gravity (a vector, as in every scene)")
    drag: float = param(0.1, 0.0, 100.0, unit="1/s", help="drag k of v' = -k v (exact)")
    floor: str = param("kill", choices=("kill", "bounce"),
                       help="kill: die through the floor, to be emitted again (the seed)")
    bounce: float = param(0.5, 0.0, 1.0, help="the share of speed a floor bounce keeps")
    max_speed: float = param(12.0, 0.1, 100.0, unit="m/s", help="the velocity range's bound")

    def check(self):
        super().check()
        if self.floor == "kill" and self.bounce != self.declarations()["bounce"].default:
            raise ParameterError("--bounce: particles bounce only off --floor bounce (the "
                                 "default floor kills them); give it with it")


class Fountain(PointEmitting):
    """The JOGL chapter's fountain of fireballs, in 3D."""

    name, step, Params = "fountain", "fountain.frag", FountainParams
    # 2^11 sprites of 20 pixels: the seed's fireballs stay separate (2^14 add up to white).
    defaults = Defaults(particles=2 ** 11, point_size=20.0, rounding="dither")

    def declare(self, g, caps):
        g.quantity("position", *self.box)
        g.quantity("velocity", -self.params.max_speed, self.params.max_speed, components=3)

    def uniforms(self, caps):
        p = self.params
        return {"u_dt": p.dt, "u_gravity": p.gravity, "u_drag": p.drag, "u_bounce": p.bounce,
                "u_max_speed": p.max_speed, "u_lifetime": p.lifetime, **super().uniforms(caps)}

    def defines(self, caps):
        return {**super().defines(caps), **({"FLOOR_KILL": None} if self.params.floor == "kill"
                                        else {})}

    def meshes(self):
        return [floor(self.box[1][0]), box((2.2, 0.6, -1.2), (0.6, 0.6, 0.6),
                                           colour=(1.0, 1.0, 1.0), texture=crate_texture())]

    def sprites(self):
        return {"size_spread": 0.5, "tint": (1.0, 0.12, 0.04, 0.45), "opacity": 0.7}
