import dataclasses

import pytest
import torch

from momakitchen.data.batch import collate_episodes
from momakitchen.data.synthetic import SyntheticConfig, SyntheticEpisodes
from momakitchen.errors import MomaError
from momakitchen.models import MODELS, ModelConfig, build_model, model_names, num_parameters

EXPECTED = {
    "navaff",
    "pointnet2",
    "votenet",
    "h3dnet",
    "navaff-no-robot",
    "navaff-no-vam",
    "navaff-no-global",
}
# The registered models, plus NavAff with its options: the target set
# (ModelConfig.target_points), the robot-conditioned head (ModelConfig.robot_head) and the
# robot's reachability as a floor input (ModelConfig.reach_input).
OPTIONS = {
    "target": {"target_points": 6},
    "robot_head": {"robot_head": True},
    "reach": {"reach_input": True},
    "reach8": {"reach_input": True, "reach_points": 8},
}
VARIANTS = [*sorted(EXPECTED), *(f"navaff+{o}" for o in OPTIONS)]


def _build(name, cfg):
    name, _, option = name.partition("+")
    return build_model(name, dataclasses.replace(cfg, **OPTIONS[option]) if option else cfg)


@pytest.fixture(scope="module")
def samples():
    ds = SyntheticEpisodes(SyntheticConfig(num_episodes=3, num_global=300, num_floor=120, seed=3))
    return [ds[i] for i in range(3)]


def _pad_with_garbage(batch, extra_g, extra_f):
    """Append padded points carrying wild values that must not matter."""
    out = dict(batch)
    b = batch["global_xyz"].shape[0]
    g = torch.Generator().manual_seed(0)
    for key, extra, width in (
        ("global_xyz", extra_g, 3),
        ("global_rgb", extra_g, 3),
        ("floor_xyz", extra_f, 3),
    ):
        junk = torch.randn(b, extra, width, generator=g) * 5
        out[key] = torch.cat([batch[key], junk], 1)
    out["global_align"] = torch.cat([batch["global_align"], torch.ones(b, extra_g)], 1)
    out["floor_label"] = torch.cat([batch["floor_label"], torch.rand(b, extra_f, generator=g)], 1)
    out["global_mask"] = torch.cat([batch["global_mask"], torch.zeros(b, extra_g, dtype=bool)], 1)
    out["floor_mask"] = torch.cat([batch["floor_mask"], torch.zeros(b, extra_f, dtype=bool)], 1)
    return out


def test_registry_has_all_models_and_rejects_unknown_names(tiny_config):
    assert set(model_names()) == EXPECTED == set(MODELS)
    with pytest.raises(MomaError, match=r"unknown model 'pointnet3'.*navaff"):
        build_model("pointnet3", tiny_config)


def test_parameter_names_of_the_set_abstraction_stacks_stay(tiny_config):
    """Saved runs (the bundled checkpoint, results/) name the encoders' layers so."""
    where = {
        "navaff": "backbone.global_encoder",
        "pointnet2": "backbone.encoder",
        "votenet": "backbone.seeds.encoder",
        "h3dnet": "backbone.seeds.encoder",
    }
    for name, prefix in where.items():
        keys = build_model(name, tiny_config).state_dict()
        for level in ("sa1", "sa2", "sa3"):
            assert f"{prefix}.{level}.mlps.0.first.weight" in keys
            assert f"{prefix}.{level}.norms.1.bias" in keys
    keys = build_model("navaff", tiny_config).state_dict()
    assert "backbone.global_encoder.tokenizer.feat.0.weight" in keys


def test_model_config_validation_names_the_bad_value():
    with pytest.raises(MomaError, match=r"num_heads.*3"):
        ModelConfig(embed_dim=32, num_heads=3)
    with pytest.raises(MomaError, match="global_npoints"):
        ModelConfig(num_tokens=64, global_npoints=(128, 32))
    with pytest.raises(MomaError, match=r"dropout.*1\.5"):
        ModelConfig(dropout=1.5)
    with pytest.raises(MomaError, match=r"peak_temperature.*0\.0"):
        ModelConfig(peak_temperature=0.0)
    with pytest.raises(MomaError, match=r"peak_weight.*-1"):
        ModelConfig(peak_weight=-1)
    cfg = ModelConfig(global_npoints=[512, 128])
    assert ModelConfig.from_dict(cfg.to_dict()) == cfg


