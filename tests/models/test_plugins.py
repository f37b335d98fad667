"""Model plug-ins: found through importlib.metadata entry points or a module path, used
like the built-in models (train, checkpoint, inference), and their bad cases."""

from __future__ import annotations

import json

import pytest
import torch

from momakitchen.data.batch import EpisodeCollator
from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
from momakitchen.errors import MomaError
from momakitchen.models import build_model, get_model_entry, model_names
from momakitchen.models.base import AffordanceModel
from momakitchen.models.config import TINY_MODEL
from momakitchen.models.plugins import PluginModel, plugin_names
from plugin_helpers import ENTRY_POINTS, on_path, write_distribution


@pytest.fixture()
def installed(tmp_path):
    """The external test package, installed (visible to importlib.metadata) for one test."""
    with on_path(write_distribution(tmp_path / "site", "mk-testplugin", ENTRY_POINTS)):
        yield


def _batch(n: int = 2):
    data = SyntheticEpisodes(SyntheticConfig(num_episodes=n, num_global=128, num_floor=64))
    return EpisodeCollator(128, 64)([data[i] for i in range(n)])


def test_entry_point_model_is_found_and_wrapped(installed):
    assert {"tinyaff", "tinyaff-backbone", "badshape", "broken"} <= set(plugin_names())
    entry = get_model_entry("tinyaff")
    assert entry.plugin and entry.description.startswith("Tiny per-point MLP")
    model = build_model("tinyaff", TINY_MODEL)
    assert isinstance(model, PluginModel) and isinstance(model, AffordanceModel)
    batch = _batch()
    batch["floor_mask"][1, 40:] = False  # padding: predictions there are 0
    out = model(batch)
    assert out["pred"].shape == (2, 64) and out["loss"].requires_grad
    pred = out["pred"].detach()
    assert float(pred[1, 40:].abs().sum()) == 0.0
    real = pred[batch["floor_mask"]]
    assert 0 < float(real.min()) and float(real.max()) < 1
    assert sorted(model.state_dict()) == sorted(f"net.{k}" for k in model.net.state_dict())
    # the built-in names are unchanged by looking a plug-in up
    assert "tinyaff" not in model_names()


def test_module_path_and_backbone_plugins(installed):
    model = build_model("mk_testplugin.models:TinyAffordance", TINY_MODEL)
    assert isinstance(model, PluginModel) and model.name == "mk_testplugin.models:TinyAffordance"
    # A Backbone gets the built-in head, conditioned on the robot like the baselines'.
    backbone = build_model("tinyaff-backbone", TINY_MODEL)
    assert type(backbone) is AffordanceModel and backbone.head.use_robot
    assert backbone(_batch())["pred"].shape == (2, 64)


def test_mc_dropout_of_a_plugin(installed):
    model = build_model("tinyaff", TINY_MODEL.__class__(**{**TINY_MODEL.to_dict(), "dropout": 0.5}))
    model.eval()
    one = EpisodeCollator(128, None, num_context=64)(
        [SyntheticEpisodes(SyntheticConfig(num_episodes=1, num_global=128, num_floor=64))[0]]
    )
    torch.manual_seed(0)
    samples = model.sample_predictions(one, 4)
    assert samples.shape == (4, one["floor_xyz"].shape[1])
    assert float(samples.std(0).max()) > 0  # dropout was active
    assert not model.training  # and the mode is restored


def test_train_save_and_load_a_plugin(installed, tmp_path):
    from momakitchen.train import load_checkpoint, train
    from momakitchen.train.config import TrainConfig

    data = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=128, num_floor=64))
    cfg = TrainConfig(
        model="tinyaff",
        preset="custom",
        model_config=TINY_MODEL,
        num_global=128,
        num_floor=64,
        epochs=1,
        batch_size=2,
        progress=False,
    )
    before = build_model("tinyaff", TINY_MODEL).state_dict()
    train(cfg, data, None, tmp_path / "run")
    info = json.loads((tmp_path / "run" / "config.json").read_text())
    assert info["model"] == "tinyaff" and info["train_config"]["model_config"]["width"] == 0.125
    run = load_checkpoint(tmp_path / "run", model="tinyaff")
    assert isinstance(run.model, PluginModel) and not run.model.training
    changed = any(not torch.equal(v, run.model.state_dict()[k]) for k, v in before.items())
    assert changed  # trained weights, not a fresh model


def test_plugin_errors_are_one_line(installed):
    with pytest.raises(MomaError, match=r"'broken'.*fails to import.*a_module_that_is_not"):
        get_model_entry("broken")
    with pytest.raises(MomaError, match=r"'badshape' returned \(2,\).*\(2, 64\)"):
        build_model("badshape", TINY_MODEL)(_batch())
    with pytest.raises(MomaError, match=r"no 'Nope'"):
        get_model_entry("mk_testplugin.models:Nope")
    with pytest.raises(MomaError, match=r"not a torch.nn.Module subclass"):
        get_model_entry("mk_testplugin.models:_inputs")
    with pytest.raises(MomaError, match=r"cannot import 'no_such_package.models'.*No module"):
        get_model_entry("no_such_package.models:Model")
    with pytest.raises(MomaError, match=r"unknown model 'nope'.*tinyaff"):
        get_model_entry("nope")


