"""Entry point of the ``momakitchen`` console script.

Each subcommand lives in a module exposing ``add_parser(subparsers)`` (which sets ``func``
on its parser); the table below is the single place commands are registered. Only the
module of the command being run is imported, and no ``add_parser`` imports torch, the
simulator or a registry that does: ``momakitchen --help`` and ``--version`` build every
parser and answer in a fraction of a second (tests/cli/test_main.py checks it).
Every user error becomes one line on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from momakitchen.errors import MomaError
from momakitchen.version import __version__

# Command -> the module under momakitchen.cli that defines it, in the order of --help.
COMMANDS = {
    "demo": "demo",
    "robots": "robots",
    "scene": "scene",
    "label": "label",
    "generate": "generate",
    "check": "dataset",
    "stats": "dataset",
    "export-reference": "dataset",
    "import-reference": "dataset",
    "train": "learn",
    "evaluate": "learn",
    "export-inputs": "export_inputs",
    "msr": "msr",
    "approach": "approach",
    "robustness": "robustness",
    "robot-check": "robot_check",
    "audit": "audit",
    "benchmark": "benchmark",
    "predict": "predict",
    "serve": "serve",
}


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are a single line with exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command-line parser; with a known ``command``, only that command's module is
    imported (its parser is the one argparse will use), otherwise all of them."""
    parser = _Parser(
        prog="momakitchen",
        description="Affordance-grounded last-mile navigation for mobile manipulation.",
    )
    parser.add_argument("--version", action="version", version=f"momakitchen {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    modules = [COMMANDS[command]] if command in COMMANDS else dict.fromkeys(COMMANDS.values())
    for name in modules:
        importlib.import_module(f"momakitchen.cli.{name}").add_parser(sub)
    return parser


def register_user_robots(args: argparse.Namespace) -> None:
    """Register the user robots of MOMAKITCHEN_ROBOT_YAML (for every command) and of the
    command's ``--robot-yaml`` options (every command that takes a robot has one)."""
    from momakitchen.robots.user import ENV_VAR, load_env_robots, register_user_robots

    if os.environ.get(ENV_VAR):
        load_env_robots()
    for path in [*getattr(args, "robot_yaml", []), *getattr(args, "robot_yaml_sub", [])]:
        register_user_robots(path)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    # The command is the first word that is not an option (the top level has no option
    # that takes a value).
    parser = build_parser(next((a for a in argv if not a.startswith("-")), None))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors (status 2) and --help / --version (0)
        return int(exc.code or 0)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    out = getattr(args, "out", None)
    fresh_out = out if isinstance(out, str) and not os.path.lexists(out) else None
    status = _run(args)
    if status != 0 and fresh_out is not None:
        _remove_if_empty(fresh_out)
    return status


def _run(args: argparse.Namespace) -> int:
    """Run the parsed command; user errors become one line and a status."""
    from momakitchen.fileio import DISK_FULL

    try:
        register_user_robots(args)
        return int(args.func(args) or 0)
    except MomaError as exc:
        print(f"momakitchen {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # The reader went away (`momakitchen stats DIR | head -1`): stop quietly, as other
        # tools do; stdout goes to /dev/null so that the exit's flush cannot fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141  # 128 + SIGPIPE, the status a shell shows for such a tool
    except OSError as exc:
        # A full disk in a writer that does not report it itself (a figure, a library):
        # the user's problem too, not a traceback.
        if exc.errno not in DISK_FULL:
            raise
        where = f" writing {exc.filename!r}" if exc.filename else ""
        print(
            f"momakitchen {args.command}: error: {os.strerror(exc.errno)}{where}; "
            "free some space or write elsewhere",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print(f"momakitchen {args.command}: interrupted", file=sys.stderr)
        return 130


def _remove_if_empty(path: str) -> None:
    """Remove ``path`` (an --out this failed run created) if nothing is left in it: a
    failed run leaves no empty directory, whichever step failed."""
    try:
        os.rmdir(path)  # only ever removes an empty directory
    except OSError:
        pass


if __name__ == "__main__":
    sys.exit(main())
