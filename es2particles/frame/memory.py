"""How much memory a run needs, from its plan, and whether the machine has it: checked once,
before anything per particle is made.

On llvmpipe the "GPU memory" is the process's own, so a run that does not fit ends in a
MemoryError (or the kernel's OOM killer) seconds into the work. :func:`estimate` adds up what a
:class:`~es2particles.frame.plan.FramePlan` declares and what the run makes beside it;
:func:`available` reads what the machine lets this process have; :func:`check` refuses in one
line naming the option to lower. :class:`~es2particles.frame.pipeline.Pipeline` calls
:func:`check` right after planning, before its executor makes a texture and before the scene's
start makes its arrays, so the command line, the cluster's workers, the shares of a large still,
the live view and the notebook are all checked in that one place.

What a run holds from its executor on (``Estimate.held``):

- **state**: each quantity's textures (parts x 2 for ping-pong x texels x the format's bytes);
- **targets**: every render target (density, image and depth, shadow map, sort order, the post
  chain) at its size; **textures**: the scene's images (fields, sprites, ramps) as uploaded;
- **vertex buffers**: a particle's texel (8 bytes), a quad's four corners and six indices,
  meshes, and the buffers state is read back into where vertex texture fetch is off;
- **driver**: llvmpipe's compiled shaders and its rasteriser's bins (measured: 10-21 MiB for a
  run of 1024 particles, up to ~105 MiB of bins for 2^22 points and more, never more).

and, one after the other (``Estimate.peaks``: the largest counts):

- **making**: the host copies made while uploading (the texel grid as float32, ``tobytes``);
- **start**: the scene's start as numpy float64 arrays (count, components), or a grid's
  (cells, components), all held at once
  (counted for every state quantity: the plan cannot say which the start leaves at zero),
  and the numpy temporaries of packing the largest of them (``twins/pack.py``, measured with
  tracemalloc: 30 bytes a particle per packed 16-bit component in RGBA8, 17 per component and
  16 more in the float formats);
- **frames**: the picture read back and written (16 bytes a pixel, measured ~10), state read
  back for vertex buffers, an animation's tile order of reseeded points (48 bytes a particle)
  and what its writer holds: pillow keeps every decoded frame of a WebP (4 bytes a pixel a
  frame), GIF (6) or APNG (8) until the file is written, and ffmpeg's H.264 encoder takes
  ~220 bytes a pixel (measured at 2048x2048) in its own process.

Measured against llvmpipe on a 2-core machine: the peak RSS of ``es2particles run`` (from a
shell: a child's ru_maxrss starts at its parent's) less that of the same scene with 1024
particles (the interpreter, numpy and the driver: 123-149 MiB), with ``--steps 1`` at the
default 1024x1024; the estimate is its total and what the plan made. The rows from dejong 2^22
to smoke 2^24 were measured again once the start was packed ENCODE_ROWS rows at a time
(``frame/state.py``): fountain's 2^24 peak went from 3154 to 1660 MiB, smoke's from 3988 to
2492, confetti's 2^22 from 1575 to 935 (its quads' corners are made after the check now, too):

=========================================  ============  ============  =====
run                                        estimate MiB  measured MiB  ratio
=========================================  ============  ============  =====
dejong 2^20                                164           87            1.89
dejong 2^22 (clifford alike)               356           254           1.40
dejong --reseed 2^22, 3 frames to .webp    496           280           1.77
fountain 2^20                              296           217           1.36
fountain 2^22                              752           512           1.47
fountain 2^24                              2320          1660          1.40
collision 2^20                             213           117           1.81
collision 2^22                             549           331           1.66
collision3d 2^22                           754           511           1.47
confetti 2^22                              1194          935           1.28
smoke 2^22                                 961           719           1.34
smoke 2^24                                 3153          2492          1.27
dejong 1024 at 4096x4096                   540           398           1.36
the same, 6 frames to .webp / .gif / .png  1244-1436     1054-1284     1.12-1.20
fountain 1024 at 4096x4096                 416           322           1.29
=========================================  ============  ============  =====

It is above the measure in every case, by 1.1-1.8x, and up to 2.1x for the attractors (their
start is a fill, drawn in float32, where the estimate counts a float64 array: the plan cannot
tell them apart; dejong --reseed 2^20, 3 frames: 180 against 86). A 64x64 picture measures as 1024x1024 does, less its targets. A still of more than
2^22 attractor points is drawn in shares (``cluster/shares.py``), each checked as the pipeline
of its own 2^22. The check leaves out what the plan has made (a sort's first order is made as
the plan is): the process's usage holds it by then.
"""

