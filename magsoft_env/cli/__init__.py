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


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (``magsoft solve: error: ...``), exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {_one_line(message)} (see {self.prog} --help)\n")


def _one_line(text) -> str:
    return " ".join(str(text).split())


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
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
    """Run one command; returns the exit status (2 for bad input, with a one-line message and no traceback)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or a bad flag (2, message already printed)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    try:
        return int(args.run(args) or 0)
    except ValueError as exc:  # bad input: a clear message, no traceback
        print(f"magsoft {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that cannot be read or written (checked up front where possible)
        where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
        print(f"magsoft {args.command}: error: cannot access{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
