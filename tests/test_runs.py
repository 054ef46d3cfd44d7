"""A scene's parameters declared once, and a run as a file: the help states each scene's true
defaults and only the options it uses; --save-config then --config makes the same bytes;
--load-state resumes byte for byte; a bad run file or state file is one line and writes
nothing."""

import re

import numpy as np
import pytest

from es2particles.cli import build_parser, main
from es2particles.scenes import BUILT_IN, scene_class

SMALL = ["--particles", "2048", "--size", "96x96"]
# Options every scene's run takes (the output, the run as a file, the frames, the cluster).
RUN_OPTIONS = {"--out", "--config", "--save-config", "--frames", "--steps-per-frame",
               "--fps", "--save-state", "--load-state", "--workers", "--scheduler",
               "--worker-timeout", "--backend"}
# The frame settings a 3D sprite scene draws with, and the ones only a density picture has.
# Bloom is over every picture: switched off where the density has it on by default, on where
# the rendering leaves it off. The gradient map too: a density's tone map colours along it, any
# other picture is recoloured by its brightness where a ramp is given.
COMMON = {"--particles", "--size", "--format", "--rounding", "--steps", "--seed", "--point-size",
          "--gradient", "--trails", "--bloom-threshold", "--bloom-radius", "--bloom-intensity"}
DENSITY_ONLY = {"--intensity", "--exposure", "--accumulate", "--no-bloom", "--vertex-fetch"}


def help_of(capsys, *argv):
    with pytest.raises(SystemExit):
        main([*argv, "--help"])
    return capsys.readouterr().out


def listed_options(text):
    return set(re.findall(r"^\s+(--[a-z-]+)", text, re.M))


@pytest.mark.parametrize("name", BUILT_IN)
def test_help_lists_only_the_options_the_scene_uses(capsys, name):
    text = help_of(capsys, "run", name)
    listed = listed_options(text)
    params = {"--" + n.replace("_", "-") for n in scene_class(name).Params.options()}
    three_d = name in ("fountain", "collision3d", "confetti", "smoke", "flame")
    # Quads have a world size; the flame draws no points.
    common = COMMON - {"--point-size"} if name in ("confetti", "flame") else COMMON
    sprites = {"--vertex-fetch"} if name in ("fountain", "collision3d", "smoke") else set()
    expected = (RUN_OPTIONS | common | params | sprites
                | ({"--bloom"} if three_d else DENSITY_ONLY))
    if name == "flame":  # the march: its dithered marches averaged over --accumulate steps
        expected = RUN_OPTIONS | (COMMON - {"--point-size"}) | params | {"--bloom",
                                                                          "--accumulate"}
    if name == "liquid":  # metaballs: discs of the buffer's size, no tone map
        expected = RUN_OPTIONS | (COMMON - {"--point-size"}) | params | {"--bloom",
                                                                          "--vertex-fetch"}
    assert listed == expected, (listed ^ expected)
    if three_d:
        averages = {"--accumulate"} if name == "flame" else set()
        assert not listed & (DENSITY_ONLY - sprites - averages)


# Each scene's defaults as the README and docs state them, typed here, not read from the code.
STATED = {"dejong": ("2^20", "1"), "clifford": ("2^20", "1"), "collision": ("2^17", "2"),
          "fountain": ("2^11", "20"), "collision3d": ("2^14", "9"), "confetti": ("2^13", None),
          "smoke": ("2^15", "16"), "wind": ("2^20", "1"), "boids": ("2^14", "2"),
          "liquid": ("2^14", None), "sph": ("3200", "2"),
          "flame": ("none (noise, wind), 2^16 (smoke)", None)}


