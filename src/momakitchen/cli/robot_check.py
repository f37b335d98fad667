"""``momakitchen robot-check``: does the bundled model serve my robot?

Makes a few kitchens labelled for ROBOT alone (``generate --robot ROBOT``), runs the model
(default: the bundled one), the oracle and random on them in closed loop (``msr``, Top-1:
the base placed on the model's pick from one view, the labelling's trial run in physics),
and prints the model's gap to the oracle with a 95 % interval and a verdict: it *serves*
the robot when the whole interval lies within ``--tolerance`` points of the oracle, it
does *not* when all of it lies beyond, otherwise more scenes are needed. On its own six
robots the bundled model is 3.4 points below the oracle (85.3 against 88.7 % on 600 test
configurations, docs/RESULTS.md).

With ``--finetune-scenes N`` it then makes N more scenes for the robot (their train
split), fine-tunes the model on them (``train --init``: two epochs at a quarter of the
learning rate; ``--train-config`` overrides) and checks again on the same configurations.

Everything goes under ``--out``: ``data/`` (the check's scenes), ``check.json``,
``train-data/``, ``finetuned/`` (a run directory ``--checkpoint`` takes) and
``check-finetuned.json``. A killed check resumes there: run the same command again.

    momakitchen robot-check myarm --robot-yaml myarm.yaml --out check-myarm
    momakitchen robot-check myarm --robot-yaml myarm.yaml --out check-myarm --finetune-scenes 20
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from momakitchen.cli.common import non_negative_float, non_negative_int, positive_int, scene_id
from momakitchen.cli.options import add_checkpoint, add_quiet, add_robot_yaml, add_seed
from momakitchen.errors import MomaError
from momakitchen.eval.methods import CLASSICAL

# Fine-tuning for one robot: the bundled model's recipe (the cpu preset), from its
# weights, two epochs at a quarter of the learning rate (as the real-sensor fine-tuning).
FINETUNE_RECIPE = {"preset": "cpu", "epochs": 2, "lr": 0.0002, "num_workers": 1}


def add_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser(
        "robot-check",
        help="does the bundled model serve my robot? its closed-loop gap to the oracle",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("robot", help="robot name (built in, or registered by --robot-yaml)")
    ap.add_argument(
        "--out", required=True, help="working directory (scenes, results, fine-tuned run)"
    )
    ap.add_argument("--scenes", type=positive_int, default=6, help="scenes to check on (6)")
    ap.add_argument(
        "--first-scene-id",
        type=scene_id,
        default=900000,
        help="first scene id of the check (900000)",
    )
    ap.add_argument("--workers", type=positive_int, default=1, help="generation workers")
    add_checkpoint(ap)
    ap.add_argument(
        "--tolerance",
        type=non_negative_float,
        default=10.0,
        help="points below the oracle that still serve (10)",
    )
    add_seed(ap)
    ap.add_argument(
        "--config",
        metavar="FILE",
        help="generation options for the scenes (as `generate --config`)",
    )
    ap.add_argument(
        "--finetune-scenes",
        type=non_negative_int,
        default=0,
        metavar="N",
        help="then fine-tune on the train scenes of N more scenes for the robot, check again",
    )
    ap.add_argument(
        "--finetune-first-scene-id",
        type=scene_id,
        default=950000,
        help="first scene id of the fine-tuning scenes (950000)",
    )
    ap.add_argument(
        "--train-config",
        metavar="FILE",
        help="training options over the fine-tuning recipe (as `train --config`)",
    )
    add_robot_yaml(ap)
    add_quiet(ap)
    ap.set_defaults(func=run)


def _command(argv: list[str], log: Path, what: str) -> None:
    """Run another subcommand in this process, its printout appended to ``log`` (progress
    bars stay on stderr); its errors are this command's."""
    import contextlib

    from momakitchen.cli.main import build_parser

    print(what, flush=True)
    args = build_parser(argv[0]).parse_args(argv)
    with open(log, "a") as f, contextlib.redirect_stdout(f):
        print("$ momakitchen " + " ".join(argv), flush=True)
        status = args.func(args)
    if status:
        raise MomaError(f"`momakitchen {argv[0]}` stopped with status {status} (see {log})")


def _check_key(data: Path, checkpoint: str, seed: int) -> dict[str, Any]:
    """What a closed loop's result depends on: the dataset (its manifest), the model's
    weights and the seed."""
    import hashlib

    def digest(path: Path) -> str:
        return hashlib.sha256(path.read_bytes()).hexdigest()

    return {
        "manifest_sha256": digest(data / "manifest.json"),
        "checkpoint": checkpoint,
        "weights_sha256": digest(Path(_run_dir(checkpoint)) / "model.safetensors"),
        "seed": seed,
    }


def _reuse(path: Path, key: dict[str, Any]) -> dict[str, Any] | None:
    """A check's msr result written before with this key, else None."""
    from momakitchen.fileio import read_json_object

    if not path.is_file():
        return None
    try:
        old = read_json_object(path)
    except MomaError:
        return None
    return old if old.get("check") == key else None


