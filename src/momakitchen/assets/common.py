"""Shared pieces of the procedural categories: their base class (procedural instances plus
registered external ones), sampling helpers, colour palettes, handles, and the step from
link/joint lists to an :class:`AssetModel`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from momakitchen.assets import external
from momakitchen.assets.registry import (
    Articulation,
    AssetCategory,
    AssetModel,
    Envelope,
    GraspFrame,
    Rect,
)
from momakitchen.assets.urdf import (
    ALONG_X,
    ALONG_Y,
    RGBA,
    Box,
    Cylinder,
    Joint,
    Link,
    Shape,
    Vec3,
    bounding_box,
    rgba,
    robot_urdf,
)
from momakitchen.errors import MomaError


class ProceduralCategory(AssetCategory):
    """A category generated from code that can also draw instances from external URDF
    folders (``external.register_external_assets``).

    Subclasses implement ``sample_procedural`` and ``build_procedural``. ``sample`` returns
    an :class:`external.ExternalParams` for a share of the draws when external assets of
    this category are registered, and consumes no random numbers for that otherwise, so the
    procedural streams are unchanged by the feature.
    """

    @classmethod
    def sample(cls, rng: np.random.Generator, envelope: Envelope | None = None) -> Any:
        drawn = external.maybe_sample(cls.name, rng, envelope)
        return drawn if drawn is not None else cls.sample_procedural(rng, envelope)

    @classmethod
    def build(cls, params: Any) -> AssetModel:
        if isinstance(params, external.ExternalParams):
            return external.build_external(params)
        return cls.build_procedural(params)

    @classmethod
    def params_from_dict(cls, data: dict[str, Any]) -> Any:
        if data.get("source") == external.SOURCE:
            return external.ExternalParams.from_dict(data)
        return super().params_from_dict(data)

    @classmethod
    def sample_procedural(cls, rng: np.random.Generator, envelope: Envelope | None = None) -> Any:
        raise NotImplementedError

    @classmethod
    def build_procedural(cls, params: Any) -> AssetModel:
        raise NotImplementedError


# Densities (kg/m^3) used to derive masses from geometry.
MDF = 720.0  # carcass panels and fronts
STONE = 2600.0  # granite / quartz countertops
WOOD = 680.0  # butcher block, solid wood
STEEL_SHEET = 1100.0  # appliance shells, averaged over sheet metal, insulation and air
METAL = 2700.0  # handles (aluminium / hollow steel)


def u(rng: np.random.Generator, lo: float, hi: float, nd: int = 4) -> float:
    """Uniform draw rounded to ``nd`` decimals (0.1 mm, short JSON), kept inside
    ``[lo, hi]`` (a bound taken from an envelope must never be exceeded by rounding)."""
    if hi < lo:
        raise MomaError(f"empty parameter range [{lo}, {hi}]")
    return min(max(round(float(rng.uniform(lo, hi)), nd), lo), hi)


def pick(rng: np.random.Generator, options: tuple[str, ...] | list[str]) -> str:
    return str(options[int(rng.integers(len(options)))])


def jitter(rng: np.random.Generator, base: tuple[float, ...], amount: float = 0.05) -> RGBA:
    """A palette colour with a small random shift, so no two instances look identical."""
    c = np.asarray(base[:3]) + rng.uniform(-amount, amount, 3)
    return rgba(tuple(c.tolist()), base[3] if len(base) > 3 else 1.0)


def palette_colour(
    rng: np.random.Generator, palette: tuple[tuple[float, ...], ...], amount: float = 0.04
) -> RGBA:
    return jitter(rng, palette[int(rng.integers(len(palette)))], amount)


# Plausible kitchen materials (RGB).
FRONT_COLOURS = (
    (0.95, 0.95, 0.93),
    (0.92, 0.89, 0.82),
    (0.80, 0.81, 0.80),
    (0.30, 0.31, 0.33),
    (0.55, 0.63, 0.55),
    (0.20, 0.25, 0.38),
    (0.72, 0.56, 0.38),
    (0.45, 0.30, 0.20),
    (0.60, 0.47, 0.35),
    (0.13, 0.13, 0.14),
)
CARCASS_COLOURS = ((0.93, 0.93, 0.91), (0.85, 0.80, 0.70), (0.60, 0.60, 0.60))
COUNTERTOP_COLOURS = (
    (0.18, 0.18, 0.19),
    (0.90, 0.90, 0.88),
    (0.62, 0.46, 0.30),
    (0.55, 0.55, 0.53),
    (0.08, 0.08, 0.09),
    (0.78, 0.74, 0.66),
)
HANDLE_COLOURS = ((0.75, 0.76, 0.78), (0.62, 0.62, 0.60), (0.08, 0.08, 0.08), (0.72, 0.58, 0.30))
APPLIANCE_COLOURS = ((0.80, 0.81, 0.82), (0.95, 0.95, 0.95), (0.12, 0.12, 0.13), (0.68, 0.69, 0.70))
GLASS = (0.08, 0.09, 0.10, 1.0)

HANDLE_TYPES = ("bar_h", "bar_v", "flat_h", "knob")


@dataclass(frozen=True)
class Handle:
    """Handle shapes in a part's frame and the grasp on them (position on the grasped
    surface, ``normal`` out of the part, fingers closing across the bar)."""

    shapes: tuple[Shape, ...]
    position: Vec3
    closing_axis: Vec3
    width: float


def make_handle(
    kind: str, centre: Vec3, length: float, thickness: float, standoff: float, material: str
) -> Handle:
    """A handle on a front whose outward normal is +y; ``centre`` lies on the front surface.

    ``bar_h``/``bar_v``: round bar on two posts; ``flat_h``/``flat_v``: rectangular bar on two
    posts; ``knob``: mushroom knob (``thickness`` is its diameter).
    """
    x, y, z = centre
    post_r = max(0.004, thickness * 0.35)
    front = y + standoff + thickness  # outermost y of the handle
    if kind == "knob":
        r = thickness / 2
        shapes = (
            Shape(Cylinder(0.006, standoff), (x, y + standoff / 2, z), ALONG_Y, material),
            Shape(
                Cylinder(r, thickness * 0.6),
                (x, y + standoff + thickness * 0.3, z),
                ALONG_Y,
                material,
            ),
        )
        return Handle(shapes, (x, y + standoff + thickness * 0.6, z), (1.0, 0.0, 0.0), thickness)
    if kind in ("bar_h", "bar_v", "flat_h", "flat_v"):
        horizontal = kind.endswith("_h")
        along = ALONG_X if horizontal else (0.0, 0.0, 0.0)
        off = length / 2 - 0.012
        ends = [(x - off, z), (x + off, z)] if horizontal else [(x, z - off), (x, z + off)]
        posts = tuple(
            Shape(Cylinder(post_r, standoff), (px, y + standoff / 2, pz), ALONG_Y, material)
            for px, pz in ends
        )
        bar_y = y + standoff + thickness / 2
        if kind.startswith("bar"):
            bar = Shape(Cylinder(thickness / 2, length), (x, bar_y, z), along, material)
        else:
            dims = (
                (length, thickness, thickness * 1.6)
                if horizontal
                else (thickness * 1.6, thickness, length)
            )
            bar = Shape(Box(dims), (x, bar_y, z), (0.0, 0.0, 0.0), material)
        width = thickness * (1.6 if kind.startswith("flat") else 1.0)
        closing = (0.0, 0.0, 1.0) if horizontal else (1.0, 0.0, 0.0)
        return Handle((bar, *posts), (x, front, z), closing, round(width, 4))
    raise MomaError(f"unknown handle type {kind!r}; known: bar_h, bar_v, flat_h, flat_v, knob")


def handle_grasp(
    link: str, h: Handle, normal: Vec3 = (0.0, 1.0, 0.0), name: str = "handle"
) -> GraspFrame:
    return GraspFrame(link, h.position, normal, h.closing_axis, h.width, name)


def check_envelope(name: str, envelope: Envelope | None, min_size: Vec3) -> Envelope:
    if envelope is None:
        raise MomaError(f"category {name!r} needs an envelope (width, depth, height)")
    w, d, h = min_size
    if envelope.width < w or envelope.depth < d or envelope.height < h:
        raise MomaError(
            f"category {name!r}: envelope {envelope} is smaller than the minimum {min_size}"
        )
    return envelope


def finish(
    category: str,
    links: list[Link],
    joints: list[Joint],
    materials: dict[str, RGBA],
    *,
    grasps: tuple[GraspFrame, ...] = (),
    articulations: tuple[Articulation, ...] = (),
    placement_areas: tuple[Rect, ...] = (),
) -> AssetModel:
    """Write the URDF and collect metadata (size from the collision geometry, total mass)."""
    lk, jt = tuple(links), tuple(joints)
    lo, hi = bounding_box(lk, jt)
    size = tuple(round(b - a, 6) for a, b in zip(lo, hi, strict=True))
    return AssetModel(
        category=category,
        urdf=robot_urdf(category, lk, jt, materials),
        size=size,  # type: ignore[arg-type]
        mass=round(sum(x.mass for x in lk), 6),
        grasps=grasps,
        articulations=articulations,
        placement_areas=placement_areas,
    )


def box_at(
    lo: Vec3, hi: Vec3, material: str, density: float = 1.0, collision: bool = True
) -> Shape:
    """A box given by its lower and upper corners (easier to read than centre + size)."""
    size = tuple(b - a for a, b in zip(lo, hi, strict=True))
    centre = tuple((a + b) / 2 for a, b in zip(lo, hi, strict=True))
    if min(size) <= 0:
        raise MomaError(f"degenerate box {lo} .. {hi}")
    return Shape(
        Box((size[0], size[1], size[2])),
        (centre[0], centre[1], centre[2]),
        material=material,
        density=density,
        collision=collision,
    )
