"""Asset categories: one registry, one entry per category.

A category knows how to *sample* the parameters of a new instance from a seeded generator
(pure data) and how to *build* an :class:`AssetModel` (URDF text plus the metadata the
simulator needs) from those parameters. Nothing here touches PyBullet.

Frames (all asset frames are right-handed, z up, metres):

* furniture (``kind == "furniture"``): origin on the floor at the centre of the back edge of
  the footprint (the edge against the wall); +x along the wall, +y out of the wall into the
  room (the front), so the unit occupies ``x in [-w/2, w/2], y in [0, d]``.
* countertop appliances (``kind == "appliance"``, e.g. microwave): same convention, origin at
  the bottom of the appliance (it stands on a countertop).
* rigid targets and obstacles: origin at the centre of the footprint on the supporting
  surface (bottom of the object), +x its "front" where it has one.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from momakitchen.errors import MomaError
from momakitchen.registry import Registry

Vec3 = tuple[float, float, float]

KINDS = ("furniture", "appliance", "rigid", "obstacle")


@dataclass(frozen=True)
class Envelope:
    """Space the layout grants a furniture unit or an appliance.

    ``width`` along the wall (x), ``depth`` away from it (y), ``height`` the counter height
    (top of the countertop, z) for base units; for tall units and appliances the maximum height.
    """

    width: float
    depth: float
    height: float


@dataclass(frozen=True)
class GraspFrame:
    """Where and how to grasp, expressed in the frame of URDF link ``link``.

    ``normal`` is the outward surface normal at ``position``: the end-effector approaches
    along ``-normal``. ``closing_axis`` is the direction the fingers close along (unit,
    perpendicular to ``normal``); a suction cup ignores it. ``width`` is the object's
    extent along ``closing_axis`` at the grasp (must be < the 0.08 m gripper opening for
    a gripper grasp).
    """

    link: str
    position: Vec3
    normal: Vec3
    closing_axis: Vec3
    width: float
    name: str = "grasp"


@dataclass(frozen=True)
class Articulation:
    """A functional part of an articulated asset: a joint opened by grasping a handle.

    ``open_direction`` is +1 if opening increases the joint position, -1 otherwise; the joint
    starts closed at position 0. ``part`` names the kind of part (door, drawer, lever).
    """

    joint: str
    joint_type: str  # "revolute" | "prismatic"
    part: str
    handle: GraspFrame
    open_direction: int
    limit: float  # |travel| in rad or m from closed to fully open


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle at height ``z`` in the asset frame (a placement area)."""

    x0: float
    x1: float
    y0: float
    y1: float
    z: float


@dataclass(frozen=True)
class AssetModel:
    """A built asset instance: URDF text and what the simulator needs to use it.

    ``size`` is the axis-aligned bounding box extent (x, y, z) in the asset frame at rest
    (joints closed). ``placement_areas`` are free horizontal surfaces (countertop) where
    rigid objects may stand. ``grasps`` are grasp frames of a rigid target;
    ``articulations`` are the functional parts of an articulated asset.

    External assets (``momakitchen.assets.external``) set ``path``: load that URDF file (its
    meshes are relative to it) with PyBullet's ``globalScaling=scale`` instead of writing
    ``urdf`` to the cache; ``urdf`` then holds the file's text and ``size`` is already scaled.
    """

    category: str
    urdf: str
    size: Vec3
    mass: float
    grasps: tuple[GraspFrame, ...] = ()
    articulations: tuple[Articulation, ...] = ()
    placement_areas: tuple[Rect, ...] = ()
    path: str | None = None
    scale: float = 1.0


class AssetCategory:
    """Base class of a registered category. Subclasses set ``name``, ``kind``, ``Params``
    (a frozen dataclass of floats/ints/strings/tuples) and implement ``sample`` and ``build``.
    """

    name: ClassVar[str]
    kind: ClassVar[str]
    Params: ClassVar[type]

    @classmethod
    def sample(cls, rng: np.random.Generator, envelope: Envelope | None = None) -> Any:
        """Draw the parameters of a new instance. Furniture and appliances must fit ``envelope``."""
        raise NotImplementedError

    @classmethod
    def build(cls, params: Any) -> AssetModel:
        """Build the instance (pure Python: URDF text and metadata)."""
        raise NotImplementedError

    @classmethod
    def params_from_dict(cls, data: dict[str, Any]) -> Any:
        """Inverse of ``dataclasses.asdict`` for this category's ``Params`` (JSON round trip)."""
        fields = {f.name: f for f in dataclasses.fields(cls.Params)}
        unknown = set(data) - set(fields)
        if unknown:
            raise MomaError(f"category {cls.name!r}: unknown parameter(s) {sorted(unknown)}")
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls.Params(**values)


CATEGORIES: Registry[type[AssetCategory]] = Registry("asset category", plural="asset categories")


def register_category(cls: type[AssetCategory]) -> type[AssetCategory]:
    """Class decorator adding a category to ``CATEGORIES`` (one source of truth)."""
    if cls.kind not in KINDS:
        raise MomaError(f"category {cls.name!r}: kind must be one of {KINDS}, got {cls.kind!r}")
    return CATEGORIES.register(cls)


def get_category(name: str) -> type[AssetCategory]:
    """Look up a category; unknown names raise MomaError listing the known ones."""
    return CATEGORIES.get_entry(name)


def categories_of_kind(kind: str) -> list[str]:
    """Names of registered categories of ``kind``, sorted (deterministic order)."""
    return sorted(n for n, c in CATEGORIES.items() if c.kind == kind)


SampleFn = Callable[[np.random.Generator, Envelope | None], Any]
