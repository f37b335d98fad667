"""The robot's reachability as a floor input (ModelConfig.reach_input)."""

import dataclasses

import numpy as np
import pytest
import torch

from momakitchen.data.batch import collate_episodes
from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
from momakitchen.errors import MomaError
from momakitchen.models import ModelConfig, build_model
from momakitchen.models.reach_input import REACH_CHANNELS, floor_reach, target_points
from momakitchen.sim.reachability import ReachabilityMap
from momakitchen.train.checkpoint import load_weights, save_weights


def test_floor_reach_is_the_placement_stages_map_of_the_robot_at_its_mount():
    target = np.array([0.0, 0.0, 0.9])
    # in front of the target, facing it: 0.4 m away, 3 m away, and beside it
    floor = np.array([[-0.4, 0.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 0.5, 0.0]])
    out = floor_reach("panda", 1.03, target, floor)
    assert out.shape == (3, REACH_CHANNELS) and out.dtype == np.float32
    assert out[0, 0] > 0 and out[0, 2] > 0  # reached, with a dexterity index
    assert out[1, 0] == -1.0 and out[1, 1] == -1.0 and out[1, 2] == 0.0  # far out of reach
    rmap = ReachabilityMap.for_robot("panda", 1.03)
    side = rmap.reachable_from(floor[:, :2], target)
    down = rmap.reachable_from(floor[:, :2], target, [0.0, 0.0, -1.0])
    np.testing.assert_array_equal(out[:, 0] > 0, side)
    np.testing.assert_array_equal(out[:, 1] > 0, down)
    rho, z, _, _ = rmap.tcp_coordinates(floor[:, :2], target)
    np.testing.assert_allclose(out[:, 2], rmap.reachability_index(rho, z), atol=1e-6)


def test_floor_reach_follows_the_mount_height():
    target = np.array([0.0, 0.0, 0.2])  # low: a high mount reaches it from fewer points
    xs = np.linspace(-1.5, -0.1, 29)
    floor = np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)])
    low = floor_reach("panda", 0.4, target, floor)[:, 0]
    high = floor_reach("panda", 1.3, target, floor)[:, 0]
    assert (low > 0).sum() > (high > 0).sum()


@pytest.fixture(scope="module")
def batch():
    ds = SyntheticEpisodes(SyntheticConfig(num_episodes=3, num_global=300, num_floor=120, seed=5))
    return collate_episodes([ds[i] for i in range(3)])


def test_a_model_without_the_input_starts_one_with_it_unchanged(tmp_path, batch):
    """Widened weights (zero columns for the new channels) predict what they did."""
    from momakitchen.models.config import TINY_MODEL

    torch.manual_seed(0)
    old = build_model("navaff", TINY_MODEL).eval()
    with torch.no_grad():  # a fresh head predicts a constant: make it read its features
        for p in old.head.parameters():
            p.normal_(0.0, 0.5)
    save_weights(tmp_path / "w.safetensors", old)
    new = build_model("navaff", dataclasses.replace(TINY_MODEL, reach_input=True)).eval()
    with pytest.raises(MomaError, match="do not fit"):
        load_weights(tmp_path / "w.safetensors", new)
    load_weights(tmp_path / "w.safetensors", new, reach_from_none=True)
    with torch.no_grad():
        torch.testing.assert_close(new(batch)["pred"], old(batch)["pred"])
        # ... and the channels reach the output once their weights are not zero
        first = new.backbone.floor_sa1.mlps[0].first.weight
        first[:, -REACH_CHANNELS:] = 1.0
        assert not torch.allclose(new(batch)["pred"], old(batch)["pred"])


def test_the_input_needs_each_episodes_robot(batch):
    from momakitchen.models.config import TINY_MODEL

    model = build_model("navaff", dataclasses.replace(TINY_MODEL, reach_input=True)).eval()
    with pytest.raises(MomaError, match="robot name"):
        model({**batch, "robot_name": ["", "", ""]})
    with pytest.raises(MomaError, match=r"robot 'nosuch' is not registered .*has no URDF"):
        model({**batch, "robot_name": ["nosuch"] * 3})


