"""The base-unit carcass shared by counter furniture (cabinet, sink, dishwasher, oven).

A base unit fills its envelope: width ``w`` along the wall, depth ``D`` (handles reach the
front of the envelope), countertop top at ``H``. From the back (y = 0) forward: carcass
panels, then the fronts (doors, drawers, appliance doors) on the carcass front face at
``y_front``, then handles. The toe-kick plinth is recessed under the fronts.

Doors and drawers are child links placed *in front of* the carcass, so closed parts never
overlap the carcass; drawer boxes slide inside it (PyBullet ignores collisions between links
of one body).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momakitchen.assets.common import (
    CARCASS_COLOURS,
    COUNTERTOP_COLOURS,
    FRONT_COLOURS,
    HANDLE_COLOURS,
    HANDLE_TYPES,
    MDF,
    METAL,
    STONE,
    WOOD,
    Handle,
    box_at,
    check_envelope,
    handle_grasp,
    make_handle,
    palette_colour,
    pick,
    u,
)
from momakitchen.assets.registry import Articulation, Envelope, Rect
from momakitchen.assets.urdf import RGBA, Joint, Link, Shape, density_mass

GAP = 0.003  # clearance between neighbouring fronts and around them (no contacts)
# Joint dynamics: damping (N m s / N s/m) and friction (N m / N). Friction is meant to be
# applied as the force of PyBullet's default velocity motor (see docs/ASSETS.md); it keeps a
# pull-down door shut under its own weight yet yields to a pull of a few newtons.
DOOR_DYNAMICS = (0.3, 0.3)
DRAWER_DYNAMICS = (2.0, 1.0)
# Pull-down doors: real ones have counterbalance springs; the extra friction stands in for
# them, holding the door shut against the weight of its handle.
FLAP_DYNAMICS = (0.5, 1.5)
MIN_ENVELOPE = (0.3, 0.45, 0.6)


@dataclass(frozen=True)
class CounterParams:
    """Parameters every base unit shares (dimensions in m, colours RGBA)."""

    width: float
    depth: float
    height: float
    plinth_height: float
    plinth_recess: float
    panel: float
    front_thickness: float
    top_thickness: float
    top_overhang: float
    top_material: str  # stone | wood
    handle_type: str
    handle_length: float
    handle_thickness: float
    handle_standoff: float
    carcass_rgba: RGBA
    front_rgba: RGBA
    top_rgba: RGBA
    handle_rgba: RGBA


def sample_counter(
    rng: np.random.Generator,
    envelope: Envelope | None,
    name: str,
    handle_types: tuple[str, ...] = HANDLE_TYPES,
) -> dict:
    """Field values of :class:`CounterParams` for a unit filling ``envelope``."""
    env = check_envelope(name, envelope, MIN_ENVELOPE)
    handle_type = pick(rng, handle_types)
    knob = handle_type == "knob"
    top_material = "wood" if rng.random() < 0.25 else "stone"
    top_rgba = palette_colour(
        rng, COUNTERTOP_COLOURS[2:3] if top_material == "wood" else COUNTERTOP_COLOURS
    )
    return dict(
        # the envelope as given (rounding could push a unit past its slot)
        width=float(env.width),
        depth=float(env.depth),
        height=float(env.height),
        plinth_height=u(rng, 0.08, 0.13),
        plinth_recess=u(rng, 0.04, 0.07),
        panel=u(rng, 0.016, 0.019),
        front_thickness=u(rng, 0.018, 0.022),
        top_thickness=u(rng, 0.02, 0.04) if top_material == "stone" else u(rng, 0.03, 0.04),
        top_overhang=u(rng, 0.01, 0.025),
        top_material=top_material,
        handle_type=handle_type,
        handle_length=0.0 if knob else u(rng, 0.1, 0.32),
        handle_thickness=u(rng, 0.025, 0.034) if knob else u(rng, 0.01, 0.016),
        handle_standoff=u(rng, 0.018, 0.03),
        carcass_rgba=palette_colour(rng, CARCASS_COLOURS, 0.02),
        front_rgba=palette_colour(rng, FRONT_COLOURS),
        top_rgba=top_rgba,
        handle_rgba=palette_colour(rng, HANDLE_COLOURS, 0.03),
    )


@dataclass(frozen=True)
class CounterGeometry:
    """Derived planes of a base unit (m, asset frame)."""

    w: float
    depth: float
    height: float
    y_front: float  # carcass front face = back face of the fronts
    y_top: float  # front edge of the countertop
    z_carcass: float  # underside of the countertop
    z_fronts: tuple[float, float]  # bottom and top of the front area
    x_inner: tuple[float, float]  # inside faces of the side panels


def handle_depth(p: CounterParams) -> float:
    """How far a handle sticks out of the front surface."""
    knob = p.handle_type == "knob"
    return p.handle_standoff + (p.handle_thickness * 0.6 if knob else p.handle_thickness)


def geometry(p: CounterParams) -> CounterGeometry:
    y_front = p.depth - handle_depth(p) - p.front_thickness
    z_carcass = p.height - p.top_thickness
    return CounterGeometry(
        w=p.width,
        depth=p.depth,
        height=p.height,
        y_front=y_front,
        y_top=min(p.depth, y_front + p.front_thickness + p.top_overhang),
        z_carcass=z_carcass,
        z_fronts=(p.plinth_height + GAP, z_carcass - GAP),
        x_inner=(-p.width / 2 + p.panel, p.width / 2 - p.panel),
    )


def carcass_shapes(
    p: CounterParams, g: CounterGeometry, *, countertop: bool = True, shelf: bool = False
) -> list[Shape]:
    """Side, back and bottom panels, plinth, optional shelf, and the countertop slab."""
    hw, t = p.width / 2, p.panel
    (xi0, xi1), zc = g.x_inner, g.z_carcass
    shapes = [
        box_at((-hw, 0.0, 0.0), (xi0, g.y_front, zc), "carcass", MDF),
        box_at((xi1, 0.0, 0.0), (hw, g.y_front, zc), "carcass", MDF),
        box_at((xi0, 0.0, p.plinth_height), (xi1, t, zc), "carcass", MDF),
        box_at((xi0, t, p.plinth_height), (xi1, g.y_front, p.plinth_height + t), "carcass", MDF),
        box_at(
            (xi0, g.y_front - p.plinth_recess - t, 0.0),
            (xi1, g.y_front - p.plinth_recess, p.plinth_height),
            "plinth",
            MDF,
        ),
    ]
    if shelf:
        zs = (p.plinth_height + zc) / 2
        shapes.append(
            box_at((xi0, t, zs - t / 2), (xi1, g.y_front - 0.02, zs + t / 2), "carcass", MDF)
        )
    if countertop:
        shapes.append(countertop_slab(p, g, -hw, hw, 0.0, g.y_top))
    return shapes


def countertop_slab(
    p: CounterParams, g: CounterGeometry, x0: float, x1: float, y0: float, y1: float
) -> Shape:
    density = STONE if p.top_material == "stone" else WOOD
    return box_at((x0, y0, g.z_carcass), (x1, y1, g.height), "top", density)


def materials(p: CounterParams) -> dict[str, RGBA]:
    return {
        "carcass": p.carcass_rgba,
        "plinth": p.front_rgba,
        "front": p.front_rgba,
        "top": p.top_rgba,
        "handle": p.handle_rgba,
    }


def countertop_area(g: CounterGeometry, margin: float = 0.01) -> Rect:
    return Rect(
        round(-g.w / 2 + margin, 6),
        round(g.w / 2 - margin, 6),
        margin,
        round(g.y_top - margin, 6),
        round(g.height, 6),
    )


@dataclass(frozen=True)
class HandleSpec:
    kind: str
    length: float
    thickness: float
    standoff: float

    def make(
        self,
        centre: tuple[float, float, float],
        length: float | None = None,
        kind: str | None = None,
    ) -> Handle:
        return make_handle(
            kind or self.kind,
            centre,
            self.length if length is None else length,
            self.thickness,
            self.standoff,
            "handle",
        )


def handle_spec(p: CounterParams) -> HandleSpec:
    return HandleSpec(p.handle_type, p.handle_length, p.handle_thickness, p.handle_standoff)


def with_density(shapes: tuple[Shape, ...], density: float) -> tuple[Shape, ...]:
    return tuple(
        Shape(s.geometry, s.xyz, s.rpy, s.material, s.collision, s.visual, density) for s in shapes
    )


def door(
    name: str,
    parent: str,
    y_front: float,
    x0: float,
    x1: float,
    z0: float,
    z1: float,
    hinge: str,
    handle: HandleSpec,
    thickness: float,
    *,
    handle_at_top: bool = True,
    material: str = "front",
    density: float = MDF,
    extra: tuple[Shape, ...] = (),
    limit: float = 1.75,
) -> tuple[Link, Joint, Articulation]:
    """A side-hinged door covering ``[x0, x1] x [z0, z1]`` with its back face at ``y_front``.

    The joint sits on the hinge edge at the *front* face of the door, as a cabinet hinge
    pivots: the door swings out without its hinge edge moving sideways (pivoting at the
    back face, that edge swung into the next unit's worktop and stopped the door at about
    20°). Both hinge sides open with a positive angle (the axis is flipped for right
    hinges), the free edge swinging to +y.
    ``extra`` shapes (windows, trims) are given in the frame of a left-hinged door and
    mirrored for right hinges.
    """
    t = thickness
    dw, dh = x1 - x0, z1 - z0
    left = hinge == "left"
    sx = 1.0 if left else -1.0
    # Link frame on the front face (y = 0), the panel behind it.
    panel = box_at((min(0.0, sx * dw), -t, 0.0), (max(0.0, sx * dw), 0.0, dh), material, density)
    vertical = handle.kind in ("bar_v", "flat_v")
    hl = min(handle.length, (dh if vertical else dw) * 0.6)
    hx = sx * (dw - 0.04 - hl / 2) if handle.kind in ("bar_h", "flat_h") else sx * (dw - 0.045)
    top_z = dh - 0.06 - (hl / 2 if vertical else 0.0)
    h = handle.make((hx, 0.0, top_z if handle_at_top else dh / 2), hl)
    mirrored = tuple(
        Shape(
            s.geometry,
            (sx * s.xyz[0], s.xyz[1] - t, s.xyz[2]),
            s.rpy,
            s.material,
            s.collision,
            s.visual,
            s.density,
        )
        for s in extra
    )
    shapes = (panel, *with_density(h.shapes, METAL), *mirrored)
    link = Link(name, shapes, round(density_mass(shapes), 4))
    joint = Joint(
        f"{name}_hinge",
        "revolute",
        parent,
        name,
        (x0 if left else x1, y_front + t, z0),
        axis=(0.0, 0.0, 1.0 if left else -1.0),
        lower=0.0,
        upper=limit,
        effort=50.0,
        velocity=3.0,
        damping=DOOR_DYNAMICS[0],
        friction=DOOR_DYNAMICS[1],
    )
    art = Articulation(joint.name, "revolute", "door", handle_grasp(name, h), 1, limit)
    return link, joint, art


def flap(
    name: str,
    parent: str,
    y_front: float,
    x0: float,
    x1: float,
    z0: float,
    z1: float,
    handle: HandleSpec,
    thickness: float,
    *,
    material: str,
    density: float,
    extra: tuple[Shape, ...] = (),
    handle_length: float | None = None,
    limit: float = 1.45,
) -> tuple[Link, Joint, Articulation]:
    """A pull-down door (dishwasher, oven) hinged about a horizontal axis at its bottom edge.

    The hinge runs through the middle of the door's thickness, so a closed door carries no
    gravity torque worth speaking of; the axis is -x so that opening is a positive angle.
    """
    t = thickness
    dw, dh = x1 - x0, z1 - z0
    panel = box_at((-dw / 2, -t / 2, 0.0), (dw / 2, t / 2, dh), material, density)
    kind = {"bar_v": "bar_h", "flat_v": "flat_h", "knob": "bar_h"}.get(handle.kind, handle.kind)
    hl = handle_length if handle_length is not None else min(max(handle.length, 0.3), dw * 0.8)
    h = handle.make((0.0, t / 2, dh - 0.05), hl, kind)
    shapes = (panel, *with_density(h.shapes, METAL), *extra)
    link = Link(name, shapes, round(density_mass(shapes), 4))
    joint = Joint(
        f"{name}_hinge",
        "revolute",
        parent,
        name,
        ((x0 + x1) / 2, y_front + t / 2, z0),
        axis=(-1.0, 0.0, 0.0),
        lower=0.0,
        upper=limit,
        effort=80.0,
        velocity=3.0,
        damping=FLAP_DYNAMICS[0],
        friction=FLAP_DYNAMICS[1],
    )
    art = Articulation(joint.name, "revolute", "door", handle_grasp(name, h), 1, limit)
    return link, joint, art


def drawer(
    name: str,
    parent: str,
    y_front: float,
    x0: float,
    x1: float,
    z0: float,
    z1: float,
    handle: HandleSpec,
    thickness: float,
    inner_depth: float,
    inner_width: float,
    *,
    material: str = "front",
    box_material: str = "carcass",
    density: float = MDF,
) -> tuple[Link, Joint, Articulation]:
    """A drawer: front panel plus a box sliding into the carcass along +y."""
    t = thickness
    fw, fh = x1 - x0, z1 - z0
    wall = 0.012
    bw = min(fw, inner_width) / 2 - 0.015
    bh = max(0.05, fh * 0.7)
    d = inner_depth
    shapes = [
        box_at((-fw / 2, 0.0, 0.0), (fw / 2, t, fh), material, density),
        box_at((-bw, -d, 0.02), (bw, 0.0, 0.02 + wall), box_material, MDF),
        box_at((-bw, -d, 0.02), (-bw + wall, 0.0, 0.02 + bh), box_material, MDF),
        box_at((bw - wall, -d, 0.02), (bw, 0.0, 0.02 + bh), box_material, MDF),
        box_at((-bw, -d, 0.02), (bw, -d + wall, 0.02 + bh), box_material, MDF),
    ]
    kind = {"bar_v": "bar_h", "flat_v": "flat_h"}.get(handle.kind, handle.kind)
    h = handle.make(
        (0.0, t, fh / 2 if fh < 0.25 else fh - 0.08), min(handle.length, fw * 0.6), kind
    )
    shapes += list(with_density(h.shapes, METAL))
    link = Link(name, tuple(shapes), round(density_mass(shapes), 4))
    limit = round(d * 0.8, 4)
    joint = Joint(
        f"{name}_slide",
        "prismatic",
        parent,
        name,
        ((x0 + x1) / 2, y_front, z0),
        axis=(0.0, 1.0, 0.0),
        lower=0.0,
        upper=limit,
        effort=200.0,
        velocity=1.0,
        damping=DRAWER_DYNAMICS[0],
        friction=DRAWER_DYNAMICS[1],
    )
    art = Articulation(joint.name, "prismatic", "drawer", handle_grasp(name, h), 1, limit)
    return link, joint, art


def counter_door(
    p: CounterParams,
    g: CounterGeometry,
    name: str,
    parent: str,
    x0: float,
    x1: float,
    z0: float,
    z1: float,
    hinge: str,
) -> tuple[Link, Joint, Articulation]:
    return door(name, parent, g.y_front, x0, x1, z0, z1, hinge, handle_spec(p), p.front_thickness)


def counter_drawer(
    p: CounterParams,
    g: CounterGeometry,
    name: str,
    parent: str,
    x0: float,
    x1: float,
    z0: float,
    z1: float,
) -> tuple[Link, Joint, Articulation]:
    return drawer(
        name,
        parent,
        g.y_front,
        x0,
        x1,
        z0,
        z1,
        handle_spec(p),
        p.front_thickness,
        g.y_front - p.panel - 0.02,
        g.x_inner[1] - g.x_inner[0],
    )


def split(x0: float, x1: float, n: int) -> list[tuple[float, float]]:
    """``n`` equal intervals of ``[x0, x1]`` with :data:`GAP` between them."""
    step = (x1 - x0 + GAP) / n
    return [(x0 + k * step, x0 + (k + 1) * step - GAP) for k in range(n)]
