"""Kitchen layouts: pure data, fully determined by ``scene_id`` (no PyBullet here).

World frame: z up, the floor at z = 0, the furniture wall along the x axis at y = 0 and
the room extending towards +y. Every furniture unit stands against the wall with its front
facing +y; the room spans ``x in [0, room.width]``, ``y in [0, room.depth]``.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from momakitchen.assets import AssetModel, Envelope, Rect, get_category
from momakitchen.errors import MomaError
from momakitchen.scene.geometry import Footprint
from momakitchen.scene.ids import check_scene_id

# Countertop heights (m) of the kitchens: each scene's is drawn uniformly from this range.
COUNTER_HEIGHTS = (0.86, 0.94)
LAYOUT_STREAM = 0  # seed stream of the layout; configurations use stream 1

# Widths along the wall (m) that the layout grants each base-unit category; standard
# kitchen modules are 0.45-0.9 m, appliances 0.6 m.
UNIT_WIDTHS: dict[str, tuple[float, float]] = {
    "cabinet": (0.45, 0.9),
    "sink": (0.6, 0.9),
    "dishwasher": (0.58, 0.62),
    "oven": (0.58, 0.76),
    "fridge": (0.7, 0.9),
}
UNIT_GAP = 0.004  # clearance between neighbouring units: no interpenetration at spawn
FRIDGE_GAP = 0.04  # clearance beside a fridge, whose door would hit the next unit otherwise


def _r(value: float) -> float:
    """Positions are rounded to 0.1 mm so that a layout equals its JSON exactly."""
    return round(float(value), 4)


@dataclass(frozen=True)
class Room:
    """Room extents (m): ``width`` along the furniture wall (x), ``depth`` away from it (y)."""

    width: float
    depth: float
    wall_height: float


@dataclass(frozen=True)
class Placed:
    """One asset instance placed in the world.

    ``uid`` is unique within a scene (``f*`` furniture, ``a*`` appliances, ``r*`` rigid
    objects, ``o*`` obstacles); ``(x, y, z, yaw)`` is the pose of the asset frame.
    """

    uid: str
    category: str
    params: Any
    x: float
    y: float
    z: float
    yaw: float = 0.0

    @functools.cached_property
    def model(self) -> AssetModel:
        """The built asset (URDF text and metadata); cached on the instance."""
        return get_category(self.category).build(self.params)

    def footprint(self, margin: float = 0.0) -> Footprint:
        """Floor footprint of the asset's bounding box, grown by ``margin``."""
        sx, sy, _ = self.model.size
        # Furniture frames have their origin on the back edge: the box centre is +sy/2 in y.
        off = sy / 2 if get_category(self.category).kind in ("furniture", "appliance") else 0.0
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return Footprint(self.x - s * off, self.y + c * off, self.yaw, sx, sy).inflated(margin)

    def to_world(self, local: np.ndarray) -> np.ndarray:
        """Transform points from the asset frame to the world. Shapes: (..., 3) -> (..., 3)."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return np.asarray(local) @ rot.T + np.array([self.x, self.y, self.z])

    def to_dict(self) -> dict[str, Any]:
        return {
            "uid": self.uid,
            "category": self.category,
            "params": dataclasses.asdict(self.params),
            "pose": [self.x, self.y, self.z, self.yaw],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Placed:
        params = get_category(data["category"]).params_from_dict(data["params"])
        x, y, z, yaw = data["pose"]
        return cls(data["uid"], data["category"], params, x, y, z, yaw)


@dataclass(frozen=True)
class Layout:
    """A kitchen: room, counter dimensions and the furniture along the wall (pure data)."""

    scene_id: int
    room: Room
    counter_height: float
    counter_depth: float
    furniture: tuple[Placed, ...]

    def unit(self, uid: str) -> Placed:
        for p in self.furniture:
            if p.uid == uid:
                return p
        raise MomaError(f"scene {self.scene_id} has no furniture {uid!r}")

    def footprints(self, margin: float = 0.0) -> list[Footprint]:
        """Floor footprints of floor-standing furniture (appliances stand on counters)."""
        return [
            p.footprint(margin)
            for p in self.furniture
            if get_category(p.category).kind == "furniture"
        ]

    def placement_areas(self) -> list[Rect]:
        """Free countertop rectangles in world coordinates (appliances cut out)."""
        appliances = [p for p in self.furniture if get_category(p.category).kind == "appliance"]
        areas: list[Rect] = []
        for p in self.furniture:
            for a in p.model.placement_areas:
                rect = Rect(
                    _r(p.x + a.x0), _r(p.x + a.x1), _r(p.y + a.y0), _r(p.y + a.y1), _r(p.z + a.z)
                )
                areas.extend(_subtract_appliances(rect, appliances))
        return [a for a in areas if a.x1 - a.x0 > 0.12 and a.y1 - a.y0 > 0.12]

    def to_dict(self) -> dict[str, Any]:
        return {
            "scene_id": self.scene_id,
            "room": dataclasses.asdict(self.room),
            "counter_height": self.counter_height,
            "counter_depth": self.counter_depth,
            "furniture": [p.to_dict() for p in self.furniture],
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Layout:
        return cls(
            scene_id=int(data["scene_id"]),
            room=Room(**data["room"]),
            counter_height=data["counter_height"],
            counter_depth=data["counter_depth"],
            furniture=tuple(Placed.from_dict(p) for p in data["furniture"]),
        )


def _subtract_appliances(rect: Rect, appliances: list[Placed]) -> list[Rect]:
    """Split ``rect`` along x around the footprints of appliances standing on it."""
    pieces = [rect]
    for app in appliances:
        fp = app.footprint(margin=0.03)
        ax0, ax1 = fp.x - fp.length / 2, fp.x + fp.length / 2
        out = []
        for r in pieces:
            if abs(app.z - r.z) > 0.02 or ax1 <= r.x0 or ax0 >= r.x1:
                out.append(r)
                continue
            if ax0 > r.x0:
                out.append(Rect(r.x0, _r(ax0), r.y0, r.y1, r.z))
            if ax1 < r.x1:
                out.append(Rect(_r(ax1), r.x1, r.y0, r.y1, r.z))
        pieces = out
    return pieces


def scene_rng(scene_id: int, *stream: int) -> np.random.Generator:
    """Independent, reproducible random stream for ``scene_id`` (and sub-stream indices)."""
    return np.random.default_rng([int(scene_id), *stream])


def _unit_sequence(rng: np.random.Generator) -> list[str]:
    """Category order along the wall: a sink, usually a fridge at one end, some appliances
    and cabinets, in random order."""
    units = ["sink"] + ["cabinet"] * int(rng.integers(2, 5))
    for cat, prob in (("dishwasher", 0.7), ("oven", 0.7)):
        if rng.random() < prob:
            units.append(cat)
    order = [units[i] for i in rng.permutation(len(units))]
    if rng.random() < 0.85:
        order = ["fridge", *order] if rng.random() < 0.5 else [*order, "fridge"]
    return order


def sample_layout(scene_id: int) -> Layout:
    """The kitchen of ``scene_id``: room, furniture sequence and instances, counter height."""
    check_scene_id(scene_id)
    rng = scene_rng(scene_id, LAYOUT_STREAM)
    counter_height = _r(rng.uniform(*COUNTER_HEIGHTS))
    counter_depth = _r(rng.uniform(0.56, 0.66))
    order = _unit_sequence(rng)
    widths = [_r(rng.uniform(*UNIT_WIDTHS[c])) for c in order]
    # A fridge keeps FRIDGE_GAP from its neighbours: the hinge edge of its thick door
    # turns close to the worktop overhang beside it.
    gaps = [FRIDGE_GAP if "fridge" in (a, b) else UNIT_GAP for a, b in itertools.pairwise(order)]
    run = sum(widths) + sum(gaps)
    left_margin = _r(rng.uniform(0.25, 1.2))
    room = Room(
        width=_r(run + left_margin + rng.uniform(0.25, 1.2)),
        depth=_r(rng.uniform(3.6, 5.0)),
        wall_height=_r(rng.uniform(2.4, 2.7)),
    )
    furniture: list[Placed] = []
    x = left_margin
    for i, (cat, w) in enumerate(zip(order, widths, strict=True)):
        if cat == "fridge":
            depth = _r(counter_depth + rng.uniform(0.04, 0.12))
            env = Envelope(w, depth, _r(rng.uniform(1.75, 2.0)))
        else:
            env = Envelope(w, counter_depth, counter_height)
        params = get_category(cat).sample(rng, env)
        furniture.append(Placed(f"f{i}", cat, params, _r(x + w / 2), 0.0, 0.0, 0.0))
        x += w + (gaps[i] if i < len(gaps) else 0.0)
    layout = Layout(scene_id, room, counter_height, counter_depth, tuple(furniture))
    return _add_microwave(layout, rng)


def _add_microwave(layout: Layout, rng: np.random.Generator) -> Layout:
    """Most kitchens get a microwave standing at the back of a wide enough countertop."""
    if rng.random() >= 0.75:
        return layout
    areas = [a for a in layout.placement_areas() if a.x1 - a.x0 >= 0.5]
    if not areas:
        return layout
    area = areas[int(rng.integers(len(areas)))]
    width = min(0.6, area.x1 - area.x0 - 0.02)
    env = Envelope(_r(width), _r(min(0.42, area.y1 - area.y0 - 0.12)), 0.4)
    params = get_category("microwave").sample(rng, env)
    size = get_category("microwave").build(params).size
    cx = _r(rng.uniform(area.x0 + size[0] / 2 + 0.01, area.x1 - size[0] / 2 - 0.01))
    app = Placed(
        f"a{len(layout.furniture)}",
        "microwave",
        params,
        cx,
        _r(area.y0 + 0.02),
        _r(area.z + 0.001),
        0.0,
    )
    return dataclasses.replace(layout, furniture=(*layout.furniture, app))
