"""The held-out robot tables of ``scripts/anyarm.sh``: per robot, each model's closed-loop
Top-1, the share of the random -> oracle gap it closes and its map PCC; McNemar between
the models; and the checks against the any-arm figures to reach.

    python scripts/anyarm_report.py results/anyarm

DIR holds one folder per robot set (``trained``, optional: the any-arm test split, the
robots the retraining saw, against which the PCC goal is judged; the others: held-out
robots), each with the ``msr.json`` of ``msr
--top-k 1`` (every model, the oracle and random on the same views), optionally more
``msr-*.json`` of the same configurations adding models (a model in two files must have
the same outcomes in both), and one ``MODEL-maps.json`` of ``evaluate`` per model. Writes
``DIR/report.json`` and ``DIR/report.md``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from script_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.eval.robot_check import gap_closed_interval, top1_outcomes
from momakitchen.eval.stats import mcnemar
from momakitchen.fileio import atomic_write_text, dumps_strict, read_json_object

# msr's name of each model (the model's, then ":run" for a second run of one model), and
# the report's; its maps are in MAPS-maps.json, MAPS the name's last part.
MODELS = {
    "navaff": "NavAff (bundled)",
    "pointnet2": "PointNet++ (12 epochs)",
    "navaff:navaff-anyarm": "NavAff, any-arm",
    "pointnet2:pointnet2-anyarm": "PointNet++, any-arm",
    "navaff:navaff-anyarm-scaled": "NavAff, any-arm + scaled links",
    "pointnet2:pointnet2-anyarm-scaled": "PointNet++, any-arm + scaled links",
    "navaff:navaff-anyarm-dense": "NavAff, several arms per reach",
    "navaff:navaff-anyarm-grip": "NavAff, several arms per reach and grip force",
    "navaff:navaff-anyarm-rehearse": "NavAff, grip-force data beside the six's own",
    "navaff:navaff-anyarm-shoulder": "NavAff, grip-force data, descriptor with the shoulder",
}
# (a, b): McNemar of a against b on every robot set and pooled over the held-out ones.
PAIRS = [
    ("navaff:navaff-anyarm", "navaff"),
    ("pointnet2:pointnet2-anyarm", "pointnet2"),
    ("navaff", "pointnet2"),
    ("navaff:navaff-anyarm", "pointnet2:pointnet2-anyarm"),
    ("navaff:navaff-anyarm-scaled", "navaff"),
    ("navaff:navaff-anyarm-scaled", "navaff:navaff-anyarm"),
    ("navaff:navaff-anyarm-scaled", "pointnet2"),
    ("pointnet2:pointnet2-anyarm-scaled", "pointnet2"),
    ("navaff:navaff-anyarm-scaled", "pointnet2:pointnet2-anyarm-scaled"),
    ("navaff:navaff-anyarm-dense", "navaff"),
    ("navaff:navaff-anyarm-dense", "navaff:navaff-anyarm-scaled"),
    ("navaff:navaff-anyarm-dense", "pointnet2"),
    ("navaff:navaff-anyarm-grip", "navaff"),
    ("navaff:navaff-anyarm-grip", "navaff:navaff-anyarm-dense"),
    ("navaff:navaff-anyarm-grip", "pointnet2"),
    ("navaff:navaff-anyarm-rehearse", "navaff"),
    ("navaff:navaff-anyarm-rehearse", "navaff:navaff-anyarm-grip"),
    ("navaff:navaff-anyarm-shoulder", "navaff"),
    ("navaff:navaff-anyarm-shoulder", "navaff:navaff-anyarm-grip"),
    ("navaff:navaff-anyarm-shoulder", "pointnet2"),
    ("navaff:navaff-anyarm-rehearse", "pointnet2"),
]
TRAINED = "trained"
GAP_CLOSED, PCC_DROP = 0.90, 0.05  # the figures to reach on every held-out robot


def _config_keys(msr: dict[str, Any]) -> list[tuple[Any, Any]]:
    return [(r.get("scene_id"), r.get("config_index")) for r in msr["records"]]


def read_msr(folder: Path) -> dict[str, Any]:
    """``folder/msr.json`` with the methods of every ``folder/msr-*.json`` added; MomaError
    if one covers other configurations or gives a method already there other outcomes."""
    msr = read_json_object(folder / "msr.json")
    for extra_file in sorted(folder.glob("msr-*.json")):
        extra = read_json_object(extra_file)
        if _config_keys(extra) != _config_keys(msr):
            raise MomaError(f"{extra_file}: not the configurations of {folder / 'msr.json'}")
        for name, method in extra["methods"].items():
            if name in msr["methods"]:
                if top1_outcomes(extra, name) != top1_outcomes(msr, name):
                    raise MomaError(
                        f"{extra_file}: {name}'s outcomes differ from those in msr.json"
                    )
                continue
            msr["methods"][name] = method
            for record, new in zip(msr["records"], extra["records"], strict=True):
                record["methods"][name] = new["methods"][name]
    return msr


def robot_set(folder: Path) -> dict[str, Any]:
    """One robot set's rates, gap shares, PCCs and paired Top-1 outcomes."""
    msr = read_msr(folder)
    oracle = top1_outcomes(msr, "oracle")
    random = top1_outcomes(msr, "random")
    o, r = sum(oracle) / len(oracle), sum(random) / len(random)
    out: dict[str, Any] = {
        "configurations": len(oracle),
        "robots": sorted({rob for m in msr["methods"].values() for rob in m["per_robot"]}),
        "oracle": o,
        "random": r,
        "models": {},
        "outcomes": {"oracle": oracle, "random": random},
    }
    for name in [m for m in MODELS if m in msr["methods"]]:
        won = top1_outcomes(msr, name)
        top1 = sum(won) / len(won)
        # The map metrics are optional: closed loop alone makes a table too.
        maps_file = folder / f"{name.split(':')[-1]}-maps.json"
        maps = read_json_object(maps_file)["metrics"] if maps_file.is_file() else {}
        out["models"][name] = {
            "top1": top1,
            "gap_closed": (top1 - r) / (o - r) if o > r else None,
            # At 60 configurations a robot the share is uncertain by +-0.1 to 0.15.
            "gap_closed_95": list(gap_closed_interval(won, oracle, random)) if o > r else None,
            "pcc": maps.get("pcc"),
            "sim": maps.get("sim"),
        }
        out["outcomes"][name] = won
    return out


