"""Print the command-line reference, ``docs/command-line.md``, as Markdown.

Run from the repository root::

    python docs/cli_reference.py > docs/command-line.md

Nothing in the output is written by hand: the commands and their own options come from the real
parser (``es2particles.cli.build_parser``); each built-in scene's parameters from its ``Params``
declarations (``es2particles/params.py``: help, unit, range, default, value form); the frame
settings a scene uses from ``es2particles/frame/settings.py`` and the scene's rendering, with the
scene's own defaults (``Scene.default_text``). ``tests/test_cli_reference.py`` checks that the
committed page is this script's output. No GL context is opened.
"""

import argparse
import contextlib
import io
import re
import sys
from pathlib import Path

from es2particles.cli import build_parser, main
from es2particles.frame.settings import BLOOM_PARTS, SETTINGS, Defaults, particles_setting
from es2particles.params import Param
from es2particles.scenes import BUILT_IN, scene_class

DOCS = Path(__file__).resolve().parent
COMMANDS = ("info", "plan", "run", "view", "export", "report")
SCENE_COMMANDS = ("plan", "run", "view", "export")
SCENE_DEFAULTS = set(Defaults.__dataclass_fields__)
# An example of a refusal, produced by running it (nothing is written, no context is opened).
REFUSED = ["run", "fountain", "--exposure", "2", "--out", "fountain.png"]


def subparsers(parser):
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


def command_parser(command, scene="dejong"):
    """The parser of ``command`` (for a scene command, of ``command scene``), built as the
    program builds it for that command line: only the built-in scene named is loaded."""
    argv = [command, scene] if command in SCENE_COMMANDS else [command]
    parser = subparsers(build_parser(argv)).choices[command]
    if command in SCENE_COMMANDS:
        parser = subparsers(parser).choices[scene]
    return parser


def groups(parser):
    """(command options, scene parameters, frame settings) action groups of a scene command."""
    named = {g.title: g for g in parser._action_groups}
    params = next(g for t, g in named.items() if t.endswith("'s parameters"))
    settings = next(g for t, g in named.items() if t.startswith("frame settings"))
    own = [a for a in parser._actions if a.option_strings and "-h" not in a.option_strings
           and a not in params._group_actions and a not in settings._group_actions]
    return own, params._group_actions, settings._group_actions


def cell(text):
    """Text for a table cell: pipes escaped, no line breaks."""
    return " ".join(str(text).split()).replace("|", "\\|")


def code(text):
    return f"`{cell(text)}`"


def number(value):
    """A number as the command line writes it (Param.describe_value, as the help does)."""
    return Param(None).describe_value(value)


def bound(value, component, none):
    if isinstance(value, tuple):
        value = value[component]
    return none if value is None else number(value)


def range_text(d):
    """A declaration's range: [lo, hi] (each component's, where they differ), whole or not."""
    if d.flag or d.text or d.choices is not None or (d.lo is None and d.hi is None):
        return ""
    whole = ", whole" if d.integer else ""
    if not (isinstance(d.lo, tuple) or isinstance(d.hi, tuple)):
        each = " each" if d.count not in (None, 1) else ""
        return f"[{bound(d.lo, 0, '-inf')}, {bound(d.hi, 0, 'inf')}]{each}{whole}"
    size = max(len(v) for v in (d.lo, d.hi) if isinstance(v, tuple))
    names = [re.sub(r"\W", "", n) for n in (d.metavar or "X,Y,Z,W").split(",")]
    parts = []
    for k in range(size):
        name = names[k] if k < len(names) and names[k] else f"component {k + 1}"
        parts.append(f"{name} [{bound(d.lo, k, '-inf')}, {bound(d.hi, k, 'inf')}]")
    return ", ".join(parts) + whole


def value_text(d, action):
    if (d is not None and d.flag) or action.nargs == 0:
        return "(none: a switch)"
    if d is not None and d.choices is not None:
        return ", ".join(code(c) for c in d.choices)
    return code(action.metavar or action.dest.upper())


def help_words(d):
    return cell(d.help.rstrip("."))


