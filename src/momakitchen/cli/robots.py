"""``momakitchen robots``: list the robots, export a robot's URDF.

    momakitchen robots [--json] [--robot-yaml FILE ...]
    momakitchen robots export-urdf NAME --out FILE [--robot-yaml FILE ...]

``--robot-yaml`` (repeatable) registers user robots (URDF + YAML, see
``momakitchen.robots.user``) before the command runs, here as on every command that takes
a robot (demo, label, predict); so does the environment variable ``MOMAKITCHEN_ROBOT_YAML``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "robots",
        help="list robots (reach, mount height, DoF, end-effector) or export a URDF",
        description="List the registered robots, or export one robot's URDF.",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument(
        "--robot-yaml",
        action="append",
        default=[],
        metavar="FILE",
        help="register a user robot from a YAML file (repeatable)",
    )
    parser.set_defaults(func=run, robots_command=None)
    sub = parser.add_subparsers(
        dest="robots_command",
        metavar="[ACTION]",
        title="actions (optional; default: list the robots)",
    )
    export = sub.add_parser(
        "export-urdf",
        help="write a robot's URDF (base + arm + tool)",
        description="Write one URDF file (mobile base, arm and "
        "end-effector) that loads with p.loadURDF(FILE).",
    )
    export.add_argument("name", help="robot name (see `momakitchen robots`)")
    export.add_argument("--out", required=True, metavar="FILE", help="URDF file to write")
    export.add_argument(
        "--robot-yaml",
        dest="robot_yaml_sub",
        action="append",
        default=[],
        metavar="FILE",
        help="register a user robot from a YAML file",
    )


def robot_rows() -> list[dict]:
    """One JSON-ready dict per registered robot."""
    from momakitchen.robots.spec import (
        DESCRIPTOR_NAMES,
        DESCRIPTOR_VERSION,
        ROBOTS,
        robot_descriptor,
    )

    rows = []
    for spec in ROBOTS.values():
        rows.append(
            {
                "name": spec.name,
                "reach_m": spec.reach,
                "mount_height_m": spec.mount_height,
                "dof": spec.dof,
                "end_effector": spec.end_effector,
                "footprint_m": list(spec.footprint),
                "descriptor": dict(zip(DESCRIPTOR_NAMES, robot_descriptor(spec), strict=True)),
                "descriptor_version": DESCRIPTOR_VERSION,
            }
        )
    return rows


def run(args: argparse.Namespace) -> int:
    # The --robot-yaml files (of either level) are registered by the entry point.
    if args.robots_command == "export-urdf":
        return _export(args)
    rows = robot_rows()
    if args.json:
        print(dumps_strict(rows, indent=2))
        return 0
    header = ("name", "reach (m)", "mount height (m)", "DoF", "end-effector")
    table = [header] + [
        (
            r["name"],
            f"{r['reach_m']:.3f}",
            f"{r['mount_height_m']:.2f}",
            str(r["dof"]),
            r["end_effector"],
        )
        for r in rows
    ]
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for row in table:
        print("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip())
    return 0


def _export(args: argparse.Namespace) -> int:
    from momakitchen.fileio import atomic_write_text
    from momakitchen.robots.urdf import robot_urdf

    text = robot_urdf(args.name)
    out = Path(args.out)
    if not out.parent.is_dir():
        raise MomaError(f"output directory {str(out.parent)!r} does not exist")
    try:
        atomic_write_text(out, text)
    except OSError as exc:
        raise MomaError(f"cannot write {str(out)!r}: {exc.strerror}") from None
    print(f"wrote {out} ({args.name}: mobile base + arm + end-effector)")
    return 0
