"""What a scene is: a declaration the framework carries out.

A scene returns data and never touches GL: its pass graph for a context's capabilities
(quantities, passes with their shaders, defines and uniforms, scene textures as numpy arrays), its
start (numpy arrays or uniform fills), the uniforms that change per frame, its rendering (a
:class:`~es2particles.render.points.Density` or :class:`~es2particles.render.sprites.Sprites`
declaration), a 3D scene's camera and motion, and its defaults. The framework plans the frame,
uploads and owns every texture, applies the start, and resolves each default once
(:func:`~es2particles.frame.plan.plan_frame`), so the command line passes only what the user
typed.

Scenes register by entry point (group ``es2particles.scenes``): another package adds one with
``[project.entry-points."es2particles.scenes"] name = "package.module:SceneClass"``.
"""

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import CostWarning, GraphError, ParameterError
from ..frame.settings import Defaults
from ..render.points import Density
from ..params import Params


COST_FACTOR = 10  # a cost this many times the defaults' is said (Scene.warn_of_cost)
# What a scene's cost() may name, and what a large one means.
COSTS = {"sub-steps a step": "each step takes about that much longer",
         "field cells": "the field takes about that much longer to make, and as much more memory"}


@dataclass(frozen=True)
class Control:
    """A slider of the scene's WebGL page (``export/page.py``): component ``component`` of uniform
    ``uniform`` (which the scene's passes declare), from ``lo`` to ``hi``."""

    label: str
    uniform: str
    component: int
    lo: float
    hi: float


@dataclass(frozen=True)
class Grip:
    """A sphere of the scene that a hand drags over the floor (a live view, the page): its rest
    centre ``centre`` is uniform ``uniform`` (a vec3: the motion's ``u_motion_offset`` where the
    motion places the sphere), its rest centre's velocity while dragged is uniform
    ``velocity`` (both declared by the scene's passes), and the drag keeps
    that centre's x within ``x_range`` and z within ``z_range``. Its moving meshes are modelled
    about the origin and placed by the scene's motion, whose offset is the rest centre: a drag
    moves them by what it moves the rest centre."""

    uniform: str
    velocity: str
    centre: tuple
    radius: float
    x_range: tuple
    z_range: tuple


@dataclass(frozen=True)
class Push:
    """What a hand's drag does to a 2D scene (a live view, the widget): it pushes the scene
    where it passes. While the button is down the drag sets uniform ``at`` to (x, y, radius,
    1) in world units and ``velocity`` to the pointer's world velocity (both declared by the
    scene's passes); when it comes up, ``at``'s last number goes back to 0 (no push)."""

    at: str
    velocity: str
    radius: float


@dataclass(frozen=True)
class Fill:
    """A start drawn uniformly from the box [lo, hi] (one bound per component, or one for all)."""

    lo: object
    hi: object


def clamp_report(sim, skip=(), hints=None):
    """One line per quantity of ``sim`` (but ``skip``) with values on an edge of its range that
    means a clamped write (its ``clamps``): its share of them, per component, with the range and
    ``hints[quantity]`` (how to widen it), if any. Counted on the stored codes at a run's end."""
    lines = []
    for name, buffer in sim.buffers.items():
        q = buffer.quantity
        if name in skip or q.clamps == "none":
            continue
        counts = sim.clamped_writes(name)
        if not any(counts):
            continue
        n = q.domain.cells if q.domain is not None else sim.count
        axes = "xyzw" if q.components > 1 else " "
        shares = ", ".join(f"{axes[k].strip() + ' ' if q.components > 1 else ''}"
                           f"{100 * c / n:.3g}%" for k, c in enumerate(counts) if c)
        ranges = ", ".join(f"[{lo:g}, {hi:g}]"
                           for lo, hi in dict.fromkeys(zip(q.lo, q.hi)))
        hint = (hints or {}).get(name)
        lines.append(f"{name}: {shares} of its values sit on its range's edge ({ranges}): "
                     f"written beyond it and clamped" + (f"; {hint}" if hint else ""))
    return lines


