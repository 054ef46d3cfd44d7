"""The wind field: the article's first repository demo, a Navier-Stokes solver on a grid carrying
particles, here with the fluid in ES 2.0 passes too (the article's repository solves it on the
CPU).

The air is a grid (``--grid WxH`` cells over ``--box W,H`` metres) of three quantities in the
run's state format: ``wind`` (the velocity, m/s, cell-centred), ``divergence`` and ``pressure``.
A step is Stam's stable fluids (``shaders/glsl100/wind/fluid.frag``, one define a pass):
semi-Lagrangian advection (or MacCormack: ahead, behind, a limited correction), the wind's body
force with gusts and the pointer's drag (and vorticity confinement), implicit viscosity by Jacobi
iterations, the divergence, ``--pressure-iterations`` Jacobi iterations of the Poisson equation
(from ``--warm-start`` of last step's pressure) and the projection. Walls and obstacles sit on
the faces between cells, as ghost values (``wind/fluid.glsl``). The particles (default 2^20)
take the article's step: a velocity pass relaxing toward the air's bilinear velocity, then a
position pass; they are born again at a free random place when old, or when a step would take
them out of the box or into an obstacle (``wind/particles.frag``).
"""

import re
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from ..frame.graph import PassGraph
from ..frame.settings import Defaults
from ..params import Params, param
from ..twins.life import life_range, longest_life
from .air import ADVECTIONS, WALL_KINDS, Air, carried_faces
from .base import Push, Scene, clamp_report

SIDES = ("left", "right", "bottom", "top")
MAX_GRID = 4096  # cells a side: beyond, the context's textures decide (and refuse)
MAX_ALPHA = 1e4  # nu dt / dx^2 beyond which k Jacobi iterations leave almost all of the error


