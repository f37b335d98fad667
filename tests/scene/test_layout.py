import json

import numpy as np
import pytest

from momakitchen.assets import get_category
from momakitchen.errors import MomaError
from momakitchen.robots import get_robot_spec
from momakitchen.scene.configuration import (
    Scene,
    SceneConfig,
    sample_configuration,
    sample_scene,
)
from momakitchen.scene.geometry import overlaps
from momakitchen.scene.layout import Layout, sample_layout

SCENE_IDS = [0, 1, 7, 42, 123]


@pytest.mark.parametrize("scene_id", SCENE_IDS)
def test_scene_is_deterministic_and_round_trips(scene_id):
    a = json.dumps(sample_scene(scene_id).to_dict())
    b = json.dumps(sample_scene(scene_id).to_dict())
    assert a == b
    back = Scene.from_dict(json.loads(a))
    assert json.dumps(back.to_dict()) == a
    assert back == sample_scene(scene_id)


def test_different_scenes_differ():
    dumps = {json.dumps(sample_layout(s).to_dict()) for s in range(20)}
    assert len(dumps) == 20


@pytest.mark.parametrize("scene_id", SCENE_IDS)
def test_furniture_stands_along_the_wall_inside_the_room(scene_id):
    layout = sample_layout(scene_id)
    fps = layout.footprints()
    for i, a in enumerate(fps):
        c = a.corners()
        assert c[:, 1].min() >= -1e-6, "units stand against the wall at y = 0"
        assert c[:, 0].min() > 0 and c[:, 0].max() < layout.room.width
        for b in fps[i + 1 :]:
            assert not overlaps(a, b)
    cats = [u.category for u in layout.furniture]
    assert "sink" in cats and cats.count("cabinet") >= 2
    for unit in layout.furniture:
        kind = get_category(unit.category).kind
        assert kind in ("furniture", "appliance")
        if kind == "appliance":  # stands on a countertop
            assert unit.z == pytest.approx(layout.counter_height, abs=0.01)


@pytest.mark.parametrize("scene_id", SCENE_IDS)
def test_configurations_respect_the_rules(scene_id):
    scene = sample_scene(scene_id)
    layout = scene.layout
    furniture = layout.footprints()
    areas = layout.placement_areas()
    for cfg in scene.configurations:
        reach = get_robot_spec(cfg.robot).reach
        assert 1 <= len(cfg.objects) <= 3
        assert 1 <= len(cfg.obstacles) <= 3
        for obj in cfg.objects:
            assert any(
                a.x0 <= obj.x <= a.x1 and a.y0 <= obj.y <= a.y1 and abs(a.z - obj.z) < 0.01
                for a in areas
            ), obj
        tx, ty, _ = cfg.target.anchor
        for i, ob in enumerate(cfg.obstacles):
            rel = np.array([ob.x - tx, ob.y - ty])
            assert np.linalg.norm(rel) <= reach + 1e-6 and rel[1] > 0, "inside the semicircle"
            fp = ob.footprint()
            assert not any(overlaps(fp, f) for f in furniture)
            assert not any(overlaps(fp, o.footprint()) for o in cfg.obstacles[i + 1 :])
        if cfg.target.is_articulated:
            unit = layout.unit(cfg.target.uid)
            assert cfg.target.articulation < len(unit.model.articulations)
        else:
            assert cfg.target.uid in {o.uid for o in cfg.objects}


def test_robots_cover_all_six_within_a_scene_set():
    robots = {c.robot for s in range(3) for c in sample_scene(s).configurations}
    assert robots == {"panda", "flexiv", "ur5e", "xarm6", "realman", "elephant"}


def test_bad_values():
    with pytest.raises(MomaError, match="-3"):
        sample_layout(-3)
    with pytest.raises(MomaError, match="configs_per_scene"):
        SceneConfig(configs_per_scene=0)
    with pytest.raises(MomaError, match="unknown robot 'r2d2'"):
        SceneConfig(robots=("r2d2",))
    with pytest.raises(MomaError, match="configuration index"):
        sample_configuration(sample_layout(0), 99)


def test_layout_dict_round_trip():
    layout = sample_layout(3)
    assert Layout.from_dict(layout.to_dict()) == layout
    # through JSON too (tuples come back as lists), as scene.json is read back
    assert Layout.from_dict(json.loads(json.dumps(layout.to_dict()))) == layout
