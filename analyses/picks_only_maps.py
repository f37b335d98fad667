"""The map metrics of the dexterity weight for picks only (``ModelConfig.index_picks_only``),
from ``momakitchen evaluate`` run with the weight on every target and without it.

    python analyses/picks_only_maps.py --data ev/panda_public13 \
        results/body/dexterity/evaluate-panda_public13-r05.json \
        results/body/retrained/evaluate/body-panda_public13.json

The weight is a gate with no weights of its own (``picks_only.py``): on the same episodes a
picks-only model's map is the weighted model's where the robot picks its target and the
unweighted model's where it opens it. ``evaluate`` averages each metric over episodes and
reports the averages per target category with their episode counts, and a category is
either opened or picked (the dataset's manifest names each configuration's target, e.g.
``"fridge/door"``). So the picks-only model's averages are the per-category averages of
the weighted run for the picked categories and of the unweighted run for the opened ones,
weighted by their episodes (RMSE: the square root of the composed MSE, as ``evaluate``
reports it). Prints the three models' metrics; ``--check FILE`` compares the composition
with an ``evaluate`` of the picks-only model itself.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from analysis_cli import run_main

from momakitchen.data.manifest import load_manifest, target_category, target_opens
from momakitchen.errors import MomaError
from momakitchen.fileio import read_json_object
from momakitchen.metrics import METRIC_NAMES

SHOWN = ("pcc", "sim", "ciou", "rmse")


def opened_categories(data: Path) -> dict[str, bool]:
    """Each target category of a dataset -> whether its robot opens it; an error where a
    category is opened in one configuration and picked in another."""
    out: dict[str, bool] = {}
    for sid, entry in load_manifest(data)["shards"].items():
        for target in entry.get("targets", []):
            cat, opens = target_category(str(target)), target_opens(str(target))
            if out.setdefault(cat, opens) != opens:
                raise MomaError(f"category {cat!r} is both opened and picked (scene {sid})")
    if not out:
        raise MomaError(f"the manifest of {str(data)!r} names no target")
    return out


def _evaluation(path: str) -> dict[str, Any]:
    """An ``evaluate --json`` result that breaks its metrics down per target category."""
    result = read_json_object(path)
    per = result.get("per_category")
    if not isinstance(per, dict) or not per:
        raise MomaError(f"{path!r} is not a momakitchen evaluate --json result with per_category")
    return result


def compose(
    weighted: dict[str, dict[str, float]],
    unweighted: dict[str, dict[str, float]],
    opens: dict[str, bool],
) -> dict[str, float]:
    """The picks-only model's episode-averaged metrics (``METRIC_NAMES``) and its
    ``openings`` (episodes whose target opens), from two ``per_category`` tables."""
    if weighted.keys() != unweighted.keys():
        raise MomaError(
            f"the runs hold other categories: {sorted(weighted)} against {sorted(unweighted)}"
        )
    sums = dict.fromkeys(METRIC_NAMES, 0.0)
    episodes = openings = 0.0
    for cat in sorted(weighted):
        if cat not in opens:
            raise MomaError(f"category {cat!r} is not in --data")
        n = weighted[cat]["episodes"]
        if unweighted[cat]["episodes"] != n:
            raise MomaError(f"category {cat!r} has other episodes in the two runs")
        row = unweighted[cat] if opens[cat] else weighted[cat]
        for k in METRIC_NAMES:
            sums[k] += n * row[k]
        episodes += n
        openings += n if opens[cat] else 0
    out = {k: v / episodes for k, v in sums.items()}
    out["rmse"] = math.sqrt(out["mse"])
    return out | {"episodes": episodes, "openings": openings}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="the runs' dataset")
    ap.add_argument("weighted", help="evaluate --json, the weight on every target")
    ap.add_argument("unweighted", help="evaluate --json, the same model without the weight")
    ap.add_argument("--check", help="evaluate --json of the picks-only model, to compare")
    args = ap.parse_args()
    w, u = _evaluation(args.weighted), _evaluation(args.unweighted)
    if w["episodes"] != u["episodes"]:
        raise MomaError(f"the runs hold {w['episodes']} and {u['episodes']} episodes")
    picks = compose(w["per_category"], u["per_category"], opened_categories(args.data))
    print(f"{int(picks['episodes'])} episodes, {int(picks['openings'])} open their target")
    rows: list[tuple[str, dict[str, Any]]] = [
        ("weighted", w["metrics"]),
        ("unweighted", u["metrics"]),
        ("picks only", picks),
    ]
    if args.check:
        rows.append(("picks only, measured", read_json_object(args.check)["metrics"]))
    print("model | " + " | ".join(SHOWN))
    for name, m in rows:
        print(f"{name} | " + " | ".join(f"{m[k]:.4f}" for k in SHOWN))


if __name__ == "__main__":
    run_main(main, "picks_only_maps.py")
