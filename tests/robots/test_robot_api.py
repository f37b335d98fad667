"""The Robot API: placement, joints, FK, IK, collisions, gripper, suction, clients."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.errors import MomaError
from momakitchen.robots import (
    DESCRIPTOR_NAMES,
    DESCRIPTOR_VERSION,
    ROBOTS,
    get_robot_spec,
    robot_descriptor,
)
from momakitchen.robots.arms import MODELS
from momakitchen.robots.robot import Robot, quaternion_angle
from momakitchen.robots.urdf import BASE_LINK

NAMES = ["panda", "flexiv", "ur5e", "xarm6", "realman", "elephant"]


@pytest.fixture
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


def box(client, half, pos, mass=0.0):
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=client)
    return p.createMultiBody(mass, col, basePosition=list(pos), physicsClientId=client)


def test_registry_and_models_agree():
    builtin = set(NAMES)
    assert builtin <= set(ROBOTS) and builtin <= set(MODELS)
    assert {n: ROBOTS[n].end_effector for n in NAMES} == {
        "panda": "parallel_gripper", "flexiv": "parallel_gripper", "ur5e": "suction",
        "xarm6": "parallel_gripper", "realman": "parallel_gripper",
        "elephant": "parallel_gripper",
    }


def test_descriptor_is_reach_mount_height_dof_tool():
    assert DESCRIPTOR_VERSION == 1
    assert DESCRIPTOR_NAMES[:2] == ("reach_m", "mount_height_m")
    assert robot_descriptor(get_robot_spec("ur5e")) == (0.85, 1.03, 6 / 7, 1.0)
    assert robot_descriptor(get_robot_spec("xarm6")) == (0.70, 0.33, 6 / 7, 0.0)


def test_unknown_robot_is_a_moma_error(client):
    with pytest.raises(MomaError, match="unknown robot 'nope'"):
        Robot(client, "nope")


@pytest.mark.parametrize("name", NAMES)
def test_structure_matches_spec(client, name):
    robot = Robot(client, name)
    spec = get_robot_spec(name)
    assert robot.dof == spec.dof == len(robot.joint_names)
    assert np.all(robot.lower < robot.upper)
    assert robot.within_limits(robot.home)
    # Arm mounted at the mount height: the arm's base frame sits on the pillar top.
    first = robot.arm_joints[0]
    parent = robot._parent[first]
    z = robot.link_pose(parent)[0][2]
    assert z == pytest.approx(spec.mount_height, abs=1e-6)
    if spec.end_effector == "suction":
        assert robot.cup_link is not None and not robot.finger_joints
    else:
        assert len(robot.finger_joints) == 2
        assert robot.max_opening == pytest.approx(0.08)
    # No self-collision at home.
    assert robot.arm_collisions([]) == []


def test_place_base_moves_everything_rigidly(client):
    robot = Robot(client, "panda")
    q = robot.home
    robot.set_joint_positions(q)
    pos0, orn0 = robot.tcp_pose()
    robot.place_base(1.5, -0.7, math.pi / 3)
    assert robot.base_pose() == pytest.approx((1.5, -0.7, math.pi / 3), abs=1e-9)
    pos1, orn1 = robot.tcp_pose()
    c, s = math.cos(math.pi / 3), math.sin(math.pi / 3)
    want = np.array([c * pos0[0] - s * pos0[1] + 1.5, s * pos0[0] + c * pos0[1] - 0.7, pos0[2]])
    assert np.allclose(pos1, want, atol=1e-6)
    assert quaternion_angle(orn0, orn1) == pytest.approx(math.pi / 3, abs=1e-6)
    # The base stays on the floor.
    assert robot.link_pose(-1)[0][2] == pytest.approx(0.0, abs=1e-9)


def test_joint_positions_round_trip_and_validation(client):
    robot = Robot(client, "realman")
    q = np.array([0.1, 0.5, 1.0, -0.3, 0.8, 0.2])
    robot.set_joint_positions(q)
    assert np.allclose(robot.joint_positions(), q)
    with pytest.raises(MomaError, match="expected 6 joint values"):
        robot.set_joint_positions([0.0] * 5)
    # FK at a given q does not disturb the current configuration.
    robot.tcp_pose(np.zeros(6))
    assert np.allclose(robot.joint_positions(), q)


@pytest.mark.parametrize("name", NAMES)
def test_ik_round_trip(client, name):
    """FK -> IK -> FK within 5 mm and 2 degrees on reachable poses (IK seeded at home)."""
    robot = Robot(client, name, base=(0.3, 0.2, 0.5))
    rng = np.random.default_rng(7)
    successes = 0
    for _ in range(12):
        q = rng.uniform(robot.lower, robot.upper)
        pos, orn = robot.tcp_pose(q)
        res = robot.solve_ik(pos, orn, seed=robot.home, rng=rng)
        assert robot.within_limits(res.q)
        got_pos, got_orn = robot.tcp_pose(res.q)
        # The reported residuals are the measured ones.
        assert float(np.linalg.norm(got_pos - pos)) == pytest.approx(res.position_error,
                                                                     abs=1e-6)
        if res.success:
            successes += 1
            assert np.linalg.norm(got_pos - pos) <= 0.005
            assert quaternion_angle(got_orn, orn) <= math.radians(2)
            assert np.allclose(robot.joint_positions(), res.q)  # left at the answer
    assert successes >= 9


def test_ik_position_only_and_unreachable(client):
    robot = Robot(client, "ur5e")
    sh = robot.shoulder_position()
    res = robot.solve_ik(sh + np.array([0.5, 0.1, -0.2]))
    assert res.success and res.orientation_error == 0.0
    far = robot.solve_ik(sh + np.array([3.0, 0.0, 0.0]), (1, 0, 0, 0))
    assert not far.success and far.position_error > 1.5
    assert far.calls == 0 and far.seconds < 0.05  # rejected by the reach pre-check
    assert not robot.could_reach(sh + np.array([3.0, 0.0, 0.0]))
    assert robot.could_reach(sh + np.array([0.5, 0.0, 0.0]))
    # At the edge of the TCP sphere, pointing down puts the flange out of its own sphere.
    tcp_reach = robot.workspace()[1]
    edge = sh + np.array([tcp_reach - 0.02, 0.0, 0.0])
    assert robot.could_reach(edge)
    assert not robot.could_reach(edge, (1, 0, 0, 0))
    assert robot.could_reach(edge, (0, 0.7071068, 0, 0.7071068))  # pointing outwards
    res = robot.solve_ik(edge, (1, 0, 0, 0))
    assert not res.success and res.calls == 0
    with pytest.raises(MomaError, match="unit quaternion"):
        robot.solve_ik(sh, (0, 0, 0, 0))


@pytest.mark.parametrize("name", NAMES)
def test_workspace_exceeds_manufacturer_reach_modestly(client, name):
    """Measured flange reach within 0.95-1.25 x the manufacturer's figure."""
    robot = Robot(client, name)
    flange, tcp = robot.workspace()
    reach = get_robot_spec(name).reach
    assert 0.95 * reach <= flange <= 1.25 * reach
    tool = float(np.linalg.norm(robot.tcp_pose()[0] - robot.flange_pose()[0]))
    assert tcp == pytest.approx(flange + tool, abs=0.03)


