"""The ``magsoft`` command: one subcommand per module in this package."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys

# subcommand name -> module; a module defines ``add_parser(subparsers)`` and ``run(args) -> int``
COMMANDS = {
    "demo": "magsoft_env.cli.demo",
    "solve": "magsoft_env.cli.solve",
    "sweep": "magsoft_env.cli.sweep",
    "couplings": "magsoft_env.cli.couplings",
    "crosscheck": "magsoft_env.cli.crosscheck",
    "gait": "magsoft_env.cli.gait",
    "video": "magsoft_env.cli.video",
    "design": "magsoft_env.cli.design",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="magsoft",
        description="Design and simulate centimetre-scale hard-magnetic soft robots.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for modname in COMMANDS.values():
        if importlib.util.find_spec(modname) is None:
            continue
        importlib.import_module(modname).add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        return int(args.run(args) or 0)
    except ValueError as exc:  # bad input: a clear message, no traceback
        print(f"magsoft {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
