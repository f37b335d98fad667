"""One declaration per option: every command that takes an option of
:mod:`momakitchen.cli.options` takes that declaration (same help, default, type, choices),
no other module of the command line declares it again, its defaults are those of the
configs it sets, and the range checks are the configs' (one line, the bad value named)."""

from __future__ import annotations

import argparse
import ast
import dataclasses
import math
from pathlib import Path

import pytest

from momakitchen.cli import options
from momakitchen.cli.main import COMMANDS, build_parser, main

CLI = Path(options.__file__).parent

# Options that share a flag with one of options.py but mean something else: command ->
# flag -> why it is that command's own.
DISTINCT = {
    "train": {
        "--data": "several datasets' train splits read as one (repeatable)",
        "--seed": "the training seed, over the --config file's and the preset's",
    },
    "audit": {
        "--data": "an existing dataset instead of --scenes",
        "--json": "optional (OUT/audit.json by default)",
    },
    "generate": {"--split": "which split's scenes of the range to make"},
    "stats": {"--json": "print JSON instead of a table"},
    "robots": {"--json": "print JSON instead of a table"},
    "evaluate": {"--name": "the name of its one --predictions file"},
    "robustness": {"--method": "classical methods only: no baseline reads a frame"},
    "serve": {
        "--mc-samples": "a request's default, capped at the server's limit",
        "--method": "the one classical method served instead of a model",
    },
}
SHARED = {option.flag for option in options.OPTIONS}
# What an action is, as argparse shows and parses it.
ATTRIBUTES = ("nargs", "const", "default", "type", "choices", "required", "help", "metavar")


def _parsers() -> list[tuple[str, argparse.ArgumentParser]]:
    """Every command's parser, and those of its own subcommands (``robots export-urdf``)."""

    def subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
        return next(
            (dict(a.choices) for a in parser._actions if isinstance(a, argparse._SubParsersAction)),
            {},
        )

    out = []
    for command, parser in subparsers(build_parser()).items():
        out.append((command, parser))
        out += [(command, sub) for sub in subparsers(parser).values()]
    return out


def _shape(action: argparse.Action, same_default: bool = True) -> dict:
    shape = {name: getattr(action, name) for name in ATTRIBUTES}
    shape["class"] = type(action)
    if not same_default:
        del shape["default"]
    return shape


def _declared(option: options.Option) -> argparse.Action:
    return option.add(argparse.ArgumentParser(add_help=False))


def test_every_command_takes_the_one_declaration_of_a_shared_option():
    seen: dict[str, set[str]] = {}
    for command, parser in _parsers():
        for action in parser._actions:
            flag = next((f for f in action.option_strings if f.startswith("--")), None)
            if flag not in SHARED or flag in DISTINCT.get(command, {}):
                continue
            same = flag not in options.PER_COMMAND_DEFAULT
            shapes = [_shape(_declared(o), same) for o in options.OPTIONS if o.flag == flag]
            shape = _shape(action, same)
            if (command, flag) == ("approach", "--data"):  # not required with --merge
                assert not shape["required"]
                shape["required"] = True
            assert shape in shapes, (command, flag)
            if flag != "--robot-yaml":  # a subcommand's list has a dest of its own
                assert action.dest in {o.dest for o in options.OPTIONS if o.flag == flag}
            seen.setdefault(flag, set()).add(command)
    # Every option is used; all but predict's own are shared; the commands that declared
    # them each before take them.
    assert set(seen) == SHARED
    assert {flag for flag, commands in seen.items() if len(commands) < 2} == {
        "--mc-samples",
        "--relative-depth",
        "--opens",
    }
    for command in ("msr", "robustness", "approach", "export-inputs", "evaluate"):
        assert command in seen["--split"]
    for command in ("msr", "robustness", "predict"):
        assert command in seen["--top-k"] and command in seen["--pick-radius"]


def test_the_distinct_options_are_there():
    """Each exception above is a real option of its command (none is left stale)."""
    flags = {command: set() for command in DISTINCT}
    for command, parser in _parsers():
        if command in flags:
            flags[command] |= {f for a in parser._actions for f in a.option_strings}
    for command, named in DISTINCT.items():
        assert set(named) <= flags[command], command


def test_no_other_cli_module_declares_a_shared_option():
    """An AST scan: ``add_argument("--split", ...)`` appears in options.py only (and the
    distinct options in their own command's module)."""
    allowed: dict[str, set[str]] = {}
    for command, named in DISTINCT.items():
        allowed.setdefault(COMMANDS[command], set()).update(named)
    found = []
    for path in sorted(CLI.glob("*.py")):
        if path.name == "options.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if not (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "add_argument"
            ):
                continue
            for arg in node.args:
                if (
                    isinstance(arg, ast.Constant)
                    and arg.value in SHARED
                    and arg.value not in allowed.get(path.stem, set())
                ):
                    found.append(f"{path.name}:{node.lineno} {arg.value}")
    assert not found, found


def _defaults(command: str) -> dict:
    parser = dict(_parsers_by_command())[command]
    return {a.dest: a.default for a in parser._actions}


def _parsers_by_command() -> list[tuple[str, argparse.ArgumentParser]]:
    return [(c, p) for c, p in _parsers() if p.prog == f"momakitchen {c}"]


