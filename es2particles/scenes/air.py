"""The wind's air as a declaration: Stam's stable fluids on a MAC grid of two or three
dimensions, declared on a pass graph (``shaders/glsl100/wind/fluid.frag``, one define a pass).

:class:`Air` holds what the passes need (cells, box, walls, obstacles, the solver's settings and
forces) and :meth:`Air.declare` adds its grids, quantities, scene textures and passes to a
:class:`~es2particles.frame.graph.PassGraph`, in the order a step runs them: advection, the
fire's carry (where there is a :class:`Fire`), forces, viscosity, the divergence, the pressure's
Jacobi iterations and the projection, and the wind at the cell centres. The wind scene declares
it in 2D under particles; the flame's wind source in 3D, carrying a fire it lifts.

The grids: ``air`` (the cells: pressure, divergence, the centred ``wind``, the fire), and one
grid of faces an axis, a cell longer along it (``xfaces``: u, ``yfaces``: v, ``zfaces``: w),
whose box puts its cell centres on the faces, so ``sample_u`` is a plain bilinear (trilinear)
read. A face is blocked (held at 0) on a closed wall or beside an obstacle
(:func:`blocked_faces`); each blocked mask is a scene texture laid out as its grid
(``Grid.image``), read by ``G_uv(cell)``.
"""

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError

WALL_KINDS = {"slip": 0.0, "noslip": 1.0, "open": 2.0}  # a number: a moving no-slip wall (3)
ADVECTIONS = ("semi-lagrangian", "maccormack")
COMPONENTS = ("u", "v", "w")
FACE_GRIDS = ("xfaces", "yfaces", "zfaces")


def blocked_faces(solid, closed):
    """The faces held at 0, one boolean array an axis (x, y[, z]) for cells ``solid`` (H, W)
    or (D, H, W), row 0 at the bottom: beside a solid cell, or on a side ``closed`` says is
    closed (one (low, high) pair of booleans an axis). Axis a's array is one longer along it."""
    solid = np.asarray(solid, bool)
    out = []
    for a in range(solid.ndim):
        along = solid.ndim - 1 - a  # x is the last array axis

        def at(index):
            return tuple(index if i == along else slice(None) for i in range(solid.ndim))
        shape = list(solid.shape)
        shape[along] += 1
        faces = np.zeros(shape, bool)
        faces[at(slice(1, None))] |= solid
        faces[at(slice(None, -1))] |= solid
        faces[at(0)] |= closed[a][0]
        faces[at(-1)] |= closed[a][1]
        out.append(faces)
    return out


def carried_faces(sim):
    """The quantities of ``sim`` on the air's face grids besides the velocity itself
    (MacCormack's ahead and behind, viscosity's held faces): each interpolated from the faces
    or copied from them, so at its range's edge only where they are, and said with them."""
    return [q for q, b in sim.buffers.items() if q not in COMPONENTS
            and b.quantity.domain is not None and b.quantity.domain.name in FACE_GRIDS]


def texels(mask):
    """A boolean image (rows from the bottom) as an RGBA8 texture, r = 255 where set."""
    mask = np.asarray(mask, bool)
    out = np.zeros(mask.shape + (4,), np.uint8)
    out[mask, 0] = 255
    out[..., 3] = 255
    return out


@dataclass(frozen=True)
class Fire:
    """What the 3D air carries (the flame's wind source): a density and a temperature in [0, 1]
    at the cell centres, quantity ``fire``. Each step it moves with the wind, keeps ``keep``
    (density, temperature) of itself (it fades and cools), and is fed at the burner, a flat
    ball at ``burner`` (x, y, z, radius; half as high as wide), up to ``feed`` (density,
    temperature), flickering by noise; its temperature lifts the air by ``buoyancy`` m/s^2 at
    temperature 1."""

    burner: tuple
    feed: tuple = (1.0, 1.0)
    keep: tuple = (1.0, 1.0)
    buoyancy: float = 4.0