@dataclass(frozen=True)
class WindParams(Params):
    """The wind scene's parameters (SI units: metres, seconds)."""

    grid: str = param("256x256", text=True, metavar="WxH", help="the air's grid, in cells")
    box: tuple = param(None, 1e-3, 1e4, count=2, unit="m", metavar="W,H", optional=True,
                       help="the domain from (0, 0) at the lower left (default: 1 m high, as "
                            "wide as the grid's aspect)")
    dt: float = param(1 / 60, 1e-5, 1.0, unit="s", help="time step")
    viscosity: float = param(0.0, 0.0, 1e3, unit="m^2/s",
                             help="kinematic viscosity nu (implicit diffusion, by Jacobi "
                                  "iterations)")
    viscosity_iterations: int = param(20, 1, 1000, integer=True,
                                      help="Jacobi iterations of the viscous diffusion a step")
    pressure_iterations: int = param(40, 1, 10000, integer=True,
                                     help="Jacobi iterations of the pressure solve a step")
    warm_start: float = param(1.0, 0.0, 1.0,
                              help="the share of last step's pressure the solve starts from")
    advection: str = param("semi-lagrangian", choices=ADVECTIONS,
                           help="how the wind carries itself: semi-Lagrangian (one bilinear "
                                "backtrace) or MacCormack (ahead, behind, limited correction)")
    vorticity: float = param(0.0, 0.0, 100.0, help="vorticity confinement epsilon (0: off)")
    walls: str = param("open,open,slip,slip", text=True, metavar="LEFT,RIGHT,BOTTOM,TOP",
                       help="each side: slip, noslip, open, or a number: a no-slip wall moving "
                            "along itself at that many m/s (+y for left and right, +x for "
                            "bottom and top)")
    obstacle: str = param("circle:0.3,0.5,0.08", text=True,
                          metavar="SHAPE[+SHAPE...]|MASK.png",
                          help="obstacles: circle:X,Y,R and box:X,Y,HX,HY in metres, joined "
                               "by '+', a PNG mask (dark or opaque pixels are solid) stretched "
                               "over the box, or none")
    wind: tuple = param((1.5, 0.0), -1e3, 1e3, count=2, unit="m/s^2", metavar="X,Y",
                        help="the wind's body force")
    gusts: tuple = param((0.5, 2.0), (0.0, 1e-3), (10.0, 1e4), count=2,
                         metavar="AMPLITUDE,PERIOD",
                         help="the force varies as 1 + AMPLITUDE sin(2 pi t / PERIOD) (PERIOD "
                              "in s)")
    max_speed: float = param(4.0, 1e-3, 1e4, unit="m/s",
                             help="the velocity range of the air and the particles: faster "
                                  "values are clamped")
    relax: float = param(0.1, 0.0, 100.0, unit="s",
                         help="how fast a particle takes the air's velocity (the article's "
                              "0.1 s; 0: a tracer, exactly the air's)")
    lifetime: tuple = param((2.0, 6.0), 1e-6, None, count=2, unit="s", metavar="MIN,MAX",
                            help="lifetime range: an old particle is born again elsewhere")
    drag: tuple = param((0.0, 0.0, 0.0, 0.0, 0.1), count=5, option=False,
                        help="the pointer's drag: x, y, vx, vy (world units) and its radius")

    def check(self):
        self.shape  # parses --grid
        self.wall_uniforms
        lo, hi = self.lifetime
        longest = longest_life(self.dt)
        if not self.dt <= lo <= hi <= longest:
            raise ParameterError(f"--lifetime must be MIN,MAX with dt {self.dt:g} <= MIN <= MAX "
                                 f"<= {longest:.4g} s (the life clock counts 32512 steps of "
                                 f"--dt), got {lo:g},{hi:g}")
        if self.viscosity == 0 and self.viscosity_iterations != 20:
            raise ParameterError("--viscosity-iterations solve the viscous diffusion, and "
                                 "--viscosity is 0: give --viscosity NU with them")
        if not any(self.wind) and self.gusts != (0.5, 2.0):
            raise ParameterError("--gusts vary the --wind force, which is 0,0: they do nothing "
                                 "here; give --wind X,Y with them")
        dx, dy = self.cell
        alpha = self.viscosity * self.dt / min(dx, dy) ** 2
        if alpha > MAX_ALPHA:
            raise ParameterError(
                f"--viscosity {self.viscosity:g} gives nu dt / dx^2 = {alpha:.3g} on cells of "
                f"{min(dx, dy):.3g} m: beyond {MAX_ALPHA:g}, {self.viscosity_iterations} Jacobi "
                "iterations leave nearly all of the diffusion undone; lower --viscosity or --dt, "
                "or use a coarser --grid")

    @property
    def shape(self):
        """(W, H) cells, from ``--grid WxH``."""
        match = re.fullmatch(r"\s*(\d{1,9})\s*[xX]\s*(\d{1,9})\s*", self.grid)
        if not match:
            raise ParameterError(f"--grid must be WxH cells, e.g. 256x256, got {self.grid!r}")
        w, h = int(match[1]), int(match[2])
        for axis, n in (("W", w), ("H", h)):
            if not 2 <= n <= MAX_GRID:
                raise ParameterError(f"--grid {axis} must be in [2, {MAX_GRID}] cells, got {n}")
        return w, h

    @property
    def extent(self):
        """(W, H) of the box in metres."""
        if self.box is not None:
            return self.box
        w, h = self.shape
        return (w / h, 1.0)

    @property
    def cell(self):
        (w, h), (bw, bh) = self.shape, self.extent
        return bw / w, bh / h

    @property
    def wall_uniforms(self):
        """(kinds, speeds) of the four sides, as fluid.glsl's u_walls and u_wall_speed."""
        parts = [p.strip() for p in self.walls.split(",")]
        if len(parts) != 4:
            raise ParameterError(f"--walls must be 4 values LEFT,RIGHT,BOTTOM,TOP, got "
                                 f"{len(parts)} in {self.walls!r}")
        kinds, speeds = [], []
        for side, part in zip(SIDES, parts):
            if part in WALL_KINDS:
                kinds.append(WALL_KINDS[part])
                speeds.append(0.0)
                continue
            try:
                speed = float(part)
            except ValueError:
                raise ParameterError(f"--walls {side}: must be slip, noslip, open or a speed in "
                                     f"m/s, got {part!r}") from None
            if not abs(speed) <= self.max_speed:
                raise ParameterError(f"--walls {side}: a moving wall's speed must be in "
                                     f"[-{self.max_speed:g}, {self.max_speed:g}] m/s (--max-speed), "
                                     f"got {part}")
            kinds.append(3.0)
            speeds.append(speed)
        return tuple(kinds), tuple(speeds)