def test_the_option_is_validated_and_left_out_of_older_configs():
    with pytest.raises(MomaError, match=r"reach_input must be true or false, got 'yes'"):
        ModelConfig(reach_input="yes")  # type: ignore[arg-type]
    assert "reach_input" not in ModelConfig().to_dict()  # older runs' configs keep their bytes
    assert ModelConfig.from_dict({}).reach_input is False
    assert ModelConfig.from_dict({"reach_input": True}).to_dict()["reach_input"] is True
    with pytest.raises(MomaError, match=r"reach_points must be an integer in \[1, 64\], got 0"):
        ModelConfig(reach_points=0)
    assert "reach_points" not in ModelConfig(reach_input=True).to_dict()


def test_several_target_points_give_each_channels_best():
    # A door's panel: the handle end (y = 0.35) is in reach from where its centre is not.
    points = np.array([[0.0, y, 0.5] for y in (-0.35, 0.0, 0.35)])
    floor = np.array([[-0.5, 0.55, 0.0], [-0.5, 0.0, 0.0], [-3.0, 0.0, 0.0]])
    each = [floor_reach("elephant", 1.03, t, floor) for t in points]
    best = floor_reach("elephant", 1.03, points, floor)
    np.testing.assert_array_equal(best, np.max(each, axis=0))
    np.testing.assert_array_equal(floor_reach("elephant", 1.03, points[1:2], floor), each[1])
    assert best[0, 2] > each[1][0, 2]  # the handle end counts
    assert best[2, 2] == 0.0  # 3 m away, no point of it is in reach


def test_target_points_spread_over_the_flagged_points():
    xyz = torch.arange(30, dtype=torch.float32).reshape(1, 10, 3)
    align = torch.tensor([[0, 1, 1, 0, 1, 1, 1, 0, 1, 0]], dtype=torch.float32)
    mask = torch.ones(1, 10, dtype=torch.bool)
    centroid = torch.zeros(1, 3)
    picked = target_points(xyz, align, mask, centroid, 3)
    assert picked.shape == (1, 3, 3)
    assert picked[0, :, 0].tolist() == [3.0, 12.0, 24.0]  # first, middle, last of six
    few = target_points(xyz, align, mask, centroid, 8)  # fewer than 8 flagged: the centroid
    assert torch.equal(few, torch.zeros(1, 8, 3))


def test_hidden_descriptor_columns_are_not_read_but_the_mount_still_places_the_arm(batch):
    from momakitchen.models.config import TINY_MODEL

    hide = ("reach_m", "mount_height_m")
    cfg = dataclasses.replace(TINY_MODEL, reach_input=True, hidden_descriptor=hide)
    torch.manual_seed(0)
    model = build_model("navaff", cfg).eval()
    with torch.no_grad():
        for p in model.head.parameters():
            p.normal_(0.0, 0.5)
        for mlp in model.backbone.floor_sa1.mlps:
            mlp.first.weight[:, -REACH_CHANNELS:] = 1.0
        base = model(batch)["pred"]
        other_reach = batch["robot"].clone()
        other_reach[:, 0] += 0.3
        torch.testing.assert_close(model({**batch, "robot": other_reach})["pred"], base)
        other_mount = batch["robot"].clone()
        other_mount[:, 1] = 0.4  # the arm sits lower: it reaches the target elsewhere
        assert not torch.allclose(model({**batch, "robot": other_mount})["pred"], base)
    with pytest.raises(MomaError, match=r"hidden_descriptor must name distinct columns"):
        ModelConfig(hidden_descriptor=("reach",))


@pytest.mark.parametrize("name", ["navaff", "pointnet2"])
def test_the_reach_gate_scales_any_models_prediction_by_the_arms_reach(name, batch):
    from momakitchen.models.config import TINY_MODEL
    from momakitchen.models.reach_input import reach_gate

    torch.manual_seed(0)
    plain = build_model(name, TINY_MODEL).eval()
    gated = build_model(name, dataclasses.replace(TINY_MODEL, reach_gate=0.03)).eval()
    gated.load_state_dict(plain.state_dict())  # the gate has no weights
    with torch.no_grad():
        gate = reach_gate(batch, 0.03, 1)
        assert gate.shape == batch["floor_mask"].shape
        assert 0.0 < float(gate.min()) < 0.05 and float(gate.max()) > 0.95
        torch.testing.assert_close(gated(batch)["pred"], plain(batch)["pred"] * gate)
    with pytest.raises(MomaError, match=r"reach_gate must be in \[0, 1\] m"):
        ModelConfig(reach_gate=-0.1)
    assert "reach_gate" not in ModelConfig().to_dict()