@pytest.mark.parametrize("name", NAMES)
def test_reach_precheck_never_rejects_reachable_poses(client, name):
    """could_reach is a necessary condition: every FK pose passes it, at any base pose."""
    robot = Robot(client, name, base=(0.4, -1.2, 2.0))
    rng = np.random.default_rng(3)
    for _ in range(300):
        pos, orn = robot.tcp_pose(rng.uniform(robot.lower, robot.upper))
        assert robot.could_reach(pos) and robot.could_reach(pos, orn)


def test_base_collisions(client):
    robot = Robot(client, "panda")
    obstacle = box(client, (0.1, 0.1, 0.2), (0.3, 0.0, 0.2))  # overlaps the front edge
    far = box(client, (0.1, 0.1, 0.2), (1.0, 0.0, 0.2))
    assert robot.base_collisions([obstacle, far]) == [obstacle]
    robot.place_base(-1.0, 0.0, 0.0)
    assert robot.base_collisions([obstacle, far]) == []
    assert robot.base_collisions([far], margin=2.5) == [far]


def test_arm_collisions_allow_the_target_for_the_tool_only(client):
    robot = Robot(client, "panda")
    tcp, _ = robot.tcp_pose()
    target = box(client, (0.06, 0.06, 0.02), tcp)  # wider than the open fingers
    hits = robot.arm_collisions([target])
    assert hits and all(h.body == target for h in hits)
    assert robot.arm_collisions([target], allow=[target]) == []
    assert robot.arm_collisions([target], allow=[(target, -1)]) == []
    # An obstacle at the elbow is a collision even if it is the allowed target.
    elbow = robot.link_pose(robot.arm_joints[3])[0]
    blocker = box(client, (0.05, 0.05, 0.05), elbow)
    hits = robot.arm_collisions([blocker], allow=[blocker])
    assert hits and not any(robot.link_index(h.link) in robot.ee_links for h in hits)


