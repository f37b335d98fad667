import numpy as np
import pytest
import torch

from momakitchen.data.batch import (
    EpisodeCollator,
    collate_episodes,
    episode_maps,
    validate_sample,
)
from momakitchen.data.synthetic import (
    SyntheticConfig,
    SyntheticEpisodes,
    affordance_label,
)
from momakitchen.errors import MomaError
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.spec import DESCRIPTOR_DIM, ROBOTS


@pytest.fixture(scope="module")
def data():
    return SyntheticEpisodes(SyntheticConfig(num_episodes=12, num_global=400, num_floor=200))


def test_samples_follow_the_contract(data):
    for i in range(len(data)):
        s = data[i]
        ng, nf = s["global_xyz"].shape[0], s["floor_xyz"].shape[0]
        assert 300 <= ng <= 400 and 150 <= nf <= 200
        assert s["global_rgb"].shape == (ng, 3) and s["global_align"].shape == (ng,)
        assert s["floor_label"].shape == (nf,) and s["robot"].shape == (DESCRIPTOR_DIM,)
        assert s["global_xyz"].dtype == torch.float32
        assert set(np.unique(s["global_align"].numpy())) <= {-1.0, 0.0, 1.0}
        assert (s["global_align"] == 1).any() and (s["global_align"] == -1).any()
        assert 0 <= s["floor_label"].min() and s["floor_label"].max() <= 1
        assert s["floor_xyz"][:, 2].abs().max() < 0.02
        assert s["global_rgb"].min() >= 0 and s["global_rgb"].max() <= 1
        spec = ROBOTS[s["robot_name"]]
        assert torch.allclose(s["robot"], torch.tensor(robot_descriptor(spec)))
    # deterministic
    a, b = data[3], SyntheticEpisodes(data.config)[3]
    assert torch.equal(a["global_xyz"], b["global_xyz"])
    assert torch.equal(a["floor_label"], b["floor_label"])


def test_labels_depend_on_the_robot_and_obstacles():
    floor = np.stack(np.meshgrid(np.linspace(0, 2, 41), np.linspace(-1, 1, 41)), -1).reshape(-1, 2)
    target = np.array([2.2, 0.0, 0.95])
    none = np.zeros((0, 5))
    panda = np.array(robot_descriptor(ROBOTS["panda"]))
    xarm = np.array(robot_descriptor(ROBOTS["xarm6"]))
    a = affordance_label(floor, target, 2.0, none, panda)
    b = affordance_label(floor, target, 2.0, none, xarm)
    assert a.max() > 0.9 and not np.allclose(a, b)
    assert (a[floor[:, 0] > 1.75] == 0).all()  # base would hit the counter
    chair = np.array([[1.5, 0.0, 0.4, 0.4, 0.8]])
    c = affordance_label(floor, target, 2.0, chair, panda)
    near = (np.abs(floor[:, 0] - 1.5) < 0.3) & (np.abs(floor[:, 1]) < 0.3)
    assert (c[near] == 0).all() and a[near].max() > 0


def test_collate_pads_with_masks(data):
    samples = [data[i] for i in range(3)]
    batch = collate_episodes(samples)
    ng = max(s["global_xyz"].shape[0] for s in samples)
    nf = max(s["floor_xyz"].shape[0] for s in samples)
    assert batch["global_xyz"].shape == (3, ng, 3) and batch["global_mask"].shape == (3, ng)
    assert batch["floor_label"].shape == (3, nf) and batch["robot"].shape == (3, DESCRIPTOR_DIM)
    assert batch["global_mask"].dtype == torch.bool
    for i, s in enumerate(samples):
        n = s["global_xyz"].shape[0]
        assert batch["global_mask"][i].sum() == n
        assert torch.equal(batch["global_xyz"][i, :n], s["global_xyz"])
        assert (batch["global_xyz"][i, n:] == 0).all()
    assert batch["scene_id"] == [s["scene_id"] for s in samples]
    assert batch["robot_name"] == [s["robot_name"] for s in samples]
    preds, gts = episode_maps(batch, batch["floor_label"])
    assert [len(p) for p in preds] == [s["floor_xyz"].shape[0] for s in samples]
    assert all(np.array_equal(p, g) for p, g in zip(preds, gts, strict=True))


