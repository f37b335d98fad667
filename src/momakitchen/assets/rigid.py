"""Rigid target objects that stand on the countertop: bottle, pot, fruit, medicine bottle,
vegetable.

Each is one URDF link (free-floating body) with realistic size, mass and contact friction,
origin at the centre of the footprint on the supporting surface. Grasp frames follow one
convention: ``position`` lies on the object's surface, ``normal`` is the outward normal there
(the gripper approaches along ``-normal``), and the fingertip midpoint belongs at
``position - normal * width / 2`` (the axis of a round section). All grasp widths are
below the 0.08 m opening of a two-finger gripper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from momakitchen.assets.common import ProceduralCategory, finish, jitter, pick, u
from momakitchen.assets.registry import (
    AssetModel,
    Envelope,
    GraspFrame,
    register_category,
)
from momakitchen.assets.urdf import (
    ALONG_X,
    RGBA,
    Box,
    Contact,
    Cylinder,
    Link,
    Shape,
    Sphere,
    density_mass,
)

BODY = "body"
# Widest grasp of any target: 5 mm less than the 8 cm opening of a two-finger gripper, so
# the fingers clear the object while closing around it.
MAX_GRASP_WIDTH = 0.075


def side_grasps(z: float, radius: float, name: str = "side") -> tuple[GraspFrame, ...]:
    """Four horizontal grasps around a vertical round section of ``radius`` at height ``z``."""
    out = []
    for label, n in (
        ("+x", (1.0, 0.0, 0.0)),
        ("-x", (-1.0, 0.0, 0.0)),
        ("+y", (0.0, 1.0, 0.0)),
        ("-y", (0.0, -1.0, 0.0)),
    ):
        pos = (round(n[0] * radius, 6), round(n[1] * radius, 6), round(z, 6))
        closing = (0.0, 1.0, 0.0) if n[0] != 0 else (1.0, 0.0, 0.0)
        out.append(GraspFrame(BODY, pos, n, closing, round(2 * radius, 6), f"{name}{label}"))
    return tuple(out)


def top_grasp(
    z_top: float,
    width: float,
    closing: tuple[float, float, float] = (1.0, 0.0, 0.0),
    x: float = 0.0,
    y: float = 0.0,
    name: str = "top",
) -> GraspFrame:
    return GraspFrame(
        BODY,
        (round(x, 6), round(y, 6), round(z_top, 6)),
        (0.0, 0.0, 1.0),
        closing,
        round(width, 6),
        name,
    )


def flat_base(radius: float, height: float = 0.004) -> Shape:
    """A thin disc inside the bottom of a sphere of ``radius`` (resting on z = 0), so the
    object stands on a small flat patch instead of a point (a real apple or tomato does not
    roll away when put down). The disc's top rim lies on the sphere surface."""
    rim = (2 * radius * height - height * height) ** 0.5
    return Shape(Cylinder(rim, height), (0.0, 0.0, height / 2), material="body")


# ----------------------------------------------------------------------------- bottle