def pair_tests(sets: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """McNemar of each pair per robot set and pooled over the held-out sets."""
    tests: dict[str, Any] = {}
    every = [m for m in MODELS if all(m in s["models"] for s in sets.values())]
    for a, b in [(a, b) for a, b in PAIRS if a in every and b in every]:
        row: dict[str, Any] = {}
        pooled_a: list[int] = []
        pooled_b: list[int] = []
        for name, s in sets.items():
            only_a, only_b, p = mcnemar(s["outcomes"][a], s["outcomes"][b])
            row[name] = {"only_a": only_a, "only_b": only_b, "p": p}
            if name != TRAINED:
                pooled_a += s["outcomes"][a]
                pooled_b += s["outcomes"][b]
        only_a, only_b, p = mcnemar(pooled_a, pooled_b)
        row["held-out, pooled"] = {"only_a": only_a, "only_b": only_b, "p": p}
        tests[f"{a} vs {b}"] = row
    return tests


def goals(sets: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Each model's figures against the goals on every held-out robot set."""
    trained = sets[TRAINED]["models"] if TRAINED in sets else None
    held_out = [s for n, s in sets.items() if n != TRAINED]
    out: dict[str, Any] = {}
    # The models every held-out set scored (the trained set may hold others, or lack one).
    for name in [m for m in MODELS if all(m in s["models"] for s in held_out)]:
        rows = {}
        for set_name, s in sets.items():
            if set_name == TRAINED:
                continue
            m = s["models"][name]
            # Without the trained robots' set the PCC goal cannot be judged: None.
            pccs = (
                None if trained is None or name not in trained else (trained[name]["pcc"], m["pcc"])
            )
            drop = None if pccs is None or None in pccs else pccs[0] - pccs[1]
            closed = m["gap_closed"]
            rows[set_name] = {
                "gap_closed": closed,
                "gap_closed_met": closed is not None and closed >= GAP_CLOSED,
                "pcc_drop": drop,
                "pcc_met": None if drop is None else drop <= PCC_DROP,
            }
        out[name] = rows
    return out


def markdown(report: dict[str, Any]) -> str:
    sets = report["sets"]
    models = [m for m in MODELS if any(m in s["models"] for s in sets.values())]
    lines = [
        "| robots | configurations | oracle | random | "
        + " | ".join(f"{MODELS[m]} Top-1 (gap closed [95 % interval], PCC)" for m in models)
        + " |",
        "| --- | ---: | ---: | ---: | " + " | ".join("---:" for _ in models) + " |",
    ]
    for name, s in sets.items():
        cells = []
        for model in models:
            if model not in s["models"]:
                cells.append("–")
                continue
            m = s["models"][model]
            closed = "–"
            if m["gap_closed"] is not None:
                lo, hi = m["gap_closed_95"]
                closed = f"{m['gap_closed']:.2f} [{lo:.2f}–{hi:.2f}]"
            pcc = "–" if m["pcc"] is None else f"{m['pcc']:.3f}"
            cells.append(f"{100 * m['top1']:.1f} % ({closed}, {pcc})")
        lines.append(
            f"| {name} ({', '.join(s['robots'])}) | {s['configurations']} | "
            f"{100 * s['oracle']:.1f} % | {100 * s['random']:.1f} % | " + " | ".join(cells) + " |"
        )
    lines += ["", "| McNemar (only a / only b, p) | " + " | ".join(sets) + " | held-out, pooled |"]
    lines.append("| --- | " + " | ".join("---" for _ in range(len(sets) + 1)) + " |")
    for pair, row in report["mcnemar"].items():
        cells = [f"{t['only_a']} / {t['only_b']}, {t['p']:.2g}" for t in row.values()]
        lines.append(f"| {pair} | " + " | ".join(cells) + " |")
    lines += ["", f"Goals (gap closed >= {GAP_CLOSED}, PCC within {PCC_DROP} of `trained`):", ""]
    for model, rows in report["goals"].items():
        # A goal that cannot be judged (no trained set: pcc_met None) counts as missed.
        met = [k for k, v in rows.items() if v["gap_closed_met"] and v["pcc_met"]]
        missed = {k: v for k, v in rows.items() if not (v["gap_closed_met"] and v["pcc_met"])}
        text = ", ".join(
            f"{k} (gap closed {'–' if v['gap_closed'] is None else format(v['gap_closed'], '.2f')},"
            + (
                " PCC not judged)"
                if v["pcc_drop"] is None
                else f" PCC {-v['pcc_drop']:+.3f} vs trained)"
            )
            for k, v in missed.items()
        )
        lines.append(
            f"- {MODELS[model]}: met on {len(met)} of {len(rows)}"
            + (f"; missed on {text}" if missed else "")
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", type=Path)
    args = ap.parse_args()
    folders = sorted(p for p in args.dir.iterdir() if (p / "msr.json").is_file())
    if not [p for p in folders if p.name != TRAINED]:
        raise MomaError(f"{args.dir} holds no held-out robot folder with an msr.json")
    # The trained robots first, then the held-out sets in name order.
    folders.sort(key=lambda p: (p.name != TRAINED, p.name))
    sets = {p.name: robot_set(p) for p in folders}
    report = {"sets": sets, "mcnemar": pair_tests(sets), "goals": goals(sets)}
    atomic_write_text(args.dir / "report.json", dumps_strict(report, indent=1) + "\n")
    text = markdown(report)
    atomic_write_text(args.dir / "report.md", text)
    print(text, end="")


if __name__ == "__main__":
    run_main(main, "anyarm_report.py")