def row(*cells):
    return "| " + " | ".join(c if c else "-" for c in cells) + " |"


TABLE = ["| option | value | unit | range | default | what it is |", "|---|---|---|---|---|---|"]


def parameter_rows(scene, actions):
    declared = scene.Params.options()
    out = []
    for action in actions:
        d = declared[action.dest]
        default = "off" if d.flag else d.describe_value(d.default)
        out.append(row(code(action.option_strings[0]), value_text(d, action), cell(d.unit),
                       cell(range_text(d)), cell(default), help_words(d)))
    return out


def setting_rows(scene, actions):
    out = []
    for action in actions:
        if action.help == argparse.SUPPRESS:
            continue
        if action.dest in ("no_bloom", "bloom_on"):
            out.append(row(code(action.option_strings[0]), value_text(None, action), "", "",
                           "bloom on" if action.dest == "no_bloom" else "bloom off",
                           cell(action.help)))
            continue
        d = particles_setting(scene) if action.dest == "particles" else SETTINGS[action.dest]
        if action.dest in SCENE_DEFAULTS:
            default = scene.default_text(action.dest)
        elif action.dest in BLOOM_PARTS:  # the parts the scene's rendering blooms with
            default = d.describe_value(getattr(scene.renders.bloom_parts, action.dest[6:]))
        else:
            default = d.describe_value(d.default)
        out.append(row(code(action.option_strings[0]), value_text(d, action), cell(d.unit),
                       cell(range_text(d)), cell(default), help_words(d)))
    return out


def option_rows(actions):
    out = ["| option | value | what it does |", "|---|---|---|"]
    for action in actions:
        if action.help == argparse.SUPPRESS:
            continue
        value = value_text(None, action)
        what = cell(action.help)
        if action.required:
            what = "required: " + what
        out.append(row(code(action.option_strings[0]), value, what))
    return out


def command_help():
    """name -> the top-level help line of each command, without the installed scenes' list
    (which plug-ins change)."""
    top = subparsers(build_parser(["info"]))
    return {a.dest: re.sub(r" \(scenes: [^)]*\)$", "", a.help) for a in top._choices_actions}


def sentence(text):
    text = cell(text)
    return text[:1].upper() + text[1:] + "."


def refusal():
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(list(REFUSED))
    assert status == 2, f"{' '.join(REFUSED)} was not refused"
    return err.getvalue().strip()


def commands_section(helps):
    out = ["## Commands", "",
           "| command | what it does |", "|---|---|"]
    for name in COMMANDS:
        usage = f"es2particles {name}" + (" SCENE [options]" if name in SCENE_COMMANDS else "")
        usage += {"run": " --out FILE", "export": " --out PAGE.html",
                  "report": " [--quick] [--out FOLDER]"}.get(name, "")
        out.append(row(code(usage), cell(helps[name])))
    out += ["", "`python -m es2particles` is the same program. An error (a bad value, a setting "
            "the scene does not use, no GL driver) is one line on standard error and the exit "
            "status 2; nothing is written.", ""]
    for name in COMMANDS:
        out += [f"### {name}", "", sentence(helps[name]), ""]
        if name in SCENE_COMMANDS:
            own = groups(command_parser(name))[0]
            for scene in BUILT_IN:  # the command's own options are the same for every scene
                other = groups(command_parser(name, scene))[0]
                assert [a.option_strings for a in other] == [a.option_strings for a in own], \
                    f"{name} {scene}: its own options differ from {name} dejong's"
            out += [f"`SCENE` is one of {', '.join(code(s) for s in BUILT_IN)} (the built-in "
                    "scenes, each below) or a scene another package installs. Its own options:",
                    ""]
            out += option_rows(own)
        else:
            actions = [a for a in command_parser(name)._actions
                       if a.option_strings and "-h" not in a.option_strings]
            if not actions:
                out.append("It takes no options.")
            else:
                out += option_rows(actions)
        out.append("")
    return out