@pytest.mark.parametrize("name", VARIANTS)
def test_padding_changes_neither_outputs_nor_loss(name, tiny_config, samples):
    torch.manual_seed(0)
    cfg = dataclasses.replace(tiny_config, dropout=0.0)
    model = _build(name, cfg)
    assert num_parameters(model) > 0
    with torch.no_grad():
        model.head.out.weight.normal_(0.0, 1.0)  # not the flat initial map
    exact = collate_episodes(samples[:1])
    padded = _pad_with_garbage(exact, 57, 23)
    model.eval()
    with torch.no_grad():
        a = model(exact)
        b = model(padded)
    nf = exact["floor_xyz"].shape[1]
    assert torch.allclose(a["pred"], b["pred"][:, :nf], atol=1e-5)
    assert (b["pred"][:, nf:] == 0).all()
    assert torch.allclose(a["loss"], b["loss"], atol=1e-6)
    assert ((a["pred"] >= 0) & (a["pred"] <= 1)).all()
    # Training-mode loss (weighted MSE draw from the same RNG state) is padding-free too.
    model.train()
    torch.manual_seed(5)
    la = model(exact)["loss"]
    torch.manual_seed(5)
    lb = model(padded)["loss"]
    assert torch.allclose(la, lb, atol=1e-6)


def test_batched_episodes_equal_single_episodes(tiny_config, samples):
    torch.manual_seed(0)
    model = build_model("navaff", tiny_config).eval()
    with torch.no_grad():
        model.head.out.weight.normal_(0.0, 1.0)
    batch = collate_episodes(samples)
    with torch.no_grad():
        together = model(batch)["pred"]
        for i, s in enumerate(samples):
            alone = model(collate_episodes([s]))["pred"][0]
            n = alone.shape[0]
            assert torch.allclose(together[i, :n], alone, atol=1e-5)


def test_ablations_ignore_what_they_drop(tiny_config, samples):
    batch = collate_episodes(samples[:2])
    other_robot = dict(batch, robot=batch["robot"].flip(0) + 0.3)
    no_align = dict(batch, global_align=torch.zeros_like(batch["global_align"]))
    moved = dict(batch, global_xyz=batch["global_xyz"] + 0.5, global_rgb=1 - batch["global_rgb"])

    def run(name, b):
        torch.manual_seed(0)
        m = build_model(name, tiny_config).eval()
        with torch.no_grad():
            # The output layer starts at zero (a flat 0.5 map); make it see the features.
            m.head.out.weight.normal_(0.0, 1.0)
            return m(b)["pred"]

    base = run("navaff", batch)
    assert not torch.allclose(base, run("navaff", other_robot))
    assert not torch.allclose(base, run("navaff", no_align))
    assert torch.allclose(run("navaff-no-robot", batch), run("navaff-no-robot", other_robot))
    with_head = dataclasses.replace(tiny_config, robot_head=True)
    assert not build_model("navaff-no-robot", with_head).head.use_robot  # nothing reads it
    assert torch.allclose(run("navaff-no-vam", batch), run("navaff-no-vam", no_align))
    assert torch.allclose(run("navaff-no-global", batch), run("navaff-no-global", moved))
    for name in ("pointnet2", "votenet", "h3dnet"):
        assert not torch.allclose(run(name, batch), run(name, other_robot))


def test_robot_head_conditions_navaffs_head_on_the_robot(tiny_config, samples):
    assert not build_model("navaff", tiny_config).head.use_robot  # the paper's NavAff
    cfg = dataclasses.replace(tiny_config, robot_head=True)
    model = build_model("navaff", cfg).eval()
    assert model.head.use_robot
    with torch.no_grad():
        model.head.out.weight.normal_(0.0, 1.0)
    batch = collate_episodes(samples[:2])
    # The robot reaches the head directly: the same backbone features with another
    # descriptor give another map.
    feats = model.backbone(batch)
    robot = batch["robot"]
    with torch.no_grad():
        assert not torch.allclose(model.head(feats, robot), model.head(feats, robot.flip(0) + 0.3))
    with pytest.raises(MomaError, match=r"robot_head.*'yes'"):
        ModelConfig(robot_head="yes")


