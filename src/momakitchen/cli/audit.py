"""``momakitchen audit``: does the ground truth predict where the robot really succeeds?

Measures on any scene ids, per robot and per target: the share of configurations with no
successful grid trial (and the stage that failed there), the stability of every successful
grid position under ±3 cm / ±5 cm / ±10° displacements, the oracle's (and random and
nearest's) Top-1 / Top-5 MSR with the reason of each oracle miss, and the share of views
of feasible configurations that see floor near a success. All trials run in physics with
the labelling's own routine.

``--scenes A-B`` generates scenes A..B (inclusive) into ``OUT/data`` first (resumable,
with ``--config FILE`` as ``generate`` takes it); ``--data DIR`` audits an existing
dataset instead. Per-scene results are kept in ``OUT/records`` so an interrupted audit
resumes. Writes ``OUT/audit.json`` (or ``--json``), ``OUT/audit.md`` and ``OUT/audit.png``.
"""

from __future__ import annotations

import argparse
import json
import re
import time
from pathlib import Path
from typing import Any

from momakitchen.cli.common import non_negative_int, positive_int
from momakitchen.cli.options import add_quiet, add_robot_yaml, add_seed
from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict
from momakitchen.scene.ids import scene_range_problem

_RANGE = re.compile(r"^(\d+)(?:-(\d+))?$")
# At most this many scenes per audit: it keeps every record in memory for its summary,
# and 10,000 scenes already take about 250 hours on 2 cores (20 took 30 minutes).
MAX_AUDIT_SCENES = 10_000
# Minutes one worker spends per scene, generation and audit (measured on 2 cores).
SCENE_MINUTES = 3


def scene_range(text: str) -> tuple[int, int]:
    """argparse type: ``A-B`` (inclusive, A <= B) or a single id ``A``; (first id, count)."""
    m = _RANGE.match(text.strip())
    if not m:
        raise argparse.ArgumentTypeError(f"expected scene ids as A-B or A, got {text!r}")
    first = int(m.group(1))
    last = int(m.group(2)) if m.group(2) is not None else first
    if last < first:
        raise argparse.ArgumentTypeError(f"scene range {text!r} ends before it starts")
    problem = scene_range_problem(first, last - first + 1, MAX_AUDIT_SCENES)
    if problem:
        raise argparse.ArgumentTypeError(f"scene range {text!r}: {problem}")
    return first, last - first + 1


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser(
        "audit", help="label audit: does the ground truth predict success?", description=__doc__
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--scenes",
        type=scene_range,
        metavar="A-B",
        help="scene ids to generate and audit, e.g. 700000-700019",
    )
    source.add_argument("--data", help="audit this existing dataset (all its scenes)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--json", default=None, help="where to write the results (OUT/audit.json)")
    parser.add_argument(
        "--config",
        default=None,
        metavar="FILE",
        help="generation options for --scenes (YAML or JSON, as for generate)",
    )
    parser.add_argument("--workers", type=positive_int, default=1, help="parallel processes (1)")
    parser.add_argument(
        "--max-stability-points",
        type=non_negative_int,
        default=0,
        help="re-run at most N successful positions per configuration (0: all)",
    )
    add_seed(parser)
    add_quiet(parser)
    add_robot_yaml(parser)
    parser.set_defaults(func=run)


def _audit_scene(job: tuple[str, int, str, dict[str, Any], dict[str, Any], list]) -> list[dict]:
    """Pool task: the audit records of one shard (the dataset's user robots registered
    first, as in the driver)."""
    root, sid, file, gen_dict, audit_dict, robot_files = job
    from momakitchen import codec
    from momakitchen.data.config import GenerationConfig
    from momakitchen.eval.audit import AuditConfig, audit_shard
    from momakitchen.robots.user import UserRobotFile, register_recorded
    from momakitchen.scene.configuration import sample_scene

    register_recorded(UserRobotFile.from_dict(r) for r in robot_files)

    gen = GenerationConfig.from_dict(gen_dict)
    config = codec.from_dict(AuditConfig, audit_dict)
    return audit_shard(Path(root) / file, sample_scene(sid, gen.scene), gen, config)