def test_out_of_range_output_is_refused(installed):
    class Raw(torch.nn.Module):
        def __init__(self, config):
            super().__init__()
            self.lin = torch.nn.Linear(3, 1)

        def forward(self, batch):
            return self.lin(batch["floor_xyz"]).squeeze(-1) * 100

    from momakitchen.models.plugins import PluginModel as Wrapped

    with pytest.raises(MomaError, match=r"outside \[0, 1\].*sigmoid"):
        Wrapped("raw", TINY_MODEL, Raw(TINY_MODEL))(_batch())


def test_a_plugin_may_not_take_a_builtin_name(tmp_path):
    site = write_distribution(
        tmp_path / "site",
        "mk-clash",
        "[momakitchen.models]\nnavaff = mk_testplugin.models:TinyAffordance\n",
    )
    with on_path(site):
        with pytest.raises(MomaError, match=r"'navaff' of entry point 'navaff'.*mk-clash.*clashes"):
            get_model_entry("navaff")
        get_model_entry("pointnet2")  # other built-in names are unaffected
    get_model_entry("navaff")  # uninstalled: the built-in again


def test_train_cli_refuses_a_broken_plugin_in_one_line(installed, tmp_path, capsys):
    from momakitchen.cli.main import main

    args = ["train", "--data", str(tmp_path / "nodata"), "--out", str(tmp_path / "run")]
    assert main([*args, "--model", "broken"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fails to import" in err
    assert not (tmp_path / "run").exists()


class NeedsMore(torch.nn.Module):
    """A class whose constructor does not take a ModelConfig alone."""

    def __init__(self, config, size):
        super().__init__()


def test_a_constructor_that_fails_is_one_line():
    with pytest.raises(
        MomaError, match=r"'test_plugins:NeedsMore'.*NeedsMore\(ModelConfig\) fails"
    ):
        build_model("test_plugins:NeedsMore", TINY_MODEL)


def test_train_cli_probes_a_plugin_before_writing_the_run(installed, tmp_path, capsys):
    from momakitchen.cli.main import main
    from momakitchen.data.generator import GenerateRequest, generate_dataset
    from momakitchen.data.synthetic_scene import SyntheticSceneConfig, synthetic_scene_records

    root = tmp_path / "ds"
    small = SyntheticSceneConfig(configs_per_scene=1, episodes_per_config=2)
    request = GenerateRequest(out=root, num_scenes=2)
    generate_dataset(request, synthetic_scene_records, small, progress=False, write_card=False)
    args = ["train", "--data", str(root), "--max-steps", "1", "--workers", "0", "--quiet"]
    assert main([*args, "--model", "badshape", "--out", str(tmp_path / "bad")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'badshape' returned (2,)" in err
    assert not (tmp_path / "bad").exists()
    assert main([*args, "--model", "tinyaff", "--out", str(tmp_path / "ok")]) == 0
    assert (tmp_path / "ok" / "model.safetensors").is_file()


class NoWeights(torch.nn.Module):
    """A hand-made rule: nothing to train."""

    def __init__(self, config):
        super().__init__()

    def forward(self, batch):
        return torch.full(batch["floor_xyz"].shape[:2], 0.5)


def test_a_plugin_without_weights_is_sent_to_predictions_files():
    from momakitchen.models.plugins import probe_plugin

    model = build_model("test_plugins:NoWeights", TINY_MODEL)
    assert model(_batch())["pred"].shape == (2, 64)  # usable, but not trainable
    with pytest.raises(MomaError, match=r"no parameters to train.*predictions file"):
        probe_plugin("test_plugins:NoWeights", model, _batch())


@pytest.mark.parametrize(
    ("model", "needle"),
    [
        ("no_such_package.models:Model", "module 'no_such_package.models' cannot be imported"),
        ("no_such_entry_point", "model 'no_such_entry_point', not installed here"),
    ],
)
def test_a_run_whose_plugin_is_not_importable_says_so(model, needle, tiny_run, tmp_path, capsys):
    """A run of a plug-in whose package is not importable where it is loaded is reported
    as that, in one line naming the module (exit status 2), not as a bad training config."""
    import shutil

    from momakitchen.cli.main import main

    run = tmp_path / "run"
    shutil.copytree(tiny_run, run)
    info = json.loads((run / "config.json").read_text())
    info["model"] = info["train_config"]["model"] = model
    (run / "config.json").write_text(json.dumps(info))
    argv = ["evaluate", "--data", str(tmp_path), "--checkpoint", str(run)]
    assert main([*argv, "--json", str(tmp_path / "e.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and "bad training config" not in err, err
    assert "No module named 'no_such_package'" in err or ":" not in model
