"""A tuning view of a dataset: its train scenes only, one in every ``--every`` of them held
out as the view's "test" split, so recipes are compared without touching the real test
scenes.

    python analyses/dev_split.py --data ~/mk-data/gt2-300 --out ~/mk-data/gt2-dev --every 10
    momakitchen train --data ~/mk-data/gt2-dev --model navaff --out ~/mk-runs/dev-navaff
    momakitchen evaluate --data ~/mk-data/gt2-dev --checkpoint ~/mk-runs/dev-navaff --json dev.json

The view holds a manifest and a link to the dataset's ``scenes`` folder (no copy). The held
out scenes are every ``--every``-th train scene in scene-id order, starting with the first.
``--train-scenes N`` keeps only the first N of the others for training (in scene-id order,
so smaller views are subsets of larger ones) and the same held-out scenes: a learning
curve against data size.

    python analyses/dev_split.py --data ~/mk-data/gt2-300 --out ~/mk-data/gt2-dev54 \
        --every 10 --train-scenes 54
"""

from __future__ import annotations

import argparse
import copy
from pathlib import Path

from analysis_cli import run_main

from momakitchen.data import manifest as mf
from momakitchen.errors import MomaError


def dev_manifest(manifest: dict, every: int, train_scenes: int = 0) -> dict:
    """``manifest`` restricted to its train shards, every ``every``-th of them as "test" and
    (if ``train_scenes`` > 0) only the first ``train_scenes`` of the rest as "train"."""
    if every < 2:
        raise MomaError(f"--every must be >= 2, got {every}")
    if train_scenes < 0:
        raise MomaError(f"--train-scenes must be >= 0, got {train_scenes}")
    train = sorted((int(k), v) for k, v in manifest["shards"].items() if v["split"] == "train")
    if len(train) < every:
        raise MomaError(f"{len(train)} train scenes: too few to hold out one in {every}")
    held = train[::every]
    rest = [shard for i, shard in enumerate(train) if i % every]
    if train_scenes > len(rest):
        raise MomaError(
            f"--train-scenes {train_scenes}: the view has only {len(rest)} train scenes"
        )
    out = copy.deepcopy(manifest)
    out["shards"] = {}
    # Not a generation request: `check` would count the source's test scenes as missing.
    out.pop("requested", None)
    # finalize() sorts the shards by scene id.
    for split, shards in (("test", held), ("train", rest[: train_scenes or None])):
        for _, entry in shards:
            mf.add_shard(out, {k: v for k, v in entry.items() if k != "split"}, split)
    out["split_rule"] = (
        f"tuning view: the train scenes of the source dataset, every {every}th one "
        "(in scene-id order, from the first) held out as test"
        + (f", the first {train_scenes} of the others kept for training" if train_scenes else "")
    )
    return mf.finalize(out, bool(manifest.get("complete")))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument(
        "--train-scenes", type=int, default=0, help="keep only the first N train scenes (0: all)"
    )
    args = ap.parse_args()
    manifest = dev_manifest(mf.load_manifest(args.data), args.every, args.train_scenes)
    if args.out.resolve() == args.data.resolve():
        raise MomaError(f"--out {str(args.out)!r} is the dataset itself")
    args.out.mkdir(parents=True, exist_ok=True)
    link = args.out / "scenes"
    if not link.exists():
        link.symlink_to((args.data / "scenes").resolve(), target_is_directory=True)
    mf.save_manifest(args.out, manifest)
    counts = manifest["counts"]
    print(
        f"{args.out}: {counts['train']['scenes']} train scenes, "
        f"{counts['test']['scenes']} held out ({counts['test']['episodes']} episodes): "
        + ", ".join(map(str, manifest["splits"]["test"]))
    )


if __name__ == "__main__":
    run_main(main, "dev_split.py")