@register_category
class Bottle(ProceduralCategory):
    name = "bottle"
    kind = "rigid"

    @dataclass(frozen=True)
    class Params:
        style: str  # wine | water | oil | soda
        radius: float
        body_height: float
        shoulder_height: float
        neck_radius: float
        neck_height: float
        cap_height: float
        mass: float
        friction: float
        body_rgba: RGBA
        cap_rgba: RGBA
        label_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        style = pick(rng, ("wine", "water", "oil", "soda"))
        if style == "wine":
            r, hb, glass = u(rng, 0.035, 0.0375), u(rng, 0.17, 0.2), (0.12, 0.25, 0.12, 1.0)
            mass, mu, cap = u(rng, 1.1, 1.35, 3), u(rng, 0.5, 0.65, 3), (0.45, 0.08, 0.1)
        elif style == "water":
            r, hb, glass = u(rng, 0.03, 0.036), u(rng, 0.15, 0.2), (0.72, 0.85, 0.95, 1.0)
            mass, mu, cap = u(rng, 0.5, 0.75, 3), u(rng, 0.6, 0.8, 3), (0.15, 0.35, 0.8)
        elif style == "oil":
            r, hb, glass = u(rng, 0.03, 0.035), u(rng, 0.16, 0.2), (0.75, 0.65, 0.2, 1.0)
            mass, mu, cap = u(rng, 0.7, 1.0, 3), u(rng, 0.45, 0.6, 3), (0.1, 0.1, 0.1)
        else:
            r, hb, glass = u(rng, 0.026, 0.033), u(rng, 0.12, 0.17), (0.35, 0.15, 0.1, 1.0)
            mass, mu, cap = u(rng, 0.4, 0.6, 3), u(rng, 0.6, 0.8, 3), (0.85, 0.1, 0.1)
        return cls.Params(
            style=style,
            radius=r,
            body_height=hb,
            shoulder_height=u(rng, 0.03, 0.05),
            neck_radius=u(rng, 0.012, 0.016),
            neck_height=u(rng, 0.05, 0.09),
            cap_height=u(rng, 0.012, 0.03),
            mass=mass,
            friction=mu,
            body_rgba=jitter(rng, glass, 0.05),
            cap_rgba=jitter(rng, cap, 0.08),
            label_rgba=jitter(rng, (0.9, 0.88, 0.8), 0.1),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        mid_r = (p.radius + p.neck_radius) / 2
        z1 = p.body_height
        z2 = z1 + p.shoulder_height
        z3 = z2 + p.neck_height
        z4 = z3 + p.cap_height
        cap_r = p.neck_radius + 0.002
        shapes = (
            Shape(Cylinder(p.radius, z1), (0.0, 0.0, z1 / 2), material="body"),
            Shape(Cylinder(mid_r, p.shoulder_height), (0.0, 0.0, (z1 + z2) / 2), material="body"),
            Shape(
                Cylinder(p.neck_radius, p.neck_height), (0.0, 0.0, (z2 + z3) / 2), material="body"
            ),
            Shape(Cylinder(cap_r, p.cap_height), (0.0, 0.0, (z3 + z4) / 2), material="cap"),
            # the label is a visual skin only: it must not change the collision size
            Shape(
                Cylinder(p.radius + 0.0008, z1 * 0.45),
                (0.0, 0.0, z1 * 0.5),
                material="label",
                collision=False,
            ),
        )
        link = Link(BODY, shapes, p.mass, Contact(p.friction, 0.0005, 0.001))
        grasps = (
            *side_grasps(z1 * 0.5, p.radius),
            top_grasp(z4, 2 * cap_r),
        )
        mats = {"body": p.body_rgba, "cap": p.cap_rgba, "label": p.label_rgba}
        return finish(cls.name, [link], [], mats, grasps=grasps)


# ----------------------------------------------------------------------------- pot


@register_category
class Pot(ProceduralCategory):
    """A saucepan (one long handle) or a casserole (two short side handles)."""

    name = "pot"
    kind = "rigid"

    @dataclass(frozen=True)
    class Params:
        style: str  # saucepan | casserole
        radius: float
        height: float
        wall: float
        handle_length: float
        handle_width: float
        handle_thickness: float
        lid: int  # 1: a lid with a knob rests on the rim
        mass: float
        friction: float
        body_rgba: RGBA
        handle_rgba: RGBA

    SEGMENTS = 16  # wall facets of the round pot

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        style = pick(rng, ("saucepan", "casserole"))
        body = pick(rng, ("steel", "black", "red", "copper", "enamel"))
        colour = {
            "steel": (0.78, 0.79, 0.8),
            "black": (0.12, 0.12, 0.13),
            "red": (0.7, 0.12, 0.1),
            "copper": (0.72, 0.45, 0.28),
            "enamel": (0.2, 0.35, 0.6),
        }[body]
        handle = (0.1, 0.1, 0.1) if rng.random() < 0.6 else colour
        if style == "saucepan":
            r, h, hl = u(rng, 0.07, 0.1), u(rng, 0.07, 0.12), u(rng, 0.15, 0.2)
            hw, mass = u(rng, 0.022, 0.032), u(rng, 0.6, 1.3, 3)
        else:
            r, h, hl = u(rng, 0.09, 0.12), u(rng, 0.08, 0.13), u(rng, 0.04, 0.06)
            hw, mass = u(rng, 0.02, 0.03), u(rng, 1.2, 2.5, 3)
        return cls.Params(
            style=style,
            radius=r,
            height=h,
            wall=u(rng, 0.003, 0.005),
            handle_length=hl,
            handle_width=hw,
            handle_thickness=u(rng, 0.01, 0.016),
            lid=int(rng.random() < 0.4),
            mass=mass,
            friction=u(rng, 0.4, 0.6, 3),
            body_rgba=jitter(rng, colour, 0.04),
            handle_rgba=jitter(rng, handle, 0.03),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        # Origin at the centre of the footprint: the saucepan body sits off-centre so that
        # body + handle are centred (layouts treat the size as centred on the origin).
        cx = -p.handle_length / 2 if p.style == "saucepan" else 0.0
        n = cls.SEGMENTS
        seg = 2 * p.radius * math.tan(math.pi / n) + 0.001
        bottom = 0.006
        shapes = [Shape(Cylinder(p.radius, bottom), (cx, 0.0, bottom / 2), material="body")]
        for k in range(n):
            a = 2 * math.pi * k / n
            rr = p.radius - p.wall / 2
            shapes.append(
                Shape(
                    Box((p.wall, seg, p.height - bottom)),
                    (
                        round(cx + rr * math.cos(a), 6),
                        round(rr * math.sin(a), 6),
                        (p.height + bottom) / 2,
                    ),
                    (0.0, 0.0, round(a, 6)),
                    material="body",
                )
            )
        zh = p.height - p.handle_thickness / 2 - 0.008
        ends = [1.0] if p.style == "saucepan" else [1.0, -1.0]
        grasps = []
        for sgn in ends:
            x0 = cx + sgn * p.radius
            xc = x0 + sgn * p.handle_length / 2
            shapes.append(
                Shape(
                    Box((p.handle_length, p.handle_width, p.handle_thickness)),
                    (round(xc, 6), 0.0, round(zh, 6)),
                    material="handle",
                )
            )
            # grasp the handle from above, 2/3 out for the saucepan, middle for side handles
            xg = x0 + sgn * p.handle_length * (0.66 if p.style == "saucepan" else 0.5)
            grasps.append(
                GraspFrame(
                    BODY,
                    (round(xg, 6), 0.0, round(zh + p.handle_thickness / 2, 6)),
                    (0.0, 0.0, 1.0),
                    (0.0, 1.0, 0.0),
                    p.handle_width,
                    f"handle{'+' if sgn > 0 else '-'}x",
                )
            )
        if not p.lid:
            # The rim, from above, fingers straddling the wall 2 cm down: the pads press
            # on the wall over their whole height and hold the pot level (held by a
            # handle, it turns about the fingers' axis and tilts).
            rr, zr = p.radius - p.wall / 2, round(p.height - 0.02, 6)
            for k in range(4):
                a = k * math.pi / 2
                if abs(math.cos(a)) > 0.5 and (p.style == "casserole" or math.cos(a) > 0):
                    continue  # a handle is attached there
                grasps.insert(
                    0,
                    GraspFrame(
                        BODY,
                        (round(cx + rr * math.cos(a), 6), round(rr * math.sin(a), 6), zr),
                        (0.0, 0.0, 1.0),
                        (round(math.cos(a), 6), round(math.sin(a), 6), 0.0),
                        p.wall,
                        f"rim{k * 90}",
                    ),
                )
        if p.lid:
            shapes.append(
                Shape(Cylinder(p.radius, 0.005), (cx, 0.0, p.height + 0.0025), material="body")
            )
            shapes.append(
                Shape(Cylinder(0.014, 0.022), (cx, 0.0, p.height + 0.016), material="handle")
            )
        link = Link(BODY, tuple(shapes), p.mass, Contact(p.friction, 0.001, 0.002))
        mats = {"body": p.body_rgba, "handle": p.handle_rgba}
        return finish(cls.name, [link], [], mats, grasps=tuple(grasps))


# ----------------------------------------------------------------------------- fruit

FRUIT_COLOURS = {
    "apple": ((0.75, 0.1, 0.1), (0.55, 0.75, 0.2), (0.85, 0.7, 0.2)),
    "orange": ((0.95, 0.55, 0.1),),
    "lemon": ((0.95, 0.88, 0.2),),
    "peach": ((0.95, 0.6, 0.4),),
    "pear": ((0.7, 0.75, 0.25), (0.75, 0.6, 0.3)),
}
FRUIT_RADIUS = {  # m: diameters stay <= MAX_GRASP_WIDTH
    "apple": (0.033, 0.0375),
    "orange": (0.032, 0.0375),
    "lemon": (0.026, 0.032),
    "peach": (0.03, 0.037),
    "pear": (0.03, 0.036),
}
FRUIT_DENSITY = {"apple": 800.0, "orange": 900.0, "lemon": 950.0, "peach": 950.0, "pear": 900.0}


@register_category
class Fruit(ProceduralCategory):
    name = "fruit"
    kind = "rigid"

    @dataclass(frozen=True)
    class Params:
        fruit: str  # apple | orange | lemon | peach | pear
        radius: float
        elongation: float  # lemon: tips pushed out along x; pear: upper lobe raised
        friction: float
        rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        fruit = pick(rng, tuple(FRUIT_RADIUS))
        lo, hi = FRUIT_RADIUS[fruit]
        elong = u(rng, 0.015, 0.03) if fruit in ("lemon", "pear") else 0.0
        return cls.Params(
            fruit=fruit,
            radius=u(rng, lo, hi),
            elongation=elong,
            friction=u(rng, 0.6, 0.9, 3),
            rgba=jitter(
                rng, FRUIT_COLOURS[fruit][int(rng.integers(len(FRUIT_COLOURS[fruit])))], 0.06
            ),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        r = p.radius
        zc = r
        shapes = [Shape(Sphere(r), (0.0, 0.0, zc), material="body")]
        top = zc + r
        if p.fruit == "lemon":  # lies on its side: two tips along x
            tip = 0.55 * r
            for s in (-1.0, 1.0):
                shapes.append(
                    Shape(
                        Sphere(tip),
                        (s * (r - tip + p.elongation), 0.0, zc - (r - tip) * 0.3),
                        material="body",
                    )
                )
        elif p.fruit == "pear":  # a smaller sphere on top
            r2 = 0.68 * r
            z2 = zc + r * 0.55 + p.elongation
            shapes.append(Shape(Sphere(r2), (0.0, 0.0, z2), material="body"))
            top = z2 + r2
        stem = Shape(
            Cylinder(0.0025, 0.015), (0.0, 0.0, top + 0.004), material="stem", collision=False
        )
        if p.fruit in ("apple", "pear"):
            shapes.append(stem)
        shapes.append(flat_base(r))
        volume = 4 / 3 * math.pi * r**3
        if p.fruit == "pear":
            volume *= 1.3
        mass = round(FRUIT_DENSITY[p.fruit] * volume, 4)
        link = Link(BODY, tuple(shapes), mass, Contact(p.friction, 0.002, 0.002))
        top_width = 2 * 0.68 * r if p.fruit == "pear" else 2 * r
        grasps = (*side_grasps(zc, r), top_grasp(top, top_width))
        mats = {"body": p.rgba, "stem": (0.3, 0.2, 0.1, 1.0)}
        return finish(cls.name, [link], [], mats, grasps=grasps)


# ----------------------------------------------------------------------------- medicine


@register_category
class MedicineBottle(ProceduralCategory):
    name = "medicine_bottle"
    kind = "rigid"

    @dataclass(frozen=True)
    class Params:
        style: str  # round | square (a square tablet bottle)
        radius: float  # half width for square bottles
        height: float
        cap_height: float
        mass: float
        friction: float
        body_rgba: RGBA
        cap_rgba: RGBA
        label_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        body = pick(rng, ("amber", "white", "brown", "blue"))
        colour = {
            "amber": (0.8, 0.45, 0.1),
            "white": (0.95, 0.95, 0.93),
            "brown": (0.35, 0.2, 0.1),
            "blue": (0.2, 0.35, 0.7),
        }[body]
        cap = pick(rng, ("white", "black", "blue", "red"))
        cap_c = {
            "white": (0.97, 0.97, 0.97),
            "black": (0.08, 0.08, 0.08),
            "blue": (0.1, 0.3, 0.8),
            "red": (0.8, 0.1, 0.1),
        }[cap]
        r, h = u(rng, 0.016, 0.027), u(rng, 0.05, 0.1)
        fill = u(rng, 0.3, 0.9, 3)  # tablets/syrup fill fraction
        mass = round(0.02 + fill * 1100.0 * math.pi * r * r * h * 0.7, 4)
        return cls.Params(
            style="square" if rng.random() < 0.3 else "round",
            radius=r,
            height=h,
            cap_height=u(rng, 0.014, 0.024),
            mass=mass,
            friction=u(rng, 0.5, 0.8, 3),
            body_rgba=jitter(rng, colour, 0.05),
            cap_rgba=jitter(rng, cap_c, 0.03),
            label_rgba=jitter(rng, (0.95, 0.95, 0.9), 0.05),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        top = p.height + p.cap_height
        if p.style == "square":
            cap_r = p.radius * 0.8
            w = 2 * p.radius
            shapes: tuple[Shape, ...] = (
                Shape(Box((w, w, p.height)), (0.0, 0.0, p.height / 2), material="body"),
                Shape(
                    Box((0.0012 + w, w * 0.9, p.height * 0.6)),
                    (0.0, 0.0, p.height * 0.45),
                    material="label",
                    collision=False,
                ),
            )
        else:
            cap_r = p.radius + 0.0015
            shapes = (
                Shape(Cylinder(p.radius, p.height), (0.0, 0.0, p.height / 2), material="body"),
                Shape(
                    Cylinder(p.radius + 0.0006, p.height * 0.6),
                    (0.0, 0.0, p.height * 0.45),
                    material="label",
                    collision=False,
                ),
            )
        shapes += (
            Shape(
                Cylinder(cap_r, p.cap_height),
                (0.0, 0.0, p.height + p.cap_height / 2),
                material="cap",
            ),
        )
        link = Link(BODY, shapes, p.mass, Contact(p.friction, 0.0005, 0.001))
        grasps = (*side_grasps(p.height * 0.5, p.radius), top_grasp(top, 2 * cap_r))
        mats = {"body": p.body_rgba, "cap": p.cap_rgba, "label": p.label_rgba}
        return finish(cls.name, [link], [], mats, grasps=grasps)


# ----------------------------------------------------------------------------- vegetable

VEG_COLOURS = {
    "tomato": ((0.85, 0.12, 0.08),),
    "bell_pepper": ((0.85, 0.1, 0.05), (0.95, 0.75, 0.1), (0.2, 0.6, 0.15)),
    "carrot": ((0.95, 0.5, 0.1),),
    "cucumber": ((0.15, 0.4, 0.12),),
    "potato": ((0.72, 0.58, 0.38),),
    "eggplant": ((0.28, 0.12, 0.3),),
}


@register_category
class Vegetable(ProceduralCategory):
    """Round (tomato, bell pepper, potato) or long (carrot, cucumber, eggplant, lying along x)."""

    name = "vegetable"
    kind = "rigid"

    @dataclass(frozen=True)
    class Params:
        vegetable: str
        radius: float  # largest cross-section radius
        length: float  # along x for long vegetables, height for the pepper
        friction: float
        density: float
        rgba: RGBA

    RANGES: ClassVar[dict[str, tuple[tuple[float, float], tuple[float, float]]]] = {
        # (radius, length) in m
        "tomato": ((0.025, 0.036), (0.0, 0.0)),
        "bell_pepper": ((0.033, 0.0375), (0.07, 0.1)),
        "carrot": ((0.012, 0.019), (0.14, 0.2)),
        "cucumber": ((0.018, 0.025), (0.17, 0.24)),
        "potato": ((0.024, 0.032), (0.07, 0.11)),
        "eggplant": ((0.03, 0.0375), (0.16, 0.22)),
    }
    DENSITY: ClassVar[dict[str, float]] = {  # kg/m^3
        "tomato": 950.0,
        "bell_pepper": 450.0,
        "carrot": 1030.0,
        "cucumber": 960.0,
        "potato": 1080.0,
        "eggplant": 500.0,
    }

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        veg = pick(rng, tuple(cls.RANGES))
        (r0, r1), (l0, l1) = cls.RANGES[veg]
        colours = VEG_COLOURS[veg]
        return cls.Params(
            vegetable=veg,
            radius=u(rng, r0, r1),
            length=u(rng, l0, l1) if l1 > 0 else 0.0,
            friction=u(rng, 0.6, 0.9, 3),
            density=round(cls.DENSITY[veg] * float(rng.uniform(0.95, 1.05)), 1),
            rgba=jitter(rng, colours[int(rng.integers(len(colours)))], 0.05),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        r, v = p.radius, p.vegetable
        grasps: tuple[GraspFrame, ...]
        if v == "tomato":
            shapes = [Shape(Sphere(r), (0.0, 0.0, r), material="body"), flat_base(r)]
            grasps = (*side_grasps(r, r), top_grasp(2 * r, 2 * r))
        elif v == "bell_pepper":
            shapes = [
                Shape(Cylinder(r, p.length), (0.0, 0.0, p.length / 2), material="body"),
                Shape(
                    Cylinder(0.004, 0.02),
                    (0.0, 0.0, p.length + 0.01),
                    material="stem",
                    collision=False,
                ),
            ]
            grasps = (*side_grasps(p.length / 2, r), top_grasp(p.length, 2 * r))
        elif v == "potato":
            # two overlapping flattened lobes lying along x
            half = p.length / 2 - r
            shapes = [Shape(Sphere(r), (s * half, 0.0, r), material="body") for s in (-1.0, 1.0)]
            # a flat-bottomed middle so it rests on a patch, not on two points
            shapes.append(
                Shape(Box((2 * half, 1.5 * r, 1.6 * r)), (0.0, 0.0, 0.8 * r), material="body")
            )
            grasps = (
                top_grasp(2 * r, 2 * r, (0.0, 1.0, 0.0)),
                *[g for g in side_grasps(r, r) if g.name.endswith("y")],
            )
        else:
            # long vegetables lie along x; every segment touches the support so none tips
            if v == "carrot":
                segs = [(r, 0.4), (0.8 * r, 0.35), (0.55 * r, 0.25)]
            else:
                segs = [(r, 1.0)]
            x = -p.length / 2
            shapes = []
            for rr, frac in segs:
                ln = p.length * frac
                shapes.append(
                    Shape(
                        Cylinder(rr, ln), (round(x + ln / 2, 6), 0.0, rr), ALONG_X, material="body"
                    )
                )
                x += ln
            if v in ("cucumber", "eggplant"):  # rounded ends (visual only: no extra length)
                for s in (-1.0, 1.0):
                    shapes.append(
                        Shape(
                            Sphere(r * 0.98),
                            (s * p.length / 2 * 0.97, 0.0, r),
                            material="body",
                            collision=False,
                        )
                    )
            shapes.append(
                Shape(
                    Cylinder(0.004 if v != "carrot" else 0.006, 0.025),
                    (-p.length / 2 - 0.01, 0.0, segs[0][0]),
                    ALONG_X,
                    material="stem",
                    collision=False,
                )
            )
            # grasp across the thick part from above, or from the side
            xg = -p.length / 2 + p.length * segs[0][1] / 2
            grasps = (
                top_grasp(2 * r, 2 * r, (0.0, 1.0, 0.0), x=xg),
                GraspFrame(
                    BODY,
                    (round(xg, 6), round(r, 6), round(r, 6)),
                    (0.0, 1.0, 0.0),
                    (0.0, 0.0, 1.0),
                    round(2 * r, 6),
                    "side+y",
                ),
                GraspFrame(
                    BODY,
                    (round(xg, 6), round(-r, 6), round(r, 6)),
                    (0.0, -1.0, 0.0),
                    (0.0, 0.0, 1.0),
                    round(2 * r, 6),
                    "side-y",
                ),
            )
        shapes_t = tuple(
            Shape(s.geometry, s.xyz, s.rpy, s.material, s.collision, s.visual, p.density)
            for s in shapes
        )
        mass = round(density_mass(shapes_t), 4)
        link = Link(BODY, shapes_t, mass, Contact(p.friction, 0.002, 0.002))
        stem_c = (0.3, 0.6, 0.2, 1.0) if v == "carrot" else (0.25, 0.45, 0.15, 1.0)
        mats = {"body": p.rgba, "stem": stem_c}
        return finish(cls.name, [link], [], mats, grasps=grasps)