def test_whether_the_robot_opens_its_target_is_collated_when_a_sample_says(data):
    samples = [dict(data[i]) for i in range(3)]
    assert "target_opens" not in collate_episodes(samples)
    samples[0]["target_opens"], samples[2]["target_opens"] = True, np.bool_(False)
    opens = collate_episodes(samples)["target_opens"]
    # the sample that does not say counts as a pick
    assert opens.dtype == torch.bool and opens.tolist() == [True, False, False]
    with pytest.raises(MomaError, match="'target_opens' must be true or false, got 'yes'"):
        validate_sample(dict(samples[0], target_opens="yes"))


def test_collate_samples_down_deterministically(data):
    samples = [data[i] for i in range(4)]
    collate = EpisodeCollator(num_global=128, num_floor=64, seed=7)
    a, b = collate(samples), collate(samples)
    assert a["global_xyz"].shape == (4, 128, 3) and a["global_mask"].all()
    assert torch.equal(a["global_xyz"], b["global_xyz"])
    # the same episode is reduced the same way whatever batch it is in
    c = collate(samples[2:3])
    assert torch.equal(a["floor_xyz"][2], c["floor_xyz"][0])
    assert torch.equal(a["floor_label"][2], c["floor_label"][0])
    d = EpisodeCollator(num_global=128, num_floor=64, seed=8)(samples)
    assert not torch.equal(a["global_xyz"], d["global_xyz"])
    # sampled points are real points of the episode, labels travel with their points
    pts = {tuple(p) for p in samples[0]["floor_xyz"].numpy().tolist()}
    assert all(tuple(p) in pts for p in a["floor_xyz"][0].numpy().tolist())


def test_the_floor_context_is_the_floor_training_would_draw(data):
    """Inference predicts every floor point but encodes the floor at the training density:
    the context must be exactly the points a training collation would have kept."""
    samples = [data[i] for i in range(4)]
    trained = EpisodeCollator(num_global=128, num_floor=64, seed=7)(samples)
    infer = EpisodeCollator(num_global=128, num_floor=None, seed=7, num_context=64)(samples)
    assert torch.equal(infer["context_xyz"], trained["floor_xyz"])
    assert torch.equal(infer["context_mask"], trained["floor_mask"])
    assert torch.equal(infer["global_xyz"], trained["global_xyz"])
    nf = max(s["floor_xyz"].shape[0] for s in samples)
    assert infer["floor_xyz"].shape == (4, nf, 3)  # every floor point is still predicted
    assert "context_xyz" not in trained
    # a floor smaller than the context is kept whole, padded
    small = EpisodeCollator(num_global=128, seed=7, num_context=nf + 10)(samples[:1])
    n0 = samples[0]["floor_xyz"].shape[0]
    assert small["context_mask"][0].sum() == n0
    assert torch.equal(small["context_xyz"][0, :n0], samples[0]["floor_xyz"])
    with pytest.raises(MomaError, match="num_context must be a positive int, got 0"):
        EpisodeCollator(num_context=0)


def test_bad_samples_raise_moma_error(data):
    s = dict(data[0])
    with pytest.raises(MomaError, match="global_rgb must have shape"):
        validate_sample(dict(s, global_rgb=s["global_rgb"][:5]))
    with pytest.raises(MomaError, match="missing field 'robot'"):
        validate_sample({k: v for k, v in s.items() if k != "robot"})
    with pytest.raises(MomaError, match="robot descriptor must have shape"):
        validate_sample(dict(s, robot=torch.zeros(2)))
    with pytest.raises(MomaError, match="no global or no floor points"):
        validate_sample(dict(s, floor_mask=torch.zeros(s["floor_xyz"].shape[0], dtype=bool)))
    with pytest.raises(MomaError, match="num_global must be a positive int"):
        EpisodeCollator(num_global=0)
    with pytest.raises(MomaError, match="empty"):
        collate_episodes([])
    masked = validate_sample(dict(s, global_mask=torch.arange(s["global_xyz"].shape[0]) % 2 == 0))
    assert masked["global_xyz"].shape[0] == (s["global_xyz"].shape[0] + 1) // 2