@pytest.mark.parametrize("name", ["navaff", "pointnet2"])
def test_the_index_gate_weighs_any_models_prediction_by_the_arms_dexterity(name, batch):
    from momakitchen.models.config import TINY_MODEL
    from momakitchen.models.reach_input import batch_floor_reach, reach_gate, target_centroid

    torch.manual_seed(0)
    plain = build_model(name, TINY_MODEL).eval()
    both = build_model(name, dataclasses.replace(TINY_MODEL, reach_gate=0.03, index_gate=1.0))
    alone = build_model(name, dataclasses.replace(TINY_MODEL, index_gate=0.25))
    for model in (both, alone):
        model.eval().load_state_dict(plain.state_dict())  # the gates have no weights
    with torch.no_grad():
        target = target_centroid(batch["global_xyz"], batch["global_align"], batch["global_mask"])
        index = batch_floor_reach(
            batch["robot_name"], batch["robot"][:, 1], target, batch["floor_xyz"]
        )[..., 2]
        # some floor points reach the target from most directions, some from few, some none
        assert float(index.max()) > 0.5 and float(index.min()) == 0.0
        assert bool(((index > 0.02) & (index < 0.25)).any())
        plain_index = reach_gate(batch, 0.0, 1, index=1.0)
        torch.testing.assert_close(plain_index, index.clamp_min(0.01))
        capped = reach_gate(batch, 0.0, 1, index=0.25)
        torch.testing.assert_close(capped, (index / 0.25).clamp(0.01, 1.0))
        assert float(capped.max()) == 1.0  # well inside the arm's reach: not weighed down
        torch.testing.assert_close(alone(batch)["pred"], plain(batch)["pred"] * capped)
        torch.testing.assert_close(
            both(batch)["pred"], plain(batch)["pred"] * reach_gate(batch, 0.03, 1) * plain_index
        )
    for bad in (True, 1.5, -0.1):
        with pytest.raises(MomaError, match=r"index_gate must be in \[0, 1\]"):
            ModelConfig(index_gate=bad)
    assert "index_gate" not in ModelConfig().to_dict()


def test_the_index_gate_for_picks_only_leaves_the_targets_that_open_unweighed(batch):
    """``index_picks_only``: the dexterity weight on the episodes whose robot picks its
    target, none on those that open it; a batch that does not say is weighed whole."""
    from momakitchen.models.config import TINY_MODEL
    from momakitchen.models.reach_input import reach_gate

    torch.manual_seed(0)
    plain = build_model("navaff", TINY_MODEL).eval()
    cfg = dataclasses.replace(TINY_MODEL, reach_gate=0.03, index_gate=0.5, index_picks_only=True)
    picks = build_model("navaff", cfg).eval()
    picks.load_state_dict(plain.state_dict())
    opens = torch.tensor([True, False, True])
    with torch.no_grad():
        weighed = reach_gate(batch, 0.03, 1, index=0.5)
        reach_only = reach_gate(batch, 0.03, 1)
        assert not torch.allclose(weighed, reach_only)  # the weight does something here
        told = {**batch, "target_opens": opens}
        gate = reach_gate(told, 0.03, 1, index=0.5, picks_only=True)
        torch.testing.assert_close(gate[opens], reach_only[opens])
        torch.testing.assert_close(gate[~opens], weighed[~opens])
        # without picks_only, or without being told, every target is weighed
        torch.testing.assert_close(reach_gate(told, 0.03, 1, index=0.5), weighed)
        torch.testing.assert_close(reach_gate(batch, 0.03, 1, 0.5, picks_only=True), weighed)
        torch.testing.assert_close(picks(told)["pred"], plain(told)["pred"] * gate)
        torch.testing.assert_close(picks(batch)["pred"], plain(batch)["pred"] * weighed)
    with pytest.raises(MomaError, match="index_picks_only needs index_gate > 0"):
        ModelConfig(index_picks_only=True)
    with pytest.raises(MomaError, match="index_picks_only must be true or false"):
        ModelConfig(index_gate=0.5, index_picks_only=1)
    assert "index_picks_only" not in ModelConfig(index_gate=0.5).to_dict()


