"""The label audit: do the ground-truth maps predict where the robot really succeeds?

For every configuration of a dataset (any scene ids) it measures, in physics and with the
labelling's own trial (:meth:`momakitchen.sim.trials.TrialRunner.run`):

- **feasibility**: a configuration is infeasible when no grid trial succeeded; the stage
  where its trials failed (beyond the grid's own base collisions and out-of-reach points)
  says why;
- **spatial stability**: every successful grid position re-run at ±3 cm and ±5 cm in x
  and in y (the base facing the target from there, as in MSR) and at ±10° of yaw; the
  fraction that still succeeds;
- **oracle MSR**: the MSR baselines ``oracle`` (the ground-truth map's best visible
  points), ``random`` and ``nearest`` on one view per configuration, exactly as
  ``momakitchen msr`` runs them, with the reason of every oracle Top-1 miss: no success
  on the grid at all, no floor near a success visible in the view, the point picked near a
  success (within half a grid cell) or away from it, and the failing stage;
- **view coverage**: the fraction of the views of feasible configurations that see floor
  within 10 cm of a successful grid position.

Results are grouped overall, per robot and per target (``fridge/door``, ``bottle``...).
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.data.coverage import COVERAGE_RADIUS, near_any
from momakitchen.data.shard import SceneShard
from momakitchen.errors import MomaError
from momakitchen.eval.msr import BASELINES, MsrConfig, run_configuration
from momakitchen.sim.config import STAGE_NAMES, Stage

# Stages that say where the grid is, not how well the routine manipulates.
GEOMETRY_STAGES = (Stage.BASE_COLLISION, Stage.OUT_OF_REACH)
MISS_REASONS = ("infeasible", "not_visible", "near_success", "away_from_success")


@dataclass(frozen=True)
class AuditConfig:
    """Settings of the label audit (metres, degrees).

    Attributes:
        offsets: distances of the stability re-runs, each applied +/- in x and in y.
        yaw_offset_deg: the yaw re-runs turn the base this much either way.
        coverage_radius: a view covers a feasible configuration if it sees floor this close
            to a successful grid position.
        near_success: an oracle pick this close to a successful grid position counts as
            "near a success" (half the 10 cm grid spacing).
        max_stability_points: re-run at most this many successful positions per
            configuration, evenly spread (0: all; the audit's figures use all).
        msr: the MSR settings of the oracle, random and nearest picks.
    """

    offsets: tuple[float, ...] = (0.03, 0.05)
    yaw_offset_deg: float = 10.0
    coverage_radius: float = COVERAGE_RADIUS
    near_success: float = 0.05
    max_stability_points: int = 0
    msr: MsrConfig = field(default_factory=lambda: MsrConfig(split="all"))

    def __post_init__(self) -> None:
        if not self.offsets or not all(0.0 < d <= 0.5 for d in self.offsets):
            raise MomaError(f"AuditConfig.offsets must be in (0, 0.5] m, got {self.offsets}")
        if not 0.0 <= self.yaw_offset_deg <= 90.0:
            raise MomaError(
                f"AuditConfig.yaw_offset_deg must be in [0, 90], got {self.yaw_offset_deg}"
            )
        if not 0.0 < self.coverage_radius <= 1.0:
            raise MomaError(
                f"AuditConfig.coverage_radius must be in (0, 1] m, got {self.coverage_radius}"
            )
        if not 0.0 < self.near_success <= 1.0:
            raise MomaError(
                f"AuditConfig.near_success must be in (0, 1] m, got {self.near_success}"
            )
        if self.max_stability_points < 0:
            raise MomaError(
                f"AuditConfig.max_stability_points must be >= 0, got {self.max_stability_points}"
            )


def _offset_keys(config: AuditConfig) -> list[str]:
    return [f"{round(100 * d)}cm" for d in config.offsets] + [f"yaw{config.yaw_offset_deg:g}"]


def _stability(
    runner: Any, successes: np.ndarray, anchor: Sequence[float], config: AuditConfig
) -> dict[str, dict[str, list[int]]]:
    """Re-run the successful grid positions ``successes`` (S, 2) displaced; per offset key,
    the outcomes (1/0) and failing stages of every re-run."""
    *shift_keys, yaw_key = keys = _offset_keys(config)
    out: dict[str, dict[str, list[int]]] = {k: {"outcomes": [], "stages": []} for k in keys}

    def record(key: str, x: float, y: float, yaw: float | None = None) -> None:
        trial = runner.run(x, y, yaw)
        out[key]["outcomes"].append(int(trial.success))
        out[key]["stages"].append(int(trial.stage))

    points = successes
    if config.max_stability_points and len(points) > config.max_stability_points:
        keep = np.linspace(0, len(points) - 1, config.max_stability_points).round().astype(int)
        points = points[keep]
    for x, y in points:
        for d, key in zip(config.offsets, shift_keys, strict=True):
            for dx, dy in ((d, 0.0), (-d, 0.0), (0.0, d), (0.0, -d)):
                record(key, float(x + dx), float(y + dy))
        facing = math.atan2(anchor[1] - y, anchor[0] - x)
        for sign in (1.0, -1.0):
            record(yaw_key, float(x), float(y), facing + sign * math.radians(config.yaw_offset_deg))
    return out


def _audit_hook(shard: SceneShard, ci: int, config: AuditConfig) -> Callable[[Any, dict], None]:
    """The part of the audit that runs inside MSR's rebuilt world of configuration ``ci``."""

    def after(runner: Any, ctx: dict[str, Any]) -> None:
        record, labels = ctx["record"], ctx["labels"]
        stages = labels.trial_stages
        successes = labels.trial_positions[stages == Stage.SUCCESS]
        record["grid"] = {
            "trials": len(stages),
            "successes": len(successes),
            "stages": {
                n: int((stages == s).sum()) for s, n in zip(Stage, STAGE_NAMES, strict=True)
            },
        }
        record["stability"] = _stability(
            runner, successes, ctx["configuration"].target.anchor, config
        )
        # View coverage: every stored view of this configuration.
        record["views_covering"] = shard.covering(ci, config.coverage_radius)
        # Why the oracle's Top-1 pick failed, if it did.
        oracle = record["methods"]["oracle"]
        if oracle["outcomes"] and not oracle["outcomes"][0]:
            pick = np.asarray([oracle["points"][0]])
            if not len(successes):
                reason = "infeasible"
            elif not near_any(ctx["world_xy"], successes, config.coverage_radius).any():
                reason = "not_visible"
            elif near_any(pick, successes, config.near_success)[0]:
                reason = "near_success"
            else:
                reason = "away_from_success"
            record["oracle_miss"] = {
                "reason": reason,
                "stage": STAGE_NAMES[oracle["stages"][0]],
                "distance_to_success": (
                    round(float(np.min(np.hypot(*(successes - pick[0]).T))), 4)
                    if len(successes)
                    else None
                ),
            }

    return after


def audit_shard(
    path: str | Path, scene: Any, gen: Any, config: AuditConfig
) -> list[dict[str, Any]]:
    """Audit records of every configuration stored in the shard at ``path`` (scene
    ``scene``, rebuilt from the dataset's generation config ``gen``)."""
    records = []
    with SceneShard(path) as shard:
        for ci in shard.config_indices():
            record = run_configuration(
                shard, scene, ci, gen, {}, BASELINES, config.msr, _audit_hook(shard, ci, config)
            )
            if record is not None:
                records.append(record)
    return records


def _fraction(values: Iterable[float]) -> float | None:
    values = list(values)
    return float(np.mean(values)) if values else None


def summarize(records: list[dict[str, Any]], config: AuditConfig) -> dict[str, Any]:
    """The audit's figures over ``records``: overall, per robot and per target."""

    def figures(recs: list[dict[str, Any]]) -> dict[str, Any]:
        feasible = [r for r in recs if r["feasible"]]
        infeasible = [r for r in recs if not r["feasible"]]
        # The stage that kept infeasible configurations from succeeding.
        # Only stages that failed some trial count ("success" never does here: a zero count
        # is no failure), and the geometric ones only when nothing else failed.
        stages: Counter[str] = Counter()
        for r in infeasible:
            for name, n in r["grid"]["stages"].items():
                if n > 0 and Stage[name.upper()] not in (Stage.SUCCESS, *GEOMETRY_STAGES):
                    stages[name] += n
        if not stages:
            for r in infeasible:
                for name, n in r["grid"]["stages"].items():
                    if n > 0 and name != "success":
                        stages[name] += n
        out: dict[str, Any] = {
            "configurations": len(recs),
            "infeasible": _fraction(not r["feasible"] for r in recs),
            "infeasible_stage": stages.most_common(1)[0][0] if stages else None,
            "infeasible_stages": dict(stages.most_common()),
            "stability": {
                key: _fraction(o for r in recs for o in r["stability"][key]["outcomes"])
                for key in _offset_keys(config)
            },
            "stability_trials": {
                key: sum(len(r["stability"][key]["outcomes"]) for r in recs)
                for key in _offset_keys(config)
            },
            "coverage": _fraction(c for r in feasible for c in r["views_covering"]),
            "views": sum(len(r["views_covering"]) for r in feasible),
            "msr": {},
            "oracle_misses": dict(
                Counter(r["oracle_miss"]["reason"] for r in recs if "oracle_miss" in r)
            ),
            "oracle_miss_stages": dict(
                Counter(r["oracle_miss"]["stage"] for r in recs if "oracle_miss" in r)
            ),
        }
        for name in BASELINES:
            top1 = [r["methods"][name]["outcomes"][:1] or [0] for r in recs]
            topk = [_fraction(r["methods"][name]["outcomes"]) or 0.0 for r in recs]
            top1_f = [r["methods"][name]["outcomes"][:1] or [0] for r in feasible]
            topk_f = [_fraction(r["methods"][name]["outcomes"]) or 0.0 for r in feasible]
            out["msr"][name] = {
                "top1": _fraction(o[0] for o in top1),
                "topk": _fraction(topk),
                "top1_feasible": _fraction(o[0] for o in top1_f),
                "topk_feasible": _fraction(topk_f),
            }
        return out

    groups: dict[str, dict[str, list[dict[str, Any]]]] = {
        "per_robot": defaultdict(list),
        "per_target": defaultdict(list),
    }
    for r in records:
        groups["per_robot"][r["robot"]].append(r)
        groups["per_target"][r["target"]].append(r)
    return {
        "overall": figures(records),
        **{g: {k: figures(v) for k, v in sorted(d.items())} for g, d in groups.items()},
    }


def _pct(value: float | None) -> str:
    return "–" if value is None else f"{100 * value:.0f} %"


def format_audit_table(summary: dict[str, Any], config: AuditConfig) -> str:
    """Markdown table of the audit: one row overall, then per robot and per target."""
    keys = _offset_keys(config)
    head = [
        "group",
        "configs",
        "infeasible",
        "dominant failure (infeasible)",
        *(f"stable ±{k}" for k in keys),
        "oracle Top-1 (all / feasible)",
        "oracle Top-5",
        "random Top-1",
        "nearest Top-1",
        "view coverage",
    ]

    def row(name: str, f: dict[str, Any]) -> str:
        o, m = f["msr"]["oracle"], f["msr"]
        cells = [
            name,
            str(f["configurations"]),
            _pct(f["infeasible"]),
            f["infeasible_stage"] or "–",
            *(_pct(f["stability"][k]) for k in keys),
            f"{_pct(o['top1'])} / {_pct(o['top1_feasible'])}",
            _pct(o["topk"]),
            _pct(m["random"]["top1"]),
            _pct(m["nearest"]["top1"]),
            _pct(f["coverage"]),
        ]
        return "| " + " | ".join(cells) + " |"

    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines.append(row("**all**", summary["overall"]))
    for group in ("per_robot", "per_target"):
        for name, f in summary[group].items():
            lines.append(row(name, f))
    return "\n".join(lines)


def audit_figure(summary: dict[str, Any], config: AuditConfig) -> bytes:
    """PNG, as wide as a page shows it: per robot and per target (configurations in
    brackets), the infeasible share, oracle Top-1 over feasible configurations, stability
    at the smallest offset and view coverage, in %; dashed lines in each bar's colour mark
    the figure the ground truth must reach."""
    from itertools import pairwise

    from matplotlib.lines import Line2D

    from momakitchen.perception.figures import DOC_WIDTH, png_bytes, pyplot, text_sizes

    plt = pyplot()
    small = _offset_keys(config)[0]
    shift = small.removesuffix("cm") + " cm" if small.endswith("cm") else small
    bars = (
        ("infeasible configurations", "≤", lambda f: f["infeasible"], 0.10),
        ("oracle Top-1 (feasible)", "≥", lambda f: f["msr"]["oracle"]["top1_feasible"], 0.90),
        (f"positions stable at ±{shift}", "≥", lambda f: f["stability"][small], 0.90),
        ("view coverage", "≥", lambda f: f["coverage"], 0.95),
    )
    groups = (("per_robot", "robot"), ("per_target", "target"))
    with plt.rc_context(text_sizes()):
        fig, axes = plt.subplots(2, 1, figsize=(DOC_WIDTH, 7.6), layout="constrained")
        for ax, (group, noun) in zip(axes, groups, strict=True):
            names = ["all", *summary[group]]
            rows = [summary["overall"], *summary[group].values()]
            x = np.arange(len(names))
            width = 0.8 / len(bars)
            # The legend shows the last panel's bars (every panel has the same colours).
            handles: list[Any] = []
            for j, (label, sign, get, goal) in enumerate(bars):
                values = [100 * get(f) if get(f) is not None else np.nan for f in rows]
                offset = (j - (len(bars) - 1) / 2) * width
                bar = ax.bar(
                    x + offset, values, width, label=f"{label} (goal {sign} {100 * goal:.0f} %)"
                )
                handles.append(bar)
                ax.hlines(
                    100 * goal,
                    x[0] - 0.45,
                    x[-1] + 0.45,
                    colors=bar.patches[0].get_facecolor(),
                    linestyles="dashed",
                    linewidth=1.0,
                )
            labels = [f"{n}\n({f['configurations']})" for n, f in zip(names, rows, strict=True)]
            ax.set_xticks(x, labels)
            ax.set_xlim(x[0] - 0.5, x[-1] + 0.5)
            ax.set_ylim(0, 105)
            ax.set_ylabel("share (%)")
            ax.set_xlabel(f"{noun} (configurations)")
            ax.set_title(f"label audit per {noun}")
        goal_line = Line2D([], [], color="0.3", linestyle="dashed", linewidth=1.0)
        fig.legend(
            [*handles, goal_line],
            [*(h.get_label() for h in handles), "goal (dashed, in its bar's colour)"],
            loc="outside upper center",
            ncols=2,
        )
        # Names that do not fit side by side stand upright, one line each.
        fig.canvas.draw()
        for ax in axes:
            ticks = [t for t in ax.get_xticklabels() if t.get_text()]
            boxes = [t.get_window_extent() for t in ticks]
            if any(a.x1 + 2 > b.x0 for a, b in pairwise(boxes)):
                for t in ticks:
                    t.set_text(t.get_text().replace("\n", " "))
                ax.set_xticks(ax.get_xticks(), [t.get_text() for t in ticks], rotation=90)
        return png_bytes(fig)
