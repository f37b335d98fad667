"""How much of a robot's map metrics is its share of views with nothing to find.

    python analyses/pcc_feasible.py --data ho/panda13/data --evaluate body-panda13.json

`momakitchen evaluate` averages PCC, SIM, cosine and cIoU over episodes, and an episode
whose ground-truth map is constant (all 0: no stance on the floor the view shows, e.g. a
configuration no trial succeeded in) scores exactly 0 on each, whatever the prediction. A
robot with many such views (an arm mounted where it reaches little) scores lower for that
alone. This reads the floor labels of the episodes `evaluate` scored (the same split and
the same skipping of views without points) and prints, for each result, the share of
constant-map episodes and each of the four metrics over the others: the result's figure
times all episodes over the non-constant ones (exact, as those score 0).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from analysis_cli import run_main

from momakitchen.data import EpisodeDataset
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError
from momakitchen.fileio import read_json_object

ZERO_ON_CONSTANT = ("pcc", "sim", "cos", "ciou")


def constant_maps(root: Path, split: str) -> np.ndarray:
    """(E,) whether each episode ``evaluate`` scores on ``split`` has a constant
    ground-truth map (reads the floor labels only)."""
    out, shards = [], {}
    try:
        for file, _sid, c, e, _robot in EpisodeDataset(root, split).index:
            shard = shards.get(file) or shards.setdefault(file, SceneShard(root / file))
            label = shard.arrays(c, e, ["floor_label"])["floor_label"]
            out.append(bool(np.ptp(label) == 0))
    finally:
        for shard in shards.values():
            shard.close()
    return np.asarray(out, bool)


def rescaled(result: dict, constant: np.ndarray) -> dict[str, float]:
    """The four metrics of ``result`` (an evaluate JSON) over the non-constant episodes."""
    n = int(result.get("episodes", -1))
    if n != len(constant):
        raise MomaError(
            f"the result scored {n} episodes, the data's {result.get('split')} split has "
            f"{len(constant)}: not the same data"
        )
    kept = int((~constant).sum())
    if not kept:
        raise MomaError("every episode's map is constant: nothing to rescale")
    return {k: float(result["metrics"][k]) * n / kept for k in ZERO_ON_CONSTANT}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="the results' dataset")
    ap.add_argument("--evaluate", type=Path, nargs="+", required=True, help="evaluate JSONs")
    args = ap.parse_args()
    results = [(p, read_json_object(p)) for p in args.evaluate]
    splits = {r.get("split", "test") for _, r in results}
    if len(splits) != 1:
        raise MomaError(f"the results score different splits: {sorted(splits)}")
    constant = constant_maps(args.data, splits.pop())
    print(f"episodes {len(constant)}, constant maps {constant.mean():.1%}")
    print("result | " + " | ".join(f"{k} (all / non-constant)" for k in ZERO_ON_CONSTANT))
    for path, result in results:
        over = rescaled(result, constant)
        cells = [f"{result['metrics'][k]:.3f} / {over[k]:.3f}" for k in ZERO_ON_CONSTANT]
        print(f"{path.name} | " + " | ".join(cells))


if __name__ == "__main__":
    run_main(main, "pcc_feasible.py")
