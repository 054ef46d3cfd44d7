"""What a scene tells the rest of the package: its pass graph, outputs, start and view."""


class Scene:
    """Base of the scenes. A scene is plain data plus a graph: no GL of its own."""

    name = ""
    view = (-1.0, -1.0, 1.0, 1.0)  # world rectangle that fills the image: x0, y0, x1, y1
    outputs = ("position",)
    fade_by_life = False
    default_steps = 1
    default_particles = 2 ** 20
    default_point_size = 1.0
    default_rounding = "nearest"
    # True where each particle lands near last frame's place (reseeded scenes): the renderer then
    # orders its draw by framebuffer tile once, ~10% off the draw on a CPU rasteriser.
    positions_repeat = False

    @classmethod
    def add_arguments(cls, parser):
        """Add the scene's own command-line options."""

    @classmethod
    def from_args(cls, args):
        raise NotImplementedError

    def graph(self):
        """The scene's :class:`PassGraph`."""
        raise NotImplementedError

    def defines(self):
        return {}

    def initialise(self, sim, rng):
        """Upload the starting state."""

    def background(self):
        """An (h, w, 4) uint8 image drawn under the particles, or None."""
        return None

    def describe(self):
        """Extra lines for the printed plan."""
        return []

    def before_frame(self, sim, frame, frames):
        """Set per-frame uniforms (animation); ``frame`` counts from 0 to ``frames - 1``."""
