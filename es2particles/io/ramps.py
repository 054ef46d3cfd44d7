"""Colour ramps for the gradient map: built-in ones, a list of colours, or a W x 1 image.

A ramp is a (256, 4) uint8 array; ``frame/gradient.py`` uploads it as a 256 x 1 texture.
"""

import numpy as np

from ..errors import ParameterError

BUILTIN = {
    # Dark to bright, so the tone-mapped density reads as brightness whatever the hue.
    "inferno": ["#000004", "#320a5e", "#781b6c", "#bb3654", "#ec6824", "#fbb41a", "#fcffa4"],
    "ice": ["#000000", "#0b1a3d", "#1d4f8a", "#3aa0c8", "#a8e6f0", "#ffffff"],
    "viridis": ["#000000", "#440154", "#3b528b", "#21918c", "#5ec962", "#fde725"],
    "gold": ["#000000", "#2a1600", "#7a4a00", "#d89a1c", "#ffe08a", "#ffffff"],
    "grey": ["#000000", "#ffffff"],
    # Hues from slow to fast for colouring by speed, each about as bright (ColorBrewer's
    # Spectral, reversed, as mapbox/webgl-wind colours its wind): brightness stays the density's.
    "spectral": ["#3288bd", "#66c2a5", "#abdda4", "#e6f598", "#fee08b", "#fdae61", "#f46d43",
                 "#d53e4f"],
}


def load_ramp(spec):
    """The (256, 4) uint8 ramp for ``spec``: a built-in name, ``#rrggbb,#rrggbb,...`` (or any
    colour names pillow knows), or the path of an image whose first row is the ramp."""
    if not isinstance(spec, str) or not spec:
        raise ParameterError(f"gradient must be a name, a list of colours or a PNG path, got {spec!r}")
    if spec in BUILTIN:  # #rrggbb read here: pillow's import is ~10 ms of a run's start-up
        return _interpolate([[int(c[k:k + 2], 16) for k in (1, 3, 5)] for c in BUILTIN[spec]])
    from PIL import ImageColor

    from .images import file_fault

    if spec.lower().endswith((".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")):
        from .images import read_image

        row = np.asarray(read_image(spec, "--gradient", "RGB"))[0].astype(np.float64)
        if len(row) < 2:
            raise ParameterError(f"gradient image {spec!r} must be at least 2 pixels wide")
        return _interpolate(row)
    if "," in spec:
        try:
            colours = [ImageColor.getrgb(c.strip()) for c in spec.split(",")]
        except ValueError as error:
            raise ParameterError(f"gradient colour list {spec!r}: {error}") from None
        return _interpolate(colours)
    known = ", ".join(sorted(BUILTIN))
    raise ParameterError(f"gradient {spec!r} is unknown: use one of {known}, a comma-separated "
                         "colour list (#000000,#ff8800,#ffffff) or a PNG path"
                         + (" (file not found)" if file_fault(spec) == "does not exist" else ""))


def _interpolate(colours):
    stops = np.asarray(colours, dtype=np.float64)[:, :3]
    at = np.linspace(0, 1, len(stops))
    t = np.linspace(0, 1, 256)
    rgb = np.stack([np.interp(t, at, stops[:, k]) for k in range(3)], axis=1)
    out = np.full((256, 4), 255, dtype=np.uint8)
    out[:, :3] = np.round(rgb).astype(np.uint8)
    return out
