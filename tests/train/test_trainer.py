import csv
import dataclasses
import json
import math
import os
import signal

import numpy as np
import pytest
import torch
from safetensors.torch import load_file

from momakitchen.data.batch import collate_episodes, episode_maps
from momakitchen.errors import MomaError
from momakitchen.eval.evaluate import evaluate
from momakitchen.metrics import map_metrics
from momakitchen.models import build_model
from momakitchen.models.inference import predict_batch
from momakitchen.robots.spec import DESCRIPTOR_VERSION
from momakitchen.train import (
    TrainConfig,
    load_checkpoint,
    preset_config,
    train,
)
from momakitchen.train.trainer import cosine_lr


def test_presets_and_validation():
    paper = preset_config("paper", "navaff")
    assert paper.model_config.embed_dim == 512 and paper.model_config.num_tokens == 64
    assert paper.model_config.num_heads == 4 and paper.model_config.dropout == 0.1
    assert paper.batch_size == 64 and paper.epochs == 6 and paper.lr == 8e-4
    assert paper.weight_decay == 1e-3 and paper.betas == (0.9, 0.999)
    assert paper.model_config.lambda_zero == 0.7 and paper.model_config.zero_weight_prob == 0.5
    cpu = preset_config("cpu", "pointnet2", epochs=3)
    assert cpu.model == "pointnet2" and cpu.epochs == 3 and cpu.num_global < paper.num_global
    with pytest.raises(MomaError, match="unknown preset 'gpu'"):
        preset_config("gpu")
    with pytest.raises(MomaError, match=r"TrainConfig.lr .* got 2\.0"):
        cpu.replace(lr=2.0)
    with pytest.raises(MomaError, match=r"batch_size .* got 0"):
        cpu.replace(batch_size=0)
    with pytest.raises(MomaError, match="unknown model 'navaf'"):
        preset_config("cpu", "navaf")
    assert TrainConfig.from_dict(json.loads(json.dumps(cpu.to_dict()))) == cpu


def test_cosine_schedule(make_config):
    cfg = make_config(lr=1e-3, min_lr_ratio=0.1)
    assert cosine_lr(cfg, 0, 100) == pytest.approx(1e-3)
    assert cosine_lr(cfg, 50, 100) == pytest.approx(1e-4 + 0.9e-3 * 0.5)
    assert cosine_lr(cfg, 100, 100) == pytest.approx(1e-4)


def test_warmup_then_cosine(make_config):
    cfg = make_config(lr=1e-3, min_lr_ratio=0.1, warmup_steps=10)
    assert cosine_lr(cfg, 0, 110) == pytest.approx(1e-4)
    assert cosine_lr(cfg, 4, 110) == pytest.approx(5e-4)
    assert cosine_lr(cfg, 10, 110) == pytest.approx(1e-3)  # the cosine starts after it
    assert cosine_lr(cfg, 60, 110) == pytest.approx(1e-4 + 0.9e-3 * 0.5)
    assert cosine_lr(cfg, 110, 110) == pytest.approx(1e-4)
    with pytest.raises(MomaError, match=r"warmup_steps .* got -1"):
        cfg.replace(warmup_steps=-1)


