"""The ``es2particles`` command: ``info`` now; scenes add ``run`` and ``plan``.

Errors of the package (bad parameters, no GL, a shader that fails) are printed as one line with the
exit status 2, not as a traceback.
"""

import argparse
import sys

from .errors import Es2ParticlesError


def main(argv=None):
    parser = argparse.ArgumentParser(prog="es2particles",
                                     description="GPU particle systems, OpenGL ES 2.0 style, headless.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    info = commands.add_parser("info", help="print the GL context's capabilities")
    info.set_defaults(handler=_info)
    _add_scene_commands(commands)
    args = parser.parse_args(argv)
    try:
        return args.handler(args) or 0
    except Es2ParticlesError as error:
        print(f"es2particles: error: {error}", file=sys.stderr)
        return 2


def _info(args):
    from .context import open_context

    with open_context() as ctx:
        print(ctx.caps)


def _add_scene_commands(commands):
    """Scene commands (run, plan) register themselves here."""


if __name__ == "__main__":
    sys.exit(main())
