"""A registered robot written as a user robot's files: its arm and tool as a URDF, and the
YAML that registers them (``momakitchen.robots.user``).

``momakitchen robots export-yaml NAME --out DIR`` writes them. Registered again with
``--robot-yaml``, the copy is the same body on the same base: the same joints, limits,
collision shapes and home pose, the same reach, mount, grip force and footprint. So it
gets the same model input as the original, descriptor and reachability map alike
(``tests/robots/test_export.py`` registers each built-in's copy and compares), and a
user starts a robot of their own from a built-in's files rather than from nothing.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import yaml

from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_text
from momakitchen.robots.arms import UrdfTool
from momakitchen.robots.spec import finger_force, get_robot_spec
from momakitchen.robots.urdf import TCP_LINK, build_urdf, link_of, subtree
from momakitchen.robots.user import is_robot_name


def arm_urdf(name: str) -> str:
    """URDF text of robot ``name``'s arm and tool without the mobile base: the links below
    the arm's mount joint, as the robot is built (limits, masses, a link scale and absolute
    mesh paths included), its TCP link named ``tcp``."""
    full = ET.fromstring(build_urdf(get_robot_spec(name)))
    joints = full.findall("joint")
    mount = [j for j in joints if j.get("name") == "mount_joint"]
    if len(mount) != 1:
        raise MomaError(f"robot {name!r}: its URDF has no single mount_joint")
    keep = subtree(full, link_of(mount[0], "child"))
    out = ET.Element("robot", name=name)
    for element in full:
        if element.tag == "material":
            out.append(element)
        elif element.tag == "link" and element.get("name") in keep:
            out.append(element)
        elif element.tag == "joint" and link_of(element, "parent") in keep:
            out.append(element)
    ET.indent(out)
    return '<?xml version="1.0"?>\n' + ET.tostring(out, encoding="unicode") + "\n"


def user_yaml(name: str, as_name: str, urdf_file: str) -> str:
    """The YAML text that registers robot ``name``'s exported URDF (``urdf_file``, relative
    to the YAML) as user robot ``as_name`` with every number of the original."""
    spec = get_robot_spec(name)
    model = spec.model
    mount: float | list[float] = (
        spec.mount_height if spec.mount_range is None else list(spec.mount_range)
    )
    data: dict[str, object] = {
        "name": as_name,
        "urdf": urdf_file,
        "mount_height": mount,
        "end_effector_link": TCP_LINK,
        "end_effector": spec.end_effector,
        "reach": float(spec.reach),
    }
    tool = model.end_effector
    if spec.end_effector == "parallel_gripper":
        data["finger_joints"] = list(tool.finger_joints)
        data["finger_force"] = finger_force(spec)
    elif tool.face_tolerance != UrdfTool.face_tolerance:
        data["suction_face_tolerance"] = tool.face_tolerance
    if model.home:
        data["home"] = [float(v) for v in model.home]
    data["footprint"] = [float(v) for v in spec.footprint]
    data["mount_offset_x"] = float(spec.mount_offset_x)
    if model.arm.mount_yaw:
        data["mount_yaw"] = float(model.arm.mount_yaw)
    if model.arm.flange_link != "flange":
        data["flange_link"] = model.arm.flange_link
    head = f"# Robot {name!r} as a user robot (momakitchen robots export-yaml {name}).\n"
    return head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None)


def export_user_robot(name: str, out_dir: str | Path, as_name: str | None = None) -> Path:
    """Write ``AS.urdf`` and ``AS.yaml`` (``AS``: ``as_name``, default ``my_NAME``) into
    the directory ``out_dir`` (made if missing); returns the YAML's path. Each file is
    written atomically; MomaError names a bad name, a robot or an unwritable place."""
    as_name = as_name or f"my_{name}"
    if not is_robot_name(as_name):
        raise MomaError(f"a user robot's name must be a lower-case identifier, got {as_name!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise MomaError(f"output directory {str(out)!r} is a file")
    urdf_text, yaml_text = arm_urdf(name), user_yaml(name, as_name, f"{as_name}.urdf")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MomaError(f"cannot make directory {str(out)!r}: {exc.strerror}") from None
    paths = (out / f"{as_name}.urdf", out / f"{as_name}.yaml")
    for path, text in zip(paths, (urdf_text, yaml_text), strict=True):
        try:
            atomic_write_text(path, text)
        except OSError as exc:
            raise MomaError(f"cannot write {str(path)!r}: {exc.strerror}") from None
    return paths[1]
