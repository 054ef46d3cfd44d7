"""A window onto a live view: ``es2particles view SCENE``.

A :class:`Window` opens a glfw window (the view extra) of the picture's size, makes a moderngl
context on it and wraps it as the package's :class:`~es2particles.gl.context.Context`, so a
pipeline runs on it as on a headless one. :meth:`Window.show` runs a
:class:`~es2particles.live.view.LiveView`: events in, the clock's steps, a frame drawn through the
plan, and the presented picture copied onto the window (``post/present.frag``); the title shows
fps, particles and milliseconds a step. Closing the window, Esc or ``exit_after`` frames end it;
everything is released on the way out, in the order it was made.
"""

import os
import time

from ..errors import ContextError, ParameterError
from ..gl.context import Context
from ..gl.device import GLDevice
from ..gl.egl import MIN_GL_VERSION, probe_capabilities
from .controls import KEYS

NO_DISPLAY = ("no display to open a window on ({why}); `es2particles run` writes the same scene "
              "to files without one")


def _glfw():
    try:
        import glfw
    except ImportError:
        raise ContextError("a window needs glfw: pip install 'es2particles[view]'") from None
    return glfw


def key_names(glfw):
    """glfw key code -> the key's name in :data:`~es2particles.live.controls.KEYS`."""
    names = {getattr(glfw, f"KEY_{name.upper()}"): name for name in KEYS
             if not name.startswith("shift+")}
    names[glfw.KEY_KP_ADD], names[glfw.KEY_KP_SUBTRACT] = "equal", "minus"
    return names


