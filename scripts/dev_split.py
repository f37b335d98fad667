"""A tuning view of a dataset: its train scenes only, one in every ``--every`` of them held
out as the view's "test" split, so recipes are compared without touching the real test
scenes.

    python scripts/dev_split.py --data ~/mk-data/gt2-300 --out ~/mk-data/gt2-dev --every 10
    momakitchen train --data ~/mk-data/gt2-dev --model navaff --out ~/mk-runs/dev-navaff
    momakitchen evaluate --data ~/mk-data/gt2-dev --checkpoint ~/mk-runs/dev-navaff --json dev.json

The view holds a manifest and a link to the dataset's ``scenes`` folder (no copy). The held
out scenes are every ``--every``-th train scene in scene-id order, starting with the first.
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

from momakitchen.data import manifest as mf
from momakitchen.errors import MomaError


def dev_manifest(manifest: dict, every: int) -> dict:
    """``manifest`` restricted to its train shards, every ``every``-th of them as "test"."""
    if every < 2:
        raise MomaError(f"--every must be >= 2, got {every}")
    train = sorted((int(k), v) for k, v in manifest["shards"].items() if v["split"] == "train")
    if len(train) < every:
        raise MomaError(f"{len(train)} train scenes: too few to hold out one in {every}")
    out = copy.deepcopy(manifest)
    out["shards"] = {}
    # Not a generation request: `check` would count the source's test scenes as missing.
    out.pop("requested", None)
    for i, (_, entry) in enumerate(train):
        mf.add_shard(
            out,
            {k: v for k, v in entry.items() if k != "split"},
            "test" if i % every == 0 else "train",
        )
    out["split_rule"] = (
        f"tuning view: the train scenes of the source dataset, every {every}th one "
        "(in scene-id order, from the first) held out as test"
    )
    return mf.finalize(out, bool(manifest.get("complete")))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--every", type=int, default=10)
    args = ap.parse_args()
    manifest = dev_manifest(mf.load_manifest(args.data), args.every)
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
    try:
        main()
    except MomaError as exc:  # bad input: one line, exit status 2, as the CLI does
        print(f"dev_split.py: error: {exc}", file=sys.stderr)
        sys.exit(2)
