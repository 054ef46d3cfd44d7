"""The exception family of es2particles.

Every error the package raises on purpose derives from :class:`Es2ParticlesError`, so a caller can
catch one type. Messages name the parameter, file or capability at fault and, where there is one,
the allowed range.
"""

import math


class Es2ParticlesError(Exception):
    """Base class of every error raised by es2particles."""


class ParameterError(Es2ParticlesError, ValueError):
    """A parameter is out of its allowed range or of the wrong kind."""


class ContextError(Es2ParticlesError):
    """No headless GL context could be made (missing EGL or driver)."""


class CapabilityError(Es2ParticlesError):
    """The context lacks something the request needs (a format, vertex texture fetch, a size)."""


class ShaderError(Es2ParticlesError):
    """A shader failed to load, compile or link; the message names the file and the line."""


class NothingDrawnWarning(UserWarning):
    """A picture shows nothing of its particles (sprites too small or out of sight); the
    message says the sizes and distances that made it so."""


class CostWarning(UserWarning):
    """A scene's parameters make a step far costlier than its defaults do (sub-steps, field
    size); the message names the cost, its value and the defaults'."""


class RangeWarning(UserWarning):
    """A quantity's declared range cannot hold a value it will likely be asked to (zero, in
    RGBA8's 16-bit codes); the message says what it reads back as and which range would."""


class FaintWarning(UserWarning):
    """A feature switched on can barely show in this picture (light shafts from a light far off
    the screen); the message says why and what would show it."""


class GraphError(Es2ParticlesError):
    """A pass graph is inconsistent: a cycle, a read nobody provides, two writers of one quantity."""


def check_range(name, value, lo=None, hi=None, integer=False):
    """Return ``value`` if it lies in ``[lo, hi]`` (and is finite), else raise :class:`ParameterError`.

    Used at every public entry point so that bad input fails with the parameter's name and range
    instead of deep inside GL.
    """
    kind = "an integer" if integer else "a number"
    if isinstance(value, (bool, str, bytes)):  # True is 1 to Python, "3" a string to the caller
        raise ParameterError(f"{name} must be {kind}, got {value!r}")
    try:
        number = int(value) if integer else float(value)
    except (TypeError, ValueError, OverflowError):  # int(inf) overflows, int(nan) fails
        if isinstance(value, float) and not math.isfinite(value):
            raise ParameterError(f"{name} must be finite, got {value!r}") from None
        raise ParameterError(f"{name} must be {kind}, got {value!r}") from None
    if integer and number != value:
        raise ParameterError(f"{name} must be {kind}, got {value!r}")
    if not math.isfinite(number):
        raise ParameterError(f"{name} must be finite, got {value!r}")
    if (lo is not None and number < lo) or (hi is not None and number > hi):
        lo_text = "-inf" if lo is None else _number_text(lo)
        hi_text = "inf" if hi is None else _number_text(hi)
        raise ParameterError(f"{name} must be in [{lo_text}, {hi_text}], got "
                             f"{_number_text(number)}")
    return number


def _number_text(x):
    """A number as a person writes it: 4, 0.5, 1e+06, 0.0166667."""
    return f"{x:.6g}" if isinstance(x, float) else str(x)