def _closed_loop(args: argparse.Namespace, data: Path, checkpoint: str, out: Path) -> dict:
    """msr Top-1 of the model, the oracle and random on every configuration of ``data``."""
    from momakitchen.eval.msr import MsrConfig, format_msr_table, run_msr
    from momakitchen.fileio import atomic_write_text, dumps_strict

    key = _check_key(data, checkpoint, args.seed)
    old = _reuse(out, key)
    if old is not None:
        return old
    who = "the model" if checkpoint == args.checkpoint else checkpoint
    print(
        f"closed loop on {data} ({who}, the oracle, random and the classical methods; msr, Top-1)",
        flush=True,
    )
    config = MsrConfig(top_k=1, seed=args.seed, split="all")
    # The classical methods show where geometry alone stands for this robot.
    methods = ["oracle", "random", *CLASSICAL]
    result = run_msr(data, [_run_dir(checkpoint)], methods, config, not args.quiet)
    with open(out.parent / "log.txt", "a") as f:
        f.write(format_msr_table(result) + "\n")
    result["check"] = key
    atomic_write_text(out, dumps_strict(result, indent=1) + "\n")
    return result


def _run_dir(checkpoint: str) -> str:
    from momakitchen.train.checkpoint import resolve_run_dir

    return str(resolve_run_dir(checkpoint))


def _finetune(args: argparse.Namespace, root: Path) -> str:
    """Make the fine-tuning scenes and train (or resume) the run; its directory."""
    from momakitchen.codec import read_config_file
    from momakitchen.fileio import atomic_write_text, dumps_strict, read_json_object

    data, run = root / "train-data", root / "finetuned"
    _generate(args, data, args.finetune_scenes, args.finetune_first_scene_id, "train")
    init = _run_dir(args.checkpoint)
    recipe = {**FINETUNE_RECIPE, "model": read_json_object(Path(init) / "config.json")["model"]}
    recipe["init"] = init
    if args.train_config:
        recipe.update(read_config_file(args.train_config))
    config = root / "finetune.json"
    atomic_write_text(config, dumps_strict(recipe, indent=1) + "\n")
    resume = ["--resume"] if (run / "model.safetensors").is_file() else []
    _command(
        ["train", "--data", str(data), "--out", str(run), "--config", str(config), *resume]
        + (["--quiet"] if args.quiet else []),
        root / "log.txt",
        f"fine-tuning {init} on {data} -> {run}",
    )
    return str(run)


def _generate(args: argparse.Namespace, out: Path, scenes: int, first: int, split: str) -> None:
    from momakitchen.cli.wording import counted

    _command(
        ["generate", "--out", str(out), "--scenes", str(scenes), "--first-scene-id", str(first)]
        + ["--robot", args.robot, "--workers", str(args.workers)]
        + (["--split", split] if split else [])
        + (["--config", args.config] if args.config else [])
        + (["--quiet"] if args.quiet else []),
        out.parent / "log.txt",
        f"labelling {counted(scenes, 'scene')} for {args.robot} in {out}"
        + (f" (their {split} split)" if split else ""),
    )


def run(args: argparse.Namespace) -> int:
    from momakitchen.eval.robot_check import check_summary, format_check, top1_outcomes
    from momakitchen.eval.stats import mcnemar
    from momakitchen.fileio import atomic_write_text, dumps_strict
    from momakitchen.robots.spec import get_robot_spec

    get_robot_spec(args.robot)  # an unknown robot fails here, before anything is written
    if args.checkpoint is None:
        args.checkpoint = "bundled"
    if not (Path(_run_dir(args.checkpoint)) / "config.json").is_file():
        raise MomaError(f"--checkpoint {args.checkpoint!r} is not a run directory")
    first, last = args.first_scene_id, args.first_scene_id + args.scenes - 1
    tune_first = args.finetune_first_scene_id
    tune_last = tune_first + args.finetune_scenes - 1
    if args.finetune_scenes and tune_first <= last and first <= tune_last:  # ranges overlap
        raise MomaError(
            f"the fine-tuning scenes {tune_first}-{tune_last} (--finetune-first-scene-id "
            f"{tune_first}, --finetune-scenes {args.finetune_scenes}) overlap the check's "
            f"scenes {first}-{last} (--first-scene-id {first}, --scenes {args.scenes}): a "
            "scene fine-tuned on must not be one of the check's scenes"
        )
    root = Path(args.out)
    root.mkdir(parents=True, exist_ok=True)
    data = root / "data"
    _generate(args, data, args.scenes, args.first_scene_id, "")
    tol = args.tolerance / 100
    before = _closed_loop(args, data, args.checkpoint, root / "check.json")
    name = next(iter(before["methods"]))  # the model: msr lists it before the baselines
    summary = check_summary(before, name, args.robot, tol, seed=args.seed)
    report: dict[str, Any] = {"before": summary}
    print(format_check(summary, f"{args.checkpoint} model"))
    if args.finetune_scenes:
        run_dir = _finetune(args, root)
        after = _closed_loop(args, data, run_dir, root / "check-finetuned.json")
        report["after"] = check_summary(
            after, next(iter(after["methods"])), args.robot, tol, seed=args.seed
        )
        print(format_check(report["after"], "fine-tuned model"))
        a = top1_outcomes(before, name)
        b = top1_outcomes(after, report["after"]["model"])
        only_after, only_before, p = mcnemar(b, a)
        report["mcnemar"] = {"only_finetuned": only_after, "only_before": only_before, "p": p}
        print(f"fine-tuned against before: {only_after} / {only_before}, McNemar p = {p:.3g}")
    atomic_write_text(root / "report.json", dumps_strict(report, indent=1) + "\n")
    print(f"-> {root / 'report.json'}")
    return 0
