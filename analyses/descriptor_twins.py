"""Two arms the robot descriptor cannot tell apart: how far one's ground truth serves the
other (docs/RESULTS.md, "Robots the model never saw").

A model reads the scene and the descriptor (version 1: reach, mount height, DoF, suction),
so two arms with the same descriptor on the same configuration get the same map and the
same picks. Given two datasets labelled on the same configurations by such arms (A and B):

1. the **joint ceiling** from the labelled grid: per configuration, the best a single pick
   can do for both, max over grid positions of (success_A + success_B) / 2; its mean
   bounds the mean of the two arms' Top-1 rates for any descriptor-driven model (up to
   picks between grid points);
2. per target (category and part), the grid positions that succeed for A, for B and for
   both, and the stages at which A fails where only B succeeds (and the other way): where
   the two arms differ, and why;
3. a predictions file of B's ground-truth maps on A's views (``--out``), for
   ``momakitchen msr --data A --predictions FILE``: A standing where B's ground truth
   says, executed in physics.

    python3 analyses/descriptor_twins.py DATA_A DATA_B --out twin.npz
"""

from __future__ import annotations

import argparse
from collections import Counter, defaultdict

import numpy as np
from analysis_cli import run_main
from scipy.spatial import cKDTree

from momakitchen.data.shard import SceneShard, list_shards
from momakitchen.errors import MomaError
from momakitchen.eval.predictions import episode_key
from momakitchen.fileio import atomic_path
from momakitchen.frames import base_to_world_xy
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import descriptor_dim, get_robot_spec
from momakitchen.sim.config import STAGE_NAMES


class _Target:
    """Per target: configurations, successful grid positions of A, B and both, and the
    stages of the positions that succeed for one arm only (A's failures, B's failures)."""

    def __init__(self) -> None:
        self.configurations = 0
        self.a = self.b = self.both = 0
        self.a_fails: Counter[str] = Counter()
        self.b_fails: Counter[str] = Counter()

    def add(self, stages_a: np.ndarray, stages_b: np.ndarray) -> None:
        ok_a, ok_b = stages_a == 0, stages_b == 0
        self.configurations += 1
        self.a += int(ok_a.sum())
        self.b += int(ok_b.sum())
        self.both += int((ok_a & ok_b).sum())
        self.a_fails.update(STAGE_NAMES[s] for s in stages_a[ok_b & ~ok_a])
        self.b_fails.update(STAGE_NAMES[s] for s in stages_b[ok_a & ~ok_b])


def _stages(c: Counter[str]) -> str:
    return ", ".join(f"{name} {n}" for name, n in c.most_common()) or "–"


def _target_table(robot_a: str, robot_b: str, targets: dict[str, _Target]) -> str:
    rows = [
        f"| target | configurations | positions {robot_a} | {robot_b} | both "
        f"| {robot_a} fails where only {robot_b} succeeds | {robot_b} fails where only "
        f"{robot_a} succeeds |",
        "| --- | ---: | ---: | ---: | ---: | --- | --- |",
    ]
    for name, t in sorted(targets.items()):
        rows.append(
            f"| {name} | {t.configurations} | {t.a} | {t.b} | {t.both} "
            f"| {_stages(t.a_fails)} | {_stages(t.b_fails)} |"
        )
    return "\n".join(rows)


def _descriptor(labels) -> tuple[float, ...]:
    # Version 1 (the bundled model's): version 2 adds the finger force, which is what
    # tells the twins of results/anyarm/twins apart.
    full = robot_descriptor(get_robot_spec(labels.robot), labels.mount_height)
    return full[: descriptor_dim(1)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data_a")
    ap.add_argument("data_b")
    ap.add_argument("--out", help="predictions file (.npz): B's ground truth on A's views")
    args = ap.parse_args()
    a_shards, b_shards = list_shards(args.data_a), list_shards(args.data_b)
    if not a_shards:
        raise MomaError(f"{args.data_a!r} holds no scene shards")
    if sorted(a_shards) != sorted(b_shards):
        raise MomaError(f"{args.data_a!r} and {args.data_b!r} hold different scenes")
    joint, only_a, only_b, both, n = [], 0, 0, 0, 0
    maps: dict[str, np.ndarray] = {}
    targets: dict[str, _Target] = defaultdict(_Target)
    for sid in sorted(a_shards):
        with SceneShard(a_shards[sid]) as sa, SceneShard(b_shards[sid]) as sb:
            for ci in sa.config_indices():
                la, lb = sa.configuration(ci), sb.configuration(ci)
                if _descriptor(la) != _descriptor(lb):
                    raise MomaError(f"{la.robot} and {lb.robot}: the descriptors differ")
                if la.anchor != lb.anchor or not np.array_equal(
                    la.trial_positions, lb.trial_positions
                ):
                    raise MomaError(f"scene {sid} configuration {ci}: not the same configuration")
                sa_ok, sb_ok = la.trial_stages == 0, lb.trial_stages == 0
                n += 1
                targets[la.target].add(la.trial_stages, lb.trial_stages)
                joint.append(float(np.max((sa_ok.astype(float) + sb_ok) / 2, initial=0.0)))
                both += bool((sa_ok & sb_ok).any())
                only_a += bool(sa_ok.any() and not (sa_ok & sb_ok).any())
                only_b += bool(sb_ok.any() and not (sa_ok & sb_ok).any())
                if args.out:  # B's ground-truth floor labels, moved onto A's floor points
                    b_eps = [e for e in sb.episode_indices(ci) if sb.num_points(ci, e)[1] > 0]
                    for ea in sa.episode_indices(ci):
                        a_ep = sa.episode(ci, ea)
                        if len(a_ep.floor_xyz) == 0:
                            continue
                        key = episode_key(sid, ci, ea)
                        if not b_eps:  # B saw no floor in this configuration
                            maps[key] = np.zeros(len(a_ep.floor_xyz), np.float32)
                            continue
                        b_ep = sb.episode(ci, ea if ea in b_eps else b_eps[0])
                        xa = base_to_world_xy(a_ep.floor_xyz[:, :2].astype(float), a_ep.base_pose)
                        xb = base_to_world_xy(b_ep.floor_xyz[:, :2].astype(float), b_ep.base_pose)
                        _, nearest = cKDTree(xb).query(xa)
                        maps[key] = b_ep.floor_label[nearest].astype(np.float32)
    print(
        f"{n} configurations; a position succeeds for both arms in {both}, for "
        f"{la.robot} only in {only_a}, for {lb.robot} only in {only_b}"
    )
    print(f"joint ceiling (mean of the two Top-1 rates, grid picks): {100 * np.mean(joint):.1f} %")
    print(_target_table(la.robot, lb.robot, targets))
    if args.out:
        with atomic_path(args.out) as tmp:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **maps)
        print(f"{len(maps)} episodes -> {args.out}")


if __name__ == "__main__":
    run_main(main, "descriptor_twins.py")
