"""The Realman scaled x0.70 with the Elephant's gripper (realman_x070_eg; 40 N per finger)
or only its finger force (realman_x070_f40, robots/realman_x070_f40.yaml, docs/ROBOTS.md
"Grip force"), both registered in this process, then one of:

    python3 analyses/gripper_twins.py generate OUT eg|f40  # label scenes 910000-910005
    python3 analyses/gripper_twins.py twins A B [--out F]  # analyses/descriptor_twins.py
    python3 analyses/gripper_twins.py cli ARGS...          # any momakitchen command

(results/anyarm/twins/README.md, "The gripper"; the robots were named realman-x0.70-eg and
realman-x0.70-f40 there).
"""

from __future__ import annotations

import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.robots.urdf import link_of, parse_urdf, subtree
from momakitchen.robots.user import SHIPPED, register_user_robot

ROBOTS_DIR = Path(__file__).resolve().parent / "robots"
VARIANTS = ("eg", "f40")


def _with_elephant_gripper(out: Path) -> Path:
    """The YAML of the Realman x0.70 carrying the Elephant's gripper, written into ``out``
    with its URDF: the Realman's arm down to its flange, the Elephant's tool below it (both
    name the flange ``flange``)."""
    arm, tool = parse_urdf(SHIPPED / "realman.urdf"), parse_urdf(SHIPPED / "elephant.urdf")
    below = subtree(arm, "flange") - {"flange"}
    for el in list(arm):
        if (el.tag == "link" and el.get("name") in below) or (
            el.tag == "joint" and link_of(el, "child") in below
        ):
            arm.remove(el)
    grip = subtree(tool, "flange") - {"flange"}
    for el in tool:
        if (el.tag == "link" and el.get("name") in grip) or (
            el.tag == "joint" and link_of(el, "child") in grip
        ):
            arm.append(el)
    ET.indent(arm)
    (out / "realman_x070_eg.urdf").write_text(ET.tostring(arm, encoding="unicode"))
    yaml = out / "realman_x070_eg.yaml"
    yaml.write_text(
        "name: realman_x070_eg\nlike: realman\nurdf: realman_x070_eg.urdf\nlink_scale: 0.7\n"
        "finger_force: 40\n"
    )
    return yaml


register_user_robot(ROBOTS_DIR / "realman_x070_f40.yaml")
register_user_robot(_with_elephant_gripper(Path(tempfile.mkdtemp(prefix="gripper_twins_"))))


def main() -> None:
    what, *rest = sys.argv[1:] or [""]
    if what == "generate":
        from momakitchen.data.config import GenerationConfig
        from momakitchen.data.generator import GenerateRequest, generate_dataset
        from momakitchen.generation.producer import scene_records
        from momakitchen.scene.configuration import SceneConfig

        if len(rest) != 2 or rest[1] not in VARIANTS:
            raise MomaError(f"generate needs OUT and a variant of {sorted(VARIANTS)}, got {rest}")
        out, variant = rest
        cfg = GenerationConfig(scene=SceneConfig(robots=(f"realman_x070_{variant}",)))
        request = GenerateRequest(out=Path(out), num_scenes=6, first_scene_id=910000)
        generate_dataset(request, scene_records, cfg, progress=False)
    elif what == "twins":
        import descriptor_twins

        sys.argv = ["descriptor_twins.py", *rest]
        descriptor_twins.main()
    elif what == "cli":
        from momakitchen.cli.main import main as cli

        sys.exit(cli(rest))
    else:
        raise MomaError(f"the first word must be generate, twins or cli, got {what!r}")


if __name__ == "__main__":
    run_main(main, "gripper_twins.py")
