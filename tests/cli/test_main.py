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


def test_help_and_version_import_nothing_heavy():
    """`momakitchen --help` and `--version` build every parser without torch (3 s), numpy
    or the simulator, so they answer in a fraction of a second."""
    code = (
        "import sys; from momakitchen.cli.main import main\n"
        "for argv in (['--help'], ['--version'], []):\n"
        "    main(argv)\n"
        "heavy = ('torch', 'numpy', 'h5py', 'scipy', 'pybullet', 'matplotlib', 'tqdm')\n"
        "print(sorted(m for m in heavy if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    from momakitchen.version import __version__

    assert f"momakitchen {__version__}" in out and "train" in "\n".join(out)
    assert out[-1] == "[]"


def test_names_spelled_out_for_the_parsers_match_the_registries():
    """The parsers list model, preset, split, start and policy names (and the demo's
    default scene) without importing their modules; they must be those modules' values
    (the baselines come from the light momakitchen.eval.methods itself)."""
    from momakitchen.cli import approach, demo, learn, options
    from momakitchen.data.manifest import SPLIT_CHOICES
    from momakitchen.deploy.fusion import POLICIES
    from momakitchen.eval.approach.config import MAPS, STARTS
    from momakitchen.eval.methods import CLASSICAL
    from momakitchen.generation.demo import DEFAULT_SCENE_ID
    from momakitchen.models import model_names
    from momakitchen.placement.methods import CLASSICAL_METHODS
    from momakitchen.train import PRESETS

    assert learn.MODEL_NAMES == model_names()
    assert learn.PRESET_NAMES == tuple(PRESETS)
    assert options.SPLIT_CHOICES == SPLIT_CHOICES
    assert (approach.STARTS, approach.POLICIES, approach.MAPS) == (STARTS, POLICIES, MAPS)
    assert demo.DEFAULT_SCENE_ID == DEFAULT_SCENE_ID
    assert CLASSICAL == CLASSICAL_METHODS


def test_a_reader_that_goes_away_is_no_traceback():
    """`momakitchen robots | head -0`: the pipe closes before the table is written; the
    command stops quietly with the status of a tool ended by SIGPIPE."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "momakitchen.cli.main", "robots"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # before the interpreter has even started
    err = proc.stderr.read().decode()
    assert proc.wait() == 141 and "Traceback" not in err, err
