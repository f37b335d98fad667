"""``momakitchen approach``: the last mile as a robot drives it.

For every configuration of a split the robot starts near (the view ``msr`` judges for
the same seed) or far (3.8-6 m from the target as the room allows, within +-45 deg of
the direction it faces), looks (a render at its true pose with a perception preset,
through the real-robot path ``momakitchen.predict``), drives a collision-free path with
odometry drift, may look again on the way (``--policy``), stops with an error, turns to
face the target and runs the labelling's trial where it really is. Reports success, SPL,
looks and time per (method, policy, start), McNemar between every pair, and, with
``--stop-sweep``, success against the final-stop error. A ``--checkpoint`` may also be a
plug-in's run, or ``bundled``. See docs/APPROACH.md.

A killed run resumes: run the same command again (the configurations done so far are
kept in ``JSON.partial.jsonl`` until the run ends).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from momakitchen.cli.common import output_file, part_arg
from momakitchen.cli.options import (
    add_baselines,
    add_checkpoint,
    add_data,
    add_quiet,
    add_results_json,
    add_robot_yaml,
    add_selection,
    config_fields,
)
from momakitchen.errors import MomaError
from momakitchen.eval.methods import METHODS
from momakitchen.fileio import atomic_write_bytes, atomic_write_text

# Spelled out so that building the parser does not import numpy (tests/cli/test_main.py),
# as are the defaults of the options below: ApproachConfig's, LookPolicy's and
# MotionConfig's (in the units of the options; tests/cli/test_options.py checks them).
STARTS = ("near", "far")
POLICIES = ("single", "relook", "uncertain")
MAPS = ("static", "full")
PERCEPTION = "realistic"
MAX_LOOKS = 3
RELOOK_DISTANCE = 1.5
MAX_UNCERTAINTY = 0.10
STOP_XY_CM = 3.0
STOP_YAW_DEG = 2.0
DRIFT_PERCENT = 2.0
OBSTACLE_MIN_POINTS = 1


def add_parser(sub: argparse._SubParsersAction) -> None:
    ap = sub.add_parser(
        "approach",
        help="the last mile as driven: start far, drive with error, look again, manipulate",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_data(ap, required=False)  # not with --merge
    add_results_json(ap)
    add_checkpoint(ap, repeatable=True)
    ap.add_argument(
        "--server",
        action="append",
        default=[],
        metavar="URL",
        help="a method behind `momakitchen serve`'s HTTP API, asked at every look "
        "(repeatable; docs/METHODS.md)",
    )
    add_baselines(ap)
    ap.add_argument(
        "--start",
        action="append",
        default=[],
        metavar="START",
        help="near or far (repeatable; default far)",
    )
    ap.add_argument(
        "--policy",
        action="append",
        default=[],
        metavar="POLICY",
        help=f"look policy of the models: {', '.join(POLICIES)} (repeatable; default all)",
    )
    ap.add_argument(
        "--perception",
        default=PERCEPTION,
        help="perception preset: realistic (D435 depth, masks shifted 5 px, camera 1 cm / "
        "1 deg off), ideal, or a corruption of `momakitchen robustness --list`",
    )
    ap.add_argument(
        "--map",
        default=MAPS[0],
        choices=MAPS,
        help="what the robot knows of the room: static (walls and fixed furniture; the "
        "obstacles around the target only as its looks see them, the default) or full "
        "(everything, as before)",
    )
    ap.add_argument(
        "--obstacle-min-points",
        type=int,
        default=OBSTACLE_MIN_POINTS,
        metavar="N",
        help="static map: a look marks a 5 cm costmap cell as an obstacle only where at least N "
        "of its depth points above the floor fall in it (%(default)s: every point)",
    )
    add_selection(ap)
    ap.add_argument(
        "--part",
        type=part_arg,
        default=(1, 1),
        metavar="K/N",
        help="only part K of N of the split (every N-th scene from the K-th), to run it in "
        "N processes; --merge joins the parts' --json files",
    )
    ap.add_argument(
        "--max-looks",
        type=int,
        default=MAX_LOOKS,
        help="most looks per episode, the first included (%(default)s)",
    )
    ap.add_argument(
        "--relook-distance",
        type=float,
        default=RELOOK_DISTANCE,
        help="relook: look again this far from the goal (m, %(default)g)",
    )
    ap.add_argument(
        "--max-uncertainty",
        type=float,
        default=MAX_UNCERTAINTY,
        help="uncertain: look again while the MC-dropout std at the goal exceeds this "
        "(%(default).2f)",
    )
    ap.add_argument(
        "--stop-xy",
        type=float,
        default=STOP_XY_CM,
        help="final-stop error, cm per axis (%(default)g)",
    )
    ap.add_argument(
        "--stop-yaw",
        type=float,
        default=STOP_YAW_DEG,
        help="final-stop yaw error, deg (%(default)g)",
    )
    ap.add_argument(
        "--drift",
        type=float,
        default=DRIFT_PERCENT,
        help="odometry error along the path, %% of the distance (%(default)g; across: half of it)",
    )
    ap.add_argument(
        "--stop-sweep",
        action="store_true",
        help="also run each final trial at stop errors 0, 3, 6, 10, 20, 30 cm "
        "(0, 2, 4, 6, 10, 15 deg) from the same pre-stop pose",
    )
    ap.add_argument("--markdown", metavar="FILE", help="also write the tables as Markdown")
    ap.add_argument(
        "--csv",
        metavar="FILE",
        help="also write the summary rows as CSV (one per row of the table)",
    )
    ap.add_argument(
        "--compact",
        action="store_true",
        help="--json without the episodes' paths, unindented (for archiving)",
    )
    ap.add_argument(
        "--merge",
        nargs="+",
        default=[],
        metavar="JSON",
        help="join earlier runs' --json files (the parts of a --part run, or methods run "
        "apart on the same dataset and settings) into --json, --markdown, --csv and "
        "--figure; runs no episode (--checkpoint: the models to replay for --figure)",
    )
    ap.add_argument("--figure", metavar="PNG", help="a top-down picture of one episode per robot")
    ap.add_argument(
        "--record",
        action="append",
        default=[],
        metavar="SCENE:CONFIG",
        help="write MCAP recordings (Foxglove) of this configuration's episodes (repeatable)",
    )
    ap.add_argument(
        "--record-dir", metavar="DIR", help="where --record writes (default: beside --json)"
    )
    add_quiet(ap)
    add_robot_yaml(ap)
    ap.set_defaults(func=run)


def _record_ids(values: list[str]) -> list[tuple[int, int]]:
    out = []
    for v in values:
        try:
            sid, ci = (int(x) for x in v.split(":"))
        except ValueError:
            raise MomaError(f"--record wants SCENE:CONFIG (two integers), got {v!r}") from None
        out.append((sid, ci))
    return out


def run(args: argparse.Namespace) -> int:
    from momakitchen.deploy.fusion import LookPolicy
    from momakitchen.eval.approach.config import STOP_SWEEP, ApproachConfig
    from momakitchen.eval.approach.report import merge_results, pairwise, summarize
    from momakitchen.eval.approach.track import load_methods, run_approach
    from momakitchen.sim.motion import MotionConfig

    out = output_file(args.json)
    for f in (args.markdown, args.figure, args.csv):
        if f:
            output_file(f)
    records = _record_ids(args.record)
    if args.merge:
        from momakitchen.fileio import read_json_object

        result = merge_results([(str(p), read_json_object(Path(p))) for p in args.merge])
        _write_outputs(args, out, result, records, list(args.checkpoint), list(args.server))
        return 0
    if not args.data:
        raise MomaError("--data is required (or --merge FILE ... to join earlier runs)")
    motion = MotionConfig(
        stop_xy=args.stop_xy / 100.0,
        stop_yaw=args.stop_yaw,
        drift_along=args.drift / 100.0,
        drift_across=args.drift / 200.0,
    )
    config = ApproachConfig(
        starts=tuple(args.start) or ("far",),
        policies=tuple(args.policy) or POLICIES,
        perception=args.perception,
        part=args.part,
        look=LookPolicy(
            relook_distance=args.relook_distance,
            max_uncertainty=args.max_uncertainty,
            max_looks=args.max_looks,
        ),
        stop_sweep=STOP_SWEEP if args.stop_sweep else (),
        motion=motion,
        map=args.map,
        obstacle_min_points=args.obstacle_min_points,
        **config_fields(args, ApproachConfig),
    )
    unknown = [m for m in args.method if m not in METHODS]
    if unknown:
        raise MomaError(f"unknown method {unknown[0]!r}; methods: {', '.join(METHODS)}")
    checkpoints = list(args.checkpoint)
    if not checkpoints and not args.server and not args.method:
        checkpoints = ["bundled"]
    from momakitchen.data.config import Preprocessing
    from momakitchen.data.reader import dataset_generation

    manifest, gen = dataset_generation(Path(args.data))
    _check_recorded(Path(args.data), manifest, config, records)  # before any work
    # Servers are asked for /health here: an unreachable one fails before any work.
    methods = load_methods(
        checkpoints, args.server, Preprocessing(gen.cloud, gen.camera.max_depth), Path(args.data)
    )
    resume = out.with_name(out.name + ".partial.jsonl")
    t0 = time.perf_counter()
    result = run_approach(
        args.data,
        baselines=args.method,
        config=config,
        progress=not args.quiet,
        resume=resume,
        methods=methods,
    )
    result["results"] = summarize(result)
    result["pairs"] = pairwise(result)
    result["seconds"] = round(time.perf_counter() - t0, 1)
    _write_outputs(args, out, result, records, methods=methods)
    resume.unlink(missing_ok=True)
    return 0


def _check_recorded(
    root: Path, manifest: dict, config: Any, records: list[tuple[int, int]]
) -> None:
    """Every ``--record`` id is a configuration this run judges (one line otherwise)."""
    from momakitchen.data.reader import judged_configurations
    from momakitchen.eval.approach.track import part_of

    if not records:
        return
    todo = part_of(
        judged_configurations(root, manifest, config.split, config.max_configs), *config.part
    )
    judged = {(sid, ci) for sid, ci, _ in todo}
    for sid, ci in records:
        if (sid, ci) not in judged:
            raise MomaError(
                f"--record {sid}:{ci} is not a configuration of this run ({config.split} "
                f"split, {len(judged)} configurations; e.g. {min(judged)[0]}:{min(judged)[1]})"
            )


def _write_outputs(
    args: argparse.Namespace,
    out: Path,
    result: dict[str, Any],
    records: list[tuple[int, int]],
    checkpoints: list[str] | None = None,
    servers: list[str] | None = None,
    methods: dict[str, Any] | None = None,
) -> None:
    """The result's JSON, tables (terminal, --markdown, --csv), then the figure and
    recordings, which replay episodes (with a progress bar: they take minutes)."""
    from momakitchen.eval.approach.report import format_table, report_markdown, summary_csv

    out.parent.mkdir(parents=True, exist_ok=True)
    if args.compact:
        kept = [{k: v for k, v in r.items() if k != "path"} for r in result["records"]]
        text = json.dumps({**result, "records": kept}, allow_nan=False)
    else:
        text = json.dumps(result, indent=1, allow_nan=False)
    atomic_write_text(out, text + "\n")
    print(format_table(result["results"]))
    if args.markdown:
        atomic_write_text(Path(args.markdown), report_markdown(result))
    if args.csv:
        atomic_write_text(Path(args.csv), summary_csv(result["results"]))
    if args.figure or records:
        from tqdm.auto import tqdm

        from momakitchen.eval.approach.episode import ClassicalPerceiver
        from momakitchen.eval.approach.figure import (
            episode_figure,
            figure_picks,
            replay,
            write_mcap,
        )
        from momakitchen.eval.methods import CLASSICAL

        data = result["dataset"]
        if methods is None:  # a merged result: its models loaded again
            from momakitchen.data.config import Preprocessing
            from momakitchen.data.reader import dataset_generation
            from momakitchen.eval.approach.track import load_methods

            _, gen = dataset_generation(Path(data))
            prep = Preprocessing(gen.cloud, gen.camera.max_depth)
            methods = load_methods(checkpoints or ["bundled"], servers or [], prep, Path(data))
        methods = {**methods, **{name: ClassicalPerceiver(name) for name in CLASSICAL}}

        def replayed(picks: list[dict[str, Any]], what: str) -> list[tuple[dict[str, Any], Any]]:
            bar = tqdm(picks, desc=what, unit="episode", disable=args.quiet)
            return [e for pick in bar for e in replay(data, result, [pick], methods)]

        if args.figure:
            episodes = replayed(figure_picks(result), "figure")
            atomic_write_bytes(Path(args.figure), episode_figure(episodes))
        if records:
            folder = Path(args.record_dir) if args.record_dir else out.with_name(out.stem + "-mcap")
            picks = [
                r for r in result["records"] if (r["scene_id"], r["config_index"]) in set(records)
            ]
            missing = set(records) - {(r["scene_id"], r["config_index"]) for r in picks}
            if missing:
                raise MomaError(f"--record {sorted(missing)[0]}: no such episode in this run")
            folder.mkdir(parents=True, exist_ok=True)
            motion = result["config"]["motion"]
            for rec, _ in replayed(picks, "recordings"):
                name = f"{rec['scene_id']}_{rec['config_index']}_{rec['start']}_{rec['method']}"
                name = f"{name}_{rec['policy']}.mcap".replace("-.", "baseline.").replace(":", "-")
                write_mcap(folder / name, rec, motion["speed"])
            print(f"recordings -> {folder}")
    seconds = result.get("seconds")
    print(f"{seconds:.0f} s -> {out}" if seconds is not None else f"-> {out}")
