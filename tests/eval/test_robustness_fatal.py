"""A model whose maps are not finite stops the robustness track: it is not a bad view."""

from __future__ import annotations

import pytest

from momakitchen.eval.robustness.track import run_robustness
from momakitchen.eval.robustness.views import RobustnessConfig
from momakitchen.models import inference
from momakitchen.models.inference import NonFiniteOutput


def test_a_broken_model_stops_the_run(real_dataset, tiny_run, monkeypatch):
    def broken(*args, **kwargs):
        raise NonFiniteOutput("checkpoint 'tiny' gave non-finite affordances")

    monkeypatch.setattr(inference, "predict_map", broken)
    cfg = RobustnessConfig(corruptions=("clean", "d435"), max_configs=1)
    with pytest.raises(NonFiniteOutput, match="non-finite"):
        run_robustness(real_dataset, [tiny_run], cfg)
