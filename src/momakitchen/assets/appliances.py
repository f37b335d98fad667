"""Kitchen appliances: dishwasher and oven counters (pull-down doors under the countertop),
the fridge (tall unit, side-hinged door) and the microwave (stands on the countertop)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from momakitchen.assets import counter as C
from momakitchen.assets.common import (
    APPLIANCE_COLOURS,
    GLASS,
    HANDLE_COLOURS,
    STEEL_SHEET,
    ProceduralCategory,
    box_at,
    check_envelope,
    finish,
    palette_colour,
    pick,
    u,
)
from momakitchen.assets.registry import (
    Articulation,
    AssetModel,
    Envelope,
    register_category,
)
from momakitchen.assets.urdf import ALONG_Y, RGBA, Cylinder, Joint, Link, Shape, density_mass

BASE = "carcass"
BAR_HANDLES = ("bar_h", "flat_h")


def _knobs(x0: float, x1: float, y: float, z: float, n: int, r: float = 0.018) -> list[Shape]:
    """Control knobs on a panel (visual only: they must not change the collision size)."""
    return [
        Shape(
            Cylinder(r, 0.02),
            (x0 + (x1 - x0) * (k + 0.5) / n, y + 0.01, z),
            ALONG_Y,
            material="handle",
            collision=False,
        )
        for k in range(n)
    ]


# ----------------------------------------------------------------------------- dishwasher


@register_category
class Dishwasher(ProceduralCategory):
    """Built-in dishwasher under the countertop: pull-down door hinged at the bottom."""

    name = "dishwasher"
    kind = "furniture"
    width_range: ClassVar[tuple[float, float]] = (0.44, 0.65)
    MIN_ENVELOPE: ClassVar[tuple[float, float, float]] = (0.4, 0.5, 0.75)

    @dataclass(frozen=True)
    class Params(C.CounterParams):
        integrated: int  # 1: door clad like the cabinets, 0: appliance finish
        door_rgba: RGBA
        panel_height: float  # control strip at the top of the door

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        check_envelope(cls.name, envelope, cls.MIN_ENVELOPE)
        base = C.sample_counter(rng, envelope, cls.name, BAR_HANDLES)
        base["front_thickness"] = u(rng, 0.04, 0.06)
        base["handle_length"] = u(rng, 0.25, 0.45)
        integrated = int(rng.random() < 0.3)
        door = base["front_rgba"] if integrated else palette_colour(rng, APPLIANCE_COLOURS)
        return cls.Params(
            **base, integrated=integrated, door_rgba=door, panel_height=u(rng, 0.06, 0.1)
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        g = C.geometry(p)
        shapes = C.carcass_shapes(p, g)
        base = Link(BASE, tuple(shapes), round(density_mass(shapes), 3))
        x0, x1 = -p.width / 2 + C.GAP, p.width / 2 - C.GAP
        z0, z1 = g.z_fronts
        t = p.front_thickness
        dh = z1 - z0
        strip = box_at(
            (-(x1 - x0) / 2 + 0.01, t / 2, dh - p.panel_height),
            ((x1 - x0) / 2 - 0.01, t / 2 + 0.001, dh - 0.01),
            "panel",
            collision=False,
        )
        # hollow door: ~350 kg/m^3 over its volume gives the 5-8 kg of a real one
        link, joint, art = C.flap(
            "door",
            BASE,
            g.y_front,
            x0,
            x1,
            z0,
            z1,
            C.handle_spec(p),
            t,
            material="door",
            density=350.0,
            extra=(strip,),
            handle_length=min(p.handle_length, (x1 - x0) * 0.8),
        )
        mats = {**C.materials(p), "door": p.door_rgba, "panel": (0.15, 0.15, 0.16, 1.0)}
        return finish(
            cls.name,
            [base, link],
            [joint],
            mats,
            articulations=(art,),
            placement_areas=(C.countertop_area(g),),
        )


# ----------------------------------------------------------------------------- oven


@register_category
class Oven(ProceduralCategory):
    """Oven counter: control panel, pull-down oven door with a window, an optional storage
    drawer below, a cooktop on the countertop."""

    name = "oven"
    kind = "furniture"
    width_range: ClassVar[tuple[float, float]] = (0.5, 0.9)
    MIN_ENVELOPE: ClassVar[tuple[float, float, float]] = (0.45, 0.5, 0.82)  # fits a 45 cm oven

    @dataclass(frozen=True)
    class Params(C.CounterParams):
        oven_height: float
        panel_height: float
        drawer: int
        knobs: int
        cooktop: str  # none | glass | steel
        body_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        check_envelope(cls.name, envelope, cls.MIN_ENVELOPE)
        base = C.sample_counter(rng, envelope, cls.name, BAR_HANDLES)
        base["front_thickness"] = u(rng, 0.04, 0.055)
        base["handle_standoff"] = u(rng, 0.03, 0.045)
        base["handle_length"] = u(rng, 0.4, 0.6)
        # the oven sits in the upper part; what is left below becomes a drawer or a kick panel
        span = base["height"] - base["top_thickness"] - base["plinth_height"]
        panel_h = u(rng, 0.07, 0.1)
        oven_h = u(rng, 0.45, min(0.6, span - panel_h - 0.05))
        return cls.Params(
            **base,
            oven_height=oven_h,
            panel_height=panel_h,
            drawer=int(span - panel_h - oven_h > 0.1 and rng.random() < 0.7),
            knobs=int(rng.integers(3, 7)),
            cooktop=pick(rng, ("none", "glass", "glass", "steel")),
            body_rgba=palette_colour(rng, APPLIANCE_COLOURS),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        g = C.geometry(p)
        shapes = C.carcass_shapes(p, g)
        t = p.front_thickness
        x0, x1 = -p.width / 2 + C.GAP, p.width / 2 - C.GAP
        z0, z1 = g.z_fronts
        zp = z1 - p.panel_height  # control panel [zp, z1], oven door below
        shapes.append(box_at((x0, g.y_front, zp), (x1, g.y_front + t, z1), "body"))
        shapes += _knobs(x0 + 0.05, x1 - 0.05, g.y_front + t, (zp + z1) / 2, p.knobs)
        zd = zp - C.GAP - p.oven_height
        if p.cooktop != "none":
            cw, cd = min(0.58, p.width - 0.08), min(0.5, g.y_top - 0.06)
            mat = "glass" if p.cooktop == "glass" else "body"
            shapes.append(
                box_at(
                    (-cw / 2, 0.04, p.height),
                    (cw / 2, 0.04 + cd, p.height + 0.001),
                    mat,
                    collision=False,
                )
            )
            for k in range(4):
                bx = (-1 if k % 2 == 0 else 1) * cw / 4
                by = 0.04 + cd * (0.3 if k < 2 else 0.7)
                shapes.append(
                    Shape(
                        Cylinder(0.07 if k % 3 == 0 else 0.055, 0.0005),
                        (bx, by, p.height + 0.0013),
                        material="burner",
                        collision=False,
                    )
                )
        links: list[Link] = []
        joints: list[Joint] = []
        arts: list[Articulation] = []
        window = box_at(
            (-(x1 - x0) / 2 + 0.07, t / 2, 0.1),
            ((x1 - x0) / 2 - 0.07, t / 2 + 0.001, p.oven_height - 0.11),
            "glass",
            collision=False,
        )
        lk, jt, ar = C.flap(
            "door",
            BASE,
            g.y_front,
            x0,
            x1,
            zd,
            zp - C.GAP,
            C.handle_spec(p),
            t,
            material="body",
            density=450.0,
            extra=(window,),
        )
        links.append(lk)
        joints.append(jt)
        arts.append(ar)
        if p.drawer:
            lk, jt, ar = C.drawer(
                "drawer",
                BASE,
                g.y_front,
                x0,
                x1,
                z0,
                zd - C.GAP,
                C.handle_spec(p),
                t,
                g.y_front - p.panel - 0.02,
                g.x_inner[1] - g.x_inner[0],
                material="body",
                density=450.0,
            )
            links.append(lk)
            joints.append(jt)
            arts.append(ar)
        else:
            shapes.append(box_at((x0, g.y_front, z0), (x1, g.y_front + t, zd - C.GAP), "body"))
        base = Link(BASE, tuple(shapes), round(density_mass(shapes), 3))
        mats = {
            **C.materials(p),
            "body": p.body_rgba,
            "glass": GLASS,
            "burner": (0.35, 0.35, 0.36, 1.0),
        }
        return finish(
            cls.name,
            [base, *links],
            joints,
            mats,
            articulations=tuple(arts),
            placement_areas=(C.countertop_area(g),),
        )


# ----------------------------------------------------------------------------- fridge


@register_category
class Fridge(ProceduralCategory):
    """Tall fridge: insulated shell, side-hinged door with a vertical handle, optionally a
    freezer door or a freezer drawer below. Its top is not a placement area."""

    name = "fridge"
    kind = "furniture"
    width_range: ClassVar[tuple[float, float]] = (0.55, 0.95)

    @dataclass(frozen=True)
    class Params:
        width: float
        depth: float
        height: float
        layout: str  # single | freezer_door | freezer_drawer
        split: float  # fraction of the front height taken by the main door
        hinge: str
        door_thickness: float
        wall: float
        plinth_height: float
        handle_type: str  # bar_v | flat_v
        handle_length: float
        handle_thickness: float
        handle_standoff: float
        shelves: int
        body_rgba: RGBA
        handle_rgba: RGBA

    MAX_HEIGHT: ClassVar[float] = 2.05
    MIN_ENVELOPE: ClassVar[tuple[float, float, float]] = (0.5, 0.5, 1.4)

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        env = check_envelope(cls.name, envelope, cls.MIN_ENVELOPE)
        hi = min(env.height, cls.MAX_HEIGHT)
        return cls.Params(
            # the envelope as given (rounding could push a unit past its slot)
            width=float(env.width),
            depth=float(env.depth),
            height=u(rng, max(1.4, hi - 0.25), hi),
            layout=pick(rng, ("single", "freezer_door", "freezer_drawer")),
            split=u(rng, 0.6, 0.72),
            hinge=pick(rng, ("left", "right")),
            door_thickness=u(rng, 0.05, 0.07),
            wall=u(rng, 0.035, 0.05),
            plinth_height=u(rng, 0.03, 0.06),
            handle_type=pick(rng, ("bar_v", "flat_v")),
            handle_length=u(rng, 0.3, 0.6),
            handle_thickness=u(rng, 0.014, 0.022),
            handle_standoff=u(rng, 0.035, 0.05),
            shelves=int(rng.integers(2, 5)),
            body_rgba=palette_colour(rng, APPLIANCE_COLOURS),
            handle_rgba=palette_colour(rng, HANDLE_COLOURS, 0.03),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        hw = p.width / 2
        hdepth = p.handle_standoff + p.handle_thickness
        y_front = p.depth - hdepth - p.door_thickness
        w = p.wall
        H = p.height
        shapes = [
            box_at((-hw, 0.0, 0.0), (-hw + w, y_front, H), "body", STEEL_SHEET * 0.25),
            box_at((hw - w, 0.0, 0.0), (hw, y_front, H), "body", STEEL_SHEET * 0.25),
            box_at((-hw + w, 0.0, 0.0), (hw - w, w, H), "body", STEEL_SHEET * 0.25),
            box_at((-hw + w, w, H - w), (hw - w, y_front, H), "body", STEEL_SHEET * 0.25),
            box_at(
                (-hw + w, w, 0.0),
                (hw - w, y_front, p.plinth_height + w),
                "body",
                STEEL_SHEET * 0.25,
            ),
            # white liner visible when the door is open
            box_at(
                (-hw + w, w, p.plinth_height + w),
                (hw - w, w + 0.002, H - w),
                "liner",
                collision=False,
            ),
        ]
        z0, z1 = p.plinth_height + C.GAP, H - C.GAP
        zs = z1 - (z1 - z0) * p.split if p.layout != "single" else z0
        for k in range(p.shelves):
            z = zs + (z1 - zs) * (k + 1) / (p.shelves + 1)
            shapes.append(
                box_at(
                    (-hw + w, w, z - 0.004), (hw - w, y_front - 0.06, z + 0.004), "shelf", 1000.0
                )
            )
        if p.layout != "single":  # divider between fridge and freezer
            shapes.append(
                box_at(
                    (-hw + w, w, zs - w / 2),
                    (hw - w, y_front, zs + w / 2),
                    "body",
                    STEEL_SHEET * 0.25,
                )
            )
        base = Link(BASE, tuple(shapes), round(density_mass(shapes), 3))
        spec = C.HandleSpec(p.handle_type, p.handle_length, p.handle_thickness, p.handle_standoff)
        x0, x1 = -hw + C.GAP, hw - C.GAP
        links, joints, arts = [], [], []
        # door shelves and insulation: ~220 kg/m^3 over the door volume (7-12 kg)
        lk, jt, ar = C.door(
            "door",
            BASE,
            y_front,
            x0,
            x1,
            zs if p.layout != "single" else z0,
            z1,
            p.hinge,
            spec,
            p.door_thickness,
            handle_at_top=False,
            material="body",
            density=220.0,
            limit=1.9,
        )
        links.append(lk)
        joints.append(jt)
        arts.append(ar)
        if p.layout == "freezer_door":
            short = C.HandleSpec(
                p.handle_type,
                min(p.handle_length, (zs - z0) * 0.5),
                p.handle_thickness,
                p.handle_standoff,
            )
            lk, jt, ar = C.door(
                "freezer_door",
                BASE,
                y_front,
                x0,
                x1,
                z0,
                zs - C.GAP,
                p.hinge,
                short,
                p.door_thickness,
                material="body",
                density=220.0,
                limit=1.9,
            )
            links.append(lk)
            joints.append(jt)
            arts.append(ar)
        elif p.layout == "freezer_drawer":
            lk, jt, ar = C.drawer(
                "freezer_drawer",
                BASE,
                y_front,
                x0,
                x1,
                z0,
                zs - C.GAP,
                spec,
                p.door_thickness,
                y_front - w - 0.03,
                p.width - 2 * w,
                material="body",
                box_material="liner",
                density=220.0,
            )
            links.append(lk)
            joints.append(jt)
            arts.append(ar)
        mats = {
            "body": p.body_rgba,
            "handle": p.handle_rgba,
            "liner": (0.95, 0.95, 0.95, 1.0),
            "shelf": (0.85, 0.9, 0.92, 1.0),
        }
        return finish(cls.name, [base, *links], joints, mats, articulations=tuple(arts))


# ----------------------------------------------------------------------------- microwave


@register_category
class Microwave(ProceduralCategory):
    """Countertop microwave: hollow cavity, door hinged on the left with a handle on its free
    edge, control panel on the right."""

    name = "microwave"
    kind = "appliance"
    MIN_SIZE: ClassVar[tuple[float, float, float]] = (0.36, 0.28, 0.22)
    MIN_ENVELOPE = MIN_SIZE

    @dataclass(frozen=True)
    class Params:
        width: float
        depth: float
        height: float
        panel_fraction: float
        door_thickness: float
        handle_type: str  # bar_v | flat_v | knob-free "pocket" is not modelled
        handle_length: float
        handle_thickness: float
        handle_standoff: float
        mass: float
        body_rgba: RGBA
        door_rgba: RGBA
        handle_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        env = check_envelope(cls.name, envelope, cls.MIN_ENVELOPE)
        w = u(rng, max(cls.MIN_SIZE[0], min(0.42, env.width) - 0.04), min(0.56, env.width))
        d = u(rng, max(cls.MIN_SIZE[1], min(0.33, env.depth) - 0.03), min(0.42, env.depth))
        h = u(rng, max(cls.MIN_SIZE[2], min(0.26, env.height) - 0.03), min(0.33, env.height))
        body = palette_colour(rng, APPLIANCE_COLOURS)
        return cls.Params(
            width=w,
            depth=d,
            height=h,
            panel_fraction=u(rng, 0.2, 0.28),
            door_thickness=u(rng, 0.025, 0.035),
            handle_type=pick(rng, ("bar_v", "flat_v")),
            handle_length=u(rng, 0.12, 0.2),
            handle_thickness=u(rng, 0.012, 0.018),
            handle_standoff=u(rng, 0.015, 0.025),
            # 9-18 kg: shell, magnetron and transformer scale roughly with the volume
            mass=round(float((5.0 + 170.0 * w * d * h) * rng.uniform(0.92, 1.08)), 3),
            body_rgba=body,
            door_rgba=GLASS if rng.random() < 0.7 else body,
            handle_rgba=palette_colour(rng, HANDLE_COLOURS, 0.03),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        hw = p.width / 2
        hdepth = p.handle_standoff + p.handle_thickness
        yf = p.depth - hdepth - p.door_thickness
        s, foot = 0.012, 0.01  # shell thickness, feet height
        H = p.height
        xp = hw - p.width * p.panel_fraction  # door | control panel boundary
        shapes = [
            box_at((-hw, 0.0, foot), (hw, yf, foot + s), "body"),
            box_at((-hw, 0.0, H - s), (hw, yf, H), "body"),
            box_at((-hw, 0.0, foot + s), (-hw + s, yf, H - s), "body"),
            box_at((hw - s, 0.0, foot + s), (hw, yf, H - s), "body"),
            box_at((-hw + s, 0.0, foot + s), (hw - s, s, H - s), "body"),
            box_at((xp, s, foot + s), (xp + s, yf, H - s), "body"),  # cavity wall
            box_at((xp + s, yf - 0.05, foot + s), (hw - s, yf, H - s), "body"),  # panel block
            box_at((xp + s, yf, foot), (hw, yf + p.door_thickness, H), "panel"),  # front panel
            box_at(
                (xp + 0.02, yf + p.door_thickness, H * 0.55),
                (hw - 0.02, yf + p.door_thickness + 0.001, H - 0.03),
                "display",
                collision=False,
            ),
        ]
        for sx in (-1.0, 1.0):
            for sy in (0.05, yf - 0.05):
                shapes.append(
                    Shape(Cylinder(0.012, foot), (sx * (hw - 0.04), sy, foot / 2), material="foot")
                )
        base = Link(BASE, tuple(shapes), round(p.mass * 0.88, 3))
        spec = C.HandleSpec(p.handle_type, p.handle_length, p.handle_thickness, p.handle_standoff)
        window = box_at(
            (0.04, p.door_thickness, 0.04),
            (xp - (-hw) - 0.06, p.door_thickness + 0.001, H - foot - 0.06),
            "window",
            collision=False,
        )
        door, joint, art = C.door(
            "door",
            BASE,
            yf,
            -hw,
            xp - C.GAP,
            foot,
            H,
            "left",
            spec,
            p.door_thickness,
            handle_at_top=False,
            material="door",
            density=600.0,
            extra=(window,),
            limit=1.75,
        )
        mats = {
            "body": p.body_rgba,
            "panel": p.body_rgba,
            "door": p.door_rgba,
            "window": GLASS,
            "display": (0.05, 0.08, 0.06, 1.0),
            "handle": p.handle_rgba,
            "foot": (0.05, 0.05, 0.05, 1.0),
        }
        # its top is not offered as a placement area: targets there would be out of reach
        return finish(cls.name, [base, door], [joint], mats, articulations=(art,))