def solid_mask(spec, shape, extent):
    """Boolean (H, W) of the cells an obstacle holds, row 0 at the bottom: a cell is solid where
    its centre is inside a shape, or (a PNG mask) where any of its pixels is solid."""
    w, h = shape
    if spec.strip().lower() == "none":
        return np.zeros((h, w), bool)
    if spec.lower().endswith(".png"):
        from ..fields.field2d import load_mask

        return load_mask(spec, (w, h), "--obstacle")
    bw, bh = extent
    x = (np.arange(w) + 0.5) * bw / w
    y = (np.arange(h) + 0.5) * bh / h
    x, y = np.meshgrid(x, y)
    solid = np.zeros((h, w), bool)
    for part in spec.split("+"):
        kind, _, numbers = part.strip().partition(":")
        counts = {"circle": 3, "box": 4}
        try:
            values = [float(v) for v in numbers.split(",")]
        except ValueError:
            values = []
        if kind not in counts or len(values) != counts[kind] or \
                not all(np.isfinite(v) for v in values):
            raise ParameterError(f"--obstacle must be circle:X,Y,R or box:X,Y,HX,HY (metres) "
                                 f"joined by '+', a PNG mask or none; got {part!r}")
        if kind == "circle":
            cx, cy, r = values
            if r <= 0:
                raise ParameterError(f"--obstacle {part!r}: the radius must be > 0")
            solid |= (x - cx) ** 2 + (y - cy) ** 2 <= r * r
        else:
            cx, cy, hx, hy = values
            if hx <= 0 or hy <= 0:
                raise ParameterError(f"--obstacle {part!r}: the half sizes must be > 0")
            solid |= (np.abs(x - cx) <= hx) & (np.abs(y - cy) <= hy)
    return solid


