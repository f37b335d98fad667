"""The Realman scaled x0.70 with the Elephant's gripper (realman-x0.70-eg; 40 N per finger)
or only its finger force (realman-x0.70-f40), registered in this process, then one of:

    python3 scripts/gripper_twins.py generate OUT       # label scenes 910000-910005
    python3 scripts/gripper_twins.py twins A B [--out F]  # scripts/descriptor_twins.py
    python3 scripts/gripper_twins.py cli ARGS...        # any momakitchen command

(results/anyarm/twins/README.md, "The gripper").
"""

from __future__ import annotations

import dataclasses
import runpy
import sys
from pathlib import Path

from momakitchen.robots.spec import get_robot_spec, register_robot

BASE = get_robot_spec("realman-x0.70")
ELEPHANT_GRIPPER = get_robot_spec("elephant").model.end_effector
VARIANTS = {
    "eg": ELEPHANT_GRIPPER,
    "f40": dataclasses.replace(BASE.model.end_effector, finger_force=ELEPHANT_GRIPPER.finger_force),
}
for _v, _ee in VARIANTS.items():
    register_robot(
        dataclasses.replace(
            BASE,
            name=f"realman-x0.70-{_v}",
            model=dataclasses.replace(BASE.model, end_effector=_ee),
        )
    )

if __name__ == "__main__":
    what, *rest = sys.argv[1:]
    if what == "generate":  # OUT VARIANT
        from momakitchen.data.config import GenerationConfig
        from momakitchen.data.generator import GenerateRequest, generate_dataset
        from momakitchen.generation.producer import scene_records
        from momakitchen.scene.configuration import SceneConfig

        out, variant = rest
        cfg = GenerationConfig(scene=SceneConfig(robots=(f"realman-x0.70-{variant}",)))
        request = GenerateRequest(out=Path(out), num_scenes=6, first_scene_id=910000)
        generate_dataset(request, scene_records, cfg, progress=False)
    elif what == "twins":
        sys.path.insert(0, str(Path(__file__).parent))
        sys.argv = ["descriptor_twins.py", *rest]
        runpy.run_path(str(Path(__file__).parent / "descriptor_twins.py"), run_name="__main__")
    else:
        from momakitchen.cli.main import main

        sys.exit(main(rest))