@pytest.mark.parametrize("name", VARIANTS)
def test_every_parameter_gets_a_gradient(name, tiny_config, samples):
    torch.manual_seed(0)
    model = _build(name, tiny_config).train()
    out = model(collate_episodes(samples[:2]))
    out["loss"].backward()
    missing = [n for n, p in model.named_parameters() if p.grad is None]
    assert not missing


@pytest.mark.parametrize("name", VARIANTS)
def test_mc_samples_split_the_backbone_where_the_dropout_starts(name, tiny_config, samples):
    """sample_predictions runs encode once: it must hold no dropout, and with dropout off
    the samples must equal the plain forward pass."""
    from momakitchen.models.base import Backbone

    model = _build(name, tiny_config)
    backbone = model.backbone
    if type(backbone).encode is Backbone.encode:  # the whole backbone counts as encode
        assert not any(
            isinstance(m, torch.nn.Dropout) or getattr(m, "dropout", 0) for m in backbone.modules()
        )
    batch = collate_episodes(samples[:1])
    model.eval()
    with torch.no_grad():
        plain = model({k: v for k, v in batch.items() if k != "floor_label"})["pred"]
    for m in model.modules():  # dropout off, everything else as in sampling
        if isinstance(m, torch.nn.Dropout):
            m.p = 0.0
        if isinstance(m, torch.nn.MultiheadAttention):
            m.dropout = 0.0
    sampled = model.sample_predictions(batch, 3)
    assert sampled.shape == (3, plain.shape[1])
    torch.testing.assert_close(sampled, plain.expand(3, -1), atol=1e-6, rtol=0)


@pytest.mark.parametrize("name", VARIANTS)
def test_a_plan_computed_ahead_gives_the_same_outputs_and_gradients(name, tiny_config, samples):
    """The trainer's DataLoader workers attach Backbone.plan to each batch; the forward
    pass must then equal the one that finds the geometry itself, bit for bit."""
    cfg = dataclasses.replace(tiny_config, dropout=0.0)
    torch.manual_seed(0)
    model = _build(name, cfg)
    with torch.no_grad():
        model.head.out.weight.normal_(0.0, 1.0)
    batch = _pad_with_garbage(collate_episodes(samples), 11, 7)
    torch.manual_seed(1)
    planner = _build(name, cfg).backbone  # another instance: plans need no weights
    planned = {**batch, "plan": planner.plan(batch)}
    assert planned["plan"] or name == "navaff-no-global"
    outs, grads = [], []
    for b in (batch, planned):
        model.zero_grad()
        torch.manual_seed(5)
        out = model(b)
        out["loss"].backward()
        outs.append(out["pred"])
        grads.append([p.grad.clone() for p in model.parameters()])
    assert torch.equal(outs[0], outs[1])
    assert all(torch.equal(a, b) for a, b in zip(*grads, strict=True))


@pytest.mark.parametrize("name", VARIANTS)
def test_with_a_floor_context_each_point_scores_as_in_the_context_alone(name, tiny_config, samples):
    """Inference encodes the floor at the training density and interpolates to every floor
    point: a point of the context must get the value the context alone gives it."""
    torch.manual_seed(0)
    model = _build(name, tiny_config).eval()
    with torch.no_grad():  # the head starts flat: make the map depend on the features
        model.head.out.weight.normal_(0.0, 1.0)
    trained = collate_episodes(samples, 200, 40, seed=3)
    infer = collate_episodes(samples, 200, None, seed=3, num_context=40)
    assert infer["floor_xyz"].shape[1] > 40
    with torch.no_grad():
        alone, full = model(trained)["pred"], model(infer)["pred"]
    for i in range(len(samples)):
        ctx = trained["floor_xyz"][i][trained["floor_mask"][i]]
        hit = (infer["floor_xyz"][i][:, None] == ctx[None]).all(-1)  # (Nf, Nc)
        assert (hit.sum(0) == 1).all()
        torch.testing.assert_close(full[i, hit.float().argmax(0)], alone[i, : len(ctx)])
    # the other floor points are scored too, and not all alike (relative to the head's
    # small prior, which a random model's values sit near)
    scores = full[infer["floor_mask"]]
    assert scores.std() > 0.02 * scores.mean(), (scores.std(), scores.mean())


