"""User robots from URDF + YAML: registration, measured reach, errors naming the file."""

from __future__ import annotations

import re
import signal
import time
from contextlib import contextmanager

import numpy as np
import pytest
import yaml

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import ROBOTS
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.robot import Robot
from momakitchen.robots.user import (
    ENV_VAR,
    load_config,
    load_env_robots,
    register_user_robot,
    unregister_user_robot,
)

# Farthest tool0 distance from the shoulder of the fixture arm: 0.3 + 0.25 + 0.1.
TINY_ARM_REACH = 0.65


@pytest.fixture
def registered(tiny_robot_files):
    _, yaml_path = tiny_robot_files
    spec = register_user_robot(yaml_path)
    yield spec, yaml_path
    unregister_user_robot(spec.name)


def test_register_measures_reach_and_works_in_pybullet(registered):
    spec, yaml_path = registered
    assert spec.name in ROBOTS
    assert spec.dof == 4 and spec.end_effector == "parallel_gripper"
    assert spec.mount_height == 0.8
    # Measured: farthest tool0 distance from the shoulder, sampled (a little below the max).
    assert TINY_ARM_REACH * 0.97 <= spec.reach <= TINY_ARM_REACH + 1e-3
    assert robot_descriptor(spec)[:2] == (spec.reach, 0.8)
    assert register_user_robot(yaml_path) is ROBOTS[spec.name]  # idempotent
    client = p.connect(p.DIRECT)
    try:
        robot = Robot(client, spec.name)
        assert robot.joint_names == ["j1", "j2", "j3", "j4"]
        assert len(robot.finger_joints) == 2 and robot.max_opening == pytest.approx(0.08)
        # Mounted on the mobile base at the mount height.
        assert robot.link_pose(robot.link_index("base"))[0][2] == pytest.approx(0.8)
        sh = robot.shoulder_position()
        res = robot.solve_ik(sh + np.array([0.35, 0.1, -0.2]))
        assert res.success
    finally:
        p.disconnect(client)


def test_explicit_reach_is_kept(tiny_robot_files, tmp_path):
    _, yaml_path = tiny_robot_files
    data = yaml.safe_load(yaml_path.read_text())
    data.update(
        reach=0.6,
        name="tiny_explicit",
        finger_joints=["fl_joint", "fr_joint"],
        home=[0, 0.3, 0.8, 0],
    )
    other = tmp_path / "explicit.yaml"
    other.write_text(yaml.safe_dump(data))
    spec = register_user_robot(other)
    try:
        assert spec.reach == 0.6
    finally:
        unregister_user_robot(spec.name)


def test_finger_force_reaches_the_fingers_and_the_descriptor(
    registered, tiny_robot_files, tmp_path
):
    spec, _ = registered
    assert robot_descriptor(spec)[4] == 0.4  # the default, 40 N
    data = yaml.safe_load(tiny_robot_files[1].read_text())
    data.update(name="tiny_strong", finger_force=120)
    strong = register_user_robot(_write(tmp_path, yaml.safe_dump(data), "strong.yaml"))
    client = p.connect(p.DIRECT)
    try:
        assert robot_descriptor(strong)[4] == 1.2
        assert Robot(client, strong.name).tool.finger_force == 120.0
    finally:
        p.disconnect(client)
        unregister_user_robot(strong.name)


def _write(tmp_path, text, name="bad.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.pop("mount_height"), "missing required field 'mount_height'"),
        (lambda d: d.pop("end_effector_link"), "missing required field 'end_effector_link'"),
        (lambda d: d.update(mount_height="high"), "field 'mount_height' must be a number"),
        (lambda d: d.update(end_effector="magnet"), "end_effector must be"),
        (lambda d: d.update(end_effector_link="nowhere"), "no link 'nowhere'"),
        (lambda d: d.update(colour="red"), "unknown field"),
        (lambda d: d.update(home=[0, 1]), "home needs 4 values"),
        (lambda d: d.update(mount_height=7.0), "mount_height must be in"),
        (lambda d: d.update(name="Tiny"), "lower-case"),
        (lambda d: d.update(finger_force=500), r"finger_force must be in \[10, 200\] N, got 500"),
        (lambda d: d.update(finger_force="strong"), "field 'finger_force' must be a number"),
        (
            lambda d: d.update(end_effector="suction", finger_force=40, finger_joints=[]),
            "finger_force is for grippers",
        ),
    ],
)
def test_bad_yaml_names_file_and_problem(tiny_robot_files, tmp_path, mutate, message):
    _, yaml_path = tiny_robot_files
    data = yaml.safe_load(yaml_path.read_text())
    mutate(data)
    bad = _write(tmp_path, yaml.safe_dump(data))
    with pytest.raises(MomaError, match=message) as info:
        register_user_robot(bad)
    assert str(bad) in str(info.value) or "tiny.urdf" in str(info.value)
    assert "\n" not in str(info.value)


