"""The approach track's records: one look, one episode, one result row of the JSON file.

A run builds these typed records and writes them with :meth:`ApproachRecord.to_dict`
(the ``records`` of ``approach --json``); :func:`json_schema` derives the JSON schema of a
record from the same dataclasses, so the file's format has one declaration.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import dataclass, field
from typing import Any

# Fields written only when set (a baseline has no goals; capture and the stop sweep are
# asked for): absent from the JSON rather than null.
_OPTIONAL = frozenset({"goals", "capture", "stop_sweep"})


def _round(values: Any, n: int = 4) -> list[float]:
    return [round(float(v), n) for v in values]


@dataclass(frozen=True)
class LookRecord:
    """One look: the base's ``true`` and ``odom`` poses (x, y, yaw) when it was taken,
    whether it gave a map (``ok``), else its failure ``cause`` (one word), and the seconds
    its prediction took."""

    true: list[float]
    odom: list[float]
    ok: bool
    cause: str
    seconds: float


@dataclass(frozen=True)
class EpisodeSeconds:
    """Where an episode's robot time went (s): driving, turning, looking, inference."""

    driving: float
    turning: float
    looking: float
    inference: float
    total: float


@dataclass
class EpisodeRecord:
    """One approach from one start by one method and policy (``-`` for a baseline).

    Attributes:
        looks: every look, the failed ones included.
        blocked: the bumper stopped the base short of its path's end.
        path: the true (x, y) of the base along the drive, from the start.
        goals: per goal a model chose, ``[x, y, yaw, affordance, uncertainty]`` in the
            odometry frame (None for a baseline or a model that chose none).
        goal: the last goal (x, y, yaw), odometry frame; None when there was none.
        target_odom: where the robot believed the target was at the end (x, y).
        capture: what a figure or a recording shows (odometry path, heads, fused map).
        success: 1 when the final trial succeeded; ``stage``: its stage (``success`` or
            where it failed), or why no trial ran (``no_goal``, ``no_map``, ...).
        final: the true pose of the trial; None when no trial ran.
        stop_sweep: success at each stop error of the sweep, from the same pre-stop pose.
        driven: metres driven; ``seconds``: robot time; ``cpu_seconds``: this process's.
    """

    method: str
    policy: str
    looks: list[LookRecord] = field(default_factory=list)
    blocked: bool = False
    path: list[list[float]] = field(default_factory=list)
    goals: list[list[float]] | None = None
    goal: list[float] | None = None
    target_odom: list[float] = field(default_factory=list)
    capture: dict[str, Any] | None = None
    success: int = 0
    stage: str = ""
    final: list[float] | None = None
    stop_sweep: list[int] | None = None
    driven: float = 0.0
    seconds: EpisodeSeconds | None = None
    cpu_seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """The episode's fields of a JSON row (the optional ones only when set)."""
        row = dataclasses.asdict(self)
        return {k: v for k, v in row.items() if v is not None or k not in _OPTIONAL}


@dataclass(frozen=True)
class StartRecord:
    """What every episode from one start of one configuration shares."""

    scene_id: int
    config_index: int
    robot: str
    target: str
    category: str
    feasible: bool
    start: str
    start_pose: list[float]
    start_distance: float
    shortest: float | None  # L*, m; None for an infeasible configuration
    # What makes the stance hard (strata of every table, :func:`strata`):
    articulated: bool  # a door or drawer, whose swing the base must leave free
    obstacles_near: int  # generated obstacles whose centre lies within 1 m of the target
    target_height: float  # m above the floor
    reach: float  # the robot's published reach, m
    mount: float  # its arm's mount height, m


# Stratum bounds: target height (m) low / counter / high; robot reach (m) and mount (m).
HEIGHT_BANDS = ((0.5, "low <0.5 m"), (1.2, "counter 0.5-1.2 m"), (math.inf, "high >1.2 m"))
REACH_BANDS = ((0.7, "reach <0.7 m"), (0.9, "reach 0.7-0.9 m"), (math.inf, "reach >0.9 m"))
MOUNT_BANDS = ((0.6, "mount <0.6 m"), (1.0, "mount 0.6-1.0 m"), (math.inf, "mount >1.0 m"))


def _band(value: float, bands: tuple[tuple[float, str], ...]) -> str:
    return next(name for bound, name in bands if value < bound)


def strata(row: dict[str, Any]) -> dict[str, str]:
    """A JSON row's stratum on each axis of what makes a stance hard (older rows without
    the fields: none)."""
    if "articulated" not in row:
        return {}
    return {
        "target": "articulated" if row["articulated"] else "rigid",
        "clutter": "obstacles within 1 m" if row["obstacles_near"] else "no obstacle within 1 m",
        "height": _band(row["target_height"], HEIGHT_BANDS),
        "reach": _band(row["reach"], REACH_BANDS),
        "mount": _band(row["mount"], MOUNT_BANDS),
    }


@dataclass(frozen=True)
class ApproachRecord:
    """A row of the results: the start, the episode and its SPL (success weighted by
    path length)."""

    start: StartRecord
    episode: EpisodeRecord
    spl: float

    @classmethod
    def of(cls, start: StartRecord, episode: EpisodeRecord, shortest: float) -> ApproachRecord:
        """The row, SPL = success x L* / max(driven, L*) with L* = ``shortest`` (m, inf
        where no path exists)."""
        spl = 0.0
        longest = max(episode.driven, shortest)
        if episode.success and not math.isinf(shortest):
            spl = shortest / longest if longest > 0 else 1.0
        return cls(start, episode, spl)

    def to_dict(self) -> dict[str, Any]:
        """The JSON row (``shortest`` and ``spl`` rounded as written)."""
        return {
            **dataclasses.asdict(self.start),
            **self.episode.to_dict(),
            "spl": round(self.spl, 4),
            "n_looks": len(self.episode.looks),
        }


def _type_schema(tp: Any) -> dict[str, Any]:
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        return {"anyOf": [_type_schema(a) for a in typing.get_args(tp)]}
    if tp is type(None):
        return {"type": "null"}
    if origin is list:
        (item,) = typing.get_args(tp) or (Any,)
        return {"type": "array", "items": _type_schema(item)}
    if origin is dict or tp is dict:
        return {"type": "object"}
    if dataclasses.is_dataclass(tp):
        return _dataclass_schema(tp)
    simple = {str: "string", int: "integer", float: "number", bool: "boolean"}
    return {"type": simple[tp]} if tp in simple else {}


def _dataclass_schema(cls: Any) -> dict[str, Any]:
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    props = {n: _type_schema(hints[n]) for n in names}
    required = [n for n in names if n not in _OPTIONAL]
    return {"type": "object", "properties": props, "required": required}


def json_schema() -> dict[str, Any]:
    """The JSON schema (draft 2020-12) of a row of ``approach --json``'s ``records``,
    derived from :class:`StartRecord` and :class:`EpisodeRecord`."""
    start, episode = _dataclass_schema(StartRecord), _dataclass_schema(EpisodeRecord)
    props = {**start["properties"], **episode["properties"]}
    props["spl"] = {"type": "number", "minimum": 0, "maximum": 1}
    props["n_looks"] = {"type": "integer", "minimum": 0}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "momakitchen approach record",
        "type": "object",
        "properties": props,
        "required": [*start["required"], *episode["required"], "spl", "n_looks"],
    }


def shortest_or_none(shortest: float) -> float | None:
    """L* as written: rounded to mm, None where no path exists (inf)."""
    return None if math.isinf(shortest) else round(shortest, 3)
