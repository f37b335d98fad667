"""Write user robots (URDF + YAML) made from public URDFs that ship with ``pybullet_data``.

    python scripts/public_urdf_robots.py --out DIR

writes, in ``DIR``:

- ``iiwa_suction.yaml`` (+ ``iiwa_suction.urdf``): KUKA LBR iiwa (``kuka_iiwa/model.urdf``,
  7 DoF, no tool) with a 12 cm suction stem on its flange ending in a geometry-less
  ``tool0`` frame (the usual ROS TCP frame);
- ``xarm6_suction.yaml`` (+ ``xarm6_suction.urdf``): UFACTORY xArm6 (``xarm/xarm6_robot.urdf``,
  6 DoF, no tool) with the same suction tool;
- ``panda_public.yaml``: ``franka_panda/panda.urdf`` as shipped (hand and fingers), its
  geometry-less ``panda_grasptarget`` frame as the TCP.

No hand-tuned ``home`` is given: the YAMLs hold only what a user reads off a datasheet.
Each YAML registers with ``--robot-yaml DIR/NAME.yaml`` (docs/ROBOTS.md).
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pybullet_data

DATA = Path(pybullet_data.getDataPath())
TOOL_LENGTH = 0.12  # flange to cup face (m)
CUP_RADIUS = 0.02

# name: (URDF under pybullet_data, the link the tool mounts on, flange offset along its z)
SUCTION_ARMS = {
    # The iiwa's link_7 frame lies 4.5 cm behind its flange face (iiwa_stack's link_ee).
    "iiwa_suction": ("kuka_iiwa/model.urdf", "lbr_iiwa_link_7", 0.045),
    "xarm6_suction": ("xarm/xarm6_robot.urdf", "link6", 0.0),
}


def _absolute_meshes(root: ET.Element, urdf_dir: Path) -> None:
    """Mesh paths made absolute, so the written URDF loads from any folder."""
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        for prefix in ("package://xarm_description/", "package://"):
            if name.startswith(prefix):
                name = name[len(prefix) :]
                break
        for base in (urdf_dir, urdf_dir / "xarm_description"):
            if (base / name).exists():
                mesh.set("filename", str((base / name).resolve()))
                break


def suction_urdf(src: str, flange_link: str, flange_offset: float) -> str:
    """The public URDF ``src`` with a suction stem on ``flange_link`` and a ``tool0``
    frame (no geometry, no inertia of note) on the cup face, z out of the flange."""
    path = DATA / src
    root = ET.parse(path).getroot()
    _absolute_meshes(root, path.parent)
    stem = ET.SubElement(root, "link", name="suction_tool")
    inertial = ET.SubElement(stem, "inertial")
    ET.SubElement(inertial, "origin", xyz=f"0 0 {TOOL_LENGTH / 2}", rpy="0 0 0")
    ET.SubElement(inertial, "mass", value="0.2")
    ET.SubElement(
        inertial, "inertia", ixx="1e-4", ixy="0", ixz="0", iyy="1e-4", iyz="0", izz="1e-4"
    )
    for tag in ("visual", "collision"):
        el = ET.SubElement(stem, tag)
        ET.SubElement(el, "origin", xyz=f"0 0 {TOOL_LENGTH / 2}", rpy="0 0 0")
        geom = ET.SubElement(el, "geometry")
        ET.SubElement(geom, "cylinder", radius=str(CUP_RADIUS), length=str(TOOL_LENGTH))
    joint = ET.SubElement(root, "joint", name="suction_tool_joint", type="fixed")
    ET.SubElement(joint, "parent", link=flange_link)
    ET.SubElement(joint, "child", link="suction_tool")
    ET.SubElement(joint, "origin", xyz=f"0 0 {flange_offset}", rpy="0 0 0")
    ET.SubElement(root, "link", name="tool0")  # the TCP frame: no geometry
    joint = ET.SubElement(root, "joint", name="tool0_joint", type="fixed")
    ET.SubElement(joint, "parent", link="suction_tool")
    ET.SubElement(joint, "child", link="tool0")
    ET.SubElement(joint, "origin", xyz=f"0 0 {TOOL_LENGTH}", rpy="0 0 0")
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_robots(out: Path) -> list[Path]:
    """Write the YAMLs (and URDFs) into ``out``; returns the YAML paths."""
    out.mkdir(parents=True, exist_ok=True)
    yamls = []
    for name, (src, flange, offset) in SUCTION_ARMS.items():
        (out / f"{name}.urdf").write_text(suction_urdf(src, flange, offset), encoding="utf-8")
        text = (
            f"name: {name}\nurdf: {name}.urdf\nmount_height: 1.03\n"
            "end_effector_link: tool0\nend_effector: suction\n"
        )
        yamls.append(out / f"{name}.yaml")
        yamls[-1].write_text(text, encoding="utf-8")
    panda = DATA / "franka_panda" / "panda.urdf"
    text = (
        f"name: panda_public\nurdf: {panda}\nmount_height: 1.03\n"
        "end_effector_link: panda_grasptarget\nend_effector: parallel_gripper\n"
    )
    yamls.append(out / "panda_public.yaml")
    yamls[-1].write_text(text, encoding="utf-8")
    return yamls


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, type=Path, help="folder for the YAML/URDF files")
    args = parser.parse_args(argv)
    if args.out.exists() and not args.out.is_dir():
        parser.exit(2, f"public_urdf_robots.py: --out {str(args.out)!r} is not a folder\n")
    for path in write_robots(args.out):
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