def test_self_collision_with_base(client):
    robot = Robot(client, "ur5e")
    robot.set_joint_positions([0, math.pi / 2, 0, 0, 0, 0])  # upper arm straight down
    hits = robot.arm_collisions([])
    assert any(h.link == BASE_LINK and h.body == robot.body for h in hits)
    assert robot.arm_collisions([], self_collision=False) == []


def test_gripper_opening(client):
    robot = Robot(client, "flexiv")
    assert robot.gripper_opening() == pytest.approx(0.08)
    robot.set_gripper_opening(0.03)
    assert robot.gripper_opening() == pytest.approx(0.03)
    # The finger pads really are that far apart (inner faces along the TCP y axis).
    left = robot.link_pose(robot.link_index("finger_left"))[0]
    right = robot.link_pose(robot.link_index("finger_right"))[0]
    assert np.linalg.norm(left - right) == pytest.approx(0.03, abs=1e-6)
    with pytest.raises(MomaError, match="no suction cup"):
        robot.suction_on()


def test_suction_attaches_only_on_cup_face_contact(client):
    robot = Robot(client, "ur5e")
    robot.set_joint_positions(robot.home)  # tool pointing down
    tcp, _ = robot.tcp_pose()
    with pytest.raises(MomaError, match="no gripper"):
        robot.close_gripper()
    gap = box(client, (0.04, 0.04, 0.02), tcp - np.array([0, 0, 0.02 + 0.02]), mass=0.2)
    assert robot.suction_on() is None and robot.attached_body is None
    p.removeBody(gap, physicsClientId=client)
    beside = box(client, (0.04, 0.04, 0.04), tcp + np.array([0.061, 0, 0]), mass=0.2)
    assert robot.suction_on() is None  # touching the cup's side is not a seal
    p.removeBody(beside, physicsClientId=client)
    touching = box(client, (0.04, 0.04, 0.02), tcp - np.array([0, 0, 0.02 + 0.001]), mass=0.2)
    assert robot.suction_on() == touching == robot.attached_body
    robot.suction_off()
    assert robot.attached_body is None


def test_independent_clients_in_one_process():
    a, b = p.connect(p.DIRECT), p.connect(p.DIRECT)
    try:
        ra, rb = Robot(a, "panda"), Robot(b, "ur5e")
        rb2 = Robot(b, "panda", base=(2.0, 0.0, 0.0))
        ra.place_base(5.0, 5.0, 1.0)
        assert rb2.base_pose() == pytest.approx((2.0, 0.0, 0.0))
        for robot in (ra, rb, rb2):
            pos, orn = robot.tcp_pose()
            res = robot.solve_ik(pos + np.array([0.0, 0.05, -0.05]), orn)
            assert res.success
        assert p.getNumBodies(physicsClientId=a) == 1
        assert p.getNumBodies(physicsClientId=b) == 2
    finally:
        p.disconnect(a)
        p.disconnect(b)


def _pybullet_ik(robot, client):
    """PyBullet's own null-space IK on a robot, as a caller of the PyBullet API might."""
    movable = robot._movable
    infos = [p.getJointInfo(robot.body, j, physicsClientId=client) for j in movable]
    lower, upper = [i[8] for i in infos], [i[9] for i in infos]
    ranges = [max(h - lo, 1e-3) for lo, h in zip(lower, upper, strict=True)]
    pos, orn = robot.tcp_pose()
    for _ in range(4):
        p.calculateInverseKinematics(
            robot.body, robot.tcp_link, pos, orn, lowerLimits=lower, upperLimits=upper,
            jointRanges=ranges, restPoses=[0.0] * len(movable),
            currentPositions=[0.0] * len(movable), maxNumIterations=30, physicsClientId=client)


@pytest.mark.parametrize(("first", "second"),
                         [("flexiv", "elephant"), ("xarm6", "flexiv"), ("elephant", "flexiv")])
def test_reloading_a_different_robot_in_a_reused_body_slot(first, second):
    """PyBullet caches a kinematic tree per body and keeps it after removal, so its own IK
    and Jacobian can go stale for the second robot (whether it happens depends on memory
    reuse). The robot's IK uses link states only and keeps working."""
    client = p.connect(p.DIRECT)
    try:
        r1 = Robot(client, first)
        _pybullet_ik(r1, client)
        r1.remove()
        r2 = Robot(client, second)
        pos, orn = r2.tcp_pose()
        assert r2.solve_ik(pos + np.array([0.03, 0.0, 0.0]), orn).success
    finally:
        p.disconnect(client)