def run(args: argparse.Namespace) -> int:
    import multiprocessing

    from tqdm.auto import tqdm

    from momakitchen import codec
    from momakitchen.cli.common import output_dir
    from momakitchen.data import manifest as mf
    from momakitchen.data.config import GenerationConfig
    from momakitchen.data.integrity import check_shard_files
    from momakitchen.eval.audit import AuditConfig, audit_figure, format_audit_table, summarize
    from momakitchen.eval.msr import MsrConfig
    from momakitchen.fileio import atomic_write_bytes, atomic_write_text

    config = AuditConfig(
        max_stability_points=args.max_stability_points,
        msr=MsrConfig(split="all", seed=args.seed),
    )
    if args.data is not None:
        root = Path(args.data)
        mf.load_manifest(root)  # a missing or malformed dataset fails before anything
        if args.config is not None:
            raise MomaError(
                "--config applies to --scenes (the dataset's config is in its manifest)"
            )
        wanted = None
    else:
        first, count = args.scenes
        gen = (
            codec.load_config_file(args.config, GenerationConfig)
            if args.config
            else GenerationConfig()
        )
        out = output_dir(args.out)
        root = out / "data"
        if not args.quiet:
            # A first estimate; the bars below refine it as scenes finish.
            hours = count * SCENE_MINUTES / max(1, args.workers) / 60
            print(
                f"audit: scenes {first}..{first + count - 1}, generated then audited; about "
                f"{hours:.1f} h with {args.workers} worker(s) at {SCENE_MINUTES} min per "
                "scene and worker (scenes already done are skipped)",
                flush=True,
            )
        from momakitchen.data.generator import GenerateRequest, generate_dataset
        from momakitchen.generation.producer import scene_records

        request = GenerateRequest(
            out=root, num_scenes=count, first_scene_id=first, workers=args.workers
        )
        generate_dataset(request, scene_records, gen, progress=not args.quiet)
        wanted = set(request.scene_ids)

    manifest = mf.load_manifest(root)
    if manifest.get("producer") != mf.KITCHEN or "config" not in manifest:
        raise MomaError(
            f"{root} was not made by the simulator-backed generator (producer "
            f"{manifest.get('producer')!r}): the audit rebuilds its worlds"
        )
    gen_dict = manifest["config"]
    mf.check_user_robots(manifest, root)  # its user robots must be registered here
    from momakitchen.robots.user import user_robot_files

    # The workers register the same files as this process (wherever they are now).
    recorded = [r["name"] for r in mf.manifest_user_robots(manifest, root)]
    robot_files = [f.to_dict() for f in user_robot_files(recorded)]
    GenerationConfig.from_dict(gen_dict)  # unreadable configs fail before any work
    shards = {int(k): v["file"] for k, v in manifest["shards"].items()}
    ids = sorted(s for s in shards if wanted is None or s in wanted)
    if not ids:
        raise MomaError(f"dataset {str(root)!r} has no scenes to audit")
    check_shard_files(root, manifest, ids)  # a missing or damaged shard fails before any trial
    out = output_dir(args.out)
    records_dir = out / "records"
    records_dir.mkdir(exist_ok=True)
    audit_dict = codec.to_dict(config)

    def cached(sid: int) -> list[dict] | None:
        path = records_dir / f"scene_{sid:06d}.json"
        if not path.is_file():
            return None
        try:
            saved = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError):
            return None
        ok = saved.get("config") == audit_dict and saved.get("generation") == gen_dict
        return saved["records"] if ok else None

    t0 = time.perf_counter()
    by_scene: dict[int, list[dict]] = {}
    todo = []
    for sid in ids:
        records = cached(sid)
        if records is None:
            todo.append((str(root), sid, shards[sid], gen_dict, audit_dict, robot_files))
        else:
            by_scene[sid] = records
    bar = tqdm(
        total=len(ids), initial=len(by_scene), desc="audit", unit="scene", disable=args.quiet
    )
    ctx = multiprocessing.get_context("spawn")
    pool = ctx.Pool(min(args.workers, len(todo))) if args.workers > 1 and len(todo) > 1 else None
    try:
        results = pool.imap(_audit_scene, todo) if pool else map(_audit_scene, todo)
        for job, records in zip(todo, results, strict=True):
            sid = job[1]
            by_scene[sid] = records
            payload = {"config": audit_dict, "generation": gen_dict, "records": records}
            atomic_write_text(records_dir / f"scene_{sid:06d}.json", dumps_strict(payload) + "\n")
            bar.update(1)
    finally:
        bar.close()
        if pool is not None:
            pool.terminate()
    records = [r for sid in ids for r in by_scene[sid]]
    summary = summarize(records, config)
    table = format_audit_table(summary, config)
    result = {
        "dataset": str(root),
        "scene_ids": ids,
        "config": audit_dict,
        "configurations": len(records),
        "summary": summary,
        "records": records,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    json_path = Path(args.json) if args.json else out / "audit.json"
    json_path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(json_path, dumps_strict(result, indent=1) + "\n")
    atomic_write_text(out / "audit.md", table + "\n")
    atomic_write_bytes(out / "audit.png", audit_figure(summary, config))
    print(table)
    print(
        f"{len(records)} configurations of scenes {ids[0]}..{ids[-1]} -> {json_path}, "
        f"{out / 'audit.png'}"
    )
    return 0
