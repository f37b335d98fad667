"""``momakitchen robots``: listing, JSON, export-urdf, user robots, one-line errors."""

from __future__ import annotations

import json
import signal
from contextlib import contextmanager
from pathlib import Path

import pybullet_data
import pytest

from momakitchen.bullet import p
from momakitchen.cli.main import main
from momakitchen.robots.spec import ROBOTS
from momakitchen.robots.user import ENV_VAR, unregister_user_robot

MANUFACTURER_REACH = {
    "panda": 0.85,
    "flexiv": 0.78,
    "ur5e": 0.85,
    "xarm6": 0.70,
    "realman": 0.90,
    "elephant": 0.63,
}
MOUNT_HEIGHT = {
    "panda": 1.03,
    "flexiv": 1.03,
    "ur5e": 1.03,
    "xarm6": 0.33,
    "realman": 1.03,
    "elephant": 1.03,
}

KUKA = Path(pybullet_data.getDataPath()) / "kuka_iiwa" / "model.urdf"


def kuka_yaml(tmp_path: Path, name: str, **extra) -> Path:
    """A user robot: the KUKA iiwa shipped with pybullet_data, with a suction flange."""
    lines = [
        f"name: {name}",
        f"urdf: {KUKA}",
        "mount_height: 0.9",
        "end_effector_link: lbr_iiwa_link_7",
        "end_effector: suction",
    ]
    lines += [f"{k}: {v}" for k, v in extra.items()]
    path = tmp_path / f"{name}.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def cleanup():
    names: list[str] = []
    yield names
    for name in names:
        if name in ROBOTS:
            unregister_user_robot(name)


def test_json_lists_manufacturer_reach(capsys):
    assert main(["robots", "--json"]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    for name, reach in MANUFACTURER_REACH.items():
        assert rows[name]["reach_m"] == reach
        assert rows[name]["mount_height_m"] == MOUNT_HEIGHT[name]
        assert rows[name]["descriptor"]["reach_m"] == reach
    assert rows["panda"]["dof"] == 7 and rows["ur5e"]["end_effector"] == "suction"
    assert rows["xarm6"]["descriptor_version"] == 3
    assert rows["xarm6"]["descriptor"]["finger_force_per_100n"] == 0.4


def test_table(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:2] == ["name", "reach"]
    realman = next(line for line in out if line.startswith("realman"))
    assert realman.split() == ["realman", "0.900", "1.03", "6", "parallel_gripper", "80"]
    ur5e = next(line for line in out if line.startswith("ur5e"))
    assert ur5e.split() == ["ur5e", "0.850", "1.03", "6", "suction"]


@pytest.mark.parametrize("name", sorted(MANUFACTURER_REACH))
def test_export_urdf_loads_in_plain_pybullet(tmp_path, capsys, name):
    out = tmp_path / f"{name}.urdf"
    assert main(["robots", "export-urdf", name, "--out", str(out)]) == 0
    text = out.read_text()
    # Every mesh reference is an absolute path that exists.
    for chunk in text.split('filename="')[1:]:
        path = Path(chunk.split('"', 1)[0])
        assert path.is_absolute() and path.exists(), path
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(out), physicsClientId=client)
        names = {
            p.getJointInfo(body, j, physicsClientId=client)[12].decode()
            for j in range(p.getNumJoints(body, physicsClientId=client))
        }
        assert "tcp" in names
        assert ("suction_cup" in names) == (name == "ur5e")
    finally:
        p.disconnect(client)


