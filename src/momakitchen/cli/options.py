"""The options several commands take, each declared here once: its flag, type, default,
help and choices. A command adds them with the ``add_*`` functions below and builds its
config from them with :func:`config_fields` (the option's ``dest`` is the config field's
name), so no command declares, converts or threads one of them by hand;
tests/cli/test_options.py checks that every command's copy is this one.

Range checks live in the configs (``MsrConfig``, ``RobustnessConfig``, ``ApproachConfig``,
``MotionConfig``, ``PredictOptions``, ...), which name the bad value; the types here only
check that a number parses (and its sign, in :mod:`momakitchen.cli.common`'s wording).

Building a parser must not import numpy or torch (``momakitchen --help`` answers in a
fraction of a second, tests/cli/test_main.py), and the configs' modules import both: the
defaults below are theirs, spelled out, and tests/cli/test_options.py checks each against
its config's field.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from momakitchen.cli.common import non_negative_float, non_negative_int, positive_int
from momakitchen.eval.methods import BASELINES, CLASSICAL

# momakitchen.data.manifest.SPLIT_CHOICES (that module imports numpy).
SPLIT_CHOICES = ("train", "test", "all")
# The configs' defaults: MsrConfig / RobustnessConfig / ApproachConfig (split, seed,
# max_configs), MsrConfig / RobustnessConfig / PredictOptions (top_k, min_spread,
# pick_radius) and PredictOptions (mc_samples).
SPLIT = "test"
SEED = 0
MAX_CONFIGS = 0
MSR_TOP_K = 5
ROBUSTNESS_TOP_K = 1
PREDICT_TOP_K = 5
MIN_SPREAD = 0.2
PICK_RADIUS = 0.0
MC_SAMPLES = 8


class Option:
    """One option as every command that takes it declares it (``argparse`` keywords)."""

    def __init__(self, flag: str, **kwargs: Any) -> None:
        self.flag = flag
        self.kwargs = kwargs

    @property
    def dest(self) -> str:
        return str(self.kwargs.get("dest", self.flag.lstrip("-").replace("-", "_")))

    def add(self, parser: Any, **default: Any) -> argparse.Action:
        """Add the option to ``parser`` (a parser or an argument group); ``default`` is
        only for an option whose default is its command's (:data:`PER_COMMAND_DEFAULT`)."""
        if default and self.flag not in PER_COMMAND_DEFAULT:
            raise TypeError(f"{self.flag} has one default for every command")
        return parser.add_argument(self.flag, **{**self.kwargs, **default})


DATA = Option("--data", required=True, help="dataset directory (momakitchen generate)")
RESULTS_JSON = Option("--json", required=True, help="where to write the results (JSON)")
SPLIT_OPTION = Option(
    "--split",
    default=SPLIT,
    choices=SPLIT_CHOICES,
    help="the dataset's split to read (%(default)s; all: both)",
)
SEED_OPTION = Option(
    "--seed",
    type=non_negative_int,
    default=SEED,
    help="seeds the view judged per configuration (the same seed picks the same view in "
    "every command) and the random baseline (%(default)s)",
)
MAX_CONFIGS_OPTION = Option(
    "--max-configs",
    type=non_negative_int,
    default=MAX_CONFIGS,
    help="only the first N configurations (%(default)s: all)",
)
TOP_K = Option(
    "--top-k",
    type=positive_int,
    help="base poses picked per method and view, best first (%(default)s)",
)
MIN_SPREAD_OPTION = Option(
    "--min-spread",
    type=non_negative_float,
    default=MIN_SPREAD,
    help="minimum distance between the Top-k poses (m, %(default)g)",
)
PICK_RADIUS_OPTION = Option(
    "--pick-radius",
    type=non_negative_float,
    default=PICK_RADIUS,
    help="rank the poses by the map averaged over this radius (m; default %(default)g: the "
    "raw map)",
)
MC_SAMPLES_OPTION = Option(
    "--mc-samples",
    type=non_negative_int,
    default=MC_SAMPLES,
    help="MC-dropout passes for the uncertainty (%(default)s; 0: none)",
)
RELATIVE_DEPTH = Option(
    "--relative-depth",
    dest="metric_depth",
    action="store_false",
    help="the depth is known only up to scale (a monocular depth network): the "
    "calibrated camera height fixes the scale, read from the floor",
)
OPENS = Option(
    "--opens",
    action="store_true",
    help="the robot will open the target (a door's or a drawer's handle), not pick it up: "
    "a model that weighs the arm's dexterity for picks only (--checkpoint body) leaves it off",
)
QUIET = Option("--quiet", action="store_true", help="no progress bars")
ROBOT_YAML = Option(
    "--robot-yaml",
    action="append",
    default=[],
    metavar="FILE",
    help="register a user robot (URDF + YAML, see `momakitchen robots`) first; a directory: "
    "each of its *.yaml files; repeatable",
)
CHECKPOINT = Option(
    "--checkpoint",
    default=None,
    metavar="RUN",
    help="run directory written by `momakitchen train`, or a shipped model: 'bundled' (the "
    "default) or 'body' (it reads the robot's reachability)",
)
CHECKPOINTS = Option(
    "--checkpoint",
    action="append",
    default=[],
    metavar="RUN",
    help="run directory of a trained model, or 'bundled' or 'body' (shipped; repeatable; with "
    "no method given: the bundled model)",
)
BASELINE = Option(
    "--method",
    action="append",
    default=[],
    metavar="METHOD",
    help=f"baseline ({', '.join(BASELINES)}) or classical base placement "
    f"({', '.join(CLASSICAL)}; docs/PLACEMENT.md), repeatable",
)
METHOD_NAMES = Option(
    "--name",
    action="append",
    default=[],
    metavar="NAME",
    help="the name of each --predictions method, in order (default: the file's stem)",
)

