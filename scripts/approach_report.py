"""Merge approach runs of the same dataset and settings (e.g. baselines in one run, each
model in its own) and write their tables, and optionally the figure of one episode per
robot (replayed).

    python scripts/approach_report.py runs/a-baselines.json runs/a-bundled.json \
        --json runs/approach.json --markdown runs/approach.md --figure docs/img/approach.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

from script_cli import run_main

from momakitchen.fileio import (
    atomic_write_bytes,
    atomic_write_text,
    dumps_strict,
    read_json_object,
)


def main() -> None:
    from momakitchen.eval.approach.report import format_table, merge_results, report_markdown

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("runs", nargs="+", type=Path, help="`momakitchen approach --json` files")
    ap.add_argument("--json", type=Path, help="the merged result")
    ap.add_argument(
        "--compact",
        action="store_true",
        help="--json without the episodes' paths, unindented (for archiving)",
    )
    ap.add_argument("--markdown", type=Path)
    ap.add_argument("--figure", type=Path, help="one episode per robot (replays them)")
    ap.add_argument(
        "--checkpoint",
        action="append",
        default=[],
        help="the model runs of the figure's episodes, as given to `approach` (default: bundled)",
    )
    args = ap.parse_args()
    merged = merge_results([(str(p), read_json_object(p)) for p in args.runs])
    print(format_table(merged["results"]))
    if args.json:
        if args.compact:
            for r in merged["records"]:
                r.pop("path", None)
        text = dumps_strict(merged, indent=None if args.compact else 1)
        atomic_write_text(args.json, text + "\n")
    if args.markdown:
        atomic_write_text(args.markdown, report_markdown(merged))
    if args.figure:
        from momakitchen.data.config import Preprocessing
        from momakitchen.data.reader import dataset_generation
        from momakitchen.eval.approach.figure import episode_figure, figure_picks, replay
        from momakitchen.eval.approach.track import load_methods

        _, gen = dataset_generation(Path(merged["dataset"]))
        methods = load_methods(
            args.checkpoint or ["bundled"],
            [],
            Preprocessing(gen.cloud, gen.camera.max_depth),
            Path(merged["dataset"]),
        )
        episodes = replay(merged["dataset"], merged, figure_picks(merged), methods)
        atomic_write_bytes(args.figure, episode_figure(episodes))


if __name__ == "__main__":
    run_main(main, "approach_report.py")