@pytest.mark.parametrize("name", ["navaff", "navaff+target", "pointnet2"])
def test_backward_copies_no_slices(name, tiny_config, samples):
    """In-place ops on views (a ReLU after a Linear on a 4-D tensor) make autograd copy
    whole (B, M, K, C) gradients through CopySlices: a third of a training step once."""
    model = _build(name, tiny_config)
    out = model(collate_episodes(samples))
    seen, stack = set(), [out["loss"].grad_fn]
    while stack:
        fn = stack.pop()
        if fn is None or fn in seen:
            continue
        seen.add(fn)
        assert type(fn).__name__ != "CopySlices"
        stack += [f for f, _ in fn.next_functions]


def test_target_set_encoder_is_a_masked_pointnet_over_offsets():
    from momakitchen.models.navaff import TargetSetEncoder

    torch.manual_seed(0)
    enc = TargetSetEncoder([8, 16], radius=0.5)
    target = torch.randn(2, 5, 3)
    mask = torch.tensor([[True] * 3 + [False] * 2, [False] * 5])
    query = torch.randn(2, 4, 3)
    out = enc(target, mask, query)
    assert out.shape == (2, 4, 16)
    # brute force: the MLP on every real offset, max over the target, layer norm
    rel = (target[0, :3][None] - query[0][:, None]) / 0.5  # (4, 3, 3)
    h = enc.rest(torch.relu(rel @ enc.first.weight.t() + enc.first.bias))
    torch.testing.assert_close(out[0], enc.norm(h.amax(1)))
    assert (out[1] == 0).all()  # no target point: nothing seen
    # a target and its mirror image look different from the same place (e.g. a door
    # hinged left or right of its handle), unlike their centroids
    mirrored = target * torch.tensor([1.0, -1.0, 1.0])
    origin = torch.zeros(2, 1, 3)
    assert not torch.allclose(enc(mirrored, mask, origin)[0], enc(target, mask, origin)[0])


def test_target_set_sees_the_target_points_only(tiny_config, samples):
    cfg = dataclasses.replace(tiny_config, dropout=0.0, target_points=6)
    torch.manual_seed(0)
    model = build_model("navaff", cfg).eval()
    with torch.no_grad():
        model.head.out.weight.normal_(0.0, 1.0)
    batch = collate_episodes(samples[:2])
    plan = model.backbone.plan(batch)["target"]
    assert plan["mask"].all()
    chosen = torch.gather(batch["global_align"], 1, plan["idx"])
    assert (chosen > 0.5).all()
    # without target points the cloud still scores (the set is empty, not garbage)
    none = dict(batch, global_align=torch.zeros_like(batch["global_align"]))
    assert not model.backbone.plan(none)["target"]["mask"].any()
    with torch.no_grad():
        assert torch.isfinite(model(none)["pred"]).all()


def test_relative_dropout_hides_the_target_offset_of_some_training_episodes(tiny_config, samples):
    from momakitchen.models.navaff import fourier_channels

    cfg = dataclasses.replace(tiny_config, relative_dropout=0.5)
    model = build_model("navaff", cfg)
    seen = []
    model.backbone.floor_sa1.register_forward_hook(lambda m, args, out: seen.append(args[1]))
    batch = collate_episodes(samples * 4)  # 12 episodes
    absolute = fourier_channels(cfg.pos_freqs)

    def hidden(mode):
        seen.clear()
        torch.manual_seed(1)
        with torch.no_grad():
            model.train(mode)(batch)
        feats = seen[0]  # (B, Nc, C): absolute encoding, then the target-relative one
        rel = feats[..., absolute:].abs().amax((1, 2))
        assert (feats[..., :absolute].abs().amax((1, 2)) > 0).all()
        return rel == 0

    drawn = hidden(True)
    assert 0 < int(drawn.sum()) < len(drawn)  # some episodes hidden, not all
    assert torch.equal(drawn, hidden(True))  # one draw per episode from the seeded RNG
    assert not hidden(False).any()  # never at evaluation
    with pytest.raises(MomaError, match=r"relative_dropout.*1\.0"):
        ModelConfig(relative_dropout=1.0)