def screen_size():
    """The primary screen's size in pixels, or a :class:`ContextError` saying why there is no
    display (opening glfw)."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ContextError(NO_DISPLAY.format(why="neither DISPLAY nor WAYLAND_DISPLAY is set"))
    glfw = _glfw()
    if not glfw.init():
        raise ContextError(NO_DISPLAY.format(why=f"glfw cannot start: {_glfw_error(glfw)}"))
    monitor = glfw.get_primary_monitor()
    mode = glfw.get_video_mode(monitor) if monitor else None
    if mode is None:
        glfw.terminate()
        raise ContextError(NO_DISPLAY.format(why="the display reports no screen"))
    return mode.size.width, mode.size.height


def _glfw_error(glfw):
    try:
        code, text = glfw.get_error()
    except Exception:
        return "unknown error"
    return (text.decode() if isinstance(text, bytes) else str(text)) if code else "unknown error"


class Window:
    """A window of ``size`` (w, h) pixels titled ``title``, with a GL context: :attr:`ctx`.

    ``size`` None is ``default`` halved until the screen holds it (with a tenth to spare);
    larger than the screen is an error naming ``--size``. Release it (``with``) after the
    pipelines made on its context."""

    def __init__(self, size=None, title="es2particles", default=(1024, 1024)):
        self.window = self.ctx = None
        # No display is said before a missing glfw: installing glfw would not open a window.
        screen = screen_size()  # starts glfw, or says why not
        self.glfw = _glfw()
        try:
            if size is None:
                size = default
                while size[0] > 0.9 * screen[0] or size[1] > 0.9 * screen[1]:
                    size = (size[0] // 2, size[1] // 2)
            w, h = size
            if w > screen[0] or h > screen[1]:
                raise ParameterError(f"--size {w}x{h} is larger than the screen ({screen[0]}x"
                                     f"{screen[1]}); give a --size that fits")
            self.size = (w, h)
            self.window, profile = self._open(size, title)
            import moderngl

            mgl = moderngl.create_context()
            self.ctx = Context(GLDevice(mgl, "glfw", profile), probe=probe_capabilities)
        except BaseException:
            self.close()
            raise

    def _open(self, size, title):
        """A window with a context of GL 3.3 or newer: the compatibility profile where the driver
        gives one (as ``open_context`` prefers), else the core profile."""
        glfw = self.glfw
        for profile in ("compatibility", "core"):
            glfw.default_window_hints()
            glfw.window_hint(glfw.RESIZABLE, False)
            if profile == "core":
                glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
                glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
                glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
                glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
            window = glfw.create_window(size[0], size[1], title, None, None)
            if not window:
                continue
            glfw.make_context_current(window)
            major = glfw.get_window_attrib(window, glfw.CONTEXT_VERSION_MAJOR)
            minor = glfw.get_window_attrib(window, glfw.CONTEXT_VERSION_MINOR)
            if 100 * major + 10 * minor >= MIN_GL_VERSION:
                glfw.swap_interval(1)
                return window, profile
            glfw.destroy_window(window)
        raise ContextError(f"no window with OpenGL {MIN_GL_VERSION // 100}.{MIN_GL_VERSION // 10 % 10} "
                           f"or newer could be opened ({_glfw_error(glfw)})")

    # -- the loop ----------------------------------------------------------------------------------

    def show(self, view, exit_after=None, screenshot=None, say=print):
        """Run ``view`` until the window closes, Esc, or ``exit_after`` frames; then write the last
        frame to ``screenshot`` (a checked path), if given. Screenshots asked for by key are
        written as SCENE-NNN.png in the working folder, never over a file. Returns the frames
        drawn, the seconds they took and the last status line."""
        from ..gl.command import DrawCommand
        from ..io.output import save_image

        glfw, window = self.glfw, self.window
        names = key_names(glfw)
        w, h = self.size

        # The pointer as the events place it, in the order they came (glfw.get_cursor_pos asks
        # the display where the pointer is now, which may be past the event being handled).
        pointer = list(glfw.get_cursor_pos(window))

        def pixel():
            ww, wh = glfw.get_window_size(window)
            return pointer[0] * w / max(ww, 1), pointer[1] * h / max(wh, 1)

        def on_move(_, x, y):
            pointer[:] = x, y
            view.move(*pixel(), self.size)

        def on_key(_, key, scancode, action, mods):
            if action in (glfw.PRESS, glfw.REPEAT) and key in names:
                view.key(names[key], shift=bool(mods & glfw.MOD_SHIFT))

        def on_button(_, button, action, mods):
            if button != glfw.MOUSE_BUTTON_LEFT:
                return
            if action == glfw.PRESS:
                view.press(*pixel(), self.size)
            else:
                view.release()

        glfw.set_key_callback(window, on_key)
        glfw.set_mouse_button_callback(window, on_button)
        glfw.set_cursor_pos_callback(window, on_move)
        glfw.set_scroll_callback(window, lambda _, dx, dy: view.wheel(dy))
        group = self.ctx.group()
        present = DrawCommand(group, "present", "post/present.frag")
        screen = self.ctx.screen()
        began = time.perf_counter()
        shown, counted, since = 0, 0, began
        try:
            view.start()
            while not glfw.window_should_close(window) and not view.quit:
                view.advance()
                final = view.draw()
                present.draw(screen, {"u_source": final})
                glfw.swap_buffers(window)
                shown += 1
                now = time.perf_counter()
                if now - since >= 0.5 or shown == 1:
                    fps = (shown - counted) / max(now - since, 1e-9)
                    counted, since = shown, now
                    glfw.set_window_title(window, f"es2particles: {view.status(fps)}")
                while view.screenshots:
                    view.screenshots -= 1
                    say(f"wrote {save_image(view.pipeline.image(), free_name(view.scene.name))}")
                if exit_after is not None and shown >= exit_after:
                    break
                if view.paused:  # nothing moves but what the events move: wait for one
                    glfw.wait_events_timeout(0.1)
                else:
                    glfw.poll_events()
            seconds = time.perf_counter() - began
            if screenshot is not None and shown:
                save_image(view.pipeline.image(), screenshot)
            return shown, seconds, view.status(shown / max(seconds, 1e-9))
        finally:
            group.release()

    def close(self):
        """Release the context, then the window and glfw; safe to call twice."""
        if self.ctx is not None:
            self.ctx.release()
            self.ctx = None
        if self.window is not None:
            self.glfw.destroy_window(self.window)
            self.window = None
        self.glfw.terminate()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def free_name(stem, folder="."):
    """The first of STEM-001.png, STEM-002.png, ... in ``folder`` that does not exist."""
    from pathlib import Path

    for number in range(1, 10 ** 6):
        path = Path(folder) / f"{stem}-{number:03d}.png"
        if not path.exists() and not path.is_symlink():
            return path
    raise ParameterError(f"no free screenshot name {stem}-NNN.png left in {folder!r}")