@pytest.mark.parametrize("name", BUILT_IN)
def test_help_states_the_scene_s_own_defaults(capsys, name):
    text = " ".join(help_of(capsys, "run", name).split())
    particles, point_size = STATED[name]
    if name == "wind":  # the grids alone with --particles 0
        assert f"particle count (0: the grids alone); in [0, inf]; default {particles}" in text
    else:
        assert f"particle count; in [1, inf]; default {particles}" in text
    if point_size is not None:
        assert re.search(rf"--point-size X point or sprite diameter .*?default {point_size}\b",
                         text)


def test_the_fountain_s_help_is_its_own(capsys):
    text = " ".join(help_of(capsys, "run", "fountain").split())
    for words in ("--gravity X,Y,Z the acceleration of gravity (a vector, as in every scene); "
                  "m/s^2; in [-100, 100]; default 0,-9.81,0",
                  "--lifetime MIN,MAX lifetime range; s;", "default 2,2.5",
                  "--eye X,Y,Z the camera's place; m; in [-1000, 1000]; default 0,3,7.5"):
        assert words in text


@pytest.mark.parametrize("argv, named", [
    (["run", "fountain", "--intensity", "2"], "--intensity"),
    (["run", "smoke", "--accumulate", "4"], "--accumulate"),
    (["run", "collision3d", "--exposure", "2"], "--exposure"),
    (["run", "fountain", "--bloom", "--no-bloom"], "--no-bloom switches bloom off: leave out "
                                                   "--bloom"),
    (["run", "fountain", "--gravity", "9.81"], "--gravity must be 3 numbers"),
    (["run", "fountain", "--gravty", "1"], "unrecognized arguments: --gravty"),
    (["run", "smoke", "--lifetime", "4", "6"], "unrecognized arguments: 6"),
    (["run", "dejong", "--steps-per-frame", "3"], "--steps-per-frame: a still has one frame"),
])
def test_an_option_the_scene_does_not_take_is_one_line_naming_it(tmp_path, capsys, argv, named):
    assert main([*argv, "--out", str(tmp_path / "f.png")]) == 2
    err = capsys.readouterr().err
    assert named in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


def test_smoke_takes_its_lifetime_as_its_help_writes_it(capsys, tmp_path):
    text = " ".join(help_of(capsys, "run", "smoke").split())
    assert "--lifetime MIN,MAX lifetime range; s; in [0.0001, inf]; default 4,6" in text
    args = build_parser(["run", "smoke"]).parse_args(["run", "smoke", "--lifetime", "4,6",
                                                      "--out", str(tmp_path / "x.png")])
    from es2particles.cli import run_of

    assert run_of(args).make_scene().params.lifetime == (4.0, 6.0)


@pytest.mark.gl
@pytest.mark.parametrize("argv", [
    ["run", "fountain", *SMALL, "--emitters", "0,0,0;1,0,1,0.3,1,0,2", "--blend", "over"],
    ["run", "dejong", *SMALL, "--a", "1.7", "--gradient", "ice", "--bloom-radius", "2"],
    ["run", "smoke", "--particles", "1024", "--size", "64x48", "--sort", "3", "--frames", "2",
     "--steps-per-frame", "4"],
])
def test_a_saved_run_file_makes_the_same_bytes(tmp_path, argv):
    suffix = ".gif" if "--frames" in argv else ".png"
    a, b, config = tmp_path / f"a{suffix}", tmp_path / f"b{suffix}", tmp_path / "run.toml"
    assert main([*argv, "--save-config", str(config), "--out", str(a)]) == 0
    assert main(["run", "--config", str(config), "--out", str(b)]) == 0
    assert a.read_bytes() == b.read_bytes()
    # Flags beside the file override it: the same as typing the flag on the first command.
    c, d = tmp_path / f"c{suffix}", tmp_path / f"d{suffix}"
    assert main(["run", "--config", str(config), "--seed", "5", "--out", str(c)]) == 0
    assert main([*argv, "--seed", "5", "--out", str(d)]) == 0
    assert c.read_bytes() == d.read_bytes() != a.read_bytes()


