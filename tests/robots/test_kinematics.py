"""Forward kinematics of every arm against an independent computation.

The tables below are transcribed from the published figures (docs/ROBOTS.md) a second time,
on purpose, and evaluated with plain numpy; PyBullet's link state of the generated URDF
must agree within 1 mm (and 1e-3 rad) at random joint vectors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.robots import get_robot_spec
from momakitchen.robots.robot import Robot

PI = math.pi


def rot_rpy(r: float, pi_: float, y: float) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: R = Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(pi_),
        math.sin(pi_),
        math.cos(y),
        math.sin(y),
    )
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def rot_axis(axis, angle: float) -> np.ndarray:
    k = np.asarray(axis, float)
    k = k / np.linalg.norm(k)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx


def tf(xyz, rot) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = xyz
    return m


def chain_fk(table, q, flange=((0, 0, 0), (0, 0, 0))) -> np.ndarray:
    """table rows: (xyz, rpy, axis); returns the 4x4 flange pose in the arm base frame."""
    m = np.eye(4)
    for (xyz, rpy, axis), qi in zip(table, q, strict=True):
        m = m @ tf(xyz, rot_rpy(*rpy)) @ tf((0, 0, 0), rot_axis(axis, qi))
    return m @ tf(flange[0], rot_rpy(*flange[1]))


def ur5e_dh_fk(q) -> np.ndarray:
    """Universal Robots' standard DH table for the UR5e (frame 6 = flange)."""
    d = (0.1625, 0, 0, 0.1333, 0.0997, 0.0996)
    a = (0, -0.425, -0.3922, 0, 0, 0)
    alpha = (PI / 2, 0, 0, PI / 2, -PI / 2, 0)
    m = np.eye(4)
    for i in range(6):
        ct, st = math.cos(q[i]), math.sin(q[i])
        ca, sa = math.cos(alpha[i]), math.sin(alpha[i])
        m = m @ np.array(
            [
                [ct, -st * ca, st * sa, a[i] * ct],
                [st, ct * ca, -ct * sa, a[i] * st],
                [0, sa, ca, d[i]],
                [0, 0, 0, 1],
            ]
        )
    return m


def dh_fk(d, a, alpha, theta, q, base=None) -> np.ndarray:
    """Standard DH chain (``d``, ``a``, ``alpha``, ``theta`` offsets per joint) at ``q``,
    after the fixed ``base`` transform (4, 4); returns the last frame's pose (4, 4)."""
    m = np.eye(4) if base is None else np.asarray(base, float)
    for i, qi in enumerate(q):
        ct, st = math.cos(qi + theta[i]), math.sin(qi + theta[i])
        ca, sa = math.cos(alpha[i]), math.sin(alpha[i])
        m = m @ np.array(
            [
                [ct, -st * ca, st * sa, a[i] * ct],
                [st, ct * ca, -ct * sa, a[i] * st],
                [0, sa, ca, d[i]],
                [0, 0, 0, 1],
            ]
        )
    return m


def ur10e_dh_fk(q) -> np.ndarray:
    """Universal Robots' DH table for the UR10e (frame 6 = flange)."""
    d = (0.1807, 0, 0, 0.17415, 0.11985, 0.11655)
    a = (0, -0.6127, -0.57155, 0, 0, 0)
    return dh_fk(d, a, (PI / 2, 0, 0, PI / 2, -PI / 2, 0), (0,) * 6, q)


def gen3_dh_fk(q) -> np.ndarray:
    """The Kinova Gen3 user guide's classic DH table (7 DoF): base -> frame 0 is a turn by
    pi about x; frame 7 = the interface module's tool frame."""
    d = (-(0.1564 + 0.1284), -(0.0054 + 0.0064), -(0.2104 + 0.2104), -(0.0064 + 0.0064))
    d += (-(0.2084 + 0.1059), 0.0, -(0.1059 + 0.0615))
    alpha = (PI / 2,) * 6 + (PI,)
    theta = (0.0,) + (PI,) * 6
    return dh_fk(d, (0,) * 7, alpha, theta, q, np.diag([1.0, -1.0, -1.0, 1.0]))


