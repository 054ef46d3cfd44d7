"""A real X display for the live window's tests, driven as a person drives one: Xvfb, the
``es2particles view`` command in it, xdotool's keys and mouse (XTEST events, as a keyboard's),
screenshots of the screen (pillow's ImageGrab over XCB), and the close button's message
(WM_DELETE_WINDOW, what a window manager sends; python-xlib)."""

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

TOOLS = ("Xvfb", "xdotool")


class Display:
    """An Xvfb screen of ``size``; :meth:`close` stops it."""

    def __init__(self, size=(1280, 800)):
        missing = [t for t in TOOLS if shutil.which(t) is None]
        if missing:
            raise RuntimeError(f"the live tests need {', '.join(missing)} (sh setup.sh test "
                               "installs them)")
        read, write = os.pipe()
        self.process = subprocess.Popen(
            ["Xvfb", "-displayfd", str(write), "-screen", "0", f"{size[0]}x{size[1]}x24",
             "-nolisten", "tcp"], pass_fds=(write,), stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(write)
        with os.fdopen(read) as pipe:
            number = pipe.readline().strip()
        if not number:
            raise RuntimeError("Xvfb did not start")
        self.name = f":{number}"
        self.env = {**os.environ, "DISPLAY": self.name, "PYTHONFAULTHANDLER": "1"}
        self.env.pop("WAYLAND_DISPLAY", None)

    def xdotool(self, *args):
        return subprocess.run(["xdotool", *map(str, args)], env=self.env, check=True,
                              capture_output=True, text=True, timeout=30).stdout

    def close(self):
        self.process.terminate()
        self.process.wait(timeout=10)


class Viewer:
    """``es2particles view ARGS`` running on ``display``, its window found and focused."""

    def __init__(self, display, args, cwd):
        self.display = display
        self.process = subprocess.Popen(
            [sys.executable, "-m", "es2particles", "view", *args], env=display.env, cwd=cwd,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 60
        self.window = None
        while self.window is None:
            if self.process.poll() is not None:
                raise AssertionError(f"view ended before its window showed: "
                                     f"{self.process.stderr.read()}")
            if time.monotonic() > deadline:
                self.process.kill()
                raise AssertionError("no window within 60 s")
            # By the process's id (glfw sets _NET_WM_PID): a window of the test before may
            # still be on the screen until the server has cleaned up after its process.
            found = subprocess.run(["xdotool", "search", "--all", "--onlyvisible", "--pid",
                                    str(self.process.pid), "--name", "^es2particles"],
                                   env=display.env, capture_output=True, text=True)
            if found.stdout.strip():
                self.window = found.stdout.split()[0]
            else:
                time.sleep(0.1)
        display.xdotool("windowfocus", "--sync", self.window)
        shell = display.xdotool("getwindowgeometry", "--shell", self.window)
        geometry = dict(line.split("=") for line in shell.split())
        self.x, self.y = int(geometry["X"]), int(geometry["Y"])
        self.size = int(geometry["WIDTH"]), int(geometry["HEIGHT"])
        while len(np.unique(self.screenshot().reshape(-1, 3), axis=0)) < 2:  # the first frame
            if time.monotonic() > deadline or self.process.poll() is not None:
                raise AssertionError("the window showed no frame")
            time.sleep(0.1)

    def screenshot(self):
        """What the window shows now: (h, w, 3) uint8, grabbed from the X screen."""
        from PIL import ImageGrab

        w, h = self.size
        image = ImageGrab.grab(bbox=(self.x, self.y, self.x + w, self.y + h),
                               xdisplay=self.display.name)
        return np.asarray(image.convert("RGB"))

    def settled(self, timeout=30):
        """The screenshot once two in a row agree (the frames drawn so far are on screen)."""
        deadline = time.monotonic() + timeout
        last = self.screenshot()
        while time.monotonic() < deadline:
            time.sleep(0.3)
            now = self.screenshot()
            if np.array_equal(now, last):
                return now
            last = now
        raise AssertionError(f"the window kept changing for {timeout} s")

    def changed_from(self, before, timeout=30):
        """The settled screenshot, once it differs from ``before``."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            now = self.settled(timeout)
            if not np.array_equal(now, before):
                return now
            time.sleep(0.2)
        raise AssertionError(f"the window did not change in {timeout} s")

    def keys(self, *names):
        self.display.xdotool("key", "--delay", 60, *names)

    def drag(self, start, end, steps=8):
        """Press the left button at picture pixel ``start``, move in ``steps`` to ``end``,
        release."""
        x0, y0 = start
        x1, y1 = end
        self.display.xdotool("mousemove", "--sync", self.x + x0, self.y + y0)
        self.display.xdotool("mousedown", 1)
        for k in range(1, steps + 1):
            self.display.xdotool("mousemove", "--sync", self.x + round(x0 + (x1 - x0) * k / steps),
                                 self.y + round(y0 + (y1 - y0) * k / steps))
            time.sleep(0.05)
        self.display.xdotool("mouseup", 1)

    def wheel(self, notches):
        """Turn the wheel over the window: positive notches towards the scene (X button 4)."""
        w, h = self.size
        self.display.xdotool("mousemove", "--sync", self.x + w // 2, self.y + h // 2)
        self.display.xdotool("click", "--repeat", abs(notches), "--delay", 60,
                             4 if notches > 0 else 5)

    def close_button(self):
        """What a window manager sends when the close button is clicked: WM_DELETE_WINDOW."""
        from Xlib import X, display as xdisplay, protocol

        d = xdisplay.Display(self.display.name)
        window = d.create_resource_object("window", int(self.window))
        delete = d.intern_atom("WM_DELETE_WINDOW")
        event = protocol.event.ClientMessage(window=window, client_type=d.intern_atom(
            "WM_PROTOCOLS"), data=(32, [delete, X.CurrentTime, 0, 0, 0]))
        window.send_event(event, event_mask=X.NoEventMask)
        d.sync()  # a round trip: the server has taken the message before this connection closes
        d.close()

    def finish(self, timeout=60):
        """Wait for the command to end: (exit status, stdout, stderr)."""
        try:
            out, err = self.process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.send_signal(signal.SIGABRT)  # faulthandler prints where it was
            out, err = self.process.communicate()
            raise AssertionError(f"view did not end within {timeout} s: {out} {err}")
        return self.process.returncode, out, err


def printed(line, name):
    """The numbers after ``name`` in the view's closing line (``camera eye x,y,z``), read from
    its end, where the closing values follow the last status."""
    for part in reversed(line.split(" | ")):
        words = part.split()
        if name in words:
            value = words[words.index(name) + 1]
            return np.array([float(v) for v in value.split(",")])
    raise AssertionError(f"{name!r} is not in {line!r}")


def leftovers(folder):
    return sorted(p.name for p in Path(folder).iterdir())
