"""Where the shoulder stands, from the URDF alone, against PyBullet's link frames."""

import pybullet as p
import pytest

from momakitchen.robots.body import RobotBody
from momakitchen.robots.descriptor import robot_descriptor
from momakitchen.robots.shoulder import shoulder_geometry
from momakitchen.robots.spec import DESCRIPTOR_NAMES, get_robot_spec
from momakitchen.robots.user import register_user_robot, unregister_user_robot


@pytest.fixture(scope="module")
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


@pytest.fixture(scope="module")
def scaled(tmp_path_factory):
    """``scaled(base, s)``: the name of a robot like ``base`` with links times ``s``."""
    names: list[str] = []

    def make(base: str, scale: float) -> str:
        name = f"{base}_x{round(scale * 100)}"
        if name in names:
            return name
        path = tmp_path_factory.mktemp("robots") / f"{name}.yaml"
        path.write_text(f"name: {name}\nlike: {base}\nlink_scale: {scale}\n")
        register_user_robot(path)
        names.append(name)
        return name

    yield make
    for name in names:
        unregister_user_robot(name)


@pytest.mark.parametrize(
    "name", ["panda", "xarm6", "ur5e", "realman", "elephant", "gen3", ("flexiv", 0.71)]
)
@pytest.mark.parametrize("mount", [None, 0.45])
def test_shoulder_is_where_pybullet_puts_it(client, scaled, name, mount):
    name = scaled(*name) if isinstance(name, tuple) else name
    spec = get_robot_spec(name)
    body = RobotBody(client, name, mount)
    geometry = body.reach_geometry
    rise, offset = shoulder_geometry(spec)
    assert body.mount_height + rise == pytest.approx(geometry.centre[2], abs=1e-5)
    assert offset == pytest.approx(geometry.shoulder_offset, abs=1e-5)
    d = dict(zip(DESCRIPTOR_NAMES, robot_descriptor(spec, mount), strict=True))
    assert d["shoulder_height_m"] == pytest.approx(geometry.centre[2], abs=1e-5)
    assert d["shoulder_offset_per_10cm"] == pytest.approx(10 * geometry.shoulder_offset, abs=1e-4)


def test_a_scaled_arm_scales_its_shoulder(scaled):
    rise, offset = shoulder_geometry(get_robot_spec("realman"))
    rise_s, offset_s = shoulder_geometry(get_robot_spec(scaled("realman", 0.7)))
    assert (rise_s, offset_s) == pytest.approx((0.7 * rise, 0.7 * offset), abs=1e-6)
