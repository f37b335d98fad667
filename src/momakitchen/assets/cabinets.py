"""Counter cabinet (doors and/or drawers) and sink counter (basin + faucet lever)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from momakitchen.assets import counter as C
from momakitchen.assets.common import METAL, ProceduralCategory, box_at, finish, jitter, pick, u
from momakitchen.assets.registry import (
    Articulation,
    AssetModel,
    Envelope,
    GraspFrame,
    Rect,
    register_category,
)
from momakitchen.assets.urdf import ALONG_Y, RGBA, Cylinder, Joint, Link, Shape

BASE = "carcass"


def _fronts(
    p: C.CounterParams,
    g: C.CounterGeometry,
    layout: str,
    columns: int,
    hinge: str,
    drawer_fracs: tuple[float, ...],
) -> tuple[list[Link], list[Joint], list[Articulation]]:
    """Doors and drawers filling the front area (drawer rows from the top, doors below)."""
    links, joints, arts = [], [], []
    x0, x1 = -p.width / 2 + C.GAP, p.width / 2 - C.GAP
    z0, z1 = g.z_fronts
    span = z1 - z0
    z = z1
    rows = drawer_fracs if layout in ("drawers", "drawer_doors") else ()
    for k, frac in enumerate(rows):
        zb = z0 if (layout == "drawers" and k == len(rows) - 1) else z - frac * span
        for c, (a, b) in enumerate(C.split(x0, x1, columns)):
            name = f"drawer_{k}_{c}" if columns > 1 else f"drawer_{k}"
            lk, jt, ar = C.counter_drawer(p, g, name, BASE, a, b, zb, z - C.GAP)
            links.append(lk)
            joints.append(jt)
            arts.append(ar)
        z = zb
    if layout in ("doors", "drawer_doors"):
        cols = C.split(x0, x1, columns)
        for c, (a, b) in enumerate(cols):
            side = hinge if columns == 1 else ("left" if c == 0 else "right")
            lk, jt, ar = C.counter_door(
                p, g, f"door_{c}", BASE, a, b, z0, z - C.GAP if rows else z, side
            )
            links.append(lk)
            joints.append(jt)
            arts.append(ar)
    return links, joints, arts


@register_category
class Cabinet(ProceduralCategory):
    """Counter cabinet: ``doors`` (1-2), ``drawer_doors`` (a drawer row above doors) or
    ``drawers`` (a stack of 2-4), randomised handles, countertop on top."""

    name = "cabinet"
    kind = "furniture"
    width_range: ClassVar[tuple[float, float]] = (0.3, 1.2)
    MIN_ENVELOPE: ClassVar[tuple[float, float, float]] = C.MIN_ENVELOPE

    @dataclass(frozen=True)
    class Params(C.CounterParams):
        layout: str  # doors | drawer_doors | drawers
        columns: int  # doors (or drawers) side by side
        hinge: str  # left | right, for a single door
        drawer_fracs: tuple[float, ...]  # heights of the drawer rows, fraction of front area
        shelf: int

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        base = C.sample_counter(rng, envelope, cls.name)
        layout = pick(rng, ("doors", "drawer_doors", "drawers"))
        w = base["width"]
        if layout == "drawers":
            n = int(rng.integers(2, 5))
            weights = np.sort(rng.uniform(0.6, 1.4, n)) if rng.random() < 0.6 else np.ones(n)
            fracs = tuple(round(float(x), 4) for x in weights / weights.sum())
            columns = 2 if w > 0.95 else 1
        else:
            fracs = (u(rng, 0.15, 0.22),) if layout == "drawer_doors" else ()
            columns = 1 if w < 0.55 else (2 if w > 0.7 else int(rng.integers(1, 3)))
        return cls.Params(
            **base,
            layout=layout,
            columns=columns,
            hinge=pick(rng, ("left", "right")),
            drawer_fracs=fracs,
            shelf=int(layout != "drawers" and rng.random() < 0.7),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        g = C.geometry(p)
        shapes = C.carcass_shapes(p, g, shelf=bool(p.shelf))
        base = Link(BASE, tuple(shapes), round(C.density_mass(shapes), 3))
        links, joints, arts = _fronts(p, g, p.layout, p.columns, p.hinge, p.drawer_fracs)
        return finish(
            cls.name,
            [base, *links],
            joints,
            C.materials(p),
            articulations=tuple(arts),
            placement_areas=(C.countertop_area(g),),
        )


@register_category
class Sink(ProceduralCategory):
    """Sink counter: a basin in the countertop, a faucet behind it whose lever lifts (revolute,
    part ``lever``), doors or a fixed front below."""

    name = "sink"
    kind = "furniture"
    width_range: ClassVar[tuple[float, float]] = (0.55, 1.2)
    MIN_ENVELOPE: ClassVar[tuple[float, float, float]] = (0.5, 0.55, 0.6)

    @dataclass(frozen=True)
    class Params(C.CounterParams):
        front: str  # doors | panel
        columns: int
        hinge: str
        basin_width: float
        basin_depth: float  # along y
        basin_height: float  # how deep the bowl is
        basin_offset: float  # x of the basin centre
        faucet_height: float
        spout_length: float
        lever_length: float
        lever_side: str  # left | right of the faucet column
        basin_rgba: RGBA
        faucet_rgba: RGBA

    @classmethod
    def sample_procedural(
        cls, rng: np.random.Generator, envelope: Envelope | None = None
    ) -> Params:
        C.check_envelope(cls.name, envelope, cls.MIN_ENVELOPE)
        base = C.sample_counter(rng, envelope, cls.name)
        w, d = base["width"], base["depth"]
        # leave at least ~0.1 m of countertop on one side of the basin
        bw = u(rng, min(0.34, w - 0.3), min(0.55, w - 0.3))
        room = max(0.0, (w - bw) / 2 - 0.12)
        steel = rng.random() < 0.7
        basin = (0.78, 0.79, 0.8) if steel else pick_colour(rng)
        return cls.Params(
            **base,
            front=pick(rng, ("doors", "doors", "panel")),
            columns=1 if w < 0.6 else 2,
            hinge=pick(rng, ("left", "right")),
            basin_width=bw,
            basin_depth=u(rng, 0.32, min(0.42, d - 0.22)),
            basin_height=u(rng, 0.15, 0.2),
            basin_offset=u(rng, -room, room),
            faucet_height=u(rng, 0.18, 0.32),
            spout_length=u(rng, 0.14, 0.2),
            lever_length=u(rng, 0.08, 0.12),
            lever_side=pick(rng, ("left", "right")),
            basin_rgba=jitter(rng, basin, 0.03),
            faucet_rgba=jitter(
                rng, (0.8, 0.81, 0.83) if rng.random() < 0.8 else (0.1, 0.1, 0.1), 0.02
            ),
        )

    @classmethod
    def build_procedural(cls, p: Params) -> AssetModel:
        g = C.geometry(p)
        shapes = C.carcass_shapes(p, g, countertop=False)
        hw = p.width / 2
        # basin opening in the countertop, towards the front half
        bx0, bx1 = p.basin_offset - p.basin_width / 2, p.basin_offset + p.basin_width / 2
        by1 = g.y_top - 0.06
        by0 = by1 - p.basin_depth
        shapes += [
            C.countertop_slab(p, g, -hw, bx0, 0.0, g.y_top),
            C.countertop_slab(p, g, bx1, hw, 0.0, g.y_top),
            C.countertop_slab(p, g, bx0, bx1, 0.0, by0),
            C.countertop_slab(p, g, bx0, bx1, by1, g.y_top),
        ]
        # the bowl: bottom and four walls hanging from the countertop, inside the carcass
        t = 0.008
        zb = g.z_carcass - p.basin_height
        steel = 1000.0  # thin steel sheet averaged over the wall volume
        shapes += [
            box_at((bx0, by0, zb), (bx1, by1, zb + t), "basin", steel),
            box_at((bx0, by0, zb), (bx0 + t, by1, g.z_carcass), "basin", steel),
            box_at((bx1 - t, by0, zb), (bx1, by1, g.z_carcass), "basin", steel),
            box_at((bx0, by0, zb), (bx1, by0 + t, g.z_carcass), "basin", steel),
            box_at((bx0, by1 - t, zb), (bx1, by1, g.z_carcass), "basin", steel),
            Shape(
                Cylinder(0.025, 0.004),
                (p.basin_offset, (by0 + by1) / 2, zb + t + 0.002),
                material="faucet",
                collision=False,
            ),  # drain
        ]
        # faucet: column behind the basin, spout over it
        fx, fy = p.basin_offset, max(0.05, by0 - 0.05)
        col_r = 0.02
        H = p.height
        shapes += [
            Shape(Cylinder(0.028, 0.02), (fx, fy, H + 0.01), material="faucet", density=METAL),
            Shape(
                Cylinder(col_r, p.faucet_height),
                (fx, fy, H + p.faucet_height / 2),
                material="faucet",
                density=METAL,
            ),
            Shape(
                Cylinder(0.012, p.spout_length),
                (fx, fy + p.spout_length / 2, H + p.faucet_height - 0.012),
                ALONG_Y,
                material="faucet",
                density=METAL,
            ),
            Shape(
                Cylinder(0.01, 0.03),
                (fx, fy + p.spout_length - 0.01, H + p.faucet_height - 0.035),
                material="faucet",
                density=METAL,
            ),
        ]
        base = Link(BASE, tuple(shapes), round(C.density_mass(shapes), 3))
        links: list[Link] = []
        joints: list[Joint] = []
        arts: list[Articulation] = []
        if p.front == "doors":
            links, joints, arts = _fronts(p, g, "doors", p.columns, p.hinge, ())
        else:
            panel = box_at(
                (-hw + C.GAP, 0.0, 0.0),
                (hw - C.GAP, p.front_thickness, g.z_fronts[1] - g.z_fronts[0]),
                "front",
                C.MDF,
            )
            links = [Link("front_panel", (panel,), round(C.density_mass([panel]), 3))]
            joints = [
                Joint(
                    "front_panel_fixed",
                    "fixed",
                    BASE,
                    "front_panel",
                    (0.0, g.y_front, g.z_fronts[0]),
                )
            ]
        # lever: a bar on the side of the column pointing to the front, lifted to open
        sx = -1.0 if p.lever_side == "left" else 1.0
        lr = 0.007
        lever = Link(
            "lever",
            (
                Shape(
                    Cylinder(0.011, 0.02),
                    (0.0, 0.0, 0.0),
                    (0.0, math.pi / 2, 0.0),
                    material="faucet",
                ),
                Shape(
                    Cylinder(lr, p.lever_length),
                    (sx * 0.004, p.lever_length / 2, 0.0),
                    ALONG_Y,
                    material="faucet",
                ),
            ),
            round(0.02 + 0.5 * p.lever_length, 4),
        )
        pivot = (fx + sx * (col_r + 0.01), fy, H + min(0.07, p.faucet_height * 0.35))
        limit = 0.6
        joints.append(
            Joint(
                "lever_hinge",
                "revolute",
                BASE,
                "lever",
                pivot,
                axis=(1.0, 0.0, 0.0),
                lower=0.0,
                upper=limit,
                effort=5.0,
                velocity=3.0,
                damping=0.002,
                friction=0.01,
            )
        )
        links.append(lever)
        grasp = GraspFrame(
            "lever",
            (sx * 0.004, round(p.lever_length * 0.75, 6), lr),
            (0.0, 0.0, 1.0),
            (1.0, 0.0, 0.0),
            2 * lr,
            "lever",
        )
        arts.append(Articulation("lever_hinge", "revolute", "lever", grasp, 1, limit))
        mats = {**C.materials(p), "basin": p.basin_rgba, "faucet": p.faucet_rgba}
        # free countertop: left and right of the basin, and the strip in front of it
        areas = []
        m = 0.01
        if bx0 - m - (-hw + m) >= 0.08:
            areas.append(Rect(round(-hw + m, 6), round(bx0 - m, 6), m, round(g.y_top - m, 6), H))
        if hw - m - (bx1 + m) >= 0.08:
            areas.append(Rect(round(bx1 + m, 6), round(hw - m, 6), m, round(g.y_top - m, 6), H))
        return finish(
            cls.name,
            [base, *links],
            joints,
            mats,
            articulations=tuple(arts),
            placement_areas=tuple(areas),
        )


def pick_colour(rng: np.random.Generator) -> tuple[float, float, float]:
    """Ceramic basin colours: white, black, grey."""
    return ((0.95, 0.95, 0.94), (0.1, 0.1, 0.1), (0.5, 0.5, 0.5))[int(rng.integers(3))]
