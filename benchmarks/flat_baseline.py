"""Map metrics of a flat map (every floor point gets the train split's mean label) on the
test split: the floor any learned model has to beat.

    python benchmarks/flat_baseline.py --data DIR [--json FILE]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from momakitchen.data import EpisodeDataset
from momakitchen.metrics import map_metrics


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    train = EpisodeDataset(args.data, "train")
    total, count = 0.0, 0
    for i in range(len(train)):
        labels = np.asarray(train[i]["floor_label"], float)
        total += labels.sum()
        count += labels.size
    mean = total / max(count, 1)
    test = EpisodeDataset(args.data, "test")
    gts = [np.asarray(test[i]["floor_label"], float) for i in range(len(test))]
    metrics = map_metrics([np.full_like(g, mean) for g in gts], gts)
    report = {
        "method": "flat (train mean)",
        "value": mean,
        "episodes": len(gts),
        "metrics": metrics,
    }
    print(json.dumps(report, indent=1))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)


if __name__ == "__main__":
    main()
