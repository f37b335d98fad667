"""Map metrics of predicted vs ground-truth affordance maps (docs/DESIGN.md §3.7).

Every metric is computed per episode on the 1-D arrays of its floor-point values, then
averaged over episodes, except RMSE = sqrt(mean of the per-episode MSEs):

- ``mae``: mean |p - g|
- ``mse``: mean (p - g)^2; ``rmse``: sqrt of the episode-averaged MSE
- ``logmse``: mean (log1p p - log1p g)^2
- ``pcc``: Pearson correlation; 0 where either map is constant
- ``sim``: histogram intersection sum(min(p / (sum p + 1e-12), g / (sum g + 1e-12)))
- ``cos``: cosine similarity; 0 where either map is all zero
- ``ciou``: sum(min(p, g)) / sum(max(p, g)); 0 where both maps are all zero

No metric is ever NaN.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence

import numpy as np

from momakitchen.errors import MomaError

METRIC_NAMES = ("mae", "mse", "rmse", "logmse", "pcc", "sim", "cos", "ciou")
LOWER_IS_BETTER = frozenset({"mae", "mse", "rmse", "logmse"})
SIM_EPS = 1e-12


def episode_metrics(pred: np.ndarray, gt: np.ndarray) -> dict[str, float]:
    """Metrics of one episode (``rmse`` here is sqrt of this episode's MSE).

    Shapes:
        - ``pred``, ``gt``: (n,) with n >= 1
    """
    p = np.asarray(pred, dtype=np.float64).reshape(-1)
    g = np.asarray(gt, dtype=np.float64).reshape(-1)
    if p.shape != g.shape:
        raise MomaError(f"prediction has {p.shape[0]} values but the map has {g.shape[0]}")
    if p.size == 0:
        raise MomaError("an episode map has no floor points")
    if not (np.isfinite(p).all() and np.isfinite(g).all()):
        raise MomaError("maps must be finite (found NaN or inf)")
    diff = p - g
    mse = float(np.mean(diff**2))
    out = {
        "mae": float(np.mean(np.abs(diff))),
        "mse": mse,
        "rmse": float(np.sqrt(mse)),
        "logmse": float(np.mean((np.log1p(p) - np.log1p(g)) ** 2)),
    }
    if np.ptp(p) == 0 or np.ptp(g) == 0:
        out["pcc"] = 0.0
    else:
        pc, gc = p - p.mean(), g - g.mean()
        denom = np.sqrt(np.sum(pc**2) * np.sum(gc**2))
        out["pcc"] = float(np.sum(pc * gc) / denom) if denom > 0 else 0.0
    out["sim"] = float(np.sum(np.minimum(p / (p.sum() + SIM_EPS), g / (g.sum() + SIM_EPS))))
    norm = np.linalg.norm(p) * np.linalg.norm(g)
    out["cos"] = float(np.dot(p, g) / norm) if norm > 0 else 0.0
    big = np.sum(np.maximum(p, g))
    out["ciou"] = float(np.sum(np.minimum(p, g)) / big) if big > 0 else 0.0
    return out


def map_metrics(preds: Sequence[np.ndarray], gts: Sequence[np.ndarray]) -> dict[str, float]:
    """Episode-averaged map metrics.

    Shapes:
        - ``preds``, ``gts``: lists of E arrays, episode i of shape (n_i,)
        - output: ``{name: float}`` for ``METRIC_NAMES``
    """
    if len(preds) != len(gts):
        raise MomaError(f"{len(preds)} predictions but {len(gts)} ground-truth maps")
    if len(preds) == 0:
        raise MomaError("no episodes to evaluate")
    per = [episode_metrics(p, g) for p, g in zip(preds, gts, strict=True)]
    out = {k: float(np.mean([e[k] for e in per])) for k in METRIC_NAMES if k != "rmse"}
    out["rmse"] = float(np.sqrt(out["mse"]))
    return {k: out[k] for k in METRIC_NAMES}


def breakdown(
    preds: Sequence[np.ndarray], gts: Sequence[np.ndarray], keys: Sequence[Hashable]
) -> dict[Hashable, dict[str, float]]:
    """Map metrics per group of episodes (e.g. keys = scene ids or robot names).

    Returns ``{key: metrics + {"episodes": count}}`` in sorted key order.
    """
    if not len(preds) == len(gts) == len(keys):
        raise MomaError(
            f"breakdown needs one key per episode: {len(preds)} predictions, "
            f"{len(gts)} maps, {len(keys)} keys"
        )
    groups: dict[Hashable, list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(k, []).append(i)
    out: dict[Hashable, dict[str, float]] = {}
    for k in sorted(groups, key=lambda x: (str(type(x)), x)):
        idx = groups[k]
        m = map_metrics([preds[i] for i in idx], [gts[i] for i in idx])
        m["episodes"] = float(len(idx))
        out[k] = m
    return out


def format_table(
    rows: Mapping[str, Mapping[str, float]],
    columns: Sequence[str] = ("rmse", "logmse", "pcc", "sim", "mae", "cos", "ciou"),
    title: str = "Method",
    digits: int = 4,
) -> str:
    """A Markdown table like the paper's Table 2: one row per method (or group).

    Column headers carry ↓ (lower is better) or ↑; the best value per column is bold.
    """
    if not rows:
        raise MomaError("format_table needs at least one row")
    for name, m in rows.items():
        missing = [c for c in columns if c not in m]
        if missing:
            raise MomaError(f"row {name!r} lacks metrics {missing}")
    head = [title]
    for c in columns:
        label = "logMSE" if c == "logmse" else c.upper()
        head.append(f"{label} {'↓' if c in LOWER_IS_BETTER else '↑'}")
    best = {}
    for c in columns:
        vals = [float(m[c]) for m in rows.values()]
        best[c] = min(vals) if c in LOWER_IS_BETTER else max(vals)
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, m in rows.items():
        cells = [str(name)]
        for c in columns:
            v = f"{float(m[c]):.{digits}f}"
            cells.append(f"**{v}**" if len(rows) > 1 and float(m[c]) == best[c] else v)
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
