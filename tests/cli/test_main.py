"""The command table: every command is registered once, by the module it names, and a
command's parser is built without importing the others (torch stays out of ``generate``)."""

import subprocess
import sys

from momakitchen.cli.main import COMMANDS, build_parser


def _commands(parser) -> list[str]:
    return list(parser._subparsers._group_actions[0].choices)


def test_table_matches_the_parsers():
    assert _commands(build_parser()) == list(COMMANDS)
    for command, module in COMMANDS.items():
        own = [c for c, m in COMMANDS.items() if m == module]
        assert _commands(build_parser(command)) == own


def test_unknown_command_builds_every_parser():
    assert _commands(build_parser("nonsense")) == list(COMMANDS)


def test_generate_does_not_import_torch():
    code = (
        "import sys; from momakitchen.cli.main import build_parser; "
        "build_parser('generate').parse_args(['generate', '--out', 'x', '--scenes', '1']); "
        "print('torch' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert out[-1] == "False"
