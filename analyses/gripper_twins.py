"""The Realman scaled x0.70 with the Elephant's gripper (realman-x0.70-eg; 40 N per finger,
registered in this process) or only its finger force (realman-x0.70-f40, a gripper variant
the registry builds from its name, docs/ROBOTS.md "Grip force"), then one of:

    python3 analyses/gripper_twins.py generate OUT eg|f40  # label scenes 910000-910005
    python3 analyses/gripper_twins.py twins A B [--out F]  # analyses/descriptor_twins.py
    python3 analyses/gripper_twins.py cli ARGS...          # any momakitchen command

(results/anyarm/twins/README.md, "The gripper").
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from analysis_cli import run_main

from momakitchen.errors import MomaError
from momakitchen.robots.spec import get_robot_spec, register_robot

BASE = get_robot_spec("realman-x0.70")
VARIANTS = ("eg", "f40")
register_robot(
    dataclasses.replace(
        BASE,
        name="realman-x0.70-eg",
        model=dataclasses.replace(
            BASE.model, end_effector=get_robot_spec("elephant").model.end_effector
        ),
    )
)


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
        cfg = GenerationConfig(scene=SceneConfig(robots=(f"realman-x0.70-{variant}",)))
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
