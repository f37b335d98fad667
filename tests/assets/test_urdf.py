"""URDF helpers: number formatting, mass properties, bounding boxes, XML validity."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pybullet as pb
import pytest

from momakitchen.assets.cache import cached_urdf
from momakitchen.assets.urdf import (
    ALONG_X,
    Box,
    Contact,
    Cylinder,
    Joint,
    Link,
    Shape,
    Sphere,
    bounding_box,
    fmt,
    mass_properties,
    robot_urdf,
    rot,
)
from momakitchen.errors import MomaError
from momakitchen.frames import rpy_matrix


def test_fmt_is_fixed_precision_without_negative_zero():
    assert fmt(0.1 + 0.2) == "0.3"
    assert fmt(-0.0) == "0"
    assert fmt(-1e-9) == "0"
    assert fmt(2.0) == "2"
    assert fmt(-0.1234567) == "-0.123457"


def test_rot_is_the_urdf_rpy_matrix():
    assert rot((0.0, 0.0, 0.0)) is rot((0, 0, 0))  # the shared identity
    np.testing.assert_array_equal(rot((0.0, 0.0, 0.0)), np.eye(3))
    for rpy in ((0.3, -1.2, 2.5), (math.pi / 2, 0.0, 0.0), (0.0, 0.0, -math.pi)):
        np.testing.assert_array_equal(rot(rpy), rpy_matrix(*rpy))
    # Rz(pi/2) Ry(0) Rx(pi/2): x -> y, y -> z, z -> x
    r = rpy_matrix(math.pi / 2, 0.0, math.pi / 2)
    np.testing.assert_allclose(r, [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-12)


def test_box_and_cylinder_inertia_formulas():
    com, inertia = mass_properties(Link("a", (Shape(Box((0.2, 0.4, 0.6)), (0.1, 0.0, 0.0)),), 12.0))
    assert com == pytest.approx([0.1, 0.0, 0.0])
    assert np.diag(inertia) == pytest.approx([0.16 + 0.36, 0.04 + 0.36, 0.04 + 0.16])
    # a cylinder laid along x: its axial moment m r^2 / 2 moves to ixx
    _, inertia = mass_properties(Link("c", (Shape(Cylinder(0.1, 0.5), rpy=ALONG_X),), 2.0))
    assert inertia[0, 0] == pytest.approx(2.0 * 0.01 / 2)
    assert inertia[1, 1] == pytest.approx(2.0 * (3 * 0.01 + 0.25) / 12)
    assert np.abs(inertia - np.diag(np.diag(inertia))).max() < 1e-12


def test_parallel_axis_and_density_weighting():
    # two equal spheres 1 m apart: I about the common centre = 2 (2/5 m r^2 + m (0.5)^2)
    link = Link("s", (Shape(Sphere(0.1), (-0.5, 0, 0)), Shape(Sphere(0.1), (0.5, 0, 0))), 2.0)
    com, inertia = mass_properties(link)
    assert com == pytest.approx([0, 0, 0])
    assert inertia[1, 1] == pytest.approx(2 * (0.4 * 1.0 * 0.01 + 1.0 * 0.25))
    assert inertia[0, 0] == pytest.approx(2 * 0.4 * 1.0 * 0.01)
    # a denser shape pulls the centre of mass towards it
    heavy = Link(
        "h",
        (
            Shape(Box((0.1, 0.1, 0.1)), (0, 0, 0), density=3.0),
            Shape(Box((0.1, 0.1, 0.1)), (1, 0, 0), density=1.0),
        ),
        4.0,
    )
    assert mass_properties(heavy)[0][0] == pytest.approx(0.25)


def test_visual_only_shapes_carry_no_mass_and_no_size():
    link = Link(
        "v",
        (
            Shape(Box((0.1, 0.1, 0.1)), (0, 0, 0.05)),
            Shape(Box((1.0, 1.0, 1.0)), (0, 0, 0), collision=False),
        ),
        1.0,
    )
    com, _ = mass_properties(link)
    assert com == pytest.approx([0, 0, 0.05])
    lo, hi = bounding_box((link,), ())
    assert np.subtract(hi, lo) == pytest.approx([0.1, 0.1, 0.1])


def test_bounding_box_follows_joints_and_rotations():
    base = Link("base", (Shape(Box((1.0, 1.0, 1.0)), (0, 0, 0.5)),), 10.0)
    arm = Link("arm", (Shape(Cylinder(0.05, 0.4), (0, 0, 0), ALONG_X),), 1.0)
    j = Joint(
        "j", "revolute", "base", "arm", (0.5 + 0.2, 0.0, 1.0), rpy=(0, 0, math.pi / 2), upper=1.0
    )
    lo, hi = bounding_box((base, arm), (j,))
    # the cylinder along the arm's x points along the base's y after the 90 deg yaw
    assert lo == pytest.approx((-0.5, -0.5, 0.0))
    assert hi == pytest.approx((0.75, 0.5, 1.05))


def test_robot_urdf_is_valid_and_loads(client):
    links = (
        Link(
            "base",
            (Shape(Box((0.5, 0.5, 0.1)), (0, 0, 0.05), material="m"),),
            5.0,
            Contact(0.9, 0.01, 0.02),
        ),
        Link("lid", (Shape(Box((0.5, 0.02, 0.3)), (0, 0.01, 0.15)),), 0.5),
    )
    joints = (
        Joint(
            "hinge",
            "revolute",
            "base",
            "lid",
            (0, 0.25, 0.1),
            axis=(1, 0, 0),
            upper=1.5,
            damping=0.1,
            friction=0.2,
        ),
    )
    text = robot_urdf("thing", links, joints, {"m": (0.1, 0.2, 0.3, 1.0)})
    root = ET.fromstring(text)
    assert [e.get("name") for e in root.findall("link")] == ["base", "lid"]
    assert root.find("link/contact/lateral_friction").get("value") == "0.9"
    body = pb.loadURDF(str(cached_urdf(text, "thing")), physicsClientId=client)
    info = pb.getJointInfo(body, 0, physicsClientId=client)
    assert info[1] == b"hinge" and info[6] == pytest.approx(0.1) and info[7] == pytest.approx(0.2)
    assert pb.getDynamicsInfo(body, -1, physicsClientId=client)[1] == pytest.approx(0.9)


def test_malformed_trees_are_rejected():
    a = Link("a", (Shape(Box((1, 1, 1))),), 1.0)
    b = Link("b", (Shape(Box((1, 1, 1))),), 1.0)
    with pytest.raises(MomaError, match="root"):
        robot_urdf("x", (a, b), ())
    with pytest.raises(MomaError, match="material"):
        robot_urdf("x", (Link("a", (Shape(Box((1, 1, 1)), material="nope"),), 1.0),), ())
    with pytest.raises(MomaError, match="positive"):
        robot_urdf("x", (Link("a", (Shape(Box((1, 1, 1))),), 0.0),), ())