Z, Y, NZ, NX = (0, 0, 1), (0, 1, 0), (0, 0, -1), (-1, 0, 0)

FLEXIV = [
    ((0, 0, 0.155), (0, 0, -PI), Z),
    ((0, 0.03, 0.21), (0, 0, 0), Y),
    ((0, 0.035, 0.205), (0, 0, 0), Z),
    ((-0.02, -0.03, 0.19), (0, 0, -PI), Y),
    ((-0.02, 0.025, 0.195), (0, 0, -PI), Z),
    ((0, 0.03, 0.19), (0, 0, 0), Y),
    ((-0.015, 0.073, 0.11), (0, -PI / 2, 0), Z),
]
FLEXIV_FLANGE = ((0, 0, 0.081), (0, 0, -PI))

REALMAN = [
    ((0, 0, 0.172), (0, 0, 0), Z),
    ((-0.086, 0, 0), (-1.5708, -1.5708, 0), Z),
    ((0.38, 0, -0.00010023), (0, 0, 1.5708), Z),
    ((0.069, -0.405, 0.000099684), (1.5708, 0, 0), Z),
    ((0, 0, 0), (1.5708, 0, 3.1416), Z),
    ((0, 0.1435, 0), (1.5708, 0, -3.1416), Z),
]

ELEPHANT = [
    ((0, 0, 0.22934), (0, 0, 0), Z),
    ((0, 0, 0), (1.5707, -1.5708, 0), NZ),
    ((0.27, 0, 0), (0, 0, 0), NZ),
    ((0.267, 0, -0.0745), (0, 0, 1.5708), NZ),
    ((0, -0.095, 0.002), (1.5707, -1.5707, 0), Z),
    ((-0.054, 0, 0), (-1.5707, 0, 0), NX),
]

PANDA = [
    ((0, 0, 0.333), (0, 0, 0), Z),
    ((0, 0, 0), (-PI / 2, 0, 0), Z),
    ((0, -0.316, 0), (PI / 2, 0, 0), Z),
    ((0.0825, 0, 0), (PI / 2, 0, 0), Z),
    ((-0.0825, 0.384, 0), (-PI / 2, 0, 0), Z),
    ((0, 0, 0), (PI / 2, 0, 0), Z),
    ((0.088, 0, 0), (PI / 2, 0, 0), Z),
]
PANDA_FLANGE = ((0, 0, 0.107), (0, 0, 0))

XARM6 = [
    ((0, 0, 0.267), (0, 0, 0), Z),
    ((0, 0, 0), (-PI / 2, 0, 0), Z),
    ((0.0535, -0.2845, 0), (0, 0, 0), Z),
    ((0.0775, 0.3425, 0), (-PI / 2, 0, 0), Z),
    ((0, 0, 0), (PI / 2, 0, 0), Z),
    ((0.076, 0.097, 0), (-PI / 2, 0, 0), Z),
]

REFERENCE = {
    "ur5e": ("arm_base", ur5e_dh_fk),
    "ur10e": ("arm_base", ur10e_dh_fk),
    "gen3": ("arm_base", gen3_dh_fk),
    "flexiv": ("arm_base", lambda q: chain_fk(FLEXIV, q, FLEXIV_FLANGE)),
    "realman": ("arm_base", lambda q: chain_fk(REALMAN, q)),
    "elephant": ("arm_base", lambda q: chain_fk(ELEPHANT, q)),
    "panda": ("panda_link0", lambda q: chain_fk(PANDA, q, PANDA_FLANGE)),
    "xarm6": ("link_base", lambda q: chain_fk(XARM6, q)),
}


@pytest.fixture(scope="module")
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