# Every option declared here, and those whose default is their command's (each pinned to
# its command's config by tests/cli/test_options.py).
OPTIONS = (
    DATA,
    RESULTS_JSON,
    SPLIT_OPTION,
    SEED_OPTION,
    MAX_CONFIGS_OPTION,
    TOP_K,
    MIN_SPREAD_OPTION,
    PICK_RADIUS_OPTION,
    MC_SAMPLES_OPTION,
    RELATIVE_DEPTH,
    OPENS,
    QUIET,
    ROBOT_YAML,
    CHECKPOINT,
    CHECKPOINTS,
    BASELINE,
    METHOD_NAMES,
)
PER_COMMAND_DEFAULT = ("--top-k",)


def add_data(parser: Any, required: bool = True) -> None:
    """``--data DIR``: the dataset a command reads (required unless the command says
    when it is not)."""
    DATA.add(parser).required = required


def add_results_json(parser: Any) -> None:
    """``--json FILE``: where a command writes its results (required)."""
    RESULTS_JSON.add(parser)


def add_split(parser: Any) -> None:
    """``--split``: which split of the dataset."""
    SPLIT_OPTION.add(parser)


def add_seed(parser: Any) -> None:
    """``--seed``: the view judged per configuration and the random baseline."""
    SEED_OPTION.add(parser)


def add_max_configs(parser: Any) -> None:
    """``--max-configs N``: only the first N configurations."""
    MAX_CONFIGS_OPTION.add(parser)


def add_selection(parser: Any) -> None:
    """Which configurations and views: ``--split``, ``--max-configs`` and ``--seed``."""
    add_split(parser)
    add_max_configs(parser)
    add_seed(parser)


def add_picking(parser: Any, top_k: int) -> None:
    """How poses are picked from a map: ``--top-k`` (``top_k`` by default: the command's
    config's), ``--min-spread`` and ``--pick-radius``."""
    TOP_K.add(parser, default=top_k)
    MIN_SPREAD_OPTION.add(parser)
    PICK_RADIUS_OPTION.add(parser)


def add_prediction(parser: Any) -> None:
    """The options of a prediction on a robot's frame (``PredictOptions``): the picking
    options, ``--mc-samples``, ``--relative-depth`` and ``--opens``."""
    add_picking(parser, PREDICT_TOP_K)
    MC_SAMPLES_OPTION.add(parser)
    RELATIVE_DEPTH.add(parser)
    OPENS.add(parser)


def add_quiet(parser: Any) -> None:
    """``--quiet``: no progress bars."""
    QUIET.add(parser)


def add_robot_yaml(parser: Any, dest: str = "robot_yaml") -> None:
    """``--robot-yaml FILE`` (repeatable) on a command that takes a robot; the entry point
    registers the files' robots before the command runs (as MOMAKITCHEN_ROBOT_YAML does).
    A subcommand's parser stores them under another ``dest`` (its defaults would
    otherwise replace its parent's list)."""
    parser.add_argument(ROBOT_YAML.flag, **{**ROBOT_YAML.kwargs, "dest": dest})


def add_checkpoint(parser: Any, repeatable: bool = False) -> None:
    """``--checkpoint RUN``: one model, or (``repeatable``) the models a track compares."""
    (CHECKPOINTS if repeatable else CHECKPOINT).add(parser)


def add_baselines(parser: Any) -> None:
    """``--method METHOD`` (repeatable): the baselines and classical methods a track
    scores."""
    BASELINE.add(parser)


def add_method_names(parser: Any) -> None:
    """``--name NAME`` (repeatable): the name of each ``--predictions`` file's method."""
    METHOD_NAMES.add(parser)


def config_fields(args: argparse.Namespace, config: type) -> dict[str, Any]:
    """The values of the options declared here that ``args`` holds and that are fields of
    the dataclass ``config``, by field name: ``Config(**config_fields(args, Config))``."""
    dests = {option.dest for option in OPTIONS}
    return {
        f.name: getattr(args, f.name)
        for f in dataclasses.fields(config)
        if f.name in dests and hasattr(args, f.name)
    }