from dataclasses import dataclass

from ..errors import ParameterError, check_range
from ..gl.context import bytes_per_texel
from ..io.memory import available
from ..twins.pack import PACKED
from .state import ENCODE_ROWS

GiB = 2 ** 30
MiB = 2 ** 20

# Numpy temporaries of packing one quantity's start (state_encode / fill_texels and the write of
# its texels), bytes a particle; measured with tracemalloc at 2^20 particles.
PACK_RGBA8 = 30  # per 16-bit component, in pairs (52-56 B for 1-2 components, 108-120 for 3-4)
PACK_RGBA8_32 = 46  # per 32-bit component (42-46 B a component, encoding or filling)
PACK_FLOAT = 17  # per component, and PACK_FLOAT_FIXED more (29-68 B encoding, 33-84 B filling)
PACK_FLOAT_FIXED = 16
IMAGE_READ = 16  # bytes a pixel: the picture read back (4), as RGB (3, twice), PNG rows (3, twice)
TILE_ORDER = 48  # bytes a particle: download, sort and rewrite of the texel order (measured 48)
TEXEL_VERTEX = 8  # a particle's texel centre, two float32
# bytes a texel while a function makes a target's first contents (the sort order's identity:
# measured 40 a slot in rgba8, 36 in rgba32f); the contents are then held until uploaded
MAKING = 40
DRIVER = 32 * MiB  # compiled shaders and the driver's own (10-21 MiB resident, <= 63 MiB virtual)
BINS = 24  # bytes a particle drawn of llvmpipe's bins, up to BINS_MAX (12 MiB at 2^20 points)
BINS_MAX = 128 * MiB  # (measured ~100-105 MiB at 2^22 and 2^24 points)
# What an animation's writer holds, bytes a pixel: (a frame, once). Pillow keeps each decoded
# frame until the file is written, beside its encoder's own canvases; ffmpeg's H.264 encoder
# (in its own process) holds its look-ahead. Measured at 4096x4096 with 3 and 6 frames (WebP 4
# and 17, GIF 5.3 and 9, APNG 8 and 7) and 2048x2048 (ffmpeg 218).
WRITER = {".webp": (4, 20), ".gif": (6, 10), ".png": (8, 8), ".mp4": (0, 224)}

PARTICLES, SIZE, FRAMES = "--particles", "--size", "--frames"


@dataclass(frozen=True)
class Estimate:
    """Bytes a run needs beyond what its process holds when the plan is checked.

    ``held``: part -> {option: bytes}, kept from the executor on; ``peaks``: phase ->
    {option: bytes}, which come and go one after the other, the largest counting; ``made``:
    bytes of arrays the plan made as it was planned (already in use when it is checked), not in
    the total. The option of each amount is what it grows with (``--particles``, ``--size``,
    ``--frames``; None: neither, the scene's own)."""

    held: dict
    peaks: dict
    made: int = 0

    @property
    def peak(self):
        """(name, {option: bytes}) of the largest phase."""
        if not self.peaks:
            return None, {}
        return max(self.peaks.items(), key=lambda item: sum(item[1].values()))

    @property
    def parts(self):
        """part -> bytes of what counts: every held part, then the largest phase."""
        name, peak = self.peak
        parts = {part: sum(by.values()) for part, by in self.held.items()}
        if name is not None:
            parts[name] = sum(peak.values())
        return parts

    @property
    def total(self):
        return sum(self.parts.values())

    def by_option(self):
        """option -> bytes of the total that grow with it, largest first."""
        out = {}
        for by in list(self.held.values()) + [self.peak[1]]:
            for option, n in by.items():
                out[option] = out.get(option, 0) + n
        return dict(sorted(out.items(), key=lambda item: -item[1]))

    def describe(self):
        """'6.1 GiB (state 2.0, start 3.2, ...)': the total and its parts, in GiB."""
        parts = ", ".join(f"{name} {gib(n)}" for name, n in self.parts.items() if n >= GiB / 200)
        return f"{gib(self.total)} GiB" + (f" ({parts})" if parts else "")


