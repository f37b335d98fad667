"""Dataset tools: ``check``, ``stats``, ``export-reference`` and ``import-reference``."""

from __future__ import annotations

import argparse
import sys

from momakitchen.cli.options import add_quiet
from momakitchen.cli.wording import counted
from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "check",
        help="integrity check of a dataset",
        description="Every shard opens, matches its manifest entry (size, "
        "checksum, counts) and holds finite, in-range arrays, and the generation is "
        "complete. Exit 2 naming the first bad shard, or the number of scenes still "
        "missing, otherwise.",
    )
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--no-hash", action="store_true", help="skip the checksums (faster)")
    p.add_argument(
        "--allow-incomplete",
        action="store_true",
        help="exit 0 on an unfinished generation whose shards are sound",
    )
    add_quiet(p)
    p.set_defaults(func=run_check)

    p = sub.add_parser(
        "stats",
        help="statistics of a dataset",
        description="Counts per split, robot and target category, trial success rates, sizes.",
    )
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=run_stats)

    p = sub.add_parser(
        "export-reference",
        help="write a dataset in the reference layout",
        description="Per-episode folders with point_cloud_transformed/*.ply, "
        "the *_gaussian_success_rate.txt labels and "
        "trial_info.json (momakitchen.data.reference).",
    )
    p.add_argument("dir", help="dataset directory")
    p.add_argument("--out", required=True, help="output directory (empty or missing)")
    p.set_defaults(func=run_export)

    p = sub.add_parser(
        "import-reference",
        help="read the reference layout into a dataset",
        description="Reads the reference release layout (or an export) and "
        "writes shards, a manifest and a dataset card.",
    )
    p.add_argument("dir", help="directory in the reference layout")
    p.add_argument("--out", required=True, help="dataset directory (empty or missing)")
    p.set_defaults(func=run_import)


def run_check(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from momakitchen.data.integrity import check_dataset
    from momakitchen.data.manifest import load_manifest

    load_manifest(args.dir)  # a bad directory is reported before any progress bar is drawn
    with tqdm(desc="check", unit="shard", disable=args.quiet, file=sys.stderr, leave=False) as bar:

        def progress(done: int, total: int) -> None:
            bar.total = total
            bar.update(done - bar.n)

        report = check_dataset(args.dir, verify_hash=not args.no_hash, progress=progress)
    counts = f"{counted(report['shards'], 'shard')}, {counted(report['episodes'], 'episode')}"
    if report["incomplete"] and not args.allow_incomplete:
        # A script that gates on `check` must not take an unfinished dataset for a good one.
        raise MomaError(
            f"{args.dir}: {report['incomplete']} ({counts} sound); run the same "
            "`momakitchen generate` again to finish it, or pass --allow-incomplete"
        )
    print(
        f"{args.dir}: OK: {counts}" + (f" ({report['incomplete']})" if report["incomplete"] else "")
    )
    return 0


def run_stats(args: argparse.Namespace) -> int:
    from momakitchen.data.coverage import COVERAGE_RADIUS
    from momakitchen.data.integrity import dataset_stats

    s = dataset_stats(args.dir)
    if args.json:
        print(dumps_strict(s, indent=1))
        return 0
    print(
        f"{s['root']}: producer {s['producer']}, momakitchen {s['generator_version']}"
        + (f" ({s['incomplete']})" if s["incomplete"] else "")
    )
    print(f"{'split':<10}{'scenes':>8}{'configs':>9}{'episodes':>10}{'trials':>9}{'success':>9}")
    for name, row in s["splits"].items():
        rate = row["trial_success_rate"]
        print(
            f"{name:<10}{row['scenes']:>8}{row['configurations']:>9}{row['episodes']:>10}"
            f"{row['trials']:>9}{'-' if rate is None else f'{rate:.3f}':>9}"
        )
    for title, table in (("robot", s["robots"]), ("target", s["targets"])):
        print(f"{title:<16}{'train ep':>9}{'test ep':>9}{'success':>9}")
        for name, row in table.items():
            rate = row["total"]["trial_success_rate"]
            print(
                f"{name:<16}{row['train'].get('episodes', 0):>9}"
                f"{row['test'].get('episodes', 0):>9}"
                f"{'-' if rate is None else f'{rate:.3f}':>9}"
            )
    pts = s["points_per_episode"]
    shape = s["image_shape"]
    image = f"{shape[1]}x{shape[0]}" if shape else "-"
    print(
        f"bytes: {s['bytes']:,} ({s['bytes_per_episode']:,.0f} per episode); image {image}; "
        f"points per episode: global {_spread(pts['global'])}, floor {_spread(pts['floor'])}"
    )
    coverage = s["view_coverage"]
    print(
        f"infeasible configurations (no successful trial): {s['infeasible_configurations']} of "
        f"{s['splits']['total']['configurations']}; views of feasible configurations that see "
        f"floor within {100 * COVERAGE_RADIUS:.0f} cm of a success: "
        f"{'-' if coverage is None else f'{coverage:.1%}'}"
    )
    if s["episodes_with_empty_cloud"]:
        print(
            f"episodes without global or floor points (skipped by EpisodeDataset): "
            f"{s['episodes_with_empty_cloud']}"
        )
    return 0


def _spread(summary: dict[str, float] | None) -> str:
    """``{"mean", "min", "max"}`` as ``mean 12,345 (min 1,000, max 20,000)``."""
    if summary is None:
        return "-"
    return f"mean {summary['mean']:,.0f} (min {summary['min']:,.0f}, max {summary['max']:,.0f})"


def run_export(args: argparse.Namespace) -> int:
    from momakitchen.cli.common import planned_output_dir
    from momakitchen.data.reference import export_reference

    planned_output_dir(args.out)  # an impossible --out fails before any work
    n = export_reference(args.dir, args.out)
    print(
        f"{args.out}: {counted(n['configurations'], 'configuration')}, "
        f"{counted(n['episodes'], 'episode')} in the reference layout"
    )
    return 0


def run_import(args: argparse.Namespace) -> int:
    from momakitchen.data.reference import import_reference

    m = import_reference(args.dir, args.out)
    c = m["counts"]["total"]
    print(
        f"{args.out}: {counted(c['scenes'], 'scene')}, "
        f"{counted(c['configurations'], 'configuration')}, "
        f"{counted(c['episodes'], 'episode')} imported"
    )
    return 0