@dataclass(frozen=True)
class Air:
    """A MAC grid of air over the box ``lo``..``hi`` (metres), ``shape`` (W, H) or (W, H, D)
    cells, stepped every ``dt`` seconds (see the module's docstring).

    ``walls``: each side's kind (low x, high x, low y, high y[, low z, high z]; WALL_KINDS' values,
    3 a no-slip wall moving along itself at that side's ``speeds``, m/s). ``solid``: the cells
    obstacles hold, (H, W) or (D, H, W) booleans (None: none). ``max_speed``: the velocity's
    range, +-m/s. ``force``: the body force (m/s^2, one number an axis), varying as 1 +
    ``gusts`` amplitude sin(2 pi t / period); ``drag``: the pointer's (x, y, vx, vy, radius),
    2D only. ``fire``: a :class:`Fire` the air carries (3D only), by the same ``advection`` as
    the velocity. Viscosity and moving walls are 2D only."""

    shape: tuple
    lo: tuple
    hi: tuple
    dt: float
    max_speed: float
    walls: tuple
    speeds: tuple = None
    solid: object = None
    advection: str = "semi-lagrangian"
    viscosity: float = 0.0
    viscosity_iterations: int = 20
    pressure_iterations: int = 40
    warm_start: float = 1.0
    vorticity: float = 0.0
    force: tuple = None
    gusts: tuple = (0.0, 1.0)
    drag: tuple = (0.0, 0.0, 0.0, 0.0, 0.1)
    fire: Fire = None

    def __post_init__(self):
        d = len(self.shape)
        if d not in (2, 3) or len(self.lo) != d or len(self.hi) != d or \
                len(self.walls) != 2 * d:
            raise ParameterError(f"the air's shape, box and walls must agree on 2 or 3 "
                                 f"dimensions, got {self.shape}, {self.lo}, {self.hi}, "
                                 f"{self.walls}")
        if self.advection not in ADVECTIONS:
            raise ParameterError(f"advection must be one of {', '.join(ADVECTIONS)}, got "
                                 f"{self.advection!r}")
        if d == 3 and (self.viscosity > 0 or 3.0 in self.walls):
            raise ParameterError("viscosity and moving walls are the 2D wind's: the 3D air "
                                 "takes neither")
        if (self.fire is not None) != (d == 3):
            raise ParameterError("a fire is carried by the 3D air, and only there")

    @property
    def dimensions(self):
        return len(self.shape)

    @property
    def cell(self):
        """A cell's size (dx, dy[, dz]) in metres."""
        return tuple((b - a) / n for a, b, n in zip(self.lo, self.hi, self.shape))

    @property
    def obstacles(self):
        """``solid`` as booleans (H, W) or (D, H, W)."""
        if self.solid is None:
            return np.zeros(self.shape[::-1], bool)
        return np.asarray(self.solid, bool)

    def blocked(self):
        """The faces held at 0, an array an axis (:func:`blocked_faces`)."""
        closed = [k != WALL_KINDS["open"] for k in self.walls]
        return blocked_faces(self.obstacles, [closed[2 * a:2 * a + 2]
                                              for a in range(self.dimensions)])

    @property
    def divergence_reach(self):
        """|divergence| <= 2 u (1/dx + 1/dy [+ 1/dz]) through a cell's faces."""
        return 2 * self.max_speed * sum(1 / c for c in self.cell)

    @property
    def pressure_reach(self):
        """The pressure's range, +-(m^2/s): a quarter of the velocity's range times the box's
        longer side. The projection's pressure undoes one step's divergence, and at the wind's
        defaults it stays within +-0.06 (measured): the range keeps RGBA8's codes fine (the
        gradient divides a code's error by a cell) with room to spare."""
        return self.max_speed * max(b - a for a, b in zip(self.lo, self.hi)) / 4

    def declare(self, g):
        """Add the air's grids, quantities, textures and passes to pass graph ``g``; returns
        the grids by name (air, xfaces, yfaces[, zfaces])."""
        d, u = self.dimensions, self.max_speed
        cell, dt = tuple(map(float, self.cell)), float(self.dt)
        lo, hi = tuple(map(float, self.lo)), tuple(map(float, self.hi))
        grids = {"air": g.grid("air", tuple(self.shape), box=(lo, hi))}
        components = COMPONENTS[:d]
        for a, (c, name) in enumerate(zip(components, FACE_GRIDS)):
            shape = list(self.shape)
            shape[a] += 1
            half = [0.0] * d
            half[a] = cell[a] / 2
            grids[c] = g.grid(name, tuple(shape), box=(tuple(x - h for x, h in zip(lo, half)),
                                                       tuple(x + h for x, h in zip(hi, half))))
            g.quantity(c, -u, u, components=1, domain=grids[c])
        air = grids["air"]
        g.quantity("wind", -u, u, components=d, domain=air)  # at the cell centres
        reach = self.divergence_reach
        g.quantity("divergence", -reach, reach, components=1, domain=air)
        g.quantity("pressure", -self.pressure_reach, self.pressure_reach, components=1,
                   domain=air)
        g.texture("solid", texels(air.image(self.obstacles)[..., 0]))
        for axis, c, mask in zip("xyz", components, self.blocked()):
            g.texture(f"{axis}blocked", texels(grids[c].image(mask)[..., 0]))
        kinds = tuple(map(float, self.walls))
        speeds = tuple(map(float, self.speeds or (0.0,) * 2 * d))
        walls = {"u_walls": kinds[:4]}
        if d == 3:
            walls["u_walls_z"] = kinds[4:]
        frag = "wind/fluid.frag"
        dims = {} if d == 2 else {"DIMENSIONS": 3}

        def face_passes(name, writes, reads=(), reads_new=(), uniforms=None, define=None,
                        more=(), only=components):
            """One pass a component (of ``only``): ``writes`` and the reads name "{c}" for
            it."""
            for c in only:
                def named(q):
                    return q.format(c=c)
                axis = "xyz"[COMPONENTS.index(c)]
                g.add(f"{name}_{c}", frag, writes=named(writes),
                      reads=[named(q) for q in reads], reads_new=[named(q) for q in reads_new],
                      textures=[f"{axis}blocked"], uniforms=uniforms or {},
                      defines={**dims, **{m: None for m in (define, f"{axis.upper()}_FACES")
                                          + tuple(more)}})

        def air_pass(name, writes, reads_new, uniforms=None, defines=(), reads=()):
            g.add(name, frag, writes=writes, reads=reads, reads_new=reads_new,
                  textures=["solid"], uniforms=uniforms or {},
                  defines={**dims, **{m: None for m in ("SOLID",) + tuple(defines)}})

        if self.advection == "maccormack":
            for c in components:
                g.quantity(f"{c}_ahead", -u, u, components=1, domain=grids[c])
                g.quantity(f"{c}_behind", -u, u, components=1, domain=grids[c])
        if self.advection == "semi-lagrangian":
            face_passes("advect", "{c}", reads=components, uniforms={"u_dt": dt},
                        define="ADVECT")
        else:
            face_passes("ahead", "{c}_ahead", reads=components, uniforms={"u_dt": dt},
                        define="AHEAD")
            face_passes("behind", "{c}_behind", reads=components, reads_new=["{c}_ahead"],
                        uniforms={"u_dt": dt}, define="BEHIND")
            face_passes("advect", "{c}", reads=components,
                        reads_new=["{c}_ahead", "{c}_behind"], uniforms={"u_dt": dt},
                        define="CORRECT")
        if self.fire is not None:
            f = self.fire
            carry = {"u_dt": dt, "u_keep": tuple(map(float, f.keep)),
                     "u_feed": tuple(map(float, f.feed)), "u_burner": tuple(map(float, f.burner))}
            maccormack = self.advection == "maccormack"
            for name in ("fire",) + ("fire_ahead", "fire_behind") * maccormack:
                g.quantity(name, 0.0, 1.0, components=2, domain=air, clamps="none")
            if not maccormack:
                air_pass("carry", "fire", [], carry, ("CARRY",), reads=("fire",) + components)
            else:
                air_pass("fire_ahead", "fire_ahead", [], {"u_dt": dt}, ("FIRE_AHEAD",),
                         reads=("fire",) + components)
                air_pass("fire_behind", "fire_behind", ["fire_ahead"], {"u_dt": dt},
                         ("FIRE_BEHIND",), reads=components)
                air_pass("carry", "fire", ["fire_ahead", "fire_behind"], carry,
                         ("CARRY", "CORRECT"), reads=("fire",) + components)
        force = {"u_dt": dt, "u_force": tuple(map(float, self.force or (0.0,) * d)),
                 "u_gusts": tuple(map(float, self.gusts))}
        more, reads_force = [], ["{c}"]
        if d == 2:  # the pointer's drag pushes the 2D air (a live view, the page)
            drag = self.drag
            force.update(u_drag_at=tuple(map(float, (*drag[:2], max(drag[4], 1e-6),
                                                     1.0 if any(drag[2:4]) else 0.0))),
                         u_drag_velocity=tuple(map(float, drag[2:4])))
        if self.vorticity > 0:
            g.quantity("curl", -reach, reach, components=1 if d == 2 else 3, domain=air)
            air_pass("curl", "curl", list(components), {"u_cell": cell}, ("CURL",))
            force.update(u_vorticity=float(self.vorticity), u_cell=cell)
            reads_force.append("curl")
            more.append("VORTICITY")
        # 2D: every face may be dragged; 3D: the faces some force acts on
        forced = [c for a, c in enumerate(components)
                  if d == 2 or self.vorticity > 0 or (self.force or (0.0,) * d)[a] != 0
                  or (self.fire is not None and c == "v")]
        for c in forced:
            lift = self.fire is not None and c == "v"
            face_passes("force", "{c}", reads_new=reads_force + ["fire"] * lift,
                        uniforms={**force, **({"u_buoyancy": float(self.fire.buoyancy)}
                                              if lift else {})},
                        define="FORCE", more=more + ["BUOYANCY"] * lift, only=(c,))
        if self.viscosity > 0:
            for c in components:
                g.quantity(f"{c}_held", -u, u, components=1, domain=grids[c])
            face_passes("hold", "{c}_held", reads_new=["{c}"], define="HOLD")
            with g.repeat("viscosity_iterations", self.viscosity_iterations):
                face_passes("viscosity", "{c}", reads_new=["{c}", "{c}_held"],
                            uniforms={"u_dt": dt, "u_cell": cell,
                                      "u_viscosity": self.viscosity, "u_walls": kinds,
                                      "u_wall_speed": speeds},
                            define="VISCOSITY")
        # the projection: the divergence, the pressure's iterations (>= 1), the faces' gradient
        air_pass("divergence", "divergence", list(components), {"u_cell": cell},
                 ("DIVERGENCE",))
        with g.repeat("pressure_iterations", self.pressure_iterations,
                      warm_start={"pressure": self.warm_start}):
            air_pass("pressure", "pressure", ["pressure", "divergence"],
                     {"u_cell": cell, **walls}, ("PRESSURE", "PRESSURE_NEIGHBOURS"))
        face_passes("project", "{c}", reads_new=["{c}", "pressure"], uniforms={"u_cell": cell},
                    define="PROJECT")
        air_pass("centres", "wind", list(components), defines=("CENTRES",))
        return grids