def test_training_writes_a_reloadable_checkpoint(tmp_path, tiny_sets, make_config):
    train_set, val_set = tiny_sets
    run = tmp_path / "run"
    result = train(make_config(), train_set, val_set, run)
    for name in (
        "config.json",
        "model.safetensors",
        "trainer_state.safetensors",
        "trainer_state.json",
        "log.csv",
        "loss_curve.png",
    ):
        assert (run / name).is_file(), name
    assert not list(run.glob("*.pt")) and not list(run.glob("*.pkl"))
    info = json.loads((run / "config.json").read_text())
    assert info["model"] == "navaff" and info["descriptor_version"] == DESCRIPTOR_VERSION
    assert (run / "loss_curve.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with (run / "log.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    epochs = [r for r in rows if r["kind"] == "epoch"]
    assert len(epochs) == 2 and all(float(r["val_loss"]) > 0 for r in epochs)
    assert int(epochs[-1]["step"]) == 4 and int(epochs[-1]["samples"]) == 8
    assert len(result.history) == 2

    weights = load_file(run / "model.safetensors")
    assert set(weights) == set(result.model.state_dict())

    loaded = load_checkpoint(run, model="navaff")
    batch = collate_episodes([val_set[i] for i in range(3)], 256, 128)
    a = predict_batch(result.model, batch)
    b = predict_batch(loaded.model, batch)
    assert torch.equal(a, b)
    assert ((a >= 0) & (a <= 1)).all()
    assert (a[~batch["floor_mask"]] == 0).all()


def test_checkpoint_errors(tmp_path, tiny_sets, make_config):
    train_set, _ = tiny_sets
    run = tmp_path / "run"
    train(make_config(epochs=1, model="pointnet2"), train_set, None, run)
    with pytest.raises(MomaError, match="holds model 'pointnet2', not 'navaff'"):
        load_checkpoint(run, model="navaff")
    with pytest.raises(MomaError, match="does not exist"):
        load_checkpoint(tmp_path / "nowhere")
    with pytest.raises(MomaError, match="already holds a checkpoint; pass --resume"):
        train(make_config(epochs=1, model="pointnet2"), train_set, None, run)
    with pytest.raises(MomaError, match=r"nothing to resume.*holds no checkpoint"):
        (tmp_path / "empty").mkdir()
        train(make_config(epochs=1), train_set, None, tmp_path / "empty", resume=True)
    assert not any((tmp_path / "empty").iterdir())
    with pytest.raises(MomaError, match=r"holds model 'pointnet2'.*'navaff'"):
        train(make_config(epochs=1), train_set, None, run, resume=True)
    info = json.loads((run / "config.json").read_text())
    info["descriptor_version"] = DESCRIPTOR_VERSION + 1
    (run / "config.json").write_text(json.dumps(info))
    with pytest.raises(MomaError, match="descriptor version"):
        load_checkpoint(run)


class _Interrupting(torch.utils.data.Dataset):
    """Raises after a number of item fetches, like a killed run."""

    def __init__(self, base, limit):
        self.base, self.limit, self.count = base, limit, 0

    def __len__(self):
        return len(self.base)

    def __getitem__(self, i):
        self.count += 1
        if self.count > self.limit:
            raise KeyboardInterrupt
        return self.base[i]


def test_resume_continues_exactly(tmp_path, tiny_sets, make_config):
    train_set, _ = tiny_sets
    cfg = make_config(epochs=3)
    full = train(cfg, train_set, None, tmp_path / "full")
    with pytest.raises(KeyboardInterrupt):
        train(cfg, _Interrupting(train_set, 2 * len(train_set) + 1), None, tmp_path / "cut")
    state = json.loads((tmp_path / "cut" / "trainer_state.json").read_text())
    assert state["progress"]["epoch"] == 2
    resumed = train(cfg, train_set, None, tmp_path / "cut", resume=True)
    assert resumed.global_step == full.global_step == 6
    for (k, a), b in zip(
        full.model.state_dict().items(), resumed.model.state_dict().values(), strict=True
    ):
        assert torch.allclose(a, b, atol=1e-6), k
    assert [h["epoch"] for h in resumed.history] == [1, 2, 3]


def test_resume_within_an_epoch_continues_exactly(tmp_path, tiny_sets, make_config):
    """A checkpoint written within an epoch (checkpoint_minutes) resumes from the next
    batch: the weights and the epoch's loss are those of the run never stopped."""
    train_set, _ = tiny_sets
    cfg = make_config(epochs=3, checkpoint_minutes=1e-9)  # after every batch
    full = train(cfg, train_set, None, tmp_path / "full")
    # Epoch 2's first batch trains, and its checkpoint is written; its second fails.
    with pytest.raises(KeyboardInterrupt):
        train(cfg, _Interrupting(train_set, len(train_set) + 5), None, tmp_path / "cut")
    progress = json.loads((tmp_path / "cut" / "trainer_state.json").read_text())["progress"]
    assert (progress["epoch"], progress["epoch_step"], progress["global_step"]) == (1, 1, 3)
    resumed = train(cfg, train_set, None, tmp_path / "cut", resume=True)
    assert resumed.global_step == full.global_step == 6
    a, b = full.model.state_dict(), resumed.model.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert [h["loss"] for h in resumed.history] == [h["loss"] for h in full.history]
    assert [h["samples"] for h in resumed.history] == [8, 8, 8]


class _Signalling(torch.utils.data.Dataset):
    """Sends this process ``signum`` at one item fetch, as ``kill`` or Ctrl-C would."""

    def __init__(self, base, at, signum):
        self.base, self.at, self.signum, self.count = base, at, signum, 0

    def __len__(self):
        return len(self.base)

    def __getitem__(self, i):
        self.count += 1
        if self.count == self.at:
            os.kill(os.getpid(), self.signum)
        return self.base[i]


@pytest.mark.parametrize(
    ("at", "signum", "where"),
    [
        (10, signal.SIGTERM, (1, 1, 3)),  # within epoch 2: a checkpoint after its 1st step
        (6, signal.SIGINT, (1, None, 2)),  # in epoch 1's last batch: the epoch's checkpoint
    ],
)
def test_a_signal_stops_at_a_checkpoint_that_resumes_exactly(
    tmp_path, tiny_sets, make_config, at, signum, where
):
    train_set, _ = tiny_sets  # 8 episodes, 2 steps an epoch
    cfg = make_config(epochs=3)
    full = train(cfg, train_set, None, tmp_path / "full")
    before = signal.getsignal(signum)
    cut = train(cfg, _Signalling(train_set, at, signum), None, tmp_path / "cut")
    assert signal.getsignal(signum) is before  # the caller's handler is back
    assert cut.stopped_by == signal.Signals(signum).name and full.stopped_by is None
    progress = json.loads((tmp_path / "cut" / "trainer_state.json").read_text())["progress"]
    assert (progress["epoch"], progress.get("epoch_step"), progress["global_step"]) == where
    assert cut.global_step == where[2]
    resumed = train(cfg, train_set, None, tmp_path / "cut", resume=True)
    assert resumed.stopped_by is None and resumed.global_step == full.global_step == 6
    a, b = full.model.state_dict(), resumed.model.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert [h["loss"] for h in resumed.history] == [h["loss"] for h in full.history]


def test_checkpoint_minutes_must_be_a_duration(make_config):
    with pytest.raises(MomaError, match="checkpoint_minutes"):
        make_config(checkpoint_minutes=float("nan"))


def test_data_loading_workers_change_nothing(tmp_path, tiny_sets, make_config):
    """Batches and their geometry plans made in a worker process train the same weights
    and validate to the same figures as those made on the training thread."""
    train_set, val_set = tiny_sets
    runs = [
        train(make_config(num_workers=w), train_set, val_set, tmp_path / f"w{w}") for w in (0, 1)
    ]
    a, b = (r.model.state_dict() for r in runs)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert runs[0].history[-1]["val_pcc"] == runs[1].history[-1]["val_pcc"]


def test_evaluate_matches_metrics_of_predictions(tmp_path, tiny_sets, make_config):
    train_set, val_set = tiny_sets
    run = tmp_path / "run"
    train(make_config(epochs=1), train_set, None, run)
    report = evaluate(run, val_set, batch_size=3)
    assert report["model"] == "navaff" and report["episodes"] == len(val_set)
    loaded = load_checkpoint(run)
    assert report["floor_context"] == loaded.config.num_floor
    preds, gts = [], []
    for i in range(len(val_set)):
        batch = collate_episodes([val_set[i]], 256, None, num_context=loaded.config.num_floor)
        p, g = episode_maps(batch, predict_batch(loaded.model, batch))
        preds += p
        gts += g
    expected = map_metrics(preds, gts)
    for k, v in expected.items():
        # batched vs one-by-one forward passes differ in float rounding only; PCC of a nearly
        # flat map amplifies that a little
        assert report["metrics"][k] == pytest.approx(v, rel=1e-4, abs=1e-4)
    robots = {val_set[i]["robot_name"] for i in range(len(val_set))}
    assert set(report["per_robot"]) == robots
    assert sum(m["episodes"] for m in report["per_scene"].values()) == len(val_set)
    assert all(np.isfinite(v) for v in report["metrics"].values())


def _mse_on(model, data, num_global, num_floor):
    batch = collate_episodes([data[i] for i in range(len(data))], num_global, num_floor)
    pred = predict_batch(model, batch)
    mask = batch["floor_mask"]
    return float(((pred - batch["floor_label"]) ** 2)[mask].mean())


def _overfit(tmp_path, make_config, steps):
    from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes

    data = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=256, num_floor=128))
    cfg = make_config(
        epochs=steps,
        lr=3e-3,
        min_lr_ratio=0.1,
        val_every=steps,
        checkpoint_every=steps,
        log_every=10,
    ).replace_model(dropout=0.0)
    torch.manual_seed(cfg.seed)
    before = _mse_on(build_model(cfg.model, cfg.model_config), data, 256, 128)
    result = train(cfg, data, data, tmp_path / "run")
    after = _mse_on(result.model, data, 256, 128)
    assert result.global_step == steps
    assert result.history[-1]["val_loss"] == pytest.approx(after, rel=1e-4)
    assert math.isfinite(after)
    return before, after


