"""Floor obstacles placed in front of the targets: chair, trolley, bin, table, cart.

Each is one rigid link (a free body that stands on the floor) with realistic dimensions and
mass, origin at the centre of its footprint on the floor, +x its front where it has one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momakitchen.assets.common import ProceduralCategory, box_at, finish, jitter, pick, u
from momakitchen.assets.registry import AssetModel, Envelope, register_category
from momakitchen.assets.urdf import (
    ALONG_Y,
    RGBA,
    Contact,
    Cylinder,
    Link,
    Shape,
    Sphere,
    volume,
)

BODY = "body"
WOODS = ((0.72, 0.56, 0.38), (0.45, 0.30, 0.20), (0.85, 0.75, 0.58), (0.25, 0.18, 0.12))
PAINTS = (
    (0.95, 0.95, 0.93),
    (0.12, 0.12, 0.13),
    (0.55, 0.63, 0.55),
    (0.8, 0.3, 0.2),
    (0.25, 0.35, 0.55),
)
METALS = ((0.75, 0.76, 0.78), (0.15, 0.15, 0.16), (0.6, 0.6, 0.58))
PLASTICS = (
    (0.2, 0.25, 0.3),
    (0.85, 0.85, 0.85),
    (0.15, 0.35, 0.6),
    (0.2, 0.5, 0.25),
    (0.6, 0.15, 0.15),
)
FLOOR_CONTACT = Contact(0.7, 0.0, 0.0)


def _colour(rng: np.random.Generator, palette: tuple[tuple[float, ...], ...]) -> RGBA:
    return jitter(rng, palette[int(rng.integers(len(palette)))], 0.04)


def _legs(x: float, y: float, h: float, t: float, mat: str, round_legs: bool) -> list[Shape]:
    """Four legs with outer faces at x = +-x, y = +-y, from the floor to height h."""
    out = []
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            cx, cy = sx * (x - t / 2), sy * (y - t / 2)
            if round_legs:
                out.append(Shape(Cylinder(t / 2, h), (cx, cy, h / 2), material=mat))
            else:
                out.append(box_at((cx - t / 2, cy - t / 2, 0.0), (cx + t / 2, cy + t / 2, h), mat))
    return out


# ----------------------------------------------------------------------------- chair


@register_category
class Chair(ProceduralCategory):
    """Kitchen chair (four legs, seat, backrest on the -x side; the front faces +x) or a high
    kitchen stool (no backrest, foot rails)."""

    name = "chair"
    kind = "obstacle"

    @dataclass(frozen=True)
    class Params:
        style: str  # chair | stool
        seat_width: float
        seat_depth: float
        seat_height: float
        seat_thickness: float
        leg: float
        back_height: float
        round_legs: int
        mass: float
        frame_rgba: RGBA
        seat_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        wood = rng.random() < 0.6
        frame = _colour(rng, WOODS if wood else METALS)
        seat = frame if rng.random() < 0.5 else _colour(rng, PAINTS)
        if rng.random() < 0.3:
            return cls.Params(
                style="stool",
                seat_width=u(rng, 0.34, 0.42),
                seat_depth=u(rng, 0.34, 0.42),
                seat_height=u(rng, 0.62, 0.76),
                seat_thickness=u(rng, 0.025, 0.045),
                leg=u(rng, 0.025, 0.035),
                back_height=0.0,
                round_legs=int(rng.random() < 0.5),
                mass=u(rng, 3.0, 6.0, 3),
                frame_rgba=frame,
                seat_rgba=seat,
            )
        return cls.Params(
            style="chair",
            seat_width=u(rng, 0.4, 0.5),
            seat_depth=u(rng, 0.4, 0.48),
            seat_height=u(rng, 0.43, 0.48),
            seat_thickness=u(rng, 0.025, 0.045),
            leg=u(rng, 0.025, 0.04),
            back_height=u(rng, 0.35, 0.5),
            round_legs=int(rng.random() < 0.4),
            mass=u(rng, 3.5, 7.5, 3),
            frame_rgba=frame,
            seat_rgba=seat,
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        hx, hy = p.seat_depth / 2, p.seat_width / 2
        z0 = p.seat_height - p.seat_thickness
        shapes = _legs(hx, hy, z0, p.leg, "frame", bool(p.round_legs))
        shapes.append(box_at((-hx, -hy, z0), (hx, hy, p.seat_height), "seat"))
        if p.style == "stool":
            # foot rails between the legs, a third of the way up
            zr, t = p.seat_height * 0.33, p.leg * 0.6
            for s in (-1.0, 1.0):
                shapes.append(
                    box_at(
                        (-hx + p.leg, s * (hy - p.leg / 2) - t / 2, zr - t / 2),
                        (hx - p.leg, s * (hy - p.leg / 2) + t / 2, zr + t / 2),
                        "frame",
                    )
                )
                shapes.append(
                    box_at(
                        (s * (hx - p.leg / 2) - t / 2, -hy + p.leg, zr - t / 2),
                        (s * (hx - p.leg / 2) + t / 2, hy - p.leg, zr + t / 2),
                        "frame",
                    )
                )
            link = Link(BODY, tuple(shapes), p.mass, FLOOR_CONTACT)
            return finish(cls.name, [link], [], {"frame": p.frame_rgba, "seat": p.seat_rgba})
        top = p.seat_height + p.back_height
        # back posts continue the rear legs; a backrest board near the top
        for sy in (-1.0, 1.0):
            cy = sy * (hy - p.leg / 2)
            shapes.append(
                box_at(
                    (-hx, cy - p.leg / 2, p.seat_height),
                    (-hx + p.leg, cy + p.leg / 2, top),
                    "frame",
                )
            )
        shapes.append(
            box_at(
                (-hx, -hy + p.leg, top - min(0.15, p.back_height * 0.4)),
                (-hx + 0.02, hy - p.leg, top),
                "seat",
            )
        )
        link = Link(BODY, tuple(shapes), p.mass, FLOOR_CONTACT)
        return finish(cls.name, [link], [], {"frame": p.frame_rgba, "seat": p.seat_rgba})


# ----------------------------------------------------------------------------- table


@register_category
class Table(ProceduralCategory):
    """Kitchen table: rectangular with four legs, or round on a pedestal."""

    name = "table"
    kind = "obstacle"

    @dataclass(frozen=True)
    class Params:
        style: str  # rect | round
        length: float  # along x (diameter for round)
        width: float  # along y
        height: float
        top_thickness: float
        leg: float
        inset: float
        density: float  # kg/m^3 of the top and legs
        top_rgba: RGBA
        leg_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        style = "round" if rng.random() < 0.3 else "rect"
        top = _colour(rng, WOODS + PAINTS[:2])
        legs = top if rng.random() < 0.5 else _colour(rng, METALS)
        if style == "round":
            d = u(rng, 0.7, 1.0)
            length, width = d, d
        else:
            length, width = u(rng, 0.8, 1.4), u(rng, 0.6, 0.9)
        return cls.Params(
            style=style,
            length=length,
            width=width,
            height=u(rng, 0.72, 0.77),
            top_thickness=u(rng, 0.025, 0.04),
            leg=u(rng, 0.04, 0.06),
            inset=u(rng, 0.03, 0.08),
            density=u(rng, 550.0, 750.0, 1),
            top_rgba=top,
            leg_rgba=legs,
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        z0 = p.height - p.top_thickness
        if p.style == "round":
            r = p.length / 2
            shapes = [
                Shape(
                    Cylinder(r, p.top_thickness),
                    (0.0, 0.0, z0 + p.top_thickness / 2),
                    material="top",
                ),
                Shape(
                    Cylinder(p.leg * 0.8, z0 - 0.03),
                    (0.0, 0.0, 0.03 + (z0 - 0.03) / 2),
                    material="leg",
                ),
                # a heavy foot disc keeps the pedestal table from tipping
                Shape(Cylinder(r * 0.55, 0.03), (0.0, 0.0, 0.015), material="leg", density=4.0),
            ]
        else:
            hx, hy = p.length / 2, p.width / 2
            shapes = [box_at((-hx, -hy, z0), (hx, hy, p.height), "top")]
            shapes += _legs(hx - p.inset, hy - p.inset, z0, p.leg, "leg", False)
        mass = round(sum(volume(s.geometry) * s.density for s in shapes) * p.density, 3)
        link = Link(BODY, tuple(shapes), mass, FLOOR_CONTACT)
        return finish(cls.name, [link], [], {"top": p.top_rgba, "leg": p.leg_rgba})


# ----------------------------------------------------------------------------- bin


@register_category
class Bin(ProceduralCategory):
    """Kitchen waste bin: round or rectangular body with a lid."""

    name = "bin"
    kind = "obstacle"

    @dataclass(frozen=True)
    class Params:
        style: str  # round | square
        width: float  # diameter for round bins
        depth: float
        height: float
        lid_height: float
        mass: float
        body_rgba: RGBA
        lid_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        style = pick(rng, ("round", "square"))
        metal = rng.random() < 0.5
        body = _colour(rng, METALS if metal else PLASTICS)
        lid = body if rng.random() < 0.6 else _colour(rng, METALS)
        w = u(rng, 0.26, 0.4)
        d = w if style == "round" else u(rng, 0.25, 0.35)
        h = u(rng, 0.4, 0.72)
        return cls.Params(
            style=style,
            width=w,
            depth=d,
            height=h,
            lid_height=u(rng, 0.02, 0.05),
            mass=u(rng, 2.5, 6.0, 3) if metal else u(rng, 1.5, 3.5, 3),
            body_rgba=body,
            lid_rgba=lid,
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        zb = p.height - p.lid_height
        if p.style == "round":
            r = p.width / 2
            shapes = (
                Shape(Cylinder(r * 0.97, zb), (0.0, 0.0, zb / 2), material="body"),
                Shape(Cylinder(r, p.lid_height), (0.0, 0.0, zb + p.lid_height / 2), material="lid"),
            )
        else:
            hx, hy = p.width / 2, p.depth / 2
            shapes = (
                box_at((-hx * 0.97, -hy * 0.97, 0.0), (hx * 0.97, hy * 0.97, zb), "body"),
                box_at((-hx, -hy, zb), (hx, hy, p.height), "lid"),
            )
        link = Link(BODY, shapes, p.mass, FLOOR_CONTACT)
        return finish(cls.name, [link], [], {"body": p.body_rgba, "lid": p.lid_rgba})


# ----------------------------------------------------------------------------- trolley


@register_category
class Trolley(ProceduralCategory):
    """Kitchen service trolley: 2-3 shelves on four posts, castors, push bar at -x."""

    name = "trolley"
    kind = "obstacle"

    @dataclass(frozen=True)
    class Params:
        length: float
        width: float
        height: float
        shelves: int
        post: float
        wheel_radius: float
        mass: float
        frame_rgba: RGBA
        shelf_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        frame = _colour(rng, METALS)
        return cls.Params(
            length=u(rng, 0.5, 0.8),
            width=u(rng, 0.36, 0.5),
            height=u(rng, 0.75, 0.92),
            shelves=int(rng.integers(2, 4)),
            post=u(rng, 0.02, 0.03),
            wheel_radius=u(rng, 0.03, 0.05),
            mass=u(rng, 7.0, 16.0, 3),
            frame_rgba=frame,
            shelf_rgba=_colour(rng, WOODS + PLASTICS + METALS),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        wr = p.wheel_radius
        hx, hy = p.length / 2, p.width / 2
        z0 = 2 * wr  # castors carry the frame
        shapes: list[Shape] = []
        for sx in (-1.0, 1.0):
            for sy in (-1.0, 1.0):
                cx, cy = sx * (hx - p.post / 2), sy * (hy - p.post / 2)
                shapes.append(Shape(Sphere(wr), (cx, cy, wr), material="wheel"))
                shapes.append(
                    box_at(
                        (cx - p.post / 2, cy - p.post / 2, z0),
                        (cx + p.post / 2, cy + p.post / 2, p.height - 0.05),
                        "frame",
                    )
                )
        top_shelf = p.height - 0.05
        for k in range(p.shelves):
            z = z0 + 0.06 + (top_shelf - z0 - 0.06) * k / (p.shelves - 1)
            shapes.append(
                box_at(
                    (-hx + p.post, -hy + p.post, z - 0.02), (hx - p.post, hy - p.post, z), "shelf"
                )
            )
        # push bar on two uprights at the -x end
        for sy in (-1.0, 1.0):
            cy = sy * (hy - p.post / 2)
            shapes.append(
                box_at(
                    (-hx, cy - p.post / 2, p.height - 0.05),
                    (-hx + p.post, cy + p.post / 2, p.height - 0.015),
                    "frame",
                )
            )
        shapes.append(
            Shape(
                Cylinder(0.015, p.width),
                (-hx + p.post / 2, 0.0, p.height - 0.015),
                ALONG_Y,
                material="frame",
            )
        )
        link = Link(BODY, tuple(shapes), p.mass, FLOOR_CONTACT)
        mats = {"frame": p.frame_rgba, "shelf": p.shelf_rgba, "wheel": (0.1, 0.1, 0.1, 1.0)}
        return finish(cls.name, [link], [], mats)


# ----------------------------------------------------------------------------- cart


@register_category
class Cart(ProceduralCategory):
    """Platform hand cart (low deck, U-shaped push handle at -x) or a two-tier utility cart
    (trays with raised lips on four posts, push handle at -x), both on four wheels."""

    name = "cart"
    kind = "obstacle"

    @dataclass(frozen=True)
    class Params:
        style: str  # platform | utility
        length: float
        width: float
        deck_height: float
        handle_height: float
        wheel_radius: float
        mass: float
        deck_rgba: RGBA
        handle_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        utility = rng.random() < 0.4
        return cls.Params(
            style="utility" if utility else "platform",
            length=u(rng, 0.7, 1.0) if not utility else u(rng, 0.75, 1.05),
            width=u(rng, 0.45, 0.62),
            deck_height=u(rng, 0.16, 0.25),
            handle_height=u(rng, 0.85, 1.0),
            wheel_radius=u(rng, 0.05, 0.075),
            mass=u(rng, 9.0, 22.0, 3),
            deck_rgba=_colour(rng, PLASTICS + METALS),
            handle_rgba=_colour(rng, METALS),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        wr = p.wheel_radius
        hx, hy = p.length / 2, p.width / 2
        wt = 0.035  # wheel width
        shapes: list[Shape] = []
        for sx in (-1.0, 1.0):
            for sy in (-1.0, 1.0):
                # wheels lie along y inside the footprint; they touch the floor along a line
                shapes.append(
                    Shape(
                        Cylinder(wr, wt),
                        (sx * (hx - wr - 0.02), sy * (hy - wt / 2), wr),
                        ALONG_Y,
                        material="wheel",
                    )
                )
        deck_lo = min(2 * wr + 0.005, p.deck_height - 0.04)
        shapes.append(box_at((-hx, -hy + wt, deck_lo), (hx, hy - wt, p.deck_height), "deck"))
        tube = 0.0125
        for sy in (-1.0, 1.0):
            cy = sy * (hy - wt - tube)
            shapes.append(
                Shape(
                    Cylinder(tube, p.handle_height - p.deck_height),
                    (-hx + tube, cy, (p.handle_height + p.deck_height) / 2),
                    material="handle",
                )
            )
        shapes.append(
            Shape(
                Cylinder(tube, p.width - 2 * wt),
                (-hx + tube, 0.0, p.handle_height - tube),
                ALONG_Y,
                material="handle",
            )
        )
        if p.style == "utility":
            # a second tray below the handle height, on four posts; lips around both trays
            z_top = p.handle_height - 0.12
            x0, x1, y0, y1 = -hx + 2 * tube, hx, -hy + wt, hy - wt
            shapes.append(box_at((x0, y0, z_top - 0.03), (x1, y1, z_top), "deck"))
            for sx in (x0, x1 - 0.025):
                for sy in (y0, y1 - 0.025):
                    shapes.append(
                        box_at(
                            (sx, sy, p.deck_height),
                            (sx + 0.025, sy + 0.025, z_top - 0.03),
                            "handle",
                        )
                    )
            for z in (p.deck_height, z_top):
                shapes.append(box_at((x1 - 0.015, y0, z), (x1, y1, z + 0.04), "deck"))
                shapes.append(box_at((x0, y0, z), (x1, y0 + 0.015, z + 0.04), "deck"))
                shapes.append(box_at((x0, y1 - 0.015, z), (x1, y1, z + 0.04), "deck"))
        link = Link(BODY, tuple(shapes), p.mass, FLOOR_CONTACT)
        mats = {"deck": p.deck_rgba, "handle": p.handle_rgba, "wheel": (0.08, 0.08, 0.08, 1.0)}
        return finish(cls.name, [link], [], mats)