def resumed(tmp_path, name, options, steps):
    """Run ``name`` with ``options`` for ``steps`` steps (whole.png/.npz), for half of them
    (half.png/.npz), and the half again from its saved state (resumed.png/.npz); assert the
    resumed picture and every saved array are the whole run's. Returns the whole run's meta."""
    import json

    half = str(steps // 2)
    for label, n in (("whole", str(steps)), ("half", half)):
        assert main(["run", name, *options, "--steps", n, "--out", str(tmp_path / f"{label}.png"),
                     "--save-state", str(tmp_path / f"{label}.npz")]) == 0
    assert main(["run", name, *options, "--steps", half, "--load-state",
                 str(tmp_path / "half.npz"), "--out", str(tmp_path / "resumed.png"),
                 "--save-state", str(tmp_path / "resumed.npz")]) == 0
    assert (tmp_path / "whole.png").read_bytes() == (tmp_path / "resumed.png").read_bytes()
    with np.load(tmp_path / "whole.npz") as whole, np.load(tmp_path / "resumed.npz") as again:
        assert sorted(whole.files) == sorted(again.files)
        for key in whole.files:
            assert np.array_equal(whole[key], again[key]), key
        return json.loads(str(whole["meta"]))


@pytest.mark.gl
@pytest.mark.parametrize("name", ["fountain", "collision", "smoke", "dejong"])
def test_load_state_resumes_byte_for_byte(tmp_path, name):
    """100 steps equal 50 steps, --save-state, --load-state and 50 more: the picture and the
    saved state (every texel of every part)."""
    resumed(tmp_path, name, ["--particles", "1024", "--size", "64x64"], 100)
    assert (tmp_path / "half.png").read_bytes() != (tmp_path / "whole.png").read_bytes()


@pytest.mark.gl
@pytest.mark.parametrize("name, options", [
    ("fountain", ["--format", "rgba16f", "--particles", "1000", "--seed", "7",
                  "--gravity", "0,-5,0", "--floor", "kill"]),
    ("smoke", ["--rounding", "dither", "--particles", "1500", "--seed", "3", "--tau", "0.4"]),
    ("collision", ["--rounding", "jitter", "--particles", "2000", "--seed", "11",
                   "--bounce", "0.8"]),
    ("wind", ["--format", "rgba32f", "--particles", "3000", "--grid", "48x32",
              "--pressure-iterations", "12", "--seed", "5"]),
    ("boids", ["--dimensions", "3", "--particles", "1200", "--seed", "2"]),
], ids=["fountain", "smoke", "collision", "wind", "boids"])
def test_a_state_round_trips_with_every_field_off_its_default(tmp_path, name, options):
    """The resume of test_load_state_resumes_byte_for_byte with every field a state file holds
    off its default: a float format or another rounding (dither's and jitter's hashes run on
    from the step count the file keeps), a count that is no power of two (spare texels), a
    seed, a scene parameter, and the grids beside the particles (wind) or a neighbour grid's
    sort order rebuilt from the positions (boids in 3D). The file's meta says what was saved."""
    meta = resumed(tmp_path, name, [*options, "--size", "48x48"], 24)
    words = dict(zip(options[::2], options[1::2]))
    assert meta["scene"] == name and meta["steps_done"] == 24
    assert meta["particles"] == int(words["--particles"])
    assert meta["format"] == words.get("--format", "rgba8")


BAD_FILES = {
    "unknown key": ('scene = "fountain"\ncolour = 3\n', "run.toml: unknown key 'colour'"),
    "unknown parameter": ('scene = "fountain"\n[parameters]\ngravty = [0, -1, 0]\n',
                          "run.toml: [parameters] 'gravty' is not a parameter of fountain"),
    "wrong type": ('scene = "fountain"\n[parameters]\ndrag = "a"\n',
                   "run.toml: [parameters] drag must be a number, got 'a'"),
    "wrong count": ('scene = "fountain"\n[parameters]\ngravity = [0, -9.81]\n',
                    "run.toml: [parameters] gravity must be a list of 3 numbers"),
    "out of range": ('scene = "fountain"\n[parameters]\ndrag = 1e9\n',
                     "run.toml: [parameters] drag must be in [0, 100], got 1e+09"),
    "not a choice": ('scene = "fountain"\n[parameters]\nfloor = "up"\n',
                     "run.toml: [parameters] floor must be one of kill, bounce, got 'up'"),
    "unused setting": ('scene = "fountain"\n[settings]\nexposure = 2.0\n',
                       "--exposure: scene 'fountain' does not use this setting"),
    "bad setting": ('scene = "dejong"\n[settings]\nparticles = -4\n',
                    "[settings] particles must be in [1, inf], got -4"),
    "unknown scene": ('scene = "fountan"\n', "no scene is registered as 'fountan'"),
    "not TOML": ('scene = "fountain"\n[parameters\n', "run.toml' is not a TOML run file"),
}


@pytest.mark.parametrize("case", BAD_FILES)
def test_a_bad_run_file_is_one_line_naming_the_key(tmp_path, capsys, case):
    text, message = BAD_FILES[case]
    (tmp_path / "run.toml").write_text(text)
    out = tmp_path / "x.png"
    assert main(["run", "--config", str(tmp_path / "run.toml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.toml"]


@pytest.mark.gl
def test_a_bad_state_file_is_one_line_naming_what_differs(tmp_path, capsys):
    state = tmp_path / "s.npz"
    assert main(["run", "fountain", *SMALL, "--steps", "3", "--out", str(tmp_path / "a.png"),
                 "--save-state", str(state)]) == 0
    capsys.readouterr()
    (tmp_path / "cut.npz").write_bytes(state.read_bytes()[:1000])
    np.savez(tmp_path / "plain.npz", position=np.zeros((4, 3)))
    cases = [(["fountain", "--particles", "4096", "--size", "96x96"], state,
              "is the state of another run: particles 2048 (this run: 4096)"),
             (["smoke", *SMALL], state, "scene 'fountain' (this run: 'smoke')"),
             (["fountain", *SMALL, "--format", "rgba32f"], state,
              "format 'rgba8' (this run: 'rgba32f')"),
             (["fountain", *SMALL], tmp_path / "cut.npz", "cut.npz' is not a state file"),
             (["fountain", *SMALL], tmp_path / "plain.npz", "plain.npz' holds no run's state"),
             (["fountain", *SMALL], tmp_path / "none.npz", "none.npz")]
    before = sorted(p.name for p in tmp_path.iterdir())
    for argv, path, message in cases:
        assert main(["run", *argv, "--load-state", str(path), "--out",
                     str(tmp_path / "b.png")]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, (argv, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


@pytest.mark.parametrize("name", BUILT_IN)
def test_a_run_file_writes_every_parameter_and_setting_the_scene_uses(tmp_path, name):
    """Resolved: each of the scene's options with a value (its default where not given), and
    each frame setting it uses, so the file alone makes the same run when a default changes."""
    import tomllib

    from es2particles.frame.settings import BLOOM_PARTS, COMMON_SETTINGS
    from es2particles.run import Run, write_run

    scene = scene_class(name)()
    path = tmp_path / "run.toml"
    write_run(Run(name), scene, path)
    data = tomllib.loads(path.read_text())
    declared = scene.Params.options()
    with_values = {n for n in declared if getattr(scene.params, n) is not None}
    assert set(data["parameters"]) == with_values
    used = set(COMMON_SETTINGS) | set(scene.rendering().settings)
    if name == "flame":  # its noise keeps no state: a file naming the state settings is refused
        used -= {"particles", "format", "rounding", "seed"}
    assert set(data["settings"]) == used - set(BLOOM_PARTS)


# Options a scene takes only beside another (each flame source's own), walked with it.
BESIDE = {"flame": {**{flag: ["--source", "wind"] for flag in (
    "--burner", "--buoyancy", "--cooling", "--vorticity", "--pressure-iterations",
    "--max-speed")}, "--cells": ["--source", "smoke"]}}


@pytest.mark.slow  # ~1 s a scene: each option's scene is made twice
@pytest.mark.parametrize("name", BUILT_IN)
def test_a_run_file_round_trips_every_option_at_a_value_other_than_its_default(tmp_path, name):
    """Issue 46's round trips: for each option the scene lists (its parameters, the frame
    settings it uses, the frames, their rate and spacing, the back-end), given alone at a value
    other than its default, the run file --save-config writes reads back as the same run:
    the same resolved parameters, the same resolved settings, the same frames and back-end. A
    value the run refuses is left out (its refusal is test_options.py's), and a file refused on
    reading is allowed only where its run is refused once planned; the options that
    round-tripped are counted, so the walk cannot pass by skipping them all. It found two files
    their own run could not read: every flame run file (it named the state settings, which the
    flame's noise has none of), and the SPH's with --format rgba16f (it wrote the scene's
    default dither rounding, which float state refuses)."""
    from test_options import _alternative

    from es2particles.cli import build_parser, run_of
    from es2particles.errors import Es2ParticlesError
    from es2particles.frame.settings import COMMON_SETTINGS, SETTINGS
    from es2particles.run import read_run, resolved_settings, write_run

    cls = scene_class(name)
    declared = {d.flag_name: d for d in cls.Params.options().values()}
    for setting in COMMON_SETTINGS + tuple(cls.renders.settings):
        if setting not in ("size", "particles", "bloom"):  # given below
            declared[SETTINGS[setting].flag_name] = SETTINGS[setting]
    walks = {flag: _alternative(name, d) for flag, d in declared.items()}
    walks.update({"--size": ["--size", "48x40"], "--bloom-threshold": ["--bloom-threshold", "0.3"],
                  "--frames": ["--frames", "3"], "--steps-per-frame": ["--frames", "3",
                                                                       "--steps-per-frame", "4"],
                  "--fps": ["--frames", "3", "--fps", "12"], "--backend": ["--backend", "gles"],
                  "--particles": ["--particles", "300"]})
    kept = 0
    path = tmp_path / "run.toml"
    for flag, words in walks.items():
        if words is None:
            continue
        argv = ["run", name, *BESIDE.get(name, {}).get(flag, []), *words, "--out", "x.png"]
        try:  # a value the run refuses (here, or once the file is resolved) is left out
            run = run_of(build_parser(argv).parse_args(argv))
            scene = run.check()
            write_run(run, scene, path)
        except Es2ParticlesError:
            continue
        back = read_run(path)
        try:
            again = back.check()
        except Es2ParticlesError as refused:  # only where the run itself is refused, planned
            with pytest.raises(Es2ParticlesError):
                planned(run, scene)
            print(f"{name} {' '.join(words)}: refused when planned, and from its file: {refused}")
            continue
        assert again.params == scene.params, (words, again.params, scene.params)
        assert resolved_settings(back.settings, again) == resolved_settings(run.settings, scene), \
            words
        assert (back.frames, back.steps_per_frame, back.fps, back.backend) == \
            (run.frames, run.steps_per_frame, run.fps, run.backend), words
        kept += 1
    assert kept >= len(walks) // 2 + 3, f"{kept} of {len(walks)} options round-tripped"


def planned(run, scene):
    """Plan ``run`` on a recording context (no GL): where a run is refused once its defaults are
    resolved, it raises here."""
    from es2particles.gl.context import Capabilities, Context
    from es2particles.gl.device import RecordingDevice

    with Context(RecordingDevice(Capabilities.assumed())) as ctx:
        run.pipeline(ctx, scene)[1].release()