def _field_defaults(config: type) -> dict:
    out = {}
    for f in dataclasses.fields(config):
        if f.default is not dataclasses.MISSING:
            out[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            out[f.name] = f.default_factory()
    return out


def test_the_defaults_are_the_configs():
    """The defaults options.py and the commands spell out (the configs' modules import
    torch, which building a parser must not) are the configs' own."""
    from momakitchen.data.manifest import SPLIT_CHOICES
    from momakitchen.deploy.fusion import LookPolicy
    from momakitchen.deploy.options import PredictOptions
    from momakitchen.eval.approach.config import ApproachConfig
    from momakitchen.eval.audit import AuditConfig
    from momakitchen.eval.msr import MsrConfig
    from momakitchen.eval.report.benchmark import BenchmarkRequest
    from momakitchen.eval.robustness.views import RobustnessConfig
    from momakitchen.sim.motion import MotionConfig

    assert options.SPLIT_CHOICES == SPLIT_CHOICES
    picking = ("top_k", "min_spread", "pick_radius")
    selection = ("split", "max_configs", "seed")
    for command, config, names in (
        ("msr", MsrConfig, picking + selection),
        ("robustness", RobustnessConfig, picking + selection),
        ("export-inputs", RobustnessConfig, selection),
        ("approach", ApproachConfig, ("perception", "obstacle_min_points", *selection)),
        ("predict", PredictOptions, (*picking, "mc_samples", "metric_depth")),
    ):
        cli, fields = _defaults(command), _field_defaults(config)
        assert {n: cli[n] for n in names} == {n: fields[n] for n in names}, command
    assert _defaults("audit")["seed"] == AuditConfig().msr.seed
    assert _defaults("benchmark")["max_configs"] == _field_defaults(BenchmarkRequest)["max_configs"]
    approach, look, motion = _defaults("approach"), LookPolicy(), MotionConfig()
    assert (approach["max_looks"], approach["relook_distance"], approach["max_uncertainty"]) == (
        look.max_looks,
        look.relook_distance,
        look.max_uncertainty,
    )
    assert math.isclose(approach["stop_xy"], motion.stop_xy * 100)  # cm
    assert approach["stop_yaw"] == motion.stop_yaw
    assert math.isclose(approach["drift"], motion.drift_along * 100)  # %
    assert math.isclose(motion.drift_across, motion.drift_along / 2)  # "across: half of it"


def test_a_command_builds_its_config_from_the_shared_options():
    from momakitchen.deploy.options import PredictFields, PredictOptions
    from momakitchen.eval.approach.config import ApproachConfig
    from momakitchen.eval.msr import MsrConfig

    parser = build_parser("msr")
    args = parser.parse_args(["msr", "--data", "D", "--json", "J"])
    assert MsrConfig(**options.config_fields(args, MsrConfig)) == MsrConfig()
    argv = ["msr", "--data", "D", "--json", "J", "--top-k", "3", "--split", "all", "--seed", "7"]
    config = MsrConfig(**options.config_fields(parser.parse_args(argv), MsrConfig))
    assert (config.top_k, config.split, config.seed) == (3, "all", 7)
    # approach's own options (--stop-sweep, a flag here, a tuple there) are not taken
    args = build_parser("approach").parse_args(["approach", "--data", "D", "--json", "J"])
    fields = options.config_fields(args, ApproachConfig)
    assert fields == {"seed": 0, "split": "test", "max_configs": 0}
    argv = ["predict", "--out", "O", "--relative-depth", "--opens"]
    args = build_parser("predict").parse_args(argv)
    assert PredictOptions(**options.config_fields(args, PredictOptions)) == PredictOptions(
        metric_depth=False, opens=True
    )
    assert set(PredictFields.__annotations__) == {
        f.name for f in dataclasses.fields(PredictOptions)
    }


def test_an_option_has_one_default():
    with pytest.raises(TypeError, match="one default"):
        options.SEED_OPTION.add(argparse.ArgumentParser(), default=3)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--stop-xy", "60"], "MotionConfig.stop_xy must be in [0, 0.5], got 0.6"),
        (["--stop-yaw", "-1"], "MotionConfig.stop_yaw must be in [0, 45], got -1.0"),
        (["--drift", "nan"], "MotionConfig.drift_along must be in [0, 0.5], got nan"),
    ],
)
def test_approach_ranges_are_the_motion_configs(argv, message, tmp_path, capsys):
    out = tmp_path / "sub" / "a.json"
    code = main(["approach", "--data", str(tmp_path / "none"), "--json", str(out), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err, err
    assert not out.parent.exists()


def test_msr_and_predict_ranges_are_the_configs(tmp_path, capsys):
    json = str(tmp_path / "m.json")
    argv = ["msr", "--data", str(tmp_path), "--method", "oracle", "--json", json]
    assert main([*argv, "--top-k", "30"]) == 2
    assert "MsrConfig.top_k must be in [1, 20], got 30" in capsys.readouterr().err
    out = str(tmp_path / "p")
    assert main(["predict", "--robot", "panda", "--top-k", "60", "--out", out]) == 2
    err = capsys.readouterr().err.strip()
    assert "top_k must be in [1, 50], got 60" in err and "\n" not in err
    assert not Path(out).exists()
