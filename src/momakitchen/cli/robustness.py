"""``momakitchen robustness``: a model on the frames a real robot would give it.

For every configuration of a split, the view ``msr`` picks for the same seed is corrupted
as a real depth sensor, segmenter or calibration would (``--list`` names every
corruption and sensor preset), goes through the real-robot path (``predict``: the floor
plane fitted to the frame) and the model's Top-k base positions are tried in physics with
the labelling's own trial. The ``clean`` row is that view as ``msr`` scores it (the stored
episode): with the same ``--seed``, ``--min-spread`` and ``--pick-radius`` its Top-1 is
``msr``'s Top-1 MSR. Prints, per model and corruption, closed-loop Top-1 / Top-k,
PCC and SIM against the ground truth at the predicted floor points, views whose target
lies beyond the sensor's working range (apart, not as failures) and errors by cause;
writes them as JSON and, under ``--out``, ``robustness.png`` (one view under each
corruption) and ``robustness.md`` (the table). A method that runs elsewhere takes part
through ``export-inputs --robustness`` and ``--predictions`` (docs/METHODS.md).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from momakitchen.cli.common import checked_methods, output_file
from momakitchen.cli.options import (
    ROBUSTNESS_TOP_K,
    add_checkpoint,
    add_data,
    add_method_names,
    add_picking,
    add_quiet,
    add_results_json,
    add_robot_yaml,
    add_selection,
    config_fields,
)
from momakitchen.eval.methods import CLASSICAL
from momakitchen.fileio import atomic_write_bytes, atomic_write_text, dumps_strict, existing_dir


def add_parser(sub: argparse._SubParsersAction) -> None:
    rb = sub.add_parser(
        "robustness",
        help="closed-loop success and map metrics under real-sensor corruptions",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    # --list answers at once, like --help: --data, --json and --out are required otherwise.
    rb.add_argument(
        "--list", action=_ListAction, nargs=0, help="list the corruptions and sensors, and exit"
    )
    add_data(rb)
    add_checkpoint(rb, repeatable=True)
    rb.add_argument(
        "--predictions",
        action="append",
        default=[],
        metavar="FILE",
        help="a method's maps of every view of export-inputs --robustness (.npz or .h5, "
        "docs/METHODS.md; repeatable)",
    )
    add_method_names(rb)
    rb.add_argument(
        "--method",
        action="append",
        default=[],
        choices=CLASSICAL,
        help="a classical base-placement method scored beside the models (repeatable; "
        "docs/PLACEMENT.md)",
    )
    rb.add_argument(
        "--corruption",
        action="append",
        default=[],
        metavar="NAME",
        help="a corruption (repeatable; default: every one; 'clean' is always added first)",
    )
    add_results_json(rb)
    rb.add_argument("--out", required=True, help="directory for robustness.png and robustness.md")
    add_selection(rb)
    add_picking(rb, ROBUSTNESS_TOP_K)
    add_quiet(rb)
    add_robot_yaml(rb)
    rb.set_defaults(func=run)


class _ListAction(argparse.Action):
    """``--list``: print the corruptions and sensors and exit, before the required options
    are checked (as ``--help`` does)."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        print(corruption_list())
        parser.exit(0)


def corruption_list() -> str:
    """The corruptions and sensor presets, one line each."""
    from momakitchen.perception.sensors import CORRUPTIONS, SENSORS

    lines = ["corruptions:"]
    lines += [f"  {name:<14} {c.description}" for name, c in CORRUPTIONS.items()]
    lines.append("sensors (--corruption NAME uses the sensor of the same name):")
    for name, p in SENSORS.items():
        lo, hi = p.depth.range
        rng = "" if name == "ideal" else f", range {lo:g}-{hi:g} m"
        lines.append(f"  {name:<14} {p.camera}{rng}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from momakitchen.cli.common import output_dir, planned_output_dir
    from momakitchen.eval.robustness.tables import format_robustness_table, robustness_figure
    from momakitchen.eval.robustness.track import run_robustness
    from momakitchen.eval.robustness.views import RobustnessConfig
    from momakitchen.perception.sensors import CORRUPTIONS

    existing_dir(args.data, "dataset directory")
    predictions = checked_methods(args)
    out_json = output_file(args.json)
    planned_output_dir(args.out)
    names = list(args.corruption) or list(CORRUPTIONS)
    names = ["clean", *[n for n in names if n != "clean"]]
    config = RobustnessConfig(corruptions=tuple(names), **config_fields(args, RobustnessConfig))
    t0 = time.perf_counter()
    maps: dict = {}
    result = run_robustness(
        args.data,
        args.checkpoint,
        config,
        progress=not args.quiet,
        view_maps=maps,
        predictions=predictions,
        methods=args.method,
    )
    result["seconds"] = round(time.perf_counter() - t0, 1)
    table = format_robustness_table(result)
    out = output_dir(args.out)
    out_json.parent.mkdir(parents=True, exist_ok=True)
    # a target without a valid depth pixel has an infinite target_range: null in the JSON
    atomic_write_text(out_json, dumps_strict(result, indent=1, null_non_finite=True) + "\n")
    atomic_write_text(out / "robustness.md", "```\n" + table + "\n```\n")
    if maps and result["records"]:
        first = result["records"][0]
        title = (
            f"scene {first['scene_id']}, configuration {first['config_index']} "
            f"({first['target']}, {first['robot']}), view {first['episode_index']}: "
            f"{next(iter(result['models']))}'s map under each corruption"
        )
        views = first["views"][next(iter(result["models"]))]
        atomic_write_bytes(out / "robustness.png", robustness_figure(maps, title, views))
    print(table)
    print(f"{result['seconds']:.0f} s -> {out_json}, {out}")
    return 0
