"""Arms with scaled links: every length of a robot's arm multiplied, its tool unchanged.

A model meant for robots it never saw needs training robots whose reach varies
continuously; real arms come in a few sizes. A robot's YAML may say ``link_scale: S`` (in
:data:`SCALE_RANGE`): its URDF's arm, every link not below the flange link, then has its
joint origins, collision and visual geometry (boxes, cylinders, capsules, spheres, meshes)
and centres of mass scaled by ``S``, so its reach is ``S`` times the file's. Joint axes
and limits, masses and inertias, the home pose, the tool and the mobile base stay as they
are: a scaled arm has the same joint space and the same gripper, only longer or shorter
links. A built-in scaled is a YAML of three lines (``like: NAME``, ``user.py``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from momakitchen.errors import MomaError

# Link length factors a scaled arm may have: half to one and a half times the original.
SCALE_RANGE = (0.5, 1.5)
# A scaled link never gets thinner than this (collision radius, metres), nor than it was.
MIN_RADIUS = 0.02


def scale_problem(value: object) -> str | None:
    """Why ``value`` is not a link scale (a number in :data:`SCALE_RANGE`), or None."""
    lo, hi = SCALE_RANGE
    if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi:
        return f"link_scale must be in [{lo}, {hi}], got {value!r}"
    return None


def _numbers(text: str | None, what: str) -> list[float]:
    try:
        return [float(v) for v in (text or "").split()]
    except ValueError:
        raise MomaError(f"URDF: {what} {text!r} is not a list of numbers") from None


def _fmt(values: list[float]) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def _scale_attr(el: ET.Element, key: str, scale: float, default: str | None = None) -> None:
    text = el.get(key, default)
    if text is not None:
        el.set(key, _fmt([scale * v for v in _numbers(text, f"<{el.tag} {key}>")]))


def _scale_geometry(geometry: ET.Element, scale: float) -> None:
    for shape in geometry:
        if shape.tag == "box":
            _scale_attr(shape, "size", scale)
        elif shape.tag == "mesh":
            _scale_attr(shape, "scale", scale, default="1 1 1")
        else:  # cylinder, capsule, sphere
            radius = shape.get("radius")
            if radius is not None:
                r = float(radius)
                shape.set("radius", f"{max(min(r, MIN_RADIUS), scale * r):.9g}")
            _scale_attr(shape, "length", scale)


def scale_arm(urdf: ET.Element, tool: set[str], scale: float) -> None:
    """Scale, in place, every length of the arm of the URDF tree ``urdf``: the links not
    in ``tool`` (the links below the flange) and the joints into them; the tool is left as
    it is. MomaError on a scale outside :data:`SCALE_RANGE`."""
    problem = scale_problem(scale)
    if problem:
        raise MomaError(problem)
    for link in urdf.findall("link"):
        if link.get("name") in tool:
            continue
        for part in link:
            origin = part.find("origin")
            if origin is not None:
                _scale_attr(origin, "xyz", scale)
            geometry = part.find("geometry")
            if geometry is not None:
                _scale_geometry(geometry, scale)
    for joint in urdf.findall("joint"):
        origin, child = joint.find("origin"), joint.find("child")
        if child is not None and child.get("link") not in tool and origin is not None:
            _scale_attr(origin, "xyz", scale)