def pose_matrix(pos, orn) -> np.ndarray:
    return tf(pos, np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3))


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_flange_fk_matches_published_figures(client, name):
    robot = Robot(client, name, base=(1.0, -2.0, 0.7))
    try:
        root_name, reference = REFERENCE[name]
        root = robot.link_index(root_name)
        rng = np.random.default_rng(42)
        for _ in range(25):
            q = rng.uniform(robot.lower, robot.upper)
            robot.set_joint_positions(q)
            base = pose_matrix(*robot.link_pose(root))
            flange = pose_matrix(*robot.flange_pose())
            got = np.linalg.inv(base) @ flange
            want = reference(q)
            # 1 mm: Kinova's joint origins carry 0.2 mm offsets that its DH table rounds away.
            assert np.linalg.norm(got[:3, 3] - want[:3, 3]) < 1e-3, (name, q)
            # Rotation agreement: angle of got^T want.
            cos = (np.trace(got[:3, :3].T @ want[:3, :3]) - 1) / 2
            assert math.acos(min(1.0, max(-1.0, cos))) < 1e-3, (name, q)
    finally:
        robot.remove()


def test_ur5e_chain_and_dh_agree_in_world(client):
    """The URDF-style chain and the DH table describe the same arm: check in the world
    frame too (mount height and mount yaw included)."""
    robot = Robot(client, "ur5e", base=(0.0, 0.0, 0.0))
    try:
        spec = get_robot_spec("ur5e")
        q = np.array([0.3, -1.2, 1.0, -0.5, 0.8, 0.1])
        robot.set_joint_positions(q)
        # The arm base is turned by pi on the mobile base (joint 1 = 0 faces forward).
        mount = tf((spec.mount_offset_x, 0, spec.mount_height), rot_rpy(0, 0, PI))
        want = mount @ ur5e_dh_fk(q)
        got = pose_matrix(*robot.flange_pose())
        assert np.allclose(got[:3, 3], want[:3, 3], atol=1e-3)
    finally:
        robot.remove()


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_tcp_is_beyond_flange_along_z(client, name):
    """TCP = flange + offset along the flange's z axis (the published TCP distance)."""
    expected = {"panda": 0.1034, "xarm6": 0.172, "ur5e": 0.134, "ur10e": 0.15, "gen3": 0.15}
    robot = Robot(client, name)
    try:
        fpos, forn = robot.flange_pose()
        tpos, _ = robot.tcp_pose()
        z = np.array(p.getMatrixFromQuaternion(forn)).reshape(3, 3)[:, 2]
        d = tpos - fpos
        assert np.linalg.norm(np.cross(d, z)) < 1e-6
        assert float(d @ z) > 0.05
        if name in expected:
            assert float(d @ z) == pytest.approx(expected[name], abs=1e-4)
    finally:
        robot.remove()


@pytest.mark.parametrize(
    ("name", "reach", "dh"),
    [("ur10e", 1.30, ur10e_dh_fk), ("gen3", 0.902, gen3_dh_fk)],
)
def test_published_reach_of_the_tables_and_of_the_built_model(client, name, reach, dh):
    """The manufacturer's reach is the stretched arm's shoulder-to-flange distance of its
    table (UR: |a2| + |a3| + the wrist; Kinova: d3 + d5 + d7), and the built model's
    measured flange workspace agrees with it within 5 %."""
    spec = get_robot_spec(name)
    assert spec.reach == reach
    robot = Robot(client, name)
    try:
        flange_reach, _ = robot.workspace()
        assert 1.0 <= flange_reach / reach <= 1.05, (name, flange_reach)
    finally:
        robot.remove()
    if name == "gen3":  # straight up at q = 0: joint 2 to the tool frame is the reach
        assert 0.4208 + 0.3143 + 0.1674 == pytest.approx(reach, abs=1e-3)
        assert dh(np.zeros(7))[2, 3] == pytest.approx(0.2848 + 0.0 + reach, abs=1e-3)
    else:  # stretched out along the table's x axis: a2 + a3, and the wrist beyond
        q = np.array([0.0, 0.0, 0.0, -PI / 2, 0.0, 0.0])
        assert np.linalg.norm(dh(q)[:3, 3] - [0, 0, 0.1807]) >= reach
