"""Pictures and animations that show themselves in Jupyter.

``Pipeline.picture()`` returns a :class:`Picture`, whose PNG is what a notebook cell shows;
:class:`Animation` collects frames and shows as an HTML5 video (MP4, with the ``video`` extra)
or, without it, as an animated WebP. Both are plain objects outside a notebook:
``Picture.pixels`` is the (h, w, 3) array, ``save`` writes either to a file.
"""

import base64
import tempfile
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .output import encode_png, save_animation, save_image


class Picture:
    """A rendered frame: an (h, w, 3) uint8 array that a notebook shows as a PNG."""

    def __init__(self, pixels):
        self.pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
        if self.pixels.ndim != 3 or self.pixels.shape[2] != 3 or 0 in self.pixels.shape:
            raise ParameterError(f"a picture is an (h, w, 3) array, got {self.pixels.shape}")

    def _repr_png_(self):
        return encode_png(self.pixels)

    def save(self, path):
        return save_image(self.pixels, path)

    def __repr__(self):
        h, w = self.pixels.shape[:2]
        return f"<Picture {w}x{h}>"


class Animation:
    """Frames shown in a notebook as an HTML5 video (MP4 with the video extra; animated WebP
    without it). ``add`` takes (h, w, 3) frames or Pictures."""

    def __init__(self, fps=30):
        self.fps, self.frames = fps, []

    def add(self, frame):
        self.frames.append(frame.pixels if isinstance(frame, Picture) else np.asarray(frame))
        return self

    def save(self, path):
        return save_animation(self.frames, path, self.fps)

    def _encoded(self):
        try:
            import imageio_ffmpeg  # noqa: F401
            suffix, mime = ".mp4", "video/mp4"
        except ImportError:
            suffix, mime = ".webp", "image/webp"
        with tempfile.TemporaryDirectory() as folder:
            path = self.save(Path(folder) / f"animation{suffix}")
            return mime, base64.b64encode(path.read_bytes()).decode("ascii")

    def _repr_html_(self):
        if not self.frames:
            return "<p>(an empty animation)</p>"
        mime, data = self._encoded()
        if mime == "video/mp4":
            return (f'<video controls autoplay loop muted playsinline>'
                    f'<source src="data:{mime};base64,{data}" type="{mime}"></video>')
        return f'<img src="data:{mime};base64,{data}"/>'

    def __repr__(self):
        return f"<Animation of {len(self.frames)} frames at {self.fps} fps>"
