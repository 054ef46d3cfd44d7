"""A scene run in real time, whatever shows it: a window (``window.py``), a notebook widget
(``widget.py``) or a test.

:class:`LiveView` holds a :class:`~es2particles.frame.pipeline.Pipeline` and what a person does to
it. The simulation is stepped by the clock at the scene's own time step, decoupled from the
drawing: a frame runs the steps its wall time is worth (at most ``max_steps``: beyond that the
scene runs slower than real time, and :attr:`LiveView.slowdown` says by how much); a scene
without a time step (the attractors) steps once a frame. Keys go through
:class:`~es2particles.live.controls.Bindings` to actions; a drag orbits the camera, or moves the
scene's grip (the smoke's sphere) where it starts on it, or, in a 2D scene with a
:class:`~es2particles.scenes.base.Push` (the wind), pushes the scene where it passes; the wheel zooms; the scene's sliders (the
attractors' coefficients) are chosen and moved by keys. Frames are drawn through the pipeline's
one plan, with the person's camera and the grip's pose.
"""

import time

import numpy as np

from ..errors import ParameterError
from .controls import Bindings, ViewCamera, dragged_centre, hit_sphere


class LiveView:
    """``pipeline`` run live. ``bindings``: a :class:`~es2particles.live.controls.Bindings`
    (default: the standard keys); ``clock``: seconds, monotonic (a test may pass its own);
    ``paused``: start paused (the first frame stays until a key steps or plays it)."""

    def __init__(self, pipeline, bindings=None, max_steps=None, clock=time.perf_counter,
                 paused=False):
        self.pipeline, self.scene = pipeline, pipeline.scene
        self.bindings = bindings or Bindings()
        rule = pipeline.plan.clock  # the page's executor keeps the same
        self.max_steps = rule["max_steps"] if max_steps is None else max_steps
        self.clock = clock
        start = pipeline.camera(0, 1)
        self.view = None if start is None else ViewCamera(start)
        self.grip = self.scene.grip()
        self.push = self.scene.push() if self.view is None else None
        self.centre = None if self.grip is None else np.array(self.grip.centre, float)
        self._sim_centre = None if self.centre is None else self.centre.copy()
        self.controls = self.scene.controls()
        self.values = {}
        for control in self.controls:
            stage = next(s for s in pipeline.plan.step_stages if control.uniform in s.uniforms)
            self.values.setdefault(control.uniform, [float(v) for v in
                                                     np.ravel(stage.uniforms[control.uniform])])
        self.selected = 0
        self.dt = rule["dt"]
        self.paused, self.quit = paused, False
        self.screenshots = 0  # requests for a screenshot, taken by whoever shows the view
        self._drag = None
        self._debt, self._last = 0.0, None
        self.step_seconds = 0.0  # time spent in steps, and steps run (ms a step)
        self.steps_run = 0
        self.slowdown = 1.0  # real time over simulated time of the last frame (1: real time)
        self._started = False

    # -- time --------------------------------------------------------------------------------------

    def start(self):
        """Run the scene's steps before its first frame (once)."""
        if not self._started:
            self.pipeline.begin(1)
            self._started = True
            self._last = self.clock()

    def advance(self):
        """Run the steps the time since the last call is worth (none when paused). Returns how
        many."""
        self.start()
        now = self.clock()
        elapsed, self._last = now - self._last, now
        if self.paused:
            return 0
        if self.dt is None:
            steps = 1
        else:
            self._debt += elapsed
            steps = int(self._debt // self.dt)
            self.slowdown = 1.0 if steps <= self.max_steps else steps / self.max_steps
            steps = min(steps, self.max_steps)
            self._debt = min(self._debt - steps * self.dt, self.dt)
        self.run_steps(steps)
        return steps

    def run_steps(self, steps):
        """Run ``steps`` steps now, the grip moving evenly from where the simulation last had it
        to where the hand has put it."""
        if steps <= 0:
            return
        ctx = self.pipeline.ctx
        began = time.perf_counter()
        if self.grip is not None and not np.array_equal(self.centre, self._sim_centre):
            start, end = self._sim_centre, self.centre.copy()
            drift = (end - start) / (steps * (self.dt or 1.0))
            for k in range(1, steps + 1):
                self._place(start + (end - start) * k / steps, drift)
                self.pipeline.step(1)
            self._place(end, np.zeros(3))
            self._sim_centre = end
        else:
            self.pipeline.step(steps)
        ctx.finish()
        self.step_seconds += time.perf_counter() - began
        self.steps_run += steps

    def _place(self, centre, drift):
        g = self.grip
        self.pipeline.sim.set_uniforms({g.uniform: tuple(map(float, centre)),
                                        g.velocity: tuple(map(float, drift))})

    # -- drawing -----------------------------------------------------------------------------------

    def draw(self):
        """Draw a frame as things stand; returns the presented texture."""
        self.start()
        camera = None if self.view is None else self.view.camera()
        return self.pipeline.render(0, 1, camera=camera, drag=self.drag())

    def drag(self):
        """How far the grip has moved the moving object's rest centre (None: no grip)."""
        if self.grip is None:
            return None
        return tuple(self.centre - np.asarray(self.grip.centre, float))

    def grip_centre(self):
        """The grip's centre as drawn now: where the motion puts its meshes' origin (they are
        modelled about it, the motion's offset being the rest centre)."""
        motion = self.pipeline.plan.motion
        if self.grip is None or motion is None:
            return self.centre.copy()
        return motion.matrix(self.pipeline.sim.steps_done, self.drag())[:3, 3].copy()

    # -- input -------------------------------------------------------------------------------------

    def key(self, name, shift=False):
        """Key ``name`` (:data:`~es2particles.live.controls.KEYS`) pressed (or repeated while
        held). Returns its action, or None."""
        action = self.bindings.action(name, shift)
        view = self.view
        moves = {"turn_left": ("turn", 1), "turn_right": ("turn", -1), "forward": ("move", 1),
                 "back": ("move", -1), "rise": ("rise", 1), "sink": ("rise", -1)}
        if action in moves and view is not None:
            how, sign = moves[action]
            getattr(view, how)(sign)
        elif action == "pause":
            self.paused = not self.paused
        elif action == "step":
            self.paused = True
            self.start()
            self.run_steps(1)
        elif action == "screenshot":
            self.screenshots += 1
        elif action == "quit":
            self.quit = True
        elif action == "reset":
            if view is not None:
                self.view = ViewCamera(view.start)
        elif action == "next_control" and self.controls:
            self.selected = (self.selected + 1) % len(self.controls)
        elif action in ("increase", "decrease") and self.controls:
            c = self.controls[self.selected]
            step = (c.hi - c.lo) / 800 * (1 if action == "increase" else -1)
            self.set_control(c.label, self.values[c.uniform][c.component] + step)
        return action

    def set_control(self, label, value):
        """Set the scene's slider ``label`` (kept within its range) for the steps to come."""
        found = [c for c in self.controls if c.label == label]
        if not found:
            raise ParameterError(f"no slider {label!r} (sliders: "
                                 f"{', '.join(c.label for c in self.controls) or 'none'})")
        c = found[0]
        values = self.values[c.uniform]
        values[c.component] = min(max(float(value), c.lo), c.hi)
        self.pipeline.sim.set_uniform(c.uniform, tuple(values))
        if self.paused:  # as the page's sliders: a paused scene takes one step to show it
            self.start()
            self.run_steps(1)

    def press(self, x, y, size):
        """The pointer went down at pixel (x, y) of the picture of ``size``: on the grip, it
        takes it; elsewhere a drag orbits the camera."""
        if self.view is None:
            if self.push is not None:
                self._drag = ("push", self._world(x, y, size), self.clock())
                self._push(self._drag[1], (0.0, 0.0))
            return
        self._drag = ("orbit", (x, y))
        if self.grip is not None:
            origin, direction = self.view.ray((x, y), size)
            hit = hit_sphere(origin, direction, self.grip_centre(), self.grip.radius)
            if hit is not None:
                self._drag = ("grip", hit, self.centre.copy())

    def move(self, x, y, size):
        """The pointer moved to (x, y) with the button down (nothing when it is up)."""
        if self._drag is None:
            return
        if self._drag[0] == "push":
            _, before, then = self._drag
            now, here = self.clock(), self._world(x, y, size)
            velocity = (here - before) / max(now - then, 1e-3)
            self._drag = ("push", here, now)
            self._push(here, velocity)
        elif self._drag[0] == "orbit":
            x0, y0 = self._drag[1]
            self.view.orbit(x - x0, y - y0)
            self._drag = ("orbit", (x, y))
        else:
            _, grabbed, start = self._drag
            origin, direction = self.view.ray((x, y), size)
            self.centre = dragged_centre(self.grip, start, grabbed, origin, direction)

    def release(self):
        """The pointer's button went up."""
        if self._drag is not None and self._drag[0] == "push":
            self.pipeline.sim.set_uniforms({self.push.at: (0.0, 0.0, 1.0, 0.0),
                                            self.push.velocity: (0.0, 0.0)})
        self._drag = None

    def _world(self, x, y, size):
        """The world point of a 2D scene under pixel (x, y) (rows from the top) of ``size``."""
        x0, y0, x1, y1 = self.scene.view
        w, h = size
        return np.array([x0 + (x + 0.5) / w * (x1 - x0), y1 - (y + 0.5) / h * (y1 - y0)])

    def _push(self, at, velocity):
        p = self.push
        self.pipeline.sim.set_uniforms({p.at: (*map(float, at), float(p.radius), 1.0),
                                        p.velocity: tuple(map(float, velocity))})

    def wheel(self, notches):
        """The wheel turned ``notches`` (positive: towards the scene)."""
        if self.view is not None:
            self.view.zoom(notches)

    # -- what to show ------------------------------------------------------------------------------

    def status(self, fps):
        """One line: the scene, its particles, frames a second, milliseconds a step, and the
        selected slider or the grip."""
        ms = 1000 * self.step_seconds / self.steps_run if self.steps_run else 0.0
        parts = [self.scene.name, f"{self.pipeline.sim.count} particles", f"{fps:.1f} fps",
                 f"{ms:.1f} ms/step"]
        if self.paused:
            parts.append("paused")
        elif self.slowdown > 1.0:
            parts.append(f"{1 / self.slowdown:.2f}x real time")
        if self.controls:
            c = self.controls[self.selected]
            parts.append(f"{c.label} = {self.values[c.uniform][c.component]:.3f} (tab, -/=)")
        return " | ".join(parts)