class Wind(Scene):
    """Wind round obstacles: a stable-fluids MAC grid in passes, carrying particles."""

    name = "wind"
    Params = WindParams
    render_reads = ("position", "life")
    saves = ("wind", "pressure", "divergence")  # kept in the plan and in --save-state
    runs_alone = True  # --particles 0: the air alone, drawn as its speed
    particle_params = ("relax", "lifetime")  # refused with --particles 0
    defaults = Defaults(particles=2 ** 20, point_size=1.0, steps=120, rounding="nearest",
                        gradient="spectral")

    def __init__(self, params=None, **given):
        super().__init__(params, **given)
        p = self.params
        self.solid = solid_mask(p.obstacle, p.shape, p.extent)
        if self.solid.all():
            raise ParameterError("--obstacle fills the whole box: there is no air")
        bw, bh = p.extent
        self.view = (0.0, 0.0, bw, bh)

    def rendering(self):
        """The particles as density points, each coloured by its speed over [0, --max-speed]
        along the gradient map (a pixel the mean of its particles'), fading with age."""
        from ..render.points import Density

        return Density(self.view, self.render_reads, self.background(),
                       hue=("velocity", self.params.max_speed))

    def rendering_alone(self):
        """With no particles, the air's speed at each pixel from 0 to --max-speed along the
        gradient map, the obstacles over it."""
        from ..render.field import Field

        return Field("wind", self.view, self.params.max_speed, self.background())

    def air(self):
        """The scene's air: a 2D :class:`~es2particles.scenes.air.Air` from its parameters."""
        p = self.params
        kinds, speeds = p.wall_uniforms
        bw, bh = p.extent
        return Air(p.shape, (0.0, 0.0), (float(bw), float(bh)), p.dt, p.max_speed, kinds,
                   speeds=speeds, solid=self.solid, advection=p.advection,
                   viscosity=p.viscosity, viscosity_iterations=p.viscosity_iterations,
                   pressure_iterations=p.pressure_iterations, warm_start=p.warm_start,
                   vorticity=p.vorticity, force=p.wind, gusts=p.gusts, drag=p.drag)

    def graph(self, caps=None, count=None):
        """The fluid's passes, then the particles' (none where ``count`` is 0)."""
        from ..gl.context import Capabilities

        p = self.params
        g = PassGraph()
        (bw, bh), u = p.extent, p.max_speed
        w, h = p.shape
        largest = (caps or Capabilities.assumed()).max_texture_size
        if max(w, h) + 1 > largest:  # the faces' grids are a cell longer
            raise ParameterError(f"--grid {w}x{h}: this context's textures are at most "
                                 f"{largest} texels a side, and the faces need one more than "
                                 f"the cells: at most {largest - 1} cells a side")
        self.air().declare(g)
        dt = float(p.dt)
        if count == 0:
            return g
        # the particles: velocity, then position, then the life clock
        g.quantity("position", (0.0, 0.0), (bw, bh))
        g.quantity("velocity", -u, u)
        g.quantity("life", *life_range(p.dt), storage="rgba8")
        relax = 1.0 if p.relax == 0 else float(min(1.0, p.dt / p.relax))
        box = (0.0, 0.0, float(bw), float(bh))
        moving = {"u_dt": dt, "u_box": box, "u_lifetime": tuple(map(float, p.lifetime))}
        g.add("velocity", "wind/particles.frag", writes="velocity",
              reads=["velocity", "position"], reads_new=["u", "v"],
              uniforms={"u_relax": relax}, defines={"WRITE_VELOCITY": None})
        g.add("position", "wind/particles.frag", writes="position",
              reads=["position", "life"], reads_new=["velocity"], textures=["solid"],
              uniforms={k: moving[k] for k in ("u_dt", "u_box")},
              defines={"WRITE_POSITION": None})
        g.add("life", "wind/particles.frag", writes="life", reads=["position", "life"],
              reads_new=["velocity"], textures=["solid"], uniforms=moving,
              defines={"WRITE_LIFE": None})
        return g

    def after_run(self, sim):
        """The faces whose wind sits at the range's edge (+-max speed: clamped on write), if
        any, said once."""
        u = self.params.max_speed
        faces = sum(sim.buffers[q].quantity.domain.cells for q in ("u", "v"))
        at_edge = sum(sum(sim.clamped_writes(q)) for q in ("u", "v"))
        lines = [f"{at_edge} of {faces} faces' wind is at +-{u:g} m/s, the range's edge: faster "
                 "air was clamped on write; raise --max-speed"] if at_edge else []
        # the faces' line stands for the air: its centres and the faces' carried quantities
        # follow from the faces
        return lines + clamp_report(sim, skip=("u", "v", "wind", *carried_faces(sim)),
                                    hints={"velocity": "raise --max-speed"})

    def push(self):
        """A drag pulls the air within a tenth of the box's height toward the pointer's
        velocity (the force passes' u_drag_at and u_drag_velocity)."""
        return Push("u_drag_at", "u_drag_velocity", 0.1 * self.params.extent[1])

    @property
    def pressure_reach(self):
        """The pressure's range, +-(m^2/s): the air's (:attr:`Air.pressure_reach`)."""
        return self.air().pressure_reach

    def start(self, count, rng):
        """Particles alive at free places, ages spread over their lifetimes; the air still."""
        if not count:
            return {}
        p = self.params
        bw, bh = p.extent
        h, w = self.solid.shape
        free = np.flatnonzero(~self.solid.ravel())
        cells = rng.choice(free, count)
        position = np.stack([(cells % w + rng.random(count)) * bw / w,
                             (cells // w + rng.random(count)) * bh / h], 1)
        lifetime = rng.uniform(*p.lifetime, count)
        life = np.stack([np.floor(rng.random(count) * lifetime / p.dt) * p.dt, lifetime], 1)
        return {"position": position, "life": life}

    def background(self):
        """The obstacles, drawn under the particles (row 0 at the bottom)."""
        shade = np.zeros(self.solid.shape + (4,), np.uint8)
        shade[self.solid] = (46, 58, 84, 255)
        return shade

    def describe(self):
        p = self.params
        (w, h), (bw, bh), (dx, dy) = p.shape, p.extent, p.cell
        kinds, speeds = p.wall_uniforms
        names = {v: k for k, v in WALL_KINDS.items()}
        walls = ", ".join(f"{side} {names.get(k, f'moving at {s:g} m/s')}"
                          for side, k, s in zip(SIDES, kinds, speeds))
        solid = int(self.solid.sum())
        return [f"air: {w}x{h} cells of {dx:.4g} x {dy:.4g} m over {bw:g} x {bh:g} m; "
                f"{solid} cells solid ({p.obstacle}); walls: {walls}",
                f"fluid: {p.advection} advection, viscosity {p.viscosity:g} m^2/s"
                + (f" ({p.viscosity_iterations} Jacobi iterations)" if p.viscosity else "")
                + f", {p.pressure_iterations} pressure iterations from {p.warm_start:g} of last "
                  f"step's pressure, vorticity {p.vorticity:g}"] + super().describe()
