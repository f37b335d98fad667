"""Where the shoulder stands, from the URDF alone, against PyBullet's link frames."""

import pybullet as p
import pytest

from momakitchen.robots.body import RobotBody
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.shoulder import shoulder_geometry
from momakitchen.robots.spec import DESCRIPTOR_NAMES, get_robot_spec


@pytest.fixture(scope="module")
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


@pytest.mark.parametrize(
    "name", ["panda", "xarm6", "ur5e", "realman", "elephant", "gen3", "flexiv-x0.71-f40"]
)
@pytest.mark.parametrize("mount", [None, 0.45])
def test_shoulder_is_where_pybullet_puts_it(client, name, mount):
    spec = get_robot_spec(name)
    body = RobotBody(client, name, mount)
    geometry = body.reach_geometry
    rise, offset = shoulder_geometry(spec)
    assert body.mount_height + rise == pytest.approx(geometry.centre[2], abs=1e-5)
    assert offset == pytest.approx(geometry.shoulder_offset, abs=1e-5)
    d = dict(zip(DESCRIPTOR_NAMES, robot_descriptor(spec, mount), strict=True))
    assert d["shoulder_height_m"] == pytest.approx(geometry.centre[2], abs=1e-5)
    assert d["shoulder_offset_per_10cm"] == pytest.approx(10 * geometry.shoulder_offset, abs=1e-4)


def test_a_scaled_arm_scales_its_shoulder():
    rise, offset = shoulder_geometry(get_robot_spec("realman"))
    rise_s, offset_s = shoulder_geometry(get_robot_spec("realman-x0.70"))
    assert (rise_s, offset_s) == pytest.approx((0.7 * rise, 0.7 * offset), abs=1e-6)