def _fence_batch(name: str) -> dict:
    """One episode: a target 1 m ahead at 0.9 m, floor points along the line to it, and a
    box of points 0.6-0.7 m ahead (a stool, 0.3 m high) between them."""
    floor = np.column_stack([np.linspace(-0.2, 0.8, 11), np.zeros(11), np.zeros(11)])
    gx, gy, gz = np.meshgrid(
        np.arange(0.6, 0.71, 0.02), np.arange(-0.1, 0.11, 0.02), np.arange(0.05, 0.31, 0.02)
    )
    stool = np.column_stack([gx.ravel(), gy.ravel(), gz.ravel()])
    target = np.array([[1.0, 0.0, 0.9]] * 20) + np.linspace(0, 0.02, 20)[:, None]
    cloud = np.vstack([stool, target])
    align = np.r_[np.zeros(len(stool)), np.ones(len(target))]
    f32 = lambda a: torch.tensor(np.asarray(a)[None], dtype=torch.float32)  # noqa: E731
    return {
        "floor_xyz": f32(floor),
        "floor_mask": torch.ones(1, len(floor), dtype=torch.bool),
        "global_xyz": f32(cloud),
        "global_align": f32(align),
        "global_mask": torch.ones(1, len(cloud), dtype=torch.bool),
        "robot": torch.tensor([[0.85, 1.03, 1.0, 0.0, 0.7, 1.36, 0.0]]),
        "robot_name": [name],
    }


@pytest.mark.parametrize("name", ["panda", ""])
def test_the_footprint_gate_keeps_no_stance_whose_base_covers_an_obstacle(name):
    """The base (0.55 x 0.45 m for the Panda and for a robot given by its numbers) facing
    the target covers the stool from floor points within about 0.3 m of it."""
    from momakitchen.models.reach_input import footprint_gate

    batch = _fence_batch(name)
    gate = footprint_gate(batch)[0].numpy()
    x = batch["floor_xyz"][0, :, 0].numpy()
    half = 0.55 / 2 + 0.02  # the box's half length and the margin
    blocked = (x > 0.6 - half - 1e-6) & (x < 0.7 + half + 1e-6)
    np.testing.assert_array_equal(gate, np.where(blocked, 0.0, 1.0))
    assert blocked.any() and not blocked.all()


def test_the_footprint_gate_multiplies_any_models_prediction(batch):
    from momakitchen.models.config import TINY_MODEL
    from momakitchen.models.reach_input import footprint_gate

    torch.manual_seed(0)
    plain = build_model("pointnet2", TINY_MODEL).eval()
    gated = build_model("pointnet2", dataclasses.replace(TINY_MODEL, footprint_gate=True)).eval()
    gated.load_state_dict(plain.state_dict())
    with torch.no_grad():
        torch.testing.assert_close(
            gated(batch)["pred"], plain(batch)["pred"] * footprint_gate(batch)
        )
    with pytest.raises(MomaError, match="footprint_gate must be true or false"):
        ModelConfig(footprint_gate=1)
    assert "footprint_gate" not in ModelConfig().to_dict()


def test_the_gate_reads_the_obstacles_of_the_whole_cloud_not_the_thinned_one():
    """A model samples its cloud down (2048 points in the bundled one): too thin for the
    outlier filter, the stool would vanish. The collator of a gated model keeps each
    view's obstacle points from the whole cloud."""
    from momakitchen.data.batch import collate_episodes
    from momakitchen.models.reach_input import footprint_gate

    full = _fence_batch("panda")
    sample = {
        "global_xyz": full["global_xyz"][0].numpy(),
        "global_rgb": np.zeros_like(full["global_xyz"][0].numpy()),
        "global_align": full["global_align"][0].numpy(),
        "floor_xyz": full["floor_xyz"][0].numpy(),
        "robot": full["robot"][0].numpy(),
        "scene_id": 0,
        "config_index": 0,
        "episode_index": 0,
        "robot_name": "panda",
    }
    whole = footprint_gate(full)
    thin = collate_episodes([sample], num_global=24)
    kept = collate_episodes([sample], num_global=24, obstacles=True)
    assert kept["obstacle_xyz"].shape[1] > 24 and "obstacle_xyz" not in thin
    torch.testing.assert_close(footprint_gate(kept), whole)
    # the thinned stool loses its points to the filter: fewer stances are kept out
    assert float(footprint_gate(thin).sum()) > float(whole.sum())
