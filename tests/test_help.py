"""The command line's help is complete: every option with a default says it."""

import argparse

import pytest

from es2particles.cli import build_parser


def commands():
    parser = build_parser()
    top = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, command in top.choices.items():
        scenes = [a for a in command._actions if isinstance(a, argparse._SubParsersAction)]
        if scenes:
            for scene, sub in scenes[0].choices.items():
                yield f"{name} {scene}", sub
        else:
            yield name, command


COMMANDS = list(commands())


@pytest.mark.parametrize("name, parser", COMMANDS, ids=[n for n, _ in COMMANDS])
def test_every_option_with_a_default_states_it(name, parser):
    missing = []
    for action in parser._actions:
        if not action.option_strings or action.help in (None, argparse.SUPPRESS):
            continue
        if action.default in (None, False, argparse.SUPPRESS) or action.required:
            continue
        if "default" not in action.help:
            missing.append(f"{action.option_strings[0]} (default {action.default!r})")
    assert not missing, f"{name}: " + ", ".join(missing)
    assert "``" not in (parser.description or "")


def test_a_run_imports_only_its_own_scene(tmp_path):
    """`run dejong` builds its parser without importing the other scenes or reading the package
    metadata; a name that is not built in still finds every installed scene."""
    import subprocess
    import sys

    code = ("import sys; from es2particles.cli import build_parser; "
            "build_parser(['run', 'dejong']).parse_args(['run', 'dejong', '--out', sys.argv[1]]); "
            "print(sorted(m for m in sys.modules if m.startswith('es2particles.scenes.')))")
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "x.png")],
                         capture_output=True, text=True, check=True, cwd=tmp_path)
    assert out.stdout.split() == ["['es2particles.scenes.attractor',", "'es2particles.scenes.base',",
                                  "'es2particles.scenes.dejong']"]
    from es2particles.errors import ParameterError

    with pytest.raises(ParameterError, match="invalid choice: 'dejongg' .*'smoke'"):
        build_parser(["run", "dejongg"]).parse_args(["run", "dejongg", "--out",
                                                     str(tmp_path / "x.png")])
