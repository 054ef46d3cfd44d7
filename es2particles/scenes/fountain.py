"""The JOGL chapter's fountain in 3D: fireballs leave emitters on the floor, fly parabolas, fade
with age and die at their lifetime or through the floor, drawn as glowing sprites over a
checkered floor beside a cube, from a fixed or orbiting camera.

Three quantities: ``position`` and ``velocity`` of three components (two RGBA8 textures each,
one in the float formats) and ``life`` (the exact step clock of ``twins/life.py``). Three passes,
one per quantity, run the same ``particle_step()`` of ``fountain.frag``. World units: y is up and
the floor is the plane y = 0. float64 twin: ``twins/fountain.py``.
"""

from dataclasses import dataclass

import numpy as np

from ..render.camera import Camera, orbit
from ..errors import ParameterError, check_range
from ..frame.graph import PassGraph
from ..render.meshes import box, crate_texture, floor
from ..render.sprites import Sprites
from ..twins.life import life_range, longest_life, staggered_births
from .base import Defaults, Scene, steady_steps

FLOOR_HALF = 6.0  # the floor is [-6, 6]^2; x and z of the position range too
# The position's y range is [-1, HEIGHT]: 8 units, so the floor y = 0 is exactly a code of the
# 16-bit grid (8128 of 65024) and, rounding being monotone, nothing at or above the floor is
# stored below it (with [-1, 6], 0 fell between codes and particles on it read -1.5e-5).
HEIGHT = 7.0
FLOORS = ("kill", "bounce")
CAMERAS = ("fixed", "orbit")


@dataclass(frozen=True)
class FountainPhysics:
    """The fountain's parameters: seconds and world units. The seed: gravity 9.81, particles
    die at 2.5 s or through the floor."""

    dt: float = 1 / 30
    gravity: float = 9.81
    drag: float = 0.1
    speed_across: tuple = (0.6, 1.4)
    speed_up: tuple = (5.0, 7.0)
    lifetime: tuple = (2.0, 2.5)
    floor: str = "kill"
    bounce: float = 0.5
    # (x, y, z) points, or (x, y, z, dx, dy, dz[, rate]) with a launch direction and a rate
    emitters: tuple = ((0.0, 0.0, 0.0),)
    max_speed: float = 12.0

    def __post_init__(self):
        check_range("dt", self.dt, 1e-4, 0.25)
        check_range("gravity", self.gravity, 0.0, 100.0)
        check_range("drag", self.drag, 0.0, 100.0)
        check_range("bounce", self.bounce, 0.0, 1.0)
        check_range("max_speed", self.max_speed, 0.1, 100.0)
        for name in ("speed_across", "speed_up"):
            lo, hi = (check_range(name, v, 0.0, self.max_speed) for v in getattr(self, name))
            if hi < lo:
                raise ParameterError(f"{name} must have min <= max, got {getattr(self, name)}")
        lo, hi = (check_range("lifetime", v, self.dt, longest_life(self.dt))
                  for v in self.lifetime)
        if hi < lo:
            raise ParameterError(f"lifetime must have min <= max, got {self.lifetime}")
        if self.floor not in FLOORS:
            raise ParameterError(f"floor must be one of {FLOORS}, got {self.floor!r}")
        if not 1 <= len(self.emitters) <= 16:
            raise ParameterError(f"emitters must be 1 to 16 (x, y, z) points, got "
                                 f"{len(self.emitters)}")
        for e in self.emitters:
            if len(e) not in (3, 6, 7):
                raise ParameterError(f"an emitter is x,y,z or x,y,z,dx,dy,dz or "
                                     f"x,y,z,dx,dy,dz,rate; got {e}")
            check_range("emitter x", e[0], -FLOOR_HALF, FLOOR_HALF)
            check_range("emitter y", e[1], 0.0, HEIGHT)
            check_range("emitter z", e[2], -FLOOR_HALF, FLOOR_HALF)
            if len(e) >= 6 and not np.linalg.norm([check_range("emitter direction", v)
                                                   for v in e[3:6]]) > 0:
                raise ParameterError(f"an emitter's direction must not be zero, got {e[3:6]}")
            if len(e) == 7:
                check_range("emitter rate", e[6], 1e-6, 1e6)

    def table(self):
        """(points (k, 3), unit directions (k, 3), shares of the particles (k,))."""
        full = [tuple(e) + (0.0, 1.0, 0.0, 1.0)[len(e) - 3:] for e in self.emitters]
        table = np.array(full, dtype=float)
        directions = table[:, 3:6] / np.linalg.norm(table[:, 3:6], axis=1, keepdims=True)
        return table[:, :3], directions, table[:, 6] / table[:, 6].sum()

    def uniforms(self):
        points, directions, shares = self.table()
        emitters = np.zeros((2 * len(points), 4))
        emitters[0::2, :3], emitters[0::2, 3] = points, np.cumsum(shares)
        emitters[1::2, :3] = directions
        return {"u_dt": float(self.dt), "u_gravity": (0.0, -float(self.gravity), 0.0),
                "u_drag": float(self.drag), "u_bounce": float(self.bounce),
                "u_max_speed": float(self.max_speed),
                "u_speed": (*map(float, self.speed_across), *map(float, self.speed_up)),
                "u_lifetime": tuple(map(float, self.lifetime)), "u_emitters": emitters}


