"""Every option a scene lists acts (issue 40): for each scene, each of its parameters and the
frame settings it uses, given one value other than its default, changes the picture or the
state of a small run, or is refused in one line naming it. Options found doing nothing by this
walk (and fixed): --intensity (it cancelled in the tone map), confetti's --sprite, --blend and
--size-law (quads have none), --lamp without --shadows on, --scene-depth without --soft,
--upsample without --buffer-scale below 1, --camera orbit on a still, the fountain's --bounce
without --floor bounce."""

import contextlib
import hashlib
import io
from dataclasses import replace

import numpy as np
import pytest

from es2particles.cli import main
from es2particles.frame.settings import COMMON_SETTINGS, SETTINGS
from es2particles.scenes import scene_class

SCENES = ("dejong", "clifford", "collision", "fountain", "collision3d", "confetti", "smoke",
          "wind", "boids", "liquid", "sph", "flame")
# A value for each option whose default a rule cannot move (text, a scene's own default).
VALUES = {
    "--shape": {"collision": "box", "collision3d": "box:0,1,0,1,0.5,1",
                "confetti": "box:0,1,0,1,0.5,1"},
    "--sprite": {"fountain": "disc", "collision3d": "fireball", "smoke": "disc"},
    "--emitters": {"fountain": "0,0,0;1,0,0"},
    "--field-format": {"collision3d": "rgba16f", "confetti": "rgba16f"},
    "--shapes": {"confetti": "star"},
    "--sort": {"smoke": "off"},
    "--grid": {"wind": "32x48"},
    "--box": {"boids": "3,3"},
    "--walls": {"wind": "slip,slip,slip,slip"},
    "--obstacle": {"wind": "box:0.5,0.5,0.1,0.1"},
    "--gradient": "ice",
    "--point-size": "3",
    "--steps": "37",
    "--seed": "9",
    "--accumulate": "3",
    "--trails": "fade:0.9",  # refused on a still: the walk draws stills
    "--bound": "1",  # a loop's cap acts where a row of 3 cells holds more: refused
}
# Options whose contract is the same picture and state by another path (their own tests
# compare the paths), or that a still of this size cannot show, each with why.
SAME_BY_DESIGN = {
    "--vertex-fetch": "the points and sprites drawn by another path, pixel for pixel "
                      "(test_render.py, test_vertex_fetch.py)",
}
SMALL = ["--size", "32x32", "--particles", "256"]
BASE = {"wind": ["--grid", "32x32"], "boids": ["--steps", "20"],
        "liquid": ["--steps", "20"],
        "sph": ["--spacing", "0.1", "--steps", "300"]}  # every run but its option's own


def _run(scene, extra, tmp_path):
    out, state = tmp_path / "x.png", tmp_path / "s.npz"
    for f in (out, state):
        f.unlink(missing_ok=True)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        base = [w for w in BASE.get(scene, []) if not extra or extra[0] != BASE[scene][0]]
        small = SMALL[:2] if scene in ("sph", "flame") else SMALL  # by --spacing; no particles
        code = main(["run", scene, *small, *base, *extra, "--out", str(out), "--save-state",
                     str(state)])
    if code:
        return code, err.getvalue(), None
    digest = hashlib.sha1()
    with np.load(state) as data:
        for key in sorted(data.files):
            if key != "meta":
                digest.update(np.ascontiguousarray(data[key]).tobytes())
    return 0, err.getvalue(), (hashlib.sha1(out.read_bytes()).hexdigest(), digest.hexdigest())


def _alternative(scene, d):
    """A value of declaration ``d`` other than its default (a frame setting's: the scene's),
    as command-line words."""
    own = getattr(scene_class(scene).defaults, d.name, None)
    if own is not None:
        d = replace(d, default=own)
    given = VALUES.get(d.flag_name)
    if isinstance(given, dict):
        given = given.get(scene)
    if given is not None:
        return [d.flag_name, given]
    if d.flag:
        return [d.flag_name] if not d.default else None
    if d.choices is not None:
        return [d.flag_name, next(str(c) for c in d.choices if c != d.default)]
    assert not d.text, f"{scene} {d.flag_name}: give it a value in VALUES"
    default = d.default
    count = len(default) if isinstance(default, tuple) else None

    def moved(k):
        lo = d.lo[k] if isinstance(d.lo, tuple) else d.lo
        hi = d.hi[k] if isinstance(d.hi, tuple) else d.hi
        v = None if default is None else (default[k] if count else default)
        for c in ([v * 1.5, v * 0.5, -v, v + 1, v - 1] if v is not None else []) + [
                x for x in (lo, hi) if x is not None] + [1.0]:
            if (lo is None or c >= lo) and (hi is None or c <= hi) and c != v:
                return c
        return v

    if count:
        return [d.flag_name, ",".join(repr(float(moved(k))) for k in range(count))]
    value = moved(0)
    return [d.flag_name, str(int(value)) if d.integer else repr(float(value))]


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("scene", SCENES)
def test_every_option_of_a_scene_acts_or_is_refused(scene, tmp_path):
    cls = scene_class(scene)
    code, err, base = _run(scene, [], tmp_path)
    assert code == 0, err
    options = {d.flag_name: d for d in cls.Params.options().values()}
    for name in COMMON_SETTINGS + tuple(cls.renders.settings):
        if name not in ("size", "particles", "bloom"):
            options[SETTINGS[name].flag_name] = SETTINGS[name]
    idle, animated = [], None
    for flag, d in options.items():
        words = _alternative(scene, d)
        if words is None or flag in SAME_BY_DESIGN:
            continue
        reference = base
        if flag == "--animate-to" or words == ["--camera", "orbit"]:
            # They move over an animation's frames (a still refuses them): against the same
            # two frames without them.
            words += ["--frames", "2"]
            animated = animated or _run(scene, ["--frames", "2"], tmp_path)[2]
            reference = animated
        code, err, got = _run(scene, words, tmp_path)
        if code:
            lines = err.strip().splitlines()
            assert code == 2 and len(lines) == 1 and flag.lstrip("-").split("-")[0] in lines[0], \
                (words, err)
        elif got == reference:
            idle.append(" ".join(words))
    assert not idle, f"{scene}: these change neither the picture nor the state: {idle}"
