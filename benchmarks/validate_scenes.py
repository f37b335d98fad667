"""Validate many procedurally generated kitchens in physics and time their construction.

For each scene id: sample the scene (pure data), build it in PyBullet, and for every
configuration check that nothing interpenetrates at spawn and that nothing falls through
or flies away in 1 s of physics; pull every articulated part once per scene.

    python benchmarks/validate_scenes.py --scenes 200 --json out/validate.json

Prints a Markdown summary (for BENCHMARKS.md) and exits 1 if any check failed.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import json
import statistics
import sys
import time
from pathlib import Path

from tqdm import tqdm

from momakitchen.assets import CATEGORIES
from momakitchen.scene.configuration import SceneConfig, sample_scene
from momakitchen.sim.validate import pull_test, settle_check
from momakitchen.sim.world import World

MAX_DISPLACEMENT = 0.02  # m in 1 s: anything more is "moving", far more is "flying away"


def validate(scene_id: int, cfg: SceneConfig) -> dict:
    t0 = time.perf_counter()
    scene = sample_scene(scene_id, cfg)
    t_sample = time.perf_counter() - t0
    t0 = time.perf_counter()
    world = World(scene.layout)
    world.load_configuration(scene.configurations[0])
    t_build = time.perf_counter() - t0
    res: dict = {
        "scene_id": scene_id,
        "t_sample": t_sample,
        "t_build": t_build,
        "penetrations": [],
        "unstable": [],
        "stuck_joints": [],
        "openings": [],
        "instances": collections.defaultdict(list),
    }
    for unit in scene.layout.furniture:
        res["instances"][unit.category].append(repr(unit.params))
    try:
        for k, c in enumerate(scene.configurations):
            world.load_configuration(c)
            for placed in (*c.objects, *c.obstacles):
                res["instances"][placed.category].append(repr(placed.params))
            res["penetrations"] += [(k, *pair) for pair in world.penetrations()]
            rep = settle_check(world, 1.0)
            if rep.max_displacement > MAX_DISPLACEMENT or rep.min_z < -0.01:
                res["unstable"].append((k, rep.worst_uid, rep.max_displacement, rep.min_z))
        for unit in scene.layout.furniture:
            for i, art in enumerate(unit.model.articulations):
                opened = pull_test(world, unit.uid, i)
                need = 0.02 if art.joint_type == "prismatic" else 0.035  # 2 cm / 2 degrees
                res["openings"].append((unit.category, art.part, art.joint_type, opened))
                if opened < need:
                    res["stuck_joints"].append((unit.uid, unit.category, art.part, opened))
    finally:
        world.close()
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=200)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    cfg = SceneConfig()
    results = [
        validate(s, cfg)
        for s in tqdm(range(args.first, args.first + args.scenes), desc="scenes", unit="scene")
    ]
    instances: dict[str, set] = collections.defaultdict(set)
    for r in results:
        for cat, reprs in r["instances"].items():
            instances[cat].update(reprs)
    failures = {
        key: [(r["scene_id"], *x) for r in results for x in r[key]]
        for key in ("penetrations", "unstable", "stuck_joints")
    }
    openings = collections.defaultdict(list)
    for r in results:
        for cat, part, jtype, opened in r["openings"]:
            openings[(cat, part, jtype)].append(opened)
    print(
        f"\n## Scene validation: {args.scenes} scene ids from {args.first}, "
        f"{cfg.configs_per_scene} configurations each\n"
    )
    for key, what in (("t_sample", "sample (pure data)"), ("t_build", "build in PyBullet")):
        med = statistics.median(r[key] for r in results)
        print(f"- {what} per scene: median {med * 1e3:.0f} ms")
    for key, rows in failures.items():
        print(f"- {key}: {len(rows)}" + (f" (first: {rows[:3]})" if rows else ""))
    missing = sorted(set(CATEGORIES) - set(instances))
    print(
        f"- categories covered: {len(instances)}/{len(CATEGORIES)}"
        + (f", missing {missing}" if missing else "")
    )
    print("\n| category | distinct instances |\n| --- | ---: |")
    for cat in sorted(instances):
        print(f"| {cat} | {len(instances[cat])} |")
    print("\n| articulated part | joint | pulls | median opening after 0.6 s at 40 N |")
    print("| --- | --- | ---: | ---: |")
    for (cat, part, jtype), vals in sorted(openings.items()):
        med = statistics.median(vals)
        shown = f"{med * 57.2958:.0f} deg" if jtype == "revolute" else f"{med * 100:.1f} cm"
        print(f"| {cat}/{part} | {jtype} | {len(vals)} | {shown} |")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        summary = {
            "scenes": args.scenes,
            "first": args.first,
            "scene_config": dataclasses.asdict(cfg),
            "failures": failures,
            "instances": {k: len(v) for k, v in instances.items()},
            "t_build": [r["t_build"] for r in results],
        }
        args.json.write_text(json.dumps(summary, indent=1, default=str))
    return 1 if any(failures.values()) or missing else 0


if __name__ == "__main__":
    sys.exit(main())