class Fountain(Scene):
    """The JOGL chapter's fountain of fireballs, in 3D."""

    name = "fountain"

    def __init__(self, physics=FountainPhysics(), camera="fixed", blend="add", sprite="fireball",
                 size_spread=0.5):
        if camera not in CAMERAS:
            raise ParameterError(f"camera must be one of {CAMERAS}, got {camera!r}")
        self.physics, self.camera, self.blend, self.sprite = physics, camera, blend, sprite
        self.size_spread = size_spread
        # Steady from the first frame: one longest lifetime before it. Sprites of 20 pixels at
        # the fixed camera's distance; 2^11 particles: the seed's glowing fireballs stay
        # separate (2^14 at these sizes sum to a white blob under additive blending).
        steps = steady_steps(physics)
        self.defaults = Defaults(particles=2 ** 11, point_size=20.0, steps=steps,
                                 rounding="dither")

    @classmethod
    def add_arguments(cls, parser):
        add = parser.add_argument
        add("--dt", type=float, default=1 / 30, help="time step in seconds (default 1/30)")
        add("--gravity", type=float, default=9.81, help="downward acceleration (default 9.81)")
        add("--drag", type=float, default=0.1, help="drag coefficient k (default 0.1)")
        add("--floor", choices=FLOORS, default="kill",
            help="kill: die through the floor and be re-emitted at once (the seed); bounce "
                 "(default kill)")
        add("--bounce", type=float, default=0.5,
            help="speed kept on a floor bounce, [0, 1] (default 0.5)")
        add("--lifetime", type=float, nargs=2, default=(2.0, 2.5), metavar=("MIN", "MAX"),
            help="lifetime range in seconds (default 2 2.5)")
        add("--emitters", default="0,0,0",
            help="emitters separated by ';': x,y,z, or x,y,z,dx,dy,dz (a launch direction), or "
                 "x,y,z,dx,dy,dz,rate (a share of the particles); default one at the origin, "
                 "launching up")
        add("--camera", choices=CAMERAS, default="fixed",
            help="fixed, or orbit: circle the scene once over the frames of an animation "
                 "(default fixed)")
        add("--blend", choices=("add", "over"), default="add",
            help="sprite blending: add (glow) or over (premultiplied alpha) (default add)")
        add("--sprite", default="fireball",
            help="sprite texture: fireball, disc or a PNG path (default fireball)")

    @classmethod
    def from_args(cls, args):
        try:
            emitters = tuple(tuple(float(v) for v in e.split(","))
                             for e in args.emitters.split(";") if e.strip())
        except ValueError:
            raise ParameterError(f"--emitters must be numbers x,y,z[,dx,dy,dz[,rate]] separated "
                                 f"by ';', got {args.emitters!r}") from None
        physics = FountainPhysics(dt=args.dt, gravity=args.gravity, drag=args.drag,
                                  floor=args.floor, bounce=args.bounce,
                                  lifetime=tuple(args.lifetime), emitters=emitters)
        return cls(physics, args.camera, args.blend, args.sprite)

    def graph(self, caps=None):
        p = self.physics
        g = PassGraph()
        g.quantity("position", (-FLOOR_HALF, -1.0, -FLOOR_HALF), (FLOOR_HALF, HEIGHT, FLOOR_HALF))
        g.quantity("velocity", -p.max_speed, p.max_speed, components=3)
        g.quantity("life", *life_range(p.dt), storage="rgba8")
        state = ("position", "velocity", "life")
        defines = {"EMITTERS": len(p.emitters)}
        if p.floor == "kill":
            defines["FLOOR_KILL"] = None
        for name in state:
            g.add(name, "fountain.frag", writes=name, reads=state, uniforms=p.uniforms(),
                  defines={**defines, f"WRITE_{name.upper()}": None})
        return g

    def start(self, count, rng):
        p = self.physics
        points = p.table()[0]
        return {"life": staggered_births(count, p.lifetime, rng),
                "position": points[np.arange(count) % len(points)],
                "velocity": np.zeros((count, 3))}

    def meshes(self):
        """The seed's scenery: a checkered floor and a cube beside the fountain."""
        return [floor(FLOOR_HALF), box((2.2, 0.6, -1.2), (0.6, 0.6, 0.6), colour=(1.0, 1.0, 1.0),
                                       texture=crate_texture())]

    def camera_at(self, frame, frames):
        if self.camera == "orbit":
            return orbit(frame, frames, radius=7.5, height=3.0, target=(0.0, 1.4, 0.0))
        return Camera(eye=(0.0, 3.0, 7.5), target=(0.0, 1.4, 0.0))

    def rendering(self):
        # Point size is the size at the fixed camera's distance to the fountain (the seed scales
        # sizes by the camera's squared distance relative to its first): 1 / d^2 attenuation.
        d0 = np.linalg.norm(np.subtract(self.camera_at(0, 1).eye, (0.0, 1.4, 0.0)))
        return Sprites(sprite=self.sprite, size_spread=self.size_spread,
                       attenuation=(0.0, 0.0, 1.0 / d0 ** 2), blend=self.blend,
                       tint=(1.0, 0.12, 0.04, 0.45), opacity=0.7, meshes=self.meshes())

    def describe(self):
        p = self.physics
        return [f"physics: dt {p.dt:.4g}, gravity {p.gravity:g}, drag {p.drag:g} (exact), floor "
                f"{p.floor}" + (f" (bounce {p.bounce:g})" if p.floor == "bounce" else "")
                + f", {len(p.emitters)} emitter(s); no acceleration pass: gravity and drag are "
                "uniforms"]