class Scene:
    """Base of the scenes. Subclasses set the class attributes and override the declarations.

    A scene's parameters are its :attr:`Params` (``params.py``): ``Scene(params)`` or
    ``Scene(name=value, ...)`` for some of them (the rest their defaults); the command line's
    options, their help and checks, a run file's values and the page's sliders all come from
    that declaration."""

    Params = Params  # a scene's parameters: none by default
    renders = Density  # the kind of rendering() it returns (its frame settings follow from it)
    runs_alone = False  # True: its grids run with --particles 0, drawn by rendering_alone()
    particle_params = ()  # of a scene that runs alone: parameters --particles 0 leaves idle
    name = ""
    view = (-1.0, -1.0, 1.0, 1.0)  # a 2D scene's world rectangle: x0, y0, x1, y1
    render_reads = ("position",)  # what a 2D scene's points read: position, and life to fade
    # Quantities a run keeps in its plan beside those the rendering reads (and so in its saved
    # state): a grid a picture does not draw, say.
    saves = ()
    defaults = Defaults()
    # True where each particle lands near last frame's place (reseeded scenes): the renderer then
    # orders its draw by framebuffer tile once, ~10% off the draw on a CPU rasteriser.
    positions_repeat = False
    # True where each step starts afresh (reseeded scenes): a frame depends on its own uniforms
    # alone, so the frames of an animation can be made apart, each without the ones before it
    # (cluster/tasks.py); otherwise a frame needs every step and frame before it.
    stateless = False
    # What a step costs that the parameters drive (sub-steps, field size) -> its value at the
    # defaults (tests/test_inputs.py keeps these true); see cost() and warn_of_cost().
    typical_cost = {}

    def __init__(self, params=None, **given):
        params = self.Params() if params is None else params
        if not isinstance(params, self.Params):
            raise ParameterError(f"{self.name or type(self).__name__}: params must be a "
                                 f"{self.Params.__name__}, got {type(params).__name__}")
        if given:
            params = self.Params.from_mapping({**params.values(), **given}, self.name)
        self.params = params

    def cost(self):
        """What a step costs that this scene's parameters drive: name -> value, for each name of
        :attr:`typical_cost`."""
        return {}

    def warn_of_cost(self, *names):
        """A :class:`~es2particles.errors.CostWarning` for each cost ``names`` (default: all)
        :data:`COST_FACTOR` times or more its value at the defaults (a subclass calls it as soon
        as it knows a cost, before the work the cost is of)."""
        for what, value in self.cost().items():
            if names and what not in names:
                continue
            typical = self.typical_cost[what]
            if value >= COST_FACTOR * typical:
                warnings.warn(f"{value:,} {what}: {value / typical:.0f}x the {typical:,} at "
                              f"this scene's defaults ({COSTS[what]})", CostWarning, stacklevel=3)

    # -- declarations ----------------------------------------------------------------------

    @classmethod
    def default_text(cls, setting):
        """How the help of frame setting ``setting`` states this scene's default of it (one of
        :class:`~es2particles.frame.settings.Defaults`' fields)."""
        value = getattr(cls.defaults, setting)
        if setting == "gradient" and not cls.renders.own_gradient:
            return "none"  # a picture drawn in colour: the map is off unless a ramp is given
        if setting == "particles" and value >= 1024 and value & (value - 1) == 0:
            return f"2^{value.bit_length() - 1}"
        return f"{value:g}" if isinstance(value, float) else str(value)

    @classmethod
    def add_arguments(cls, parser):
        """Add the scene's own command-line options: one per parameter its :attr:`Params`
        offers (default None: not given)."""
        cls.Params.add_arguments(parser)

    @classmethod
    def from_args(cls, args):
        """The scene of parsed arguments (an ``argparse.Namespace`` or a mapping): the
        parameters given, the rest their defaults."""
        return cls(cls.Params.from_mapping(cls.Params.given_in(args), cls.name))

    def graph(self, caps=None):
        """The scene's complete :class:`~es2particles.PassGraph` for a context of ``caps``
        (its :class:`~es2particles.gl.context.Capabilities`: the largest texture, ASTC; None:
        the stated ones, ``Capabilities.assumed()``)."""
        raise NotImplementedError

    def rendering(self):
        """What the scene draws: by default :class:`~es2particles.render.points.Density` points
        of :attr:`render_reads` over :attr:`view`, on :meth:`background`; a 3D scene returns a
        :class:`~es2particles.render.sprites.Sprites`."""
        return Density(self.view, self.render_reads, self.background())

    def rendering_alone(self):
        """What a scene whose grids run alone (:attr:`runs_alone`) draws with ``--particles 0``:
        a :class:`~es2particles.render.field.Field`, say."""
        raise NotImplementedError(f"scene {self.name!r} does not run without particles")

    def start(self, count, rng):
        """The starting state: quantity name -> (count, components) array or :class:`Fill`.
        Quantities not named start at zero."""
        return {}

    def frame_uniforms(self, frame, frames):
        """Uniforms to set before frame ``frame`` of ``frames`` (animation): name -> value."""
        return {}

    def sample_uniforms(self, sample, samples):
        """Uniforms for accumulated sample ``sample`` of ``samples`` (one image summing the
        densities of several steps): name -> value; sample 0 must give the plain image."""
        return {}

    def background(self):
        """An (h, w, 4) uint8 image drawn under the particles, or None."""
        return None

    def grip(self):
        """The :class:`Grip` a hand may drag, or None (the default: nothing to drag)."""
        return None

    def push(self):
        """The :class:`Push` a hand's drag gives a 2D scene, or None (the default)."""
        return None

    def controls(self):
        """The sliders of the scene's WebGL page: one :class:`Control` per parameter declared
        with a ``slider``."""
        return [Control(name, *d.slider) for name, d in self.Params.declarations().items()
                if d.slider is not None]

    def describe(self):
        """Lines for the printed plan: the scene's parameters."""
        described = self.params.describe() if hasattr(self, "params") else ""
        return [f"parameters: {described}"] if described else []

    def time_step(self, count):
        """The seconds a step simulates for ``count`` particles (the saved state's time, the
        live view's clock): the ``dt`` parameter, where the scene has one; else None."""
        return getattr(getattr(self, "params", None), "dt", None)

    def derived(self, state, count):
        """Arrays a saved state holds beside the quantities, computed from them in float64
        (name -> array): none by default."""
        return {}

    def after_run(self, sim):
        """Lines a run says once, at its end, of what its state shows: by default, each quantity
        with values clamped at its range's edge (:func:`clamp_report`)."""
        return clamp_report(sim)

    def measured(self, ctx):
        """Lines the printed plan measures on the context (slow figures), after describe()."""
        return []

    # -- 3D scenes (rendering() is Sprites) ----------------------------------------------------

    def camera_at(self, frame, frames):
        """The :class:`~es2particles.render.camera.Camera` of frame ``frame`` of ``frames``."""
        raise GraphError(f"scene {self.name or type(self).__name__!r} draws in 3D but gives no "
                         "camera: define camera_at(frame, frames) returning a Camera")

    def motion(self):
        """The :class:`~es2particles.frame.motion.Motion` of the moving meshes (rest pose to
        world over time), or None where nothing moves."""
        return None

    def model_at(self, step):
        """The moving meshes' model matrix (4x4) after ``step`` simulation steps, or None."""
        motion = self.motion()
        return None if motion is None else motion.matrix(step)

    # -- carried out by the framework ------------------------------------------------------

    def initialise(self, sim, rng):
        """Apply :meth:`start` to a simulation: fills where it says, uploads elsewhere."""
        for name, value in self.start(sim.count, rng).items():
            if isinstance(value, Fill):
                sim.fill_uniform(name, value.lo, value.hi, rng)
            else:
                sim.upload(name, np.asarray(value))