def test_unknown_robot_one_line_exit_2(tmp_path, capsys):
    code = main(["robots", "export-urdf", "nope", "--out", str(tmp_path / "x.urdf")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "unknown robot 'nope'" in err
    assert not (tmp_path / "x.urdf").exists()


def test_export_to_missing_directory(tmp_path, capsys):
    code = main(["robots", "export-urdf", "ur5e", "--out", str(tmp_path / "no" / "x.urdf")])
    assert code == 2 and "does not exist" in capsys.readouterr().err


def test_user_robot_yaml_option(tmp_path, capsys, cleanup):
    cleanup.append("kuka")
    path = kuka_yaml(tmp_path, "kuka", reach=0.8)
    assert main(["robots", "--json", "--robot-yaml", str(path)]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["kuka"]["reach_m"] == 0.8 and rows["kuka"]["dof"] == 7
    assert rows["kuka"]["end_effector"] == "suction"
    out = tmp_path / "kuka.urdf"
    assert (
        main(["robots", "export-urdf", "kuka", "--out", str(out), "--robot-yaml", str(path)]) == 0
    )
    client = p.connect(p.DIRECT)
    try:
        p.loadURDF(str(out), physicsClientId=client)
    finally:
        p.disconnect(client)


def test_json_stays_json_when_a_user_urdf_draws_pybullet_warnings(tmp_path, capfd, cleanup):
    # A bare TCP frame (no <inertial>) makes PyBullet's C code print a warning to the
    # process's stdout each time the robot loads, as registration does.
    urdf = tmp_path / "kuka_tool.urdf"
    urdf.write_text(
        KUKA.read_text()
        .replace('filename="meshes/', f'filename="{KUKA.parent}/meshes/')
        .replace(
            "</robot>",
            '<link name="tool0"/><joint name="tool0_joint" type="fixed">'
            '<parent link="lbr_iiwa_link_7"/><child link="tool0"/>'
            '<origin xyz="0 0 0.05"/></joint></robot>',
        )
    )
    cleanup.append("kuka_tool")
    path = tmp_path / "kuka_tool.yaml"
    path.write_text(
        f"name: kuka_tool\nurdf: {urdf}\nmount_height: 0.9\nend_effector_link: tool0\n"
        "end_effector: suction\nreach: 0.8\n"
    )
    assert main(["robots", "--json", "--robot-yaml", str(path)]) == 0
    rows = {r["name"]: r for r in json.loads(capfd.readouterr().out)}
    assert rows["kuka_tool"]["reach_m"] == 0.8


def test_export_yaml_writes_a_copy_that_registers(tmp_path, capsys, cleanup):
    assert main(["robots", "export-yaml", "realman", "--out", str(tmp_path), "--as", "rm2"]) == 0
    out = capsys.readouterr().out
    assert "rm2.yaml" in out and "--robot-yaml" in out
    cleanup.append("rm2")
    assert main(["robots", "--json", "--robot-yaml", str(tmp_path / "rm2.yaml")]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["rm2"]["descriptor"] == rows["realman"]["descriptor"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["nope", "--out", "{tmp}"], "unknown robot 'nope'"),
        (["nope", "--out", "{tmp}/missing"], "unknown robot 'nope'"),
        (["panda", "--out", "{tmp}", "--as", "Panda-2"], "lower-case identifier, got 'Panda-2'"),
    ],
)
def test_export_yaml_bad_input_is_one_line_exit_2(tmp_path, capsys, argv, message):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(["robots", "export-yaml", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert list(tmp_path.iterdir()) == []


def test_user_robot_env_var(tmp_path, capsys, cleanup, monkeypatch):
    cleanup.append("kuka_env")
    monkeypatch.setenv(ENV_VAR, str(kuka_yaml(tmp_path, "kuka_env", reach=0.8)))
    assert main(["robots"]) == 0
    assert any(line.startswith("kuka_env") for line in capsys.readouterr().out.splitlines())


def test_yaml_missing_field_one_line_exit_2(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(
        f"name: bad\nurdf: {KUKA}\nend_effector_link: lbr_iiwa_link_7\nend_effector: suction\n"
    )
    assert main(["robots", "--robot-yaml", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert str(path) in err and "missing required field 'mount_height'" in err
    assert "bad" not in ROBOTS


def test_urdf_that_does_not_parse_one_line_exit_2(tmp_path, capsys):
    urdf = tmp_path / "broken.urdf"
    urdf.write_text("<robot name='broken'><link name='a'>")
    path = tmp_path / "broken.yaml"
    path.write_text(
        f"name: broken\nurdf: {urdf}\nmount_height: 1.0\n"
        "end_effector_link: a\nend_effector: suction\n"
    )
    assert main(["robots", "--robot-yaml", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert str(urdf) in err and "does not parse" in err
    assert "broken" not in ROBOTS


def test_more_arms_and_mount_ranges_in_the_listing(tmp_path, capsys, cleanup):
    cleanup.append("kuka_range")
    path = kuka_yaml(tmp_path, "kuka_range", reach=0.8)
    path.write_text(path.read_text().replace("mount_height: 0.9", "mount_height: [0.6, 1.3]"))
    assert main(["robots", "--json", "--robot-yaml", str(path)]) == 0
    rows = {r["name"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["kuka_range"]["mount_range_m"] == [0.6, 1.3]
    assert rows["kuka_range"]["mount_height_m"] == 0.95  # the middle of the range
    assert rows["ur10e"]["reach_m"] == 1.3 and rows["gen3"]["dof"] == 7
    assert [n for n, r in rows.items() if r["generate_default"]] == list(MANUFACTURER_REACH)
    assert rows["panda"]["mount_range_m"] is None
    assert main(["robots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert next(x for x in out if x.startswith("kuka_range")).split()[-1] == "0.60-1.30"
    assert next(x for x in out if x.startswith("ur10e")).split()[:3] == ["ur10e", "1.300", "0.80"]
    assert out[-1].startswith("generate's robots by default: panda, flexiv, ur5e")


def test_export_at_another_mount_height(tmp_path, capsys):
    out = tmp_path / "gen3.urdf"
    assert main(["robots", "export-urdf", "gen3", "--out", str(out), "--mount-height", "1.1"]) == 0
    assert "arm at 1.1 m" in capsys.readouterr().out
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(str(out), physicsClientId=client)
        names = [
            p.getJointInfo(body, j, physicsClientId=client)[1].decode()
            for j in range(p.getNumJoints(body, physicsClientId=client))
        ]
        mount = names.index("mount_joint")
        z = p.getLinkState(body, mount, physicsClientId=client)[4][2]
        assert z == pytest.approx(1.1, abs=1e-6)
    finally:
        p.disconnect(client)
    bad = tmp_path / "bad.urdf"
    argv = ["robots", "export-urdf", "gen3", "--out", str(bad), "--mount-height", "1.6"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mount_height must be in [0.3, 1.3] m, got 1.6" in err
    assert not bad.exists()


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


def _looped_kuka(tmp_path: Path) -> Path:
    """The KUKA of :func:`kuka_yaml` with an inner loop: link 3 also a child of link 5."""
    urdf = tmp_path / "loop.urdf"
    loop = (
        '<joint name="back" type="fixed"><parent link="lbr_iiwa_link_5"/>'
        '<child link="lbr_iiwa_link_3"/></joint>\n</robot>'
    )
    urdf.write_text(KUKA.read_text().replace("</robot>", loop))
    path = kuka_yaml(tmp_path, "loopy", reach=0.8)
    path.write_text(path.read_text().replace(str(KUKA), str(urdf)))
    return path


@pytest.mark.parametrize("command", [["robots"], ["robot-check", "loopy", "--out", "OUT"]])
def test_a_urdf_with_a_loop_is_one_line_exit_2(tmp_path, capsys, command):
    path = _looped_kuka(tmp_path)
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in command]
    with _within(20):
        assert main([*argv, "--robot-yaml", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "loop.urdf" in err
    assert "link 'lbr_iiwa_link_3' has two parents" in err
    assert "loopy" not in ROBOTS and not (tmp_path / "out").exists()


def test_a_huge_robot_yaml_is_one_line_exit_2(tmp_path, capsys):
    path = kuka_yaml(tmp_path, "huge")
    path.write_text(path.read_text() + "home: [" + "0, " * 400_000 + "0]\n")
    assert main(["robots", "--robot-yaml", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "over the limit of 1048576 bytes (1 MB)" in err


@pytest.mark.parametrize(
    ("ids", "message"),
    [
        (
            ["--first-scene-id", "950002", "--scenes", "2"],
            "the fine-tuning scenes 950000-950003 (--finetune-first-scene-id 950000, "
            "--finetune-scenes 4) overlap the check's scenes 950002-950003 "
            "(--first-scene-id 950002, --scenes 2)",
        ),
        (
            ["--first-scene-id", "949999", "--scenes", "1", "--finetune-first-scene-id", "949997"],
            "the fine-tuning scenes 949997-950000 (--finetune-first-scene-id 949997, "
            "--finetune-scenes 4) overlap the check's scenes 949999-949999",
        ),
    ],
)
def test_robot_check_refuses_overlapping_scene_ranges(tmp_path, capsys, monkeypatch, ids, message):
    from momakitchen.cli import robot_check

    def generate(*_):  # a check let through would label scenes for minutes: fail at once
        raise AssertionError("the overlapping ranges were not refused")

    monkeypatch.setattr(robot_check, "_generate", generate)
    out = tmp_path / "check"
    argv = ["robot-check", "panda", "--out", str(out), "--finetune-scenes", "4", *ids]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err, err
    assert not out.exists()