def test_unparsable_yaml_and_urdf(tiny_robot_files, tmp_path):
    urdf, yaml_path = tiny_robot_files
    bad_yaml = _write(tmp_path, "name: [unclosed\n")
    with pytest.raises(MomaError, match="does not parse") as info:
        load_config(bad_yaml)
    assert str(bad_yaml) in str(info.value)
    with pytest.raises(MomaError, match="does not exist"):
        load_config(tmp_path / "missing.yaml")
    with pytest.raises(MomaError, match="is not a file"):
        load_config(tmp_path)
    urdf.write_text("<robot name='x'><link name='a'></robot>")  # malformed XML
    with pytest.raises(MomaError, match="does not parse") as info:
        register_user_robot(yaml_path)
    assert str(urdf) in str(info.value) and "\n" not in str(info.value)


def test_name_clash_with_builtin(tiny_robot_files, tmp_path):
    _, yaml_path = tiny_robot_files
    data = yaml.safe_load(yaml_path.read_text())
    data["name"] = "panda"
    with pytest.raises(MomaError, match="already registered"):
        register_user_robot(_write(tmp_path, yaml.safe_dump(data)))
    assert ROBOTS["panda"].dof == 7


def test_env_var_registers(tiny_robot_files, monkeypatch):
    _, yaml_path = tiny_robot_files
    monkeypatch.setenv(ENV_VAR, str(yaml_path))
    (spec,) = load_env_robots()
    try:
        assert spec.name in ROBOTS
    finally:
        unregister_user_robot(spec.name)


def test_finger_joints_with_suction_are_an_error(tiny_robot_files):
    _, yaml_path = tiny_robot_files
    text = yaml_path.read_text().replace("parallel_gripper", "suction")
    yaml_path.write_text(text + "finger_joints: [fl_joint, fr_joint]\n")
    with pytest.raises(MomaError, match=r"finger_joints .* but end_effector is 'suction'"):
        register_user_robot(yaml_path)
    assert "tiny_user" not in ROBOTS


