"""A built-in robot exported as a user robot's files (URDF + YAML) and registered again
through the user loader: the same body, the same model input."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.export import arm_urdf, export_user_robot
from momakitchen.robots.robot import Robot
from momakitchen.robots.spec import ROBOTS, get_robot_spec
from momakitchen.robots.urdf import BASE_LINK, robot_urdf
from momakitchen.robots.user import register_user_robot, unregister_user_robot
from momakitchen.sim import reachability
from momakitchen.sim.reachability import ReachabilityMap
from momakitchen.sim.sampling import SamplingConfig

BUILT_IN = ("panda", "flexiv", "ur5e", "xarm6", "realman", "elephant", "ur10e", "gen3")


@pytest.fixture
def copy_of(tmp_path):
    """``copy_of(name) -> spec`` of robot ``name`` exported and registered as ``my_NAME``."""
    names: list[str] = []

    def make(name: str):
        spec = register_user_robot(export_user_robot(name, tmp_path))
        names.append(spec.name)
        return spec

    yield make
    for name in names:
        unregister_user_robot(name)


def _body(name: str, mount: float) -> dict:
    cid = p.connect(p.DIRECT)
    try:
        robot = Robot(cid, name, mount_height=mount)
        return {
            "links": robot.link_names,
            "arm_joints": robot.arm_joints,
            "fingers": robot.finger_joints,
            "limits": (robot.lower.tolist(), robot.upper.tolist()),
            "home": robot.home.tolist(),
            "tcp": robot.tcp_link,
            "flange_in_tcp": robot.reach_geometry.flange_in_tcp.tolist(),
            "centre": robot.reach_geometry.centre.tolist(),
            "tcp_at_home": list(robot.tcp_pose()[0]),
        }
    finally:
        p.disconnect(cid)


def test_the_registry_lists_the_built_ins_the_tests_copy():
    assert set(BUILT_IN) <= set(ROBOTS.names())


@pytest.mark.parametrize("name", BUILT_IN)
def test_a_user_copy_gets_the_built_ins_descriptor_and_body(name, copy_of):
    spec = copy_of(name)
    original = get_robot_spec(name)
    assert spec.name == f"my_{name}"
    for field in ("reach", "mount_height", "mount_range", "dof", "end_effector", "footprint"):
        assert getattr(spec, field) == getattr(original, field), field
    assert spec.mount_offset_x == original.mount_offset_x
    for mount in (None, 0.75):
        assert robot_descriptor(spec, mount) == robot_descriptor(original, mount)
    # Loaded at a mount of neither's own: the same links in the same order, the same
    # joints, limits, home pose and tool frame, to the bit.
    assert _body(spec.name, 0.9) == _body(name, 0.9)


@pytest.mark.parametrize("name", ["elephant", "panda"])
def test_a_user_copy_gets_the_built_ins_reachability_input(name, copy_of, monkeypatch):
    # elephant: an arm of primitives, mounted turned half a turn; panda: an arm of meshes
    # with its own fingers.
    monkeypatch.setattr(
        reachability, "DEFAULT_SAMPLING", SamplingConfig(cell=0.2, psi_bins=4, fk_samples=1500)
    )
    from momakitchen.models.reach_input import floor_reach

    spec = copy_of(name)
    a = ReachabilityMap.for_robot(name, 1.1)
    b = ReachabilityMap.for_robot(spec.name, 1.1)
    assert a.reachable.any()
    np.testing.assert_array_equal(a.reachable, b.reachable)
    # What the model reads: the channels at floor points around a target.
    rng = np.random.default_rng(0)
    floor = np.c_[rng.uniform(-1.5, 1.5, (64, 2)), np.zeros(64)]
    for target in ([0.2, 0.1, 0.9], [-0.3, 0.4, 0.5]):
        channels = floor_reach(name, 1.1, np.array(target), floor)
        assert np.ptp(channels) > 0
        copied = floor_reach(spec.name, 1.1, np.array(target), floor)
        np.testing.assert_array_equal(channels, copied)


def test_the_exported_urdf_is_the_arm_and_tool_without_the_base():
    root = ET.fromstring(arm_urdf("elephant"))
    links = {link.get("name") for link in root.findall("link")}
    joints = {joint.get("name") for joint in root.findall("joint")}
    assert BASE_LINK not in links and "tcp" in links and "flange" in links
    # The loader adds the mount itself: a user URDF may not have it. The TCP link is named
    # "tcp", so the loader adds no TCP joint above it and the file keeps its own.
    assert "mount_joint" not in joints and "tcp_joint" in joints
    built = ET.fromstring(robot_urdf("elephant"))
    assert links < {link.get("name") for link in built.findall("link")}


def test_the_yaml_carries_every_number_of_the_built_in(tmp_path):
    path = export_user_robot("elephant", tmp_path, "arm_copy")
    data = yaml.safe_load(path.read_text())
    assert data["name"] == "arm_copy" and data["urdf"] == "arm_copy.urdf"
    assert (tmp_path / "arm_copy.urdf").is_file()
    assert data["reach"] == 0.63 and data["mount_height"] == 1.03
    assert data["mount_offset_x"] == 0.15 and data["mount_yaw"] == pytest.approx(math.pi)
    assert data["home"] == list(get_robot_spec("elephant").model.home)
    # A suction robot has no fingers to list.
    ur5e = yaml.safe_load(export_user_robot("ur5e", tmp_path).read_text())
    assert ur5e["end_effector"] == "suction" and "finger_joints" not in ur5e


def test_export_errors_name_the_bad_value(tmp_path):
    with pytest.raises(MomaError, match="lower-case identifier, got 'My-Arm'"):
        export_user_robot("panda", tmp_path, "My-Arm")
    (tmp_path / "file").write_text("")
    with pytest.raises(MomaError, match="is a file"):
        export_user_robot("panda", tmp_path / "file")
    with pytest.raises(MomaError, match="unknown robot 'nope'"):
        export_user_robot("nope", tmp_path / "new")
    assert [p.name for p in tmp_path.iterdir()] == ["file"]
    assert export_user_robot("panda", tmp_path / "a" / "b").is_file()  # made if missing


def test_mount_yaw_turns_the_arm_and_is_checked(tmp_path, copy_of):
    spec = copy_of("elephant")
    text = (tmp_path / f"{spec.name}.yaml").read_text()
    turned = tmp_path / "turned.yaml"
    turned.write_text(
        text.replace(f"name: {spec.name}", "name: turned").replace(
            "mount_yaw: 3.141592653589793", "mount_yaw: 0.0"
        )
    )
    register_user_robot(turned)
    try:
        # Joint 1 at its home of 0 points the arm backwards without the half turn.
        ahead = _body(spec.name, 1.03)["tcp_at_home"][0]
        behind = _body("turned", 1.03)["tcp_at_home"][0]
        assert ahead > 0.15 > behind
    finally:
        unregister_user_robot("turned")
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        text.replace(f"name: {spec.name}", "name: bad").replace(
            "mount_yaw: 3.141592653589793", "mount_yaw: 9.5"
        )
    )
    with pytest.raises(MomaError, match=r"mount_yaw must be in \[-2 pi, 2 pi\] rad, got 9.5"):
        register_user_robot(bad)


@pytest.mark.slow
@pytest.mark.parametrize("name", BUILT_IN)
def test_a_user_copy_gets_the_built_ins_labels(name, copy_of):
    """The trials of one configuration, run in physics by the built-in and by its copy:
    the same outcome, stage and motion at every grid position."""
    from momakitchen.scene.configuration import SceneConfig, sample_scene, with_robot
    from momakitchen.sim.config import TrialConfig
    from momakitchen.sim.labels import label_configuration
    from momakitchen.sim.world import World

    spec = copy_of(name)
    scene_cfg = SceneConfig()
    scene = sample_scene(7, scene_cfg)
    runs = []
    for robot in (name, spec.name):
        cfg = with_robot(scene.configurations[0], robot, scene_cfg)
        with World(scene.layout) as world:
            runs.append(
                label_configuration(
                    world, cfg, trial_config=TrialConfig(), grid_spacing=scene_cfg.grid_spacing
                )
            )
    a, b = runs
    assert len(a.outcomes) > 0
    for field in ("positions", "yaws", "outcomes", "stages", "moved"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert a.grasps == b.grasps