def test_overfitting_four_episodes_quick(tmp_path, make_config):
    """Quick variant for the default suite: 120 steps on 4 episodes get at least twice as
    close as the best flat map (the head starts near flat, so that is the bar to beat)."""
    from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes

    data = SyntheticEpisodes(SyntheticConfig(num_episodes=4, num_global=256, num_floor=128))
    labels = collate_episodes([data[i] for i in range(4)], 256, 128)
    flat_mse = float(labels["floor_label"][labels["floor_mask"]].var(unbiased=False))
    _, after = _overfit(tmp_path, make_config, 120)
    assert after < flat_mse / 2, (flat_mse, after)


@pytest.mark.slow
def test_overfitting_four_episodes_tenfold(tmp_path, make_config):
    """200 steps on 4 episodes drop the MSE at least tenfold."""
    before, after = _overfit(tmp_path, make_config, 200)
    assert after < before / 10, (before, after)


def test_resume_across_a_changed_preset(tmp_path, tiny_sets, make_config):
    """A preset change in a size the model never reads does not block a resume; one in a
    size it does read is refused, naming the field."""
    train_set, _ = tiny_sets
    first = make_config(epochs=1, model="pointnet2")
    run = tmp_path / "pointnet2"
    train(first, train_set, None, run)
    wider = dataclasses.replace(first.model_config, floor_npoints=64)
    resumed = train(first.replace(epochs=2, model_config=wider), train_set, None, run, resume=True)
    assert resumed.global_step == 4
    # The run goes on with the sizes it was started with.
    assert resumed.model.config == first.model_config

    navaff = make_config(epochs=1)
    train(navaff, train_set, None, tmp_path / "navaff")
    with pytest.raises(MomaError, match=r"floor_npoints 32 vs 64\)"):
        train(navaff.replace(model_config=wider), train_set, None, tmp_path / "navaff", resume=True)


