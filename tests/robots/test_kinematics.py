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
    expected = {"panda": 0.1034, "xarm6": 0.172, "ur5e": 0.134}
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
