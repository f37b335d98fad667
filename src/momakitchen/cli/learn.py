"""``momakitchen train`` and ``momakitchen evaluate``: models on a generated dataset.

``train`` fits a model on the dataset's train split (scenes unseen at test time) and
writes a run directory: ``config.json``, ``model.safetensors``, the trainer state, a CSV
log and ``loss_curve.png``. Under ``torchrun`` it trains with DDP (gloo on CPU).
``evaluate`` computes the map metrics of a run on the test split, prints a table like the
paper's Table 2 and writes them (with per-robot and per-scene breakdowns) as JSON.
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from momakitchen.cli.common import (
    checked_run_dir,
    non_negative_float,
    non_negative_int,
    output_file,
    positive_int,
)
from momakitchen.cli.options import (
    add_checkpoint,
    add_data,
    add_quiet,
    add_results_json,
    add_robot_yaml,
    add_split,
)
from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_text, dumps_strict, existing_dir

if TYPE_CHECKING:
    from momakitchen.train.config import TrainConfig

# The registries' names, spelled out so that building the parser (``momakitchen --help``)
# does not import torch; tests/cli/test_main.py checks them against the registries.
MODEL_NAMES = (
    "navaff",
    "pointnet2",
    "votenet",
    "h3dnet",
    "navaff-no-robot",
    "navaff-no-vam",
    "navaff-no-global",
)
PRESET_NAMES = ("paper", "cpu")

EVALUATE_DESCRIPTION = (
    "Map metrics of a trained model (a run directory written by `momakitchen train`; "
    "without --checkpoint or --predictions, the bundled model) on a "
    "split of a dataset, the test split by default: RMSE, logMSE, PCC, SIM, MAE, cosine and "
    "cIoU, printed as a table like the paper's Table 2 and written with per-robot and "
    "per-scene breakdowns as JSON. Every shard read is checked first."
)

TRAIN_CONFIG_HELP = """\
training options come from, highest precedence first:
  1. command-line options given explicitly (--model, --epochs, --lambda-zero, ...);
  2. the --config FILE (YAML or JSON): any subset of the training config's fields, e.g.
       model: navaff
       epochs: 3
       lr: 5.0e-4
       model_config: {embed_dim: 64, num_tokens: 16}
     (model_config fields not given keep the preset's values);
  3. the preset: --preset, else the file's 'preset', else cpu.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    tr = sub.add_parser(
        "train",
        help="train a model (navaff, baselines, ablations)",
        description=__doc__,
        epilog=TRAIN_CONFIG_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    tr.add_argument(
        "--data",
        required=True,
        action="append",
        help="dataset directory (momakitchen generate); repeat to train on the train "
        "splits of several as one (e.g. a new robot's data beside the data a run started "
        "from, so that a fine-tune keeps what it knew)",
    )
    tr.add_argument(
        "--model",
        default=None,
        help=f"model name: {', '.join(MODEL_NAMES)}, an installed plug-in's name or "
        "package.module:ClassName (docs/METHODS.md; required unless the --config file "
        "sets 'model')",
    )
    tr.add_argument("--out", required=True, help="run directory")
    tr.add_argument(
        "--config",
        default=None,
        metavar="FILE",
        help="YAML or JSON file of training config fields (explicit options "
        "override it; see below)",
    )
    tr.add_argument(
        "--preset",
        default=None,
        choices=PRESET_NAMES,
        help="hyper-parameter preset (default: the --config file's, else cpu: trains on 2 cores)",
    )
    tr.add_argument("--epochs", type=positive_int, default=None)
    tr.add_argument("--batch-size", type=positive_int, default=None)
    tr.add_argument(
        "--max-steps",
        type=non_negative_int,
        default=None,
        help="stop after this many optimiser steps (0: no limit)",
    )
    tr.add_argument(
        "--workers", type=non_negative_int, default=None, help="DataLoader worker processes"
    )
    tr.add_argument(
        "--threads",
        type=non_negative_int,
        default=None,
        help="torch threads per process (0: torch's default)",
    )
    tr.add_argument("--seed", type=non_negative_int, default=None)
    tr.add_argument(
        "--lambda-zero",
        type=non_negative_float,
        default=None,
        help="loss weight on zero-valued labels (the paper's lambda; preset 0.7)",
    )
    tr.add_argument(
        "--sensor-noise",
        action="store_true",
        default=None,
        help="train on the frames as real depth sensors, segmenters and calibrations would "
        "give them (random per sample and epoch; the data stay clean)",
    )
    tr.add_argument(
        "--init",
        default=None,
        metavar="RUN",
        help="start from this run's weights (fine-tuning; 'bundled', 'body': a shipped model)",
    )
    tr.add_argument(
        "--checkpoint-minutes",
        type=non_negative_float,
        default=None,
        help="also write the checkpoint this often within an epoch, for --resume to go on "
        "from (default 20; 0: only at epoch ends)",
    )
    tr.add_argument("--resume", action="store_true", help="continue the run in --out")
    add_quiet(tr)
    add_robot_yaml(tr)
    tr.set_defaults(func=run_train)

    ev = sub.add_parser(
        "evaluate",
        help="map metrics of a trained model on the test split",
        description=EVALUATE_DESCRIPTION,
    )
    add_data(ev)
    which = ev.add_mutually_exclusive_group()
    add_checkpoint(which)
    which.add_argument(
        "--predictions",
        metavar="FILE",
        help="a method's maps of every episode of the split (.npz or .h5, docs/METHODS.md)",
    )
    ev.add_argument(
        "--name", default=None, help="the --predictions method's name (default: the file's stem)"
    )
    add_results_json(ev)
    add_split(ev)
    ev.add_argument(
        "--model", default=None, help="expected model name (refuses a checkpoint of another model)"
    )
    ev.add_argument("--batch-size", type=positive_int, default=8)
    add_quiet(ev)
    add_robot_yaml(ev)
    ev.set_defaults(func=run_evaluate)


def _dataset(root: str, split: str):
    """The episodes of ``split``, once every shard they come from has passed the quick
    check and its checksum (so a missing or damaged shard is found before any training or
    evaluation: both read every byte of these shards anyway)."""
    from momakitchen.data import EpisodeDataset
    from momakitchen.data.integrity import check_shard_files

    data = EpisodeDataset(existing_dir(root, "dataset directory"), split)
    if len(data) == 0:
        raise MomaError(_no_episodes(root, split, data.manifest))
    check_shard_files(
        root, data.manifest, {sid for _, sid, _, _, _ in data.index}, verify_hash=True
    )
    return data


def _train_data(roots: list[str]):
    """The train split of one dataset, or of several read as one (each checked as
    :func:`_dataset` checks it); the same directory twice is an error."""
    from momakitchen.data import EpisodeDatasets

    seen: dict[Path, str] = {}
    for root in roots:
        key = Path(root).resolve()
        if key in seen:
            raise MomaError(f"--data {root!r} is given twice (as {seen[key]!r} before)")
        seen[key] = root
    parts = [_dataset(root, "train") for root in roots]
    return parts[0] if len(parts) == 1 else EpisodeDatasets(parts)


def _no_episodes(root: str, split: str, manifest: dict) -> str:
    """Why a dataset has no episodes of ``split``, and what to do about it."""
    from momakitchen.cli.wording import counted
    from momakitchen.data.manifest import scenes_for_both_splits

    scenes = sorted(int(k) for k in manifest["shards"])
    text = f"dataset {root!r} has no {split} episodes"
    if not scenes:
        return f"{text}: it holds no scene yet (run `momakitchen generate` to finish it)"
    splits = {manifest["shards"][str(s)]["split"] for s in scenes}
    if split in splits or split == "all":
        return f"{text} (every view of its {split} scenes lacks floor or global points)"
    first = scenes[0]
    return (
        f"{text}: its {counted(len(scenes), 'scene')} {'is' if len(scenes) == 1 else 'are'} "
        f"all {'/'.join(sorted(splits))} scenes "
        f"(one scene id in 5 is a test scene); `momakitchen generate --scenes "
        f"{scenes_for_both_splits(first)}` or more from scene {first} gives both splits"
    )


def train_config(args: argparse.Namespace) -> TrainConfig:
    """The training config of ``momakitchen train``: the preset, updated by the --config
    file, updated by the options given explicitly (see ``TRAIN_CONFIG_HELP``)."""
    from momakitchen import codec
    from momakitchen.models import get_model_entry
    from momakitchen.train import PRESETS, TrainConfig, preset_config

    if args.model is not None:  # a built-in, or a plug-in found and imported now
        get_model_entry(args.model)
    file = codec.read_config_file(args.config) if args.config else {}
    model = args.model if args.model is not None else file.get("model")
    if model is None:
        raise MomaError("the model is not given: pass --model or set 'model' in --config")
    preset = args.preset if args.preset is not None else file.get("preset", "cpu")
    # A preset's values under the file's; a 'custom' preset starts from the defaults.
    base = preset_config(preset if preset in PRESETS else "paper", "navaff")
    data = codec.merge(codec.to_dict(base), {**file, "model": model, "preset": preset})
    try:
        config = codec.from_dict(TrainConfig, data)
    except MomaError as exc:
        raise MomaError(f"{args.config}: {exc}" if args.config else str(exc)) from None
    overrides = {
        name: value
        for name, value in (
            ("epochs", args.epochs),
            ("batch_size", args.batch_size),
            ("max_steps", args.max_steps),
            ("num_workers", args.workers),
            ("num_threads", args.threads),
            ("seed", args.seed),
            ("progress", False if args.quiet else None),
            ("sensor_noise", args.sensor_noise),
            ("init", args.init),
            ("checkpoint_minutes", args.checkpoint_minutes),
        )
        if value is not None
    }
    if overrides:
        config = config.replace(**overrides)
    if args.lambda_zero is not None:
        config = config.replace_model(lambda_zero=args.lambda_zero)
    return config


def run_train(args: argparse.Namespace) -> int:
    from momakitchen.cli.common import planned_output_dir
    from momakitchen.train import train

    planned_output_dir(args.out)  # a file or an impossible place fails before any work
    if args.resume:
        from momakitchen.train.checkpoint import require_checkpoint

        require_checkpoint(args.out)
    config = train_config(args)
    data = _train_data(args.data)
    _probe_plugin(config, data)
    result = train(config, data, None, Path(args.out), resume=args.resume)
    if result.stopped_by:
        print(
            f"momakitchen train: stopped by {result.stopped_by} at step {result.global_step}, "
            f"checkpoint written: continue with --resume -> {args.out}",
            file=sys.stderr,
        )
        return 128 + signal.Signals[result.stopped_by].value  # the shell's convention
    last = result.history[-1] if result.history else {}
    print(
        f"trained {config.model} ({config.preset} preset) on {len(data)} episodes: "
        f"{result.global_step} steps, last epoch loss {last.get('loss', float('nan')):.4f}"
        f" -> {args.out}"
    )
    return 0


def _probe_plugin(config: TrainConfig, data) -> None:
    """A plug-in model runs once on two training episodes, so that one that does not
    follow the interface fails in one line before the run directory is written."""
    from momakitchen.data.batch import EpisodeCollator
    from momakitchen.models.plugins import probe_plugin
    from momakitchen.models.registry import build_model, is_plugin

    if is_plugin(config.model):
        collate = EpisodeCollator(config.num_global, config.num_floor, config.seed)
        batch = collate([data[i] for i in range(min(2, len(data)))])
        probe_plugin(config.model, build_model(config.model, config.model_config), batch)


def run_evaluate(args: argparse.Namespace) -> int:
    from momakitchen.eval.evaluate import evaluate
    from momakitchen.train import load_checkpoint

    if args.predictions is not None:
        if args.model is not None:
            raise MomaError("--model checks a --checkpoint; a --predictions file has none")
        return _evaluate_predictions(args)
    if args.name is not None:
        raise MomaError("--name names a --predictions file; a checkpoint's name is its model")
    if args.checkpoint is None:  # as msr and robustness: the bundled model
        from momakitchen.train.checkpoint import default_checkpoint

        run_dir = default_checkpoint()
    else:
        run_dir = checked_run_dir(args.checkpoint)
    out = output_file(args.json)  # an unwritable --json fails now, not after the work
    load_checkpoint(run_dir, model=args.model)  # fails early on a checkpoint of another model
    data = _dataset(args.data, args.split)
    report = evaluate(run_dir, data, batch_size=args.batch_size, progress=not args.quiet)
    report = {"data": str(args.data), "split": args.split, "checkpoint": str(run_dir), **report}
    _write_report(report, out, args.split)
    return 0


def _evaluate_predictions(args: argparse.Namespace) -> int:
    from momakitchen.eval.evaluate import evaluate_predictions
    from momakitchen.fileio import existing_file

    existing_file(args.predictions, "predictions file")
    out = output_file(args.json)
    data = _dataset(args.data, args.split)
    report = evaluate_predictions(args.predictions, data, args.name, progress=not args.quiet)
    _write_report({"data": str(args.data), "split": args.split, **report}, out, args.split)
    return 0


def _write_report(report: dict, out: Path, split: str) -> None:
    from momakitchen.metrics import format_table

    if out.parent and not out.parent.exists():
        out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, dumps_strict(report, indent=1, default=float) + "\n")
    print(format_table({f"{report['model']} ({report['preset']})": report["metrics"]}))
    print(f"{report['episodes']} {split} episodes -> {out}")