def test_fine_tuning_starts_from_the_given_weights(tmp_path, tiny_sets, make_config):
    train_set, _ = tiny_sets
    first = train(make_config(), train_set, None, tmp_path / "first")
    tiny_lr = make_config(init=str(tmp_path / "first"), lr=1e-9, epochs=1)
    tuned = train(tiny_lr, train_set, None, tmp_path / "tuned")
    for name, value in first.model.state_dict().items():  # a 1e-9 step moves nothing much
        assert torch.allclose(value, tuned.model.state_dict()[name], atol=1e-6), name
    scratch = train(make_config(lr=1e-9, epochs=1), train_set, None, tmp_path / "scratch")
    assert any(
        not torch.allclose(v, scratch.model.state_dict()[k], atol=1e-3)
        for k, v in first.model.state_dict().items()
    )


def test_fine_tuning_and_sensor_noise_refuse_bad_input_before_writing(
    tmp_path, tiny_sets, make_config
):
    train_set, _ = tiny_sets
    with pytest.raises(MomaError, match="does not exist"):
        train(make_config(init=str(tmp_path / "none")), train_set, None, tmp_path / "a")
    with pytest.raises(MomaError, match="'pointnet2' model of other sizes"):
        other = make_config(model="pointnet2")
        train(other, train_set, None, tmp_path / "p")
        train(make_config(init=str(tmp_path / "p")), train_set, None, tmp_path / "b")
    with pytest.raises(MomaError, match="sensor_noise needs a generated dataset"):
        train(make_config(sensor_noise=True), train_set, None, tmp_path / "c")
    assert not any((tmp_path / n).exists() for n in ("a", "b", "c"))


def test_sensor_noise_draws_from_the_configured_augmentation(tmp_path, tiny_sets, make_config):
    from momakitchen.perception.sensors import SensorAugmentation

    class Recording(torch.utils.data.Dataset):  # the hooks of a generated dataset
        def __init__(self, inner):
            self.inner, self.augmentation, self.epochs = inner, None, []

        def __len__(self):
            return len(self.inner)

        def __getitem__(self, i):
            return self.inner[i]

        def use_sensor_noise(self, augmentation):
            self.augmentation = augmentation

        def set_epoch(self, epoch, seed=0):
            self.epochs.append((epoch, seed))

    augmentation = SensorAugmentation(sensors=("d435",), p_ideal=0.5, p_calibration=0.2)
    data = Recording(tiny_sets[0])
    config = make_config(sensor_noise=True, sensor_augmentation=augmentation, epochs=2, seed=3)
    train(config, data, None, tmp_path / "run")
    assert data.augmentation == augmentation and data.epochs == [(0, 3), (1, 3)]
    # A resume goes on with the noise the run was trained with, or is refused.
    with pytest.raises(
        MomaError,
        match=r"trained with sensor_noise on \(.*p_calibration=0.2.*"
        r"the config asks for off",
    ):
        train(config.replace(sensor_noise=False, epochs=3), data, None, tmp_path / "run", True)
    other = config.replace(sensor_augmentation=SensorAugmentation(), epochs=3)
    with pytest.raises(MomaError, match="cannot resume"):
        train(other, data, None, tmp_path / "run", resume=True)
    assert train(config.replace(epochs=3), data, None, tmp_path / "run", True).global_step == 6
    assert data.epochs[-1] == (2, 3)
