"""Public URDFs from pybullet_data as user robots (scripts/public_urdf_robots.py): a suction
tool ending in a geometry-less TCP frame attaches with the link that carries the cup, and
the labelling routine gets successes with them where the built-in Panda does."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from momakitchen.bullet import p
from momakitchen.robots.robot import Robot
from momakitchen.robots.tools import SuctionTool
from momakitchen.robots.user import register_user_robot, unregister_user_robot
from momakitchen.sim.config import Stage
from momakitchen.sim.labels import Labels, rejections
from script_helpers import load_script

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "public_urdf_robots.py"


def _script():
    return load_script("public_urdf_robots")


@pytest.fixture(scope="module")
def public_yamls(tmp_path_factory) -> dict[str, Path]:
    """The script's YAMLs (and URDFs), written once per module, reach given to skip
    measuring it (the registration test of test_user.py measures one)."""
    out = tmp_path_factory.mktemp("public")
    paths = {path.stem: path for path in _script().write_robots(out)}
    for name, reach in (("iiwa_suction", 1.0), ("xarm6_suction", 0.85), ("panda_public", 0.85)):
        paths[name].write_text(paths[name].read_text() + f"reach: {reach}\n")
    return paths


@pytest.fixture
def iiwa(public_yamls):
    spec = register_user_robot(public_yamls["iiwa_suction"])
    client = p.connect(p.DIRECT)
    try:
        yield Robot(client, spec.name), client
    finally:
        p.disconnect(client)
        unregister_user_robot(spec.name)


def test_script_writes_loadable_files(tmp_path):
    out = subprocess.run(
        [sys.executable, str(SCRIPT), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    assert sorted(Path(s).name for s in out) == [
        "iiwa_suction.yaml",
        "panda_public.yaml",
        "xarm6_suction.yaml",
    ]
    urdf = (tmp_path / "iiwa_suction.urdf").read_text()
    assert '<link name="tool0" />' in urdf  # the TCP frame has no geometry
    bad = subprocess.run(
        [sys.executable, str(SCRIPT), "--out", str(tmp_path / "iiwa_suction.urdf")],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2
    assert bad.stderr.strip() == (
        f"public_urdf_robots.py: --out {str(tmp_path / 'iiwa_suction.urdf')!r} is not a folder"
    )


def test_suction_cup_is_the_link_with_geometry_above_a_bare_tcp_frame(iiwa):
    robot, client = iiwa
    tool = robot.tool
    assert isinstance(tool, SuctionTool)
    tool0 = robot.link_index("tool0")
    assert p.getCollisionShapeData(robot.body, tool0, physicsClientId=client) == ()
    assert robot.link_names[tool.cup_link] == "suction_tool"
    assert tool.face_link == robot.tcp_link
    # The bare frame has no <inertial>: 1 g, not PyBullet's default 1 kg, on the tool.
    assert p.getDynamicsInfo(robot.body, tool0, physicsClientId=client)[0] == 0.001
    assert p.getDynamicsInfo(robot.body, tool.cup_link, physicsClientId=client)[0] == 0.2


def _box_at(client: int, pos, half=(0.03, 0.03, 0.03)) -> int:
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half), physicsClientId=client)
    return p.createMultiBody(0.2, col, basePosition=list(pos), physicsClientId=client)


def test_suction_attaches_at_the_cup_face_not_along_the_stem(iiwa):
    robot, client = iiwa
    tcp, quat = robot.tcp_pose()
    z = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)[:, 2]
    x = np.array(p.getMatrixFromQuaternion(quat)).reshape(3, 3)[:, 0]
    # A box whose face lies 2 mm beyond the cup face (the TCP), across the tool's axis.
    ahead = _box_at(client, tcp + (0.002 + 0.03) * z)
    assert robot.tool.on([ahead]) == ahead
    robot.tool.off()
    p.removeBody(ahead, physicsClientId=client)
    # A box touching the side of the stem, 6 cm behind the cup face: no seal there.
    beside = _box_at(client, tcp - 0.06 * z + (0.02 + 0.002 + 0.03) * x)
    assert robot.tool.on([beside]) is None


def _labels(stages, why) -> Labels:
    n = len(stages)
    return Labels(
        scene_id=0,
        config_index=0,
        robot="r",
        target="t",
        anchor=(0.0, 0.0, 0.0),
        grid_spacing=0.1,
        positions=np.zeros((n, 2)),
        yaws=np.zeros(n),
        stages=np.array(stages, dtype=np.uint8),
        moved=np.zeros(n, np.float32),
        seconds={},
        why=tuple(why),
    )


def test_rejections_name_the_dominant_stage_and_its_collisions():
    arm, ok, base = int(Stage.ARM_COLLISION), int(Stage.SUCCESS), int(Stage.BASE_COLLISION)
    stages = [base] * 2 + [arm] * 3 + [ok]
    why = [("mobile_base with counter",)] * 2 + [
        ("link0 with mobile_base", "link3 with floor"),
        ("link0 with mobile_base",),
        ("link3 with floor", "link0 with mobile_base"),
        (),
    ]
    lines = [r.line() for r in rejections(_labels(stages, why))]
    # Base collision: 2 of 6, not most; arm collision: 3 of the 4 that got that far.
    assert lines == [
        "arm_collision rejected 3 of 4 positions: most often link0 with mobile_base (3), "
        "then link3 with floor (2)"
    ]
    assert rejections(_labels([ok, ok], [(), ()])) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", ["iiwa_suction", "xarm6_suction"])
def test_public_suction_urdf_succeeds_on_scene_12(public_yamls, name):
    """Scene 12, configuration 0 (a bottle the built-in Panda lifts from 18 positions):
    each public suction arm lifts it from some, and no execution fails for want of a seal
    (before the cup link was found, every one did)."""
    from momakitchen.scene.configuration import SceneConfig, sample_scene, with_robot
    from momakitchen.sim.labels import label_configuration
    from momakitchen.sim.world import World

    spec = register_user_robot(public_yamls[name])
    try:
        scene_cfg = SceneConfig()
        scene = sample_scene(12, scene_cfg)
        cfg = with_robot(scene.configurations[0], spec.name, scene_cfg)
        with World(scene.layout) as world:
            labels = label_configuration(world, cfg, grid_spacing=scene_cfg.grid_spacing)
        assert int(labels.outcomes.sum()) >= 8
        failed = [w for s, w in zip(labels.stages, labels.why, strict=True) if s == 5]
        assert ("the suction cup attached nothing",) not in failed
    finally:
        unregister_user_robot(spec.name)


def _flipped_tcp(public_yamls, tmp_path) -> Path:
    """The iiwa with suction, its tool0 frame turned half a turn about x (z into the arm)."""
    src = public_yamls["iiwa_suction"]
    urdf = (src.parent / "iiwa_suction.urdf").read_text()
    joint = '<origin xyz="0 0 0.12" rpy="0 0 0" />'
    assert urdf.count(joint) == 1
    (tmp_path / "flipped.urdf").write_text(
        urdf.replace(joint, joint.replace('0 0 0"', '3.14159 0 0"'))
    )
    # Without reach: registering measures it, which loads the robot.
    text = src.read_text().replace("iiwa_suction", "flipped").split("reach:")[0]
    (tmp_path / "flipped.yaml").write_text(text)
    return tmp_path / "flipped.yaml"


def test_tcp_frame_with_z_into_the_arm_is_refused(public_yamls, tmp_path):
    from momakitchen.errors import MomaError

    yaml_path = _flipped_tcp(public_yamls, tmp_path)
    with pytest.raises(MomaError, match=r"z axis of end_effector_link 'tool0' points back"):
        spec = register_user_robot(yaml_path)
        unregister_user_robot(spec.name)  # not reached when the check works
    out = subprocess.run(
        [sys.executable, "-m", "momakitchen.cli.main", "robots", "--robot-yaml", str(yaml_path)],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2
    assert out.stderr.strip().splitlines()[-1].endswith("(the approach direction)")


@pytest.mark.slow
def test_ik_diagnosis_names_the_joint_at_its_limit_and_keeps_the_outcomes(public_yamls):
    """Scene 12, configuration 1 (a cabinet door): the iiwa's long suction tool leaves it
    short of most handle poses with joint 2 at its ±120° limit; diagnosing says so and
    changes no outcome."""
    from momakitchen.scene.configuration import SceneConfig, sample_scene, with_robot
    from momakitchen.sim.labels import label_configuration
    from momakitchen.sim.world import World

    spec = register_user_robot(public_yamls["iiwa_suction"])
    try:
        scene_cfg = SceneConfig()
        scene = sample_scene(12, scene_cfg)
        cfg = with_robot(scene.configurations[1], spec.name, scene_cfg)
        runs = []
        # A world each: a second run in one world moves the part by slightly other amounts.
        for diagnose in (False, True):
            with World(scene.layout) as world:
                runs.append(label_configuration(world, cfg, diagnose=diagnose))
        plain, diagnosed = runs
        np.testing.assert_array_equal(plain.stages, diagnosed.stages)
        np.testing.assert_array_equal(plain.moved, diagnosed.moved)
        ik = [r for r in rejections(diagnosed) if r.stage == "ik_failed"]
        assert ik and ik[0].causes[0][0] == "lbr_iiwa_joint_2 at its limit"
        assert not any(r.causes for r in rejections(plain) if r.stage == "ik_failed")
    finally:
        unregister_user_robot(spec.name)
