"""Mount heights of configurations: drawn per configuration from a range (the config's or
the robot's), deterministic, recorded; the robot's own height when no range is given; bad
heights and arms that reach no counter are one-line errors."""

from __future__ import annotations

import dataclasses

import pytest

from momakitchen import codec
from momakitchen.errors import MomaError
from momakitchen.robots.spec import DEFAULT_ROBOTS, ROBOTS, get_robot_spec, register_robot
from momakitchen.scene.configuration import (
    Configuration,
    SceneConfig,
    configuration_mount,
    counter_reach_problem,
    sample_configuration,
    sample_scene,
    with_robot,
)
from momakitchen.scene.layout import COUNTER_HEIGHTS, sample_layout


def test_without_a_range_every_robot_stands_at_its_own_height():
    scene = sample_scene(3, SceneConfig(configs_per_scene=6))
    assert all(c.mount_height is None for c in scene.configurations)
    assert all("mount_height" not in c.to_dict() for c in scene.configurations)
    assert {c.mount for c in scene.configurations} <= {0.33, 1.03}
    # A config without the field writes none: manifests of earlier datasets stay the same.
    assert "mount_height" not in codec.to_dict(SceneConfig())
    assert SceneConfig().robot_names == DEFAULT_ROBOTS


def test_a_range_draws_each_configurations_height_deterministically():
    cfg = SceneConfig(configs_per_scene=8, mount_height=(0.6, 1.3))
    scene = sample_scene(5, cfg)
    heights = [c.mount_height for c in scene.configurations]
    assert all(h is not None and 0.6 <= h <= 1.3 and round(h, 3) == h for h in heights)
    assert len(set(heights)) == len(heights)  # drawn, not constant
    assert heights == [c.mount_height for c in sample_scene(5, cfg).configurations]
    # From (scene id, configuration index) alone: the same with fewer configurations.
    fewer = sample_scene(5, dataclasses.replace(cfg, configs_per_scene=3))
    assert [c.mount_height for c in fewer.configurations] == heights[:3]
    # The objects on the counter are drawn before the height matters: the same as without.
    plain = sample_scene(5, SceneConfig(configs_per_scene=8))
    assert [c.objects for c in scene.configurations] == [c.objects for c in plain.configurations]
    assert scene.configurations[0].to_dict()["mount_height"] == heights[0]
    back = Configuration.from_dict(scene.configurations[0].to_dict())
    assert back == scene.configurations[0]


def test_a_single_height_and_the_robots_own_range():
    layout = sample_layout(2)
    fixed = sample_configuration(layout, 0, SceneConfig(configs_per_scene=1, mount_height=0.7))
    assert fixed.mount_height == 0.7 and fixed.mount == 0.7
    ranged = dataclasses.replace(
        get_robot_spec("ur5e"), name="ur5e_ranged", mount_height=0.7, mount_range=(0.5, 0.9)
    )
    register_robot(ranged)
    try:
        cfg = SceneConfig(configs_per_scene=4, robots=("ur5e_ranged",))
        heights = [c.mount_height for c in sample_scene(2, cfg).configurations]
        assert all(h is not None and 0.5 <= h <= 0.9 for h in heights)
        # The config's height wins over the robot's range.
        assert configuration_mount(2, 0, ranged, dataclasses.replace(cfg, mount_height=1.2)) == 1.2
        # Relabelling with another robot takes that robot's height for the configuration.
        other = with_robot(sample_scene(2, cfg).configurations[0], "panda", cfg)
        assert other.robot == "panda" and other.mount_height is None
    finally:
        ROBOTS.unregister("ur5e_ranged")


def test_config_files_give_a_number_or_a_range(tmp_path):
    from momakitchen.data.config import GenerationConfig

    path = tmp_path / "gen.yaml"
    path.write_text("scene:\n  mount_height: [0.6, 1.3]\n  robots: [ur10e, gen3]\n")
    gen = codec.load_config_file(path, GenerationConfig)
    assert gen.scene.mount_height == (0.6, 1.3) and gen.scene.robot_names == ("ur10e", "gen3")
    assert codec.to_dict(gen.scene)["mount_height"] == [0.6, 1.3]
    path.write_text("scene:\n  mount_height: 0.9\n")
    assert codec.load_config_file(path, GenerationConfig).scene.mount_height == 0.9


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (1.5, r"scene.mount_height must be in \[0.3, 1.3\] m, got 1.5"),
        ((0.2, 1.0), r"got 0.2 \(in the range \[0.2, 1.0\]\)"),
        ((1.1, 0.7), r"lo <= hi, got \[1.1, 0.7\]"),
    ],
)
def test_a_height_outside_the_range_names_the_value(value, message):
    with pytest.raises(MomaError, match=message) as info:
        SceneConfig(mount_height=value)
    assert "\n" not in str(info.value)


def test_an_arm_that_reaches_no_counter_is_refused():
    short = dataclasses.replace(get_robot_spec("elephant"), name="stubby", reach=0.2)
    assert counter_reach_problem(get_robot_spec("elephant"), (0.3, 1.3)) is None
    problem = counter_reach_problem(short, (0.3, 0.3))
    assert problem and "robot 'stubby' cannot reach the counter at any mount height" in problem
    assert f"{COUNTER_HEIGHTS[0]:g}-{COUNTER_HEIGHTS[1]:g} m high" in problem
    # Mounted where its shoulder is at counter height, a short arm reaches the front edge.
    assert counter_reach_problem(dataclasses.replace(short, reach=0.35), (0.3, 1.3)) is None
    register_robot(short)
    try:
        with pytest.raises(MomaError, match="'stubby' cannot reach the counter"):
            SceneConfig(robots=("stubby",), mount_height=0.3)
        with pytest.raises(MomaError, match="'stubby' cannot reach the counter"):
            with_robot(
                sample_scene(1, SceneConfig(configs_per_scene=1)).configurations[0],
                "stubby",
                SceneConfig(mount_height=0.3),
            )
    finally:
        ROBOTS.unregister("stubby")