@contextmanager
def _within(seconds: int):
    """Fails the test (rather than hanging it) if the block runs longer than ``seconds``."""

    def expire(*_):
        raise TimeoutError(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize(
    ("joint", "message"),
    [
        # l2 gets a second parent: l4 -> l2 closes an inner loop l2 -> l3 -> l4 -> l2
        (
            '<joint name="back" type="fixed"><parent link="l4"/><child link="l2"/></joint>',
            "link 'l2' has two parents (joints 'j2' and 'back'): a URDF must be a tree",
        ),
        # a loop of its own, beside the tree: every link has one parent, none the root
        (
            '<link name="a"/><link name="b"/>'
            '<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>'
            '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>',
            "link 'b' is its own ancestor (the joints form a loop)",
        ),
    ],
)
def test_a_urdf_with_a_loop_is_refused_not_walked_forever(tiny_robot_files, joint, message):
    urdf, yaml_path = tiny_robot_files
    urdf.write_text(urdf.read_text().replace("</robot>", joint + "\n</robot>"))
    with _within(10), pytest.raises(MomaError, match=re.escape(message)) as info:
        register_user_robot(yaml_path)
    assert str(urdf) in str(info.value) and "\n" not in str(info.value)
    assert "tiny_user" not in ROBOTS


def test_a_huge_yaml_is_refused_before_it_is_parsed(tiny_robot_files):
    _, yaml_path = tiny_robot_files
    # valid fields, then 2 MB of a list: refused by its size alone, in no time
    yaml_path.write_text(yaml_path.read_text() + "home: [" + "0, " * 700_000 + "0]\n")
    t0 = time.monotonic()
    with pytest.raises(MomaError) as info:
        load_config(yaml_path)
    assert time.monotonic() - t0 < 1
    assert f"robot YAML file {str(yaml_path)!r} is {yaml_path.stat().st_size} bytes" in str(
        info.value
    )
    assert "over the limit of 1048576 bytes (1 MB)" in str(info.value)
    # a file just under the limit is read as ever
    yaml_path.write_text(yaml_path.read_text()[:1000].split("home")[0] + "#" * 1_040_000 + "\n")
    assert load_config(yaml_path).name == "tiny_user"


@pytest.mark.parametrize(
    ("limit", "message"),
    [
        ('lower="1.5" upper="-1.5"', "limits inverted (lower 1.5 > upper -1.5)"),
        ('lower="nan" upper="1.5"', "lower='nan', not a number"),
        ('lower="-1" upper="one"', "upper='one', not a number"),
    ],
)
def test_a_urdf_whose_joint_limits_make_no_sense_is_refused(tiny_robot_files, limit, message):
    urdf, yaml_path = tiny_robot_files
    text = urdf.read_text()
    first = re.search(r'lower="[^"]*" upper="[^"]*"', text)
    assert first is not None
    urdf.write_text(text[: first.start()] + limit + text[first.end() :])
    with pytest.raises(MomaError, match=re.escape(message)) as info:
        register_user_robot(yaml_path)
    assert str(urdf) in str(info.value) and "\n" not in str(info.value)
    assert "tiny_user" not in ROBOTS


@pytest.mark.parametrize(
    "edit",
    [
        # every arm joint locked at 0: the tool stands straight up over the pillar
        lambda t: re.sub(
            r'lower="-?[\d.]+" upper="[\d.]+" effort="(50|30|10)"',
            r'lower="0" upper="0" effort="\1"',
            t,
        ),
        # an arm that moves, on a 1.95 m riser: its tool never comes down to 2 m
        lambda t: t.replace(
            '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>',
            '<origin xyz="0 0 1.95"/><axis xyz="0 0 1"/>',
        ),
    ],
)
def test_a_tool_that_reaches_nothing_from_the_floor_is_refused(tiny_robot_files, edit):
    urdf, yaml_path = tiny_robot_files
    urdf.write_text(edit(urdf.read_text()))
    with pytest.raises(MomaError, match="its tool reaches nothing from the floor") as info:
        register_user_robot(yaml_path)
    message = str(info.value)
    assert str(yaml_path) in message and "\n" not in message
    assert (
        "'tool0' beyond the base's front edge (0.275 m" in message
        and "mount height of 0.8 m" in message
    )
    assert "tiny_user" not in ROBOTS


def _edit_urdf(urdf, old: str, new: str) -> None:
    """Replace the first ``old`` of the URDF file by ``new`` (``old`` must be there)."""
    text = urdf.read_text()
    assert old in text
    urdf.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        # a name the URDF lacks: the error lists the names it has, the nearest first
        (
            {"end_effector_link": "tool_0"},
            "no link 'tool_0' (end_effector_link in {yaml}); its links: ['tool0', 'base', "
            "'l1', 'l2', 'l3', 'l4', 'fl', 'fr']",
        ),
        (
            {"finger_joints": ["fl_joint", "right_joint"]},
            "finger_joints ['right_joint'] not in {urdf!r}; its prismatic joints: "
            "['fr_joint', 'fl_joint']",
        ),
        # a listed finger that is fixed, or an arm joint, in the URDF
        (
            {"finger_joints": ["tool_joint", "fr_joint"]},
            "finger joint 'tool_joint' is 'fixed' in {urdf!r}; finger joints must be prismatic",
        ),
        (
            {"finger_joints": ["j4", "fr_joint"]},
            "finger joint 'j4' is 'revolute' in {urdf!r}",
        ),
        # the TCP rides on a listed finger
        (
            {"end_effector_link": "fl", "finger_joints": ["fl_joint", "fr_joint"]},
            "finger joint 'fl_joint' lies on the arm chain from root link 'base' to "
            "end_effector_link 'fl' in {urdf!r}",
        ),
        ({"finger_joints": ["fr_joint", "fr_joint"]}, "finger_joints lists 'fr_joint' twice"),
        # the TCP at the root: no arm between them
        (
            {"end_effector_link": "base"},
            "no movable joint on the chain from root link 'base' to end_effector_link 'base' "
            "in {urdf!r}",
        ),
        # home outside the URDF's limits of j2, [-2, 2]
        (
            {"home": [0, 2.5, 0, 0]},
            "home value 2.5 for joint 'j2' is outside its limits [-2, 2] in {urdf!r}",
        ),
    ],
)
def test_a_yaml_that_disagrees_with_its_urdf_is_refused(tiny_robot_files, extra, message):
    urdf, yaml_path = tiny_robot_files
    data = yaml.safe_load(yaml_path.read_text())
    data.update(extra)
    yaml_path.write_text(yaml.safe_dump(data))
    expected = message.format(yaml=yaml_path, urdf=str(urdf))
    with _within(5), pytest.raises(MomaError, match=re.escape(expected)) as info:
        register_user_robot(yaml_path)
    assert str(yaml_path) in str(info.value) and "\n" not in str(info.value)
    assert "tiny_user" not in ROBOTS


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        # PyBullet crashes on two joints of one name: refused before it sees them
        ('name="j3"', 'name="j2"', "joint name 'j2' is used twice; joint names must be unique"),
        ('name="tool_joint"', 'name="tcp_joint"', "joint name 'tcp_joint' is reserved"),
        ('name="tool_joint"', 'name="mount_joint"', "joint name 'mount_joint' is reserved"),
        (
            '<link name="tool0"/>',
            '<link name="tool0"/><link name="l1"/>',
            "link name 'l1' is used twice; link names must be unique",
        ),
        # a finger that cannot open: closed at 0, open at its upper limit
        (
            '<limit lower="0" upper="0.04" effort="20"',
            '<limit lower="-0.04" upper="0" effort="20"',
            "finger joint 'fl_joint' has limits [-0.04, 0] in {urdf!r}; a finger closes at 0 "
            "and opens to its upper limit, so needs lower <= 0 < upper",
        ),
        # limits of an arm joint that are not finite
        ('lower="-3" upper="3"', 'lower="-inf" upper="3"', "joint 'j1' has lower='-inf'"),
    ],
)
def test_a_urdf_with_names_or_limits_the_robot_cannot_use_is_refused(
    tiny_robot_files, old, new, message
):
    urdf, yaml_path = tiny_robot_files
    _edit_urdf(urdf, old, new)
    with _within(5), pytest.raises(MomaError, match=re.escape(message.format(urdf=str(urdf)))):
        register_user_robot(yaml_path)
    assert "tiny_user" not in ROBOTS


@pytest.mark.parametrize(
    ("extra", "edit", "message"),
    [
        ({"end_effector_link": "tool_0"}, None, "no link 'tool_0'"),
        ({"finger_joints": ["tool_joint", "fr_joint"]}, None, "finger joint 'tool_joint'"),
        ({"home": [0, 2.5, 0, 0]}, None, "home value 2.5 for joint 'j2'"),
        ({}, ('name="j3"', 'name="j2"'), "joint name 'j2' is used twice"),
        ({}, ('lower="-2" upper="2"', 'lower="2" upper="-2"'), "limits inverted"),
    ],
)
def test_bad_robot_files_are_one_line_exit_2_on_the_command_line(
    tiny_robot_files, capsys, extra, edit, message
):
    from momakitchen.cli.main import main

    urdf, yaml_path = tiny_robot_files
    data = yaml.safe_load(yaml_path.read_text())
    data.update(extra)
    yaml_path.write_text(yaml.safe_dump(data))
    if edit:
        _edit_urdf(urdf, *edit)
    with _within(5):
        assert main(["robots", "--robot-yaml", str(yaml_path)]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and message in captured.err
    assert str(yaml_path) in captured.err or str(urdf) in captured.err
    assert "tiny_user" not in ROBOTS and not captured.out