def gib(n):
    """Bytes as GiB, to two significant figures at most ('0.05', '6.1', '13')."""
    value = n / GiB
    return f"{value:.2g}" if value < 10 else f"{value:.0f}"


class _Tally:
    """Adds amounts to parts, each by the option it grows with."""

    def __init__(self):
        self.parts = {}

    def add(self, part, option, nbytes):
        by = self.parts.setdefault(part, {})
        by[option] = by.get(option, 0) + int(nbytes)

    def largest(self, part, option, nbytes):
        by = self.parts.setdefault(part, {})
        if nbytes > sum(by.values()):
            self.parts[part] = {option: int(nbytes)}


def _elements(quantity, count, each):
    """(the option it grows with, bytes): ``each`` bytes an element of ``quantity``, whose
    elements are the ``count`` particles, or a grid's cells (the scene's own: None)."""
    if quantity.domain is None:
        return PARTICLES, count * each
    return None, quantity.domain.cells * each


def pack_bytes(components, fmt):
    """Numpy temporaries (bytes a particle) of packing a start of ``components`` values into
    ``fmt``: the encoding, or the write of its texels where that is more."""
    if fmt == "rgba8_32":
        return PACK_RGBA8_32 * components
    if fmt == "rgba8":
        return PACK_RGBA8 * 2 * (-(-components // 2))
    return max(PACK_FLOAT * components, 2 * bytes_per_texel(fmt)) + PACK_FLOAT_FIXED


def estimate(plan, animation=None):
    """The :class:`Estimate` of a run of ``plan`` (a :class:`~es2particles.frame.plan.
    FramePlan`): a still, or with ``animation`` = (frames, suffix) the frames of an animation
    written to a file of that suffix (``.webp``, ``.gif``, ``.png``, ``.mp4``). Pure
    arithmetic over what the plan declares; nothing is made."""
    layout = plan.layout
    count, texels = layout.count, layout.width * layout.height
    held, peaks = _Tally(), _Tally()
    made = 0
    for r in plan.resources.values():
        if r.kind == "state":
            q = r.quantity
            held.add("state", _elements(q, count, 0)[0], r.nbytes)  # a grid's: the scene's
            # The start: a float64 array (count, components) of each quantity, held together,
            # and the packing of the largest; a grid's quantity has its cells, not the particles
            peaks.add("start", *_elements(q, count, q.components * 8))
        elif r.kind == "target":  # a sort order's slots are the particles'; the rest, images
            held.add("targets", PARTICLES if r.swap == "draw" else SIZE, r.nbytes)
        else:
            held.add("textures", None, r.nbytes)
        if callable(r.data):  # made after the check, at the texture's making
            w, h = r.size
            option = PARTICLES if r.swap == "draw" else None
            peaks.largest("making", option, w * h * MAKING)
        elif r.data is not None:
            made += getattr(r.data, "nbytes", 0)
            peaks.largest("making", None, getattr(r.data, "nbytes", 0))  # its tobytes copy
    states = [r for r in plan.resources.values() if r.kind == "state"]
    if states:
        # Packing runs ENCODE_ROWS rows at a time: up to them, the temporaries measured; beyond,
        # each row's texels and the upload's copy of them.
        def packing(r):
            option, n = _elements(r.quantity, count, 1)
            rows = min(n, ENCODE_ROWS)
            return option, (rows * pack_bytes(r.quantity.components, r.format) + (n - rows) * 2
                             * r.quantity.parts(r.format) * bytes_per_texel(r.format))

        option, nbytes = max((packing(r) for r in states), key=lambda p: p[1])
        peaks.add("start", option, nbytes)
    for v in plan.vertices.values():
        # Vertex data naming a particle's texel is the particles' (a mesh's is the scene's).
        option = PARTICLES if "a_texel" in dict(v.attributes) else None
        if v.source == "texels":
            held.add("vertex buffers", option, v.count * TEXEL_VERTEX)
            # the grid's texel centres (width x height) and their tobytes copy
            peaks.largest("making", option, (v.width * v.height + v.count) * TEXEL_VERTEX)
        else:
            nbytes = v.count * 4 * sum(n for _, n in v.attributes)
            held.add("vertex buffers", option, nbytes)
            made += getattr(v.data, "nbytes", 0)
            copy = 0 if getattr(v.data, "dtype", None) == "float32" else nbytes
            peaks.largest("making", option, nbytes + copy)
        if v.indexed:
            held.add("vertex buffers", option, v.indices_size * 4)
            made += getattr(v.indices, "nbytes", 0)
            peaks.largest("making", option, v.indices_size * 4)
    w, h = plan.size or (0, 0)
    pixels = w * h
    frames, suffix = animation if animation is not None else (1, None)
    frames = int(check_range("animation frames", frames, 1, None, integer=True))
    frame = {SIZE: pixels * IMAGE_READ}
    drawn = 0  # particles drawn by a stage
    for stage in plan.frame_stages:
        for ref in stage.attributes.values():  # state read back into a vertex buffer
            fmt = plan.resources[ref.resource].format
            per = 4 if fmt in PACKED else 16
            held.add("vertex buffers", PARTICLES, stage.count * per)
            frame[PARTICLES] = frame.get(PARTICLES, 0) + texels * bytes_per_texel(fmt) \
                + stage.count * (per + 16)
        if stage.vertices is not None and "a_texel" in dict(plan.vertices[stage.vertices]
                                                            .attributes):
            drawn = count  # points, sprites or quads of the particles
        if frames > 1 and stage.kind == "points" and not stage.attributes:
            frame[PARTICLES] = frame.get(PARTICLES, 0) + count * TILE_ORDER
    held.add("driver", None, DRIVER)
    held.add("driver", PARTICLES, min(drawn * BINS, BINS_MAX))
    if frames > 1:
        per_frame, once = WRITER.get(suffix, (0, 0))  # no suffix: frames not written
        frame[FRAMES] = frames * pixels * per_frame
        frame[SIZE] += pixels * once
    for option, n in frame.items():
        peaks.add("frames", option, n)
    return Estimate(held.parts, peaks.parts, made)


def check(plan, animation=None, room=None):
    """Raise :class:`ParameterError` in one line if the run of ``plan`` (with ``animation``, as
    :func:`estimate` takes it) needs more than ``room`` (a :class:`Room`; default
    :func:`available`), naming what it needs, what is available and the option to lower.
    Returns the :class:`Estimate`."""
    need = estimate(plan, animation)
    room = available() if room is None else room
    if room.bytes is None or need.total <= room.bytes:
        return need
    # What to lower: the options whose bytes are a tenth of the need or more, largest first.
    options = [o for o, n in need.by_option().items() if o is not None and n >= need.total / 10]
    options = options or [PARTICLES]
    what = {PARTICLES: f"--particles {plan.layout.count}", SIZE: "--size {}x{}".format(
        *(plan.size or (0, 0))), FRAMES: f"--frames {animation[0] if animation else 1}"}
    lower = options[0] + (f" (or {', '.join(options[1:])})" if len(options) > 1 else "")
    raise ParameterError(f"{what[options[0]]} needs about {need.describe()}; "
                         f"{gib(room.bytes)} GiB is available ({room.source}): lower {lower}")
