"""The live layer: a scene run in real time and moved by hand. ``controls`` holds what keys and
the mouse do, as numbers; ``view`` runs a pipeline by the clock with them; ``window`` shows it in
a window (``es2particles view``, the view extra) and ``widget`` in a notebook (jupyter_rfb)."""

__all__ = ["controls", "view", "window", "widget"]
