"""Scene sampling for hard scenes (the ``hard`` generation preset): obstacles where a base
would naturally stop, objects deep on the counter, articulated targets weighted towards
doors and low or high handles. At their defaults the new fields change nothing: the
default scenes keep their bytes."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from momakitchen import codec
from momakitchen.errors import MomaError
from momakitchen.scene.articulated import articulated_targets, handle_anchor
from momakitchen.scene.configuration import (
    HIGH_HANDLE,
    LOW_HANDLE,
    STANCE_ARC,
    Scene,
    SceneConfig,
    hard_part,
    sample_scene,
)
from momakitchen.scene.layout import sample_layout

# sha256 of json.dumps(sample_scene(i, SceneConfig()).to_dict(), sort_keys=True), written
# down before the hard-scene fields existed: default datasets keep their configurations
# (and so their labels) byte for byte.
DEFAULT_SCENES = {
    0: "b8e62a58b292ede21300f3cd2f29b92904fdafa6d9829d22881e64298b5d2c23",
    1: "4b44a347934016ee7dce68267340b144c72145f751b6d6fbe1831fd05159a78c",
}
NEW_FIELDS = ("stance_obstacles", "stance_band", "object_depth", "hard_part_weight")


@pytest.mark.parametrize("scene_id", sorted(DEFAULT_SCENES))
def test_default_scenes_keep_their_bytes(scene_id):
    data = sample_scene(scene_id, SceneConfig()).to_dict()
    digest = hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
    assert digest == DEFAULT_SCENES[scene_id]
    assert not set(NEW_FIELDS) & set(codec.to_dict(SceneConfig()))


def _stance(c):
    """The obstacle drawn in the stance band: the first (an obstacle that fits nowhere is
    left out, so its number names it)."""
    return [ob for ob in c.obstacles if ob.uid == "o0"]


def _stance_config(**kw):
    return SceneConfig(configs_per_scene=6, obstacles=(1, 3), stance_obstacles=1, **kw)


def test_stance_obstacles_stand_where_a_base_would_stop():
    cfg = _stance_config()
    lo, hi = cfg.stance_band
    in_band = []
    counts = []
    for scene_id in (800000, 800001, 800002):
        plain = sample_scene(scene_id, SceneConfig(configs_per_scene=6))
        scene = sample_scene(scene_id, cfg)
        for c, p in zip(scene.configurations, plain.configurations, strict=True):
            counts.append(len(c.obstacles))
            ax, ay, _ = c.target.anchor
            for ob in _stance(c):
                r = float(np.hypot(ob.x - ax, ob.y - ay))
                angle = abs(float(np.arctan2(ob.y - ay, ob.x - ax)) - np.pi / 2)
                in_band.append(lo - 1e-3 <= r <= hi + 1e-3 and angle <= STANCE_ARC + 1e-3)
            # The layout, the objects and the robot are drawn as without them.
            assert (c.objects, c.robot) == (p.objects, p.robot)
    # Most stand in the band; those that fit nowhere there (a door's sweep), or that would
    # leave no room within reach, stand elsewhere.
    assert len(in_band) >= 15 and np.mean(in_band) >= 0.7
    assert max(counts) <= 3 and min(counts) >= 1


def test_the_band_is_a_field():
    cfg = _stance_config(stance_band=(0.9, 1.0))
    r = [
        np.hypot(ob.x - c.target.anchor[0], ob.y - c.target.anchor[1])
        for scene_id in (800003, 800004, 800005)
        for c in sample_scene(scene_id, cfg).configurations
        for ob in _stance(c)
    ]
    assert np.mean([0.9 - 1e-3 <= x <= 1.0 + 1e-3 for x in r]) >= 0.7


def test_objects_stand_deeper_on_the_counter():
    def depths(cfg):
        out = []
        for scene_id in range(800000, 800006):
            scene = sample_scene(scene_id, cfg)
            areas = scene.layout.placement_areas()
            for c in scene.configurations:
                for ob in c.objects:
                    area = next(a for a in areas if a.x0 <= ob.x <= a.x1 and a.y0 <= ob.y <= a.y1)
                    out.append(area.y1 - ob.y)
        return np.array(out)

    shallow = depths(SceneConfig(configs_per_scene=4))
    deep = depths(SceneConfig(configs_per_scene=4, object_depth=0.45))
    assert shallow.max() <= 0.30 + 1e-3 and deep.max() <= 0.45 + 1e-3
    assert (deep > 0.30).mean() >= 0.2


def test_hard_parts_and_their_weight():
    seen = set()
    for scene_id in (800000, 800002):  # the second has a fridge, a dishwasher, a microwave
        layout = sample_layout(scene_id)
        for uid, art in articulated_targets(layout):
            unit = layout.unit(uid)
            z = handle_anchor(unit, art)[2]
            # A counter-top appliance's door swings over the counter, not the floor.
            door = unit.model.articulations[art].part == "door" and unit.category != "microwave"
            assert hard_part(unit, art) == (door or z < LOW_HANDLE or z > HIGH_HANDLE)
            seen.add((unit.category, hard_part(unit, art)))
    assert {("microwave", False), ("fridge", True), ("cabinet", True), ("cabinet", False)} <= seen

    def hard_share(weight):
        cfg = SceneConfig(configs_per_scene=10, rigid_target_prob=0.0, hard_part_weight=weight)
        hard = []
        for scene_id in range(800000, 800004):
            scene = sample_scene(scene_id, cfg)
            for c in scene.configurations:
                if c.target.articulation is not None:
                    unit = scene.layout.unit(c.target.uid)
                    hard.append(hard_part(unit, c.target.articulation))
        return float(np.mean(hard))

    low, plain, high = hard_share(0.05), hard_share(1.0), hard_share(20.0)
    assert low + 0.3 < plain < high - 0.15


def test_new_fields_round_trip_and_are_checked():
    cfg = _stance_config(object_depth=0.45, hard_part_weight=3.0, stance_band=(0.55, 0.85))
    data = codec.to_dict(cfg)
    assert {k: data[k] for k in NEW_FIELDS} == {
        "stance_obstacles": 1,
        "stance_band": [0.55, 0.85],
        "object_depth": 0.45,
        "hard_part_weight": 3.0,
    }
    assert codec.from_dict(SceneConfig, data) == cfg
    scene = sample_scene(800004, cfg)
    assert Scene.from_dict(json.loads(json.dumps(scene.to_dict()))).config == cfg
    for kw, needle in [
        ({"stance_obstacles": 4}, "stance_obstacles"),
        ({"stance_obstacles": -1}, "stance_obstacles"),
        ({"stance_band": (0.8, 0.5)}, "stance_band"),
        ({"stance_band": (0.1, 0.5)}, "stance_band"),
        ({"object_depth": 0.0}, "object_depth"),
        ({"hard_part_weight": 0.0}, "hard_part_weight"),
    ]:
        with pytest.raises(MomaError, match=needle):
            SceneConfig(obstacles=(1, 3), **kw)
