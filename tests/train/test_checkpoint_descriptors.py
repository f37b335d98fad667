"""Runs of an older robot descriptor: they load and read their own columns, start a
newer run with widened weights (`train --init`), and resume as they were."""

from __future__ import annotations

import dataclasses
import json

import pytest
import torch

from momakitchen.data.batch import collate_episodes
from momakitchen.errors import MomaError
from momakitchen.models import build_model
from momakitchen.models.inference import predict_batch
from momakitchen.robots.spec import DESCRIPTOR_DIM, DESCRIPTOR_VERSION
from momakitchen.train import load_checkpoint, train
from momakitchen.train.checkpoint import (
    WEIGHTS_FILE,
    default_checkpoint,
    load_weights,
    read_run_config,
)


@pytest.fixture(scope="module")
def old_run(tmp_path_factory, tiny_sets, make_config):
    """A navaff run of descriptor version 1, its config.json as runs made before models
    recorded the version wrote it (the bundled one's)."""
    run = tmp_path_factory.mktemp("v1") / "run"
    config = make_config(epochs=1).replace_model(descriptor_version=1, robot_head=True)
    train(config, tiny_sets[0], None, run)
    info = json.loads((run / "config.json").read_text())
    assert info["descriptor_version"] == 1 and len(info["descriptor_names"]) == 4
    del info["train_config"]["model_config"]["descriptor_version"]
    (run / "config.json").write_text(json.dumps(info))
    return run


def _batch(tiny_sets):
    return collate_episodes([tiny_sets[1][i] for i in range(3)], 256, 128)


def test_the_bundled_model_reads_version_1():
    config, info = read_run_config(default_checkpoint())
    assert info["descriptor_version"] == 1 and config.model_config.descriptor_dim == 4


def test_a_version_1_run_reads_only_its_four_columns(old_run, tiny_sets):
    loaded = load_checkpoint(old_run)
    assert loaded.config.model_config.descriptor_version == 1
    batch = _batch(tiny_sets)
    assert batch["robot"].shape[1] == DESCRIPTOR_DIM
    other = dict(batch, robot=batch["robot"].clone())
    other["robot"][:, 4] += 0.5
    assert torch.equal(predict_batch(loaded.model, batch), predict_batch(loaded.model, other))


def test_widened_weights_predict_what_the_old_model_did(old_run, tiny_sets):
    loaded = load_checkpoint(old_run)
    wide_config = dataclasses.replace(loaded.config.model_config, descriptor_version=2)
    wide = build_model("navaff", wide_config)
    load_weights(old_run / WEIGHTS_FILE, wide, descriptor_from=4)
    wide.eval()
    batch = _batch(tiny_sets)
    assert torch.allclose(predict_batch(wide, batch), predict_batch(loaded.model, batch), atol=1e-6)
    without = build_model("navaff", wide_config)
    # The first layer of each module that reads the descriptor has 4 input columns.
    unwidened = r"(robot_tokenizer\.mlp|robot_mlp)\.0\.weight' has shape \(\d+, 4\)"
    with pytest.raises(MomaError, match=unwidened):
        load_weights(old_run / WEIGHTS_FILE, without)


def test_init_from_a_version_1_run_trains_a_current_one(old_run, tiny_sets, make_config, tmp_path):
    config = make_config(epochs=1, init=str(old_run)).replace_model(robot_head=True)
    assert config.model_config.descriptor_version == DESCRIPTOR_VERSION
    result = train(config, tiny_sets[0], None, tmp_path / "new")
    info = json.loads((tmp_path / "new" / "config.json").read_text())
    assert info["descriptor_version"] == DESCRIPTOR_VERSION
    assert info["train_config"]["model_config"]["descriptor_version"] == DESCRIPTOR_VERSION
    weight = result.model.state_dict()["backbone.robot_tokenizer.mlp.0.weight"]
    assert weight.shape[1] == DESCRIPTOR_DIM
    # A current run does not start a version-1 one.
    with pytest.raises(
        MomaError, match=f"reads robot descriptor version {DESCRIPTOR_VERSION}, newer than this"
    ):
        train(
            make_config(epochs=1, init=str(tmp_path / "new")).replace_model(
                descriptor_version=1, robot_head=True
            ),
            tiny_sets[0],
            None,
            tmp_path / "back",
        )


def test_a_version_1_run_resumes_as_version_1(old_run, tiny_sets, make_config, tmp_path):
    import shutil

    run = tmp_path / "resumed"
    shutil.copytree(old_run, run)
    config = make_config(epochs=2).replace_model(robot_head=True)  # the current version asked
    result = train(config, tiny_sets[0], None, run, resume=True)
    assert result.model.config.descriptor_version == 1
    assert load_checkpoint(run).config.model_config.descriptor_dim == 4


def test_config_and_model_disagreeing_on_the_version_is_refused(old_run, tmp_path):
    import shutil

    run = tmp_path / "bad"
    shutil.copytree(old_run, run)
    info = json.loads((run / "config.json").read_text())
    info["train_config"]["model_config"]["descriptor_version"] = 2
    (run / "config.json").write_text(json.dumps(info))
    with pytest.raises(
        MomaError, match=r"descriptor_version 1 but model_config.descriptor_version 2"
    ):
        load_checkpoint(run)
