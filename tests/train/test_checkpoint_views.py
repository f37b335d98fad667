"""A run records how far its training views stood (config.json ``view_distance``)."""

import pytest

from momakitchen.data.config import ViewConfig, manifest_view_distance
from momakitchen.errors import MomaError


def test_the_farthest_view_comes_from_the_datasets_views():
    assert ViewConfig().farthest == pytest.approx((3.8**2 + 1.5**2) ** 0.5)
    assert ViewConfig(distance=(0.75, 6.0)).farthest == 6.0
    from momakitchen.data.config import GENERATION_CONFIG_CLASS

    manifest = {"config_class": GENERATION_CONFIG_CLASS, "config": {"views": {"distance": [1, 5]}}}
    assert manifest_view_distance(manifest) == 5.0
    assert manifest_view_distance({"config_class": "synthetic", "config": {}}) is None
    with pytest.raises(MomaError, match=r"config\.views must be a mapping"):
        manifest_view_distance({"config_class": GENERATION_CONFIG_CLASS, "config": {"views": 3}})


def test_a_run_records_its_training_views_and_loads_them(tiny_run):
    from momakitchen.train import load_checkpoint

    # the tiny run trained on synthetic records: nothing to record, the default applies
    assert load_checkpoint(tiny_run).view_distance is None
