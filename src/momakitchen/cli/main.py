"""Entry point of the ``momakitchen`` console script.

Each subcommand lives in its own module exposing ``add_parser(subparsers)`` (which sets
``func`` on its parser) so that the list below is the single place commands are registered.
Every user error becomes one line on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from momakitchen import __version__
from momakitchen.errors import MomaError

# Module names under momakitchen.cli, in the order they appear in --help.
COMMANDS = ("demo", "robots", "scene", "label", "generate", "dataset", "learn", "msr",
            "benchmark", "predict")


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are a single line with exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="momakitchen",
        description="Affordance-grounded last-mile navigation for mobile manipulation.",
    )
    parser.add_argument("--version", action="version", version=f"momakitchen {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        importlib.import_module(f"momakitchen.cli.{name}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # usage errors (status 2) and --help / --version (0)
        return int(exc.code or 0)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    try:
        from momakitchen.robots.user import ENV_VAR, load_env_robots

        if os.environ.get(ENV_VAR):  # user robots are available to every command
            load_env_robots()
        return int(args.func(args) or 0)
    except MomaError as exc:
        print(f"momakitchen {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"momakitchen {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
