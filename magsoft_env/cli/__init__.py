"""The ``magsoft`` command: one subcommand per module in this package."""

from __future__ import annotations

import argparse
import difflib
import importlib
import importlib.util
import re
import sys

from .. import __version__

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
    "export": "magsoft_env.cli.export",
    "batch": "magsoft_env.cli.batch",
    "field": "magsoft_env.cli.field",
    "fit": "magsoft_env.cli.fit",
    "fit-plan": "magsoft_env.cli.fit_plan",
    "replay": "magsoft_env.cli.replay",
}


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors print its own usage (a subcommand's, for a subcommand's flags) on
    stdout and one error line (``magsoft solve: error: ...``) on stderr, with exit status 2: stderr holds
    the error alone, so a script (or a test) reads exactly one line there."""

    #: subcommand name -> its parser (set on the top-level parser by :func:`build_parser`)
    commands: dict = {}

    def error(self, message):
        self.print_usage(sys.stdout)
        sys.stdout.flush()
        self.exit(2, f"{self.prog}: error: {_one_line(message)}{_choice_hint(message)} (see {self.prog} --help)\n")


def _one_line(text) -> str:
    return " ".join(str(text).split())


def _choice_hint(message: str) -> str:
    """``; did you mean 'x'?`` for argparse's "invalid choice: 'y' (choose from ...)" messages, else ''."""
    m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", str(message))
    if not m:
        return ""
    hint = difflib.get_close_matches(m.group(1), re.findall(r"'([^']*)'", m.group(2)), n=1, cutoff=0.5)
    return f"; did you mean {hint[0]!r}?" if hint else ""


def _unknown_flags_message(parser: argparse.ArgumentParser, extras: list[str]) -> str:
    """"unrecognized arguments: ..." with the closest flag of ``parser`` for each unknown one, if close."""
    known = {s.lstrip("-"): s for a in parser._actions for s in a.option_strings if s.startswith("--")}
    flags = [a.split("=", 1)[0] for a in extras if a.startswith("--")]
    hints = []
    for flag in flags:
        close = difflib.get_close_matches(flag.lstrip("-"), list(known), n=1, cutoff=0.75)
        if close:
            hints.append(known[close[0]] if len(flags) == 1 else f"{known[close[0]]} for {flag}")
    return f"unrecognized arguments: {' '.join(extras)}" + (f"; did you mean {', '.join(hints)}?" if hints else "")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="magsoft",
        description="Design and simulate centimetre-scale hard-magnetic soft robots.",
    )
    parser.add_argument("--version", action="version", version=f"magsoft_env {__version__}",
                        help="print the package version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for modname in COMMANDS.values():
        if importlib.util.find_spec(modname) is None:
            continue
        importlib.import_module(modname).add_parser(sub)
    parser.commands = dict(sub.choices)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns the exit status.

    Bad input (an unknown or malformed flag, a value out of range, an unknown preset or environment id,
    an output path that cannot be written) returns 2 before any work, after a one-line message on
    stderr that names the subcommand, never a traceback; errors in the flags themselves also print the
    subcommand's usage, on stdout. 0: done; 1: done, but something did not converge or the rod became
    unstable; 130: interrupted.
    """
    parser = build_parser()
    try:
        args, extras = parser.parse_known_args(argv)
        if extras:  # report unknown flags with the usage of the subcommand they were given to
            target = parser.commands.get(getattr(args, "command", None), parser)
            target.error(_unknown_flags_message(target, extras))
    except SystemExit as exc:  # argparse: --help / --version (0) or a bad flag (2, message already printed)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    if not getattr(args, "command", None):
        parser.print_usage(sys.stdout)
        print(f"magsoft: error: give a COMMAND ({', '.join(parser.commands)}) (see magsoft --help)", file=sys.stderr)
        return 2
    if "mujoco" not in sys.modules:
        from ..gl import missing_gl_library

        # MUJOCO_GL=osmesa/egl without its library: mujoco fails at import with a long traceback
        missing = missing_gl_library()
        if missing:
            print(f"magsoft {args.command}: error: {missing}", file=sys.stderr)
            return 2
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print(f"magsoft {args.command}: interrupted", file=sys.stderr)
        return 130
    except ValueError as exc:  # bad input: a clear message, no traceback
        print(f"magsoft {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that cannot be read or written (checked up front where possible)
        where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
        print(f"magsoft {args.command}: error: cannot access{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
