"""Evaluation: map metrics (:mod:`.metrics`). Model evaluation on a dataset:
:func:`momakitchen.train.evaluate`."""

from momakitchen.eval.metrics import (
    METRIC_NAMES,
    breakdown,
    episode_metrics,
    format_table,
    map_metrics,
)

__all__ = ["METRIC_NAMES", "breakdown", "episode_metrics", "format_table", "map_metrics"]