def scene_page(name):
    """The scene's own page under docs/scenes/, where there is one (the attractors share one)."""
    from es2particles.scenes.attractor import Attractor

    page = "attractors" if issubclass(scene_class(name), Attractor) else name
    return f"scenes/{page}.md" if (DOCS / "scenes" / f"{page}.md").exists() else None


def scene_section(name):
    scene = scene_class(name)
    parser = command_parser("run", name)
    own, params, settings = groups(parser)
    summary = (scene.__doc__ or name).strip().splitlines()[0].replace("``", "`")
    used = [a for a in settings if a.help != argparse.SUPPRESS]
    # the bloom switch not listed is taken and changes nothing (bloom is already on, or off)
    unused = [a.option_strings[0] for a in settings if a.help == argparse.SUPPRESS
              and a.dest not in ("bloom_on", "no_bloom")]
    page = scene_page(name)
    if page:
        summary += f" Its page: [{page}]({page})."
    out = [f"### {name}", "", summary, "",
           f"Its parameters (`es2particles run {name} --help` lists the same):", ""]
    out += TABLE + parameter_rows(scene, params)
    out += ["", f"The frame settings it uses ({scene.renders.__name__} rendering), with "
            f"{name}'s defaults:", ""]
    out += TABLE + setting_rows(scene, used)
    out.append("")
    if unused:
        out += [f"It refuses the others in one line: {', '.join(code(o) for o in unused)}.", ""]
    out += [f"`run {name}` takes the command's own options as well: "
            f"{', '.join(code(a.option_strings[0]) for a in own)} (see [run](#run); `plan` and "
            "`export` take fewer).", ""]
    return out


def page():
    helps = command_help()
    out = ["# The command line", "",
           "*Generated by `docs/cli_reference.py` from the parameter declarations; regenerate "
           "it with `python docs/cli_reference.py > docs/command-line.md`.*", "",
           "Every option below comes from one declaration: a scene's parameters from its "
           "`Params` class, the frame settings from `es2particles/frame/settings.py`. The help "
           "(`es2particles run SCENE --help`), the checks, a run file's values (`--save-config`, "
           "`--config`) and this page all read it. See also [the README](../README.md).", ""]
    out += commands_section(helps)
    out += ["## Values", "",
            "`X` is a number and `N` a whole number (so is an `X` whose range below says "
            "whole). A value of several numbers is written with commas and no spaces: "
            "`--lifetime 4,6`, `--gravity 0,-3,0` (gravity is a vector in every scene). A "
            "negative number may follow its option directly: `--b -2.3`. The other values are "
            "a word from a list (`--blend over`), free text the scene parses (`--shape "
            "circle+box`), or nothing: a switch (`--reseed`, `--no-bloom`).", "",
            "Each value is checked before a GL context is opened: a value out of its range, "
            "or a setting the scene's frame does not use, is refused in one line that names the "
            "option, and nothing is written:", "",
            "```text", "$ es2particles " + " ".join(REFUSED), refusal(), "```", "",
            "A run can be written down and run again: `--save-config RUN.toml` writes it, "
            "resolved (every parameter and setting the scene uses), and `--config RUN.toml` "
            "reads it back, options given beside it overriding its values; `--save-state "
            "STATE.npz` keeps the state after the last frame and `--load-state STATE.npz` "
            "resumes from it (the same scene, particle count and format), then runs `--steps` "
            "more:", "",
            "```sh",
            "es2particles run fountain --lifetime 2,3 --gravity 0,-5,0 --out fountain.png "
            "--save-config run.toml",
            "es2particles run --config run.toml --out again.png",
            "es2particles run dejong --steps 20 --save-state state.npz --out first.png",
            "es2particles run dejong --load-state state.npz --steps 5 --out later.png",
            "```", ""]
    out += ["## Scenes", "",
            "One section per built-in scene: its own parameters, then the frame settings its "
            "rendering uses. A default of a setting is this scene's where it has its own "
            "(particles, point size, steps, rounding), else the framework's.", ""]
    for name in BUILT_IN:
        out += scene_section(name)
    while out[-1] == "":
        out.pop()
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.stdout.write(page())
