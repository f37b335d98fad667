"""Every category: distinct instances, loadable URDF, size metadata, grasps, envelope,
determinism and the JSON round trip of its parameters."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pybullet as pb
import pytest
from asset_helpers import body_aabb, envelope_for, load

from momakitchen.assets import CATEGORIES, categories_of_kind, get_category
from momakitchen.assets.rigid import MAX_GRASP_WIDTH
from momakitchen.errors import MomaError

EXPECTED = {
    "furniture": ["cabinet", "dishwasher", "fridge", "oven", "sink"],
    "appliance": ["microwave"],
    "rigid": ["bottle", "fruit", "medicine_bottle", "pot", "vegetable"],
    "obstacle": ["bin", "cart", "chair", "table", "trolley"],
}
ALL = sorted(n for names in EXPECTED.values() for n in names)
GRIPPER_OPENING = 0.08
# PyBullet pads the AABB of convex shapes by their collision margin (up to 3 mm a side for
# cylinders); the metadata is the exact geometric box.
AABB_PAD = 0.0065


def test_registry_holds_exactly_the_categories():
    for kind, names in EXPECTED.items():
        assert categories_of_kind(kind) == names
    assert sorted(CATEGORIES) == ALL


def _instances(name: str, n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        env = envelope_for(name, rng)
        out.append((env, get_category(name).sample(rng, env)))
    return out


@pytest.mark.parametrize("name", ALL)
def test_thirty_instances_differ_load_and_match_their_metadata(name, client):
    cat = get_category(name)
    items = _instances(name, 30)
    params = [p for _, p in items]
    assert len({json.dumps(dataclasses.asdict(p), sort_keys=True) for p in params}) == 30
    models = [cat.build(p) for p in params]
    assert len({m.urdf for m in models}) == 30
    for (env, _p), model in zip(items, models, strict=True):
        assert model.category == name
        assert model.mass > 0
        body = load(model, client, fixed=True, inertia=False)
        lo, hi = body_aabb(body, client)
        extent = hi - lo
        size = np.asarray(model.size)
        assert np.all(extent >= size - 1e-4), (name, extent, size)
        assert np.all(extent - size <= AABB_PAD), (name, extent, size)
        # the origin convention: furniture at the back edge on the floor, others centred
        assert lo[2] == pytest.approx(0.0, abs=0.004)
        if cat.kind in ("furniture", "appliance"):
            assert lo[1] == pytest.approx(0.0, abs=0.004)
            assert (lo[0] + hi[0]) / 2 == pytest.approx(0.0, abs=0.004)
        else:
            assert (lo[:2] + hi[:2]) / 2 == pytest.approx([0.0, 0.0], abs=0.004)
        for g in model.grasps:
            assert 0 < g.width < GRIPPER_OPENING
            assert abs(np.dot(g.normal, g.closing_axis)) < 1e-9
        for a in model.articulations:
            assert 0 < a.handle.width < GRIPPER_OPENING
            assert a.limit > 0
        pb.removeBody(body, physicsClientId=client)
        if env is not None:
            tall = name in ("sink",)  # the faucet rises above the countertop
            assert size[0] <= env.width + 1e-6
            assert size[1] <= env.depth + 1e-6
            if not tall:
                assert size[2] <= env.height + 1e-6
            if name in ("cabinet", "sink", "dishwasher", "oven"):
                assert max(r.z for r in model.placement_areas) == pytest.approx(env.height)


@pytest.mark.parametrize("name", ALL)
def test_same_params_same_urdf_and_json_round_trip(name):
    cat = get_category(name)
    ((_env, p),) = _instances(name, 1, seed=7)
    rng = np.random.default_rng(7)
    again = cat.sample(rng, envelope_for(name, rng))
    assert again == p  # sampling is a function of the generator state
    text = json.dumps(dataclasses.asdict(p))
    back = cat.params_from_dict(json.loads(text))
    assert back == p
    assert cat.build(back).urdf == cat.build(p).urdf


@pytest.mark.parametrize("name", EXPECTED["rigid"])
def test_rigid_targets_have_grasps_and_realistic_mass(name):
    cat = get_category(name)
    for _, p in _instances(name, 30, seed=3):
        m = cat.build(p)
        assert m.grasps, name
        assert max(g.width for g in m.grasps) <= MAX_GRASP_WIDTH + 1e-9, name
        assert 0.02 <= m.mass <= 3.0, (name, m.mass)
        assert "<lateral_friction" in m.urdf


@pytest.mark.parametrize("name", ["cabinet", "sink", "dishwasher", "oven", "fridge"])
def test_furniture_rejects_a_too_small_envelope(name):
    from momakitchen.assets import Envelope

    with pytest.raises(MomaError, match=name):
        get_category(name).sample(np.random.default_rng(0), Envelope(0.1, 0.1, 0.1))


def test_articulated_categories_have_the_expected_parts():
    parts: dict[str, set[str]] = {}
    for name in ("cabinet", "sink", "dishwasher", "oven", "fridge", "microwave"):
        for _env, p in _instances(name, 30, seed=1):
            m = get_category(name).build(p)
            assert m.articulations, name
            parts.setdefault(name, set()).update(a.part for a in m.articulations)
    assert parts["cabinet"] == {"door", "drawer"}
    assert "lever" in parts["sink"]
    assert parts["dishwasher"] == {"door"}
    assert "door" in parts["oven"] and "door" in parts["fridge"] and "door" in parts["microwave"]


def test_handle_types_vary_across_cabinets():
    kinds = {p.handle_type for _, p in _instances("cabinet", 40, seed=2)}
    assert {"bar_h", "bar_v", "knob"} <= kinds


# Envelope maxima used to probe the whole range a layout might grant.
ENVELOPE_MAX = {
    "cabinet": (1.2, 0.8, 1.0),
    "sink": (1.2, 0.8, 1.0),
    "dishwasher": (0.65, 0.8, 1.0),
    "oven": (0.9, 0.8, 1.0),
    "fridge": (0.95, 0.85, 2.2),
    "microwave": (0.8, 0.6, 0.6),
}


@pytest.mark.parametrize("name", sorted(ENVELOPE_MAX))
def test_any_envelope_from_minimum_to_generous_is_filled_and_respected(name):
    from momakitchen.assets import Envelope

    cat = get_category(name)
    lo, hi = np.asarray(cat.MIN_ENVELOPE), np.asarray(ENVELOPE_MAX[name])
    rng = np.random.default_rng(4)
    for k in range(60):
        # the corners of the range first, then random envelopes
        pick = lo if k == 0 else hi if k == 1 else rng.uniform(lo, hi)
        # unrounded envelopes too: rounding inside the sampler must not overshoot them
        env = Envelope(*(float(v) if k % 2 else round(float(v), 4) for v in pick))
        model = cat.build(cat.sample(rng, env))
        w, d, h = model.size
        assert w <= env.width + 1e-6 and d <= env.depth + 1e-6, (name, env, model.size)
        if cat.kind == "furniture":
            assert w == pytest.approx(env.width, abs=1e-5)  # units fill their slot
        if name != "sink":  # the faucet stands on the countertop
            assert h <= env.height + 1e-6, (name, env, model.size)


def test_lidless_pots_offer_rim_grasps_straddling_the_wall():
    """A pot without a lid can be held at its rim, fingers closing radially across the wall
    2 cm below its top, on the sides where no handle is attached; a lid covers the rim."""
    cat = get_category("pot")
    rng = np.random.default_rng(5)
    seen = {0: 0, 1: 0}
    for _ in range(40):
        params = cat.sample(rng, None)
        model = cat.build(params)
        rims = [g for g in model.grasps if g.name.startswith("rim")]
        seen[params.lid] += 1
        if params.lid:
            assert not rims
            continue
        assert len(rims) == (3 if params.style == "saucepan" else 2)
        cx = -params.handle_length / 2 if params.style == "saucepan" else 0.0
        for g in rims:
            radial = np.array(g.position[:2]) - [cx, 0.0]
            inside = params.radius - params.wall / 2
            assert np.linalg.norm(radial) == pytest.approx(inside, abs=1e-5)
            assert np.allclose(np.array(g.closing_axis[:2]), radial / np.linalg.norm(radial))
            assert g.normal == (0.0, 0.0, 1.0) and g.width == params.wall
            assert g.position[2] == pytest.approx(params.height - 0.02)
        assert model.grasps[0].name.startswith("rim")
    assert seen[0] and seen[1]
