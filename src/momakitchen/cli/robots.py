"""``momakitchen robots``: list the robots, export a robot's URDF or its user-robot files.

    momakitchen robots [--json] [--robot-yaml FILE ...]
    momakitchen robots export-urdf NAME --out FILE [--mount-height M] [--robot-yaml FILE ...]
    momakitchen robots export-yaml NAME --out DIR [--as NEW_NAME] [--robot-yaml FILE ...]

``--robot-yaml`` (repeatable) registers user robots (URDF + YAML, see
``momakitchen.robots.user``) before the command runs, here as on every command that takes
a robot or builds worlds (demo, label, generate, msr, ...); so does the environment
variable ``MOMAKITCHEN_ROBOT_YAML``. The table ends with the robots ``generate`` assigns
by default; the others are used by name (``generate --robot NAME``, ``label --robot``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from momakitchen.cli.options import add_robot_yaml
from momakitchen.errors import MomaError
from momakitchen.fileio import dumps_strict


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "robots",
        help="list robots (reach, mount height, DoF, end-effector) or export a URDF",
        description="List the registered robots, or export one robot's URDF or its "
        "user-robot files (URDF + YAML).",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    add_robot_yaml(parser)
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
        "--mount-height",
        type=float,
        default=None,
        metavar="M",
        help="mount the arm this high (m; default: the robot's own; any height of 0.3-1.3)",
    )
    add_robot_yaml(export, dest="robot_yaml_sub")
    copy = sub.add_parser(
        "export-yaml",
        help="write a robot as a user robot's files (arm + tool URDF, YAML)",
        description="Write DIR/NEW_NAME.urdf (the arm and its tool, no base) and "
        "DIR/NEW_NAME.yaml: registered with --robot-yaml, the copy is the same robot "
        "under a new name, with the same model input. A start for your own robot's files.",
    )
    copy.add_argument("name", help="robot name (see `momakitchen robots`)")
    copy.add_argument("--out", required=True, metavar="DIR", help="directory (made if missing)")
    copy.add_argument(
        "--as",
        dest="as_name",
        default=None,
        metavar="NEW_NAME",
        help="the copy's name, a lower-case identifier (default: my_NAME)",
    )
    add_robot_yaml(copy, dest="robot_yaml_sub")


def robot_rows() -> list[dict]:
    """One JSON-ready dict per registered robot."""
    from momakitchen.robots.descriptor import robot_descriptor
    from momakitchen.robots.spec import (
        DEFAULT_ROBOTS,
        DESCRIPTOR_NAMES,
        DESCRIPTOR_VERSION,
        ROBOTS,
        finger_force,
    )

    rows = []
    for spec in ROBOTS.values():
        rows.append(
            {
                "name": spec.name,
                "reach_m": spec.reach,
                "mount_height_m": spec.mount_height,
                "mount_range_m": None if spec.mount_range is None else list(spec.mount_range),
                "generate_default": spec.name in DEFAULT_ROBOTS,
                "dof": spec.dof,
                "end_effector": spec.end_effector,
                "finger_force_n": None if spec.end_effector == "suction" else finger_force(spec),
                "footprint_m": list(spec.footprint),
                "descriptor": dict(zip(DESCRIPTOR_NAMES, robot_descriptor(spec), strict=True)),
                "descriptor_version": DESCRIPTOR_VERSION,
            }
        )
    return rows


def run(args: argparse.Namespace) -> int:
    from momakitchen.robots.scaled import SCALE_RANGE
    from momakitchen.robots.spec import FORCE_RANGE

    # The --robot-yaml files (of either level) are registered by the entry point.
    if args.robots_command == "export-urdf":
        return _export(args)
    if args.robots_command == "export-yaml":
        return _export_yaml(args)
    rows = robot_rows()
    if args.json:
        print(dumps_strict(rows, indent=2))
        return 0
    header = (
        "name",
        "reach (m)",
        "mount height (m)",
        "DoF",
        "end-effector",
        "grip (N)",
        "mount range (m)",
    )
    table = [header] + [
        (
            r["name"],
            f"{r['reach_m']:.3f}",
            f"{r['mount_height_m']:.2f}",
            str(r["dof"]),
            r["end_effector"],
            "" if r["finger_force_n"] is None else f"{r['finger_force_n']:g}",
            "" if r["mount_range_m"] is None else "{:.2f}-{:.2f}".format(*r["mount_range_m"]),
        )
        for r in rows
    ]
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for row in table:
        print("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip())
    defaults = ", ".join(r["name"] for r in rows if r["generate_default"])
    print(
        "a robot like one above, links scaled ({}-{}) or fingers of another force "
        "({:g}-{:g} N): a YAML with `like: NAME` (docs/ROBOTS.md)".format(
            *SCALE_RANGE, *FORCE_RANGE
        )
    )
    print(f"generate's robots by default: {defaults}; the others by --robot NAME")
    return 0


def _export(args: argparse.Namespace) -> int:
    from momakitchen.fileio import atomic_write_text
    from momakitchen.robots.urdf import robot_urdf

    text = robot_urdf(args.name, args.mount_height)
    out = Path(args.out)
    if not out.parent.is_dir():
        raise MomaError(f"output directory {str(out.parent)!r} does not exist")
    try:
        atomic_write_text(out, text)
    except OSError as exc:
        raise MomaError(f"cannot write {str(out)!r}: {exc.strerror}") from None
    at = "" if args.mount_height is None else f", arm at {args.mount_height:g} m"
    print(f"wrote {out} ({args.name}: mobile base + arm + end-effector{at})")
    return 0


def _export_yaml(args: argparse.Namespace) -> int:
    from momakitchen.robots.export import export_user_robot

    path = export_user_robot(args.name, args.out, args.as_name)
    print(f"wrote {path} and {path.with_suffix('.urdf')} ({args.name} as a user robot)")
    print(f"register it with: --robot-yaml {path}")
    return 0
