"""A live view in a notebook: :class:`LiveWidget`, a jupyter_rfb remote frame buffer (the
notebook extra).

The widget renders a frame when the notebook asks for one (jupyter_rfb calls
:meth:`LiveWidget.get_frame` once the browser has shown the last), runs the steps the clock is
worth when playing, and turns the browser's pointer, wheel and key events into the same actions as
the window (``view.py``): a drag orbits the camera or moves the grip, the wheel zooms, the keys of
:class:`~es2particles.live.controls.Bindings` do the rest.

    pipeline = Pipeline(open_context(), Smoke(), size=(640, 360))
    LiveWidget(pipeline)            # a cell's last line shows it
"""

try:
    from jupyter_rfb import RemoteFrameBuffer
except ImportError:  # the class below needs it; say so where it is used
    RemoteFrameBuffer = None

from ..errors import ContextError
from .view import LiveView

# The browser's key names (KeyboardEvent.key) -> ours
BROWSER_KEYS = {"ArrowLeft": "left", "ArrowRight": "right", "ArrowUp": "up", "ArrowDown": "down",
                "PageUp": "page_up", "PageDown": "page_down", " ": "space", "Escape": "escape",
                ".": "period", ",": "comma", "-": "minus", "=": "equal", "+": "equal",
                "Tab": "tab", "Enter": "enter", "Backspace": "backspace", "Home": "home",
                "End": "end"}
WHEEL_NOTCH = 100.0  # a browser's deltaY for one notch of a wheel


def browser_key(key):
    """Our name of a browser's ``KeyboardEvent.key``, or None."""
    if key in BROWSER_KEYS:
        return BROWSER_KEYS[key]
    return key.lower() if len(key) == 1 and key.isalnum() and key.isascii() else None


if RemoteFrameBuffer is None:
    class LiveWidget:
        def __init__(self, *args, **kwargs):
            raise ContextError("the notebook widget needs jupyter_rfb: pip install "
                               "'es2particles[notebook]'")
else:
    class LiveWidget(RemoteFrameBuffer):
        """``pipeline`` live in a notebook cell, paused unless ``play``; ``bindings`` as
        :class:`~es2particles.live.view.LiveView` takes them. :attr:`view` is its LiveView."""

        def __init__(self, pipeline, bindings=None, play=False, **kwargs):
            w, h = pipeline.size
            super().__init__(css_width=f"{w}px", css_height=f"{h}px", resizable=False, **kwargs)
            self.view = LiveView(pipeline, bindings, paused=not play)

        def get_frame(self):
            """The next frame, as (h, w, 3) uint8: the steps since the last one, then a draw.
            Playing, it asks for the one after."""
            self.view.advance()
            self.view.draw()
            if not self.view.paused:
                self.request_draw()
            return self.view.pipeline.image()

        def handle_event(self, event):
            """A browser event: pointer down, move and up (the left button), wheel, key down.
            The widget is shown at the picture's size (not resizable): a pointer's (x, y) is
            the picture's pixel."""
            kind, size = event.get("event_type"), self.view.pipeline.size
            if kind == "pointer_down" and event.get("button") == 1:
                self.view.press(event["x"], event["y"], size)
            elif kind == "pointer_move":
                self.view.move(event["x"], event["y"], size)
            elif kind == "pointer_up":
                self.view.release()
            elif kind == "wheel":
                self.view.wheel(-event.get("dy", 0.0) / WHEEL_NOTCH)
            elif kind == "key_down":
                name = browser_key(event.get("key", ""))
                if name is not None:
                    self.view.key(name, shift="Shift" in event.get("modifiers", ()))
            else:
                return
            self.request_draw()

        def step(self, steps=1):
            """Run ``steps`` steps and show the frame after them."""
            self.view.start()
            self.view.run_steps(steps)
            self.request_draw()
