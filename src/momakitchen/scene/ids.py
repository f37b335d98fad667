"""The valid scene ids, stated once: every command checks an id or a range of ids against
these bounds before any work (an id past them used to simulate for half a minute and then
fail where HDF5 stores it).

Ids run from 0 to :data:`MAX_SCENE_ID` (the largest signed 32-bit integer: an id fits
every integer type it is stored as). One request (``generate --scenes``, ``audit
--scenes A-B``) covers at most :data:`MAX_SCENES` scenes: at about a minute per scene and
core, more would take years, and the request's id list alone would fill the memory.
"""

from __future__ import annotations

from momakitchen.errors import MomaError

MAX_SCENE_ID = 2**31 - 1
MAX_SCENES = 1_000_000


def scene_id_problem(scene_id: object) -> str | None:
    """Why ``scene_id`` is not a valid scene id (None if it is)."""
    if isinstance(scene_id, bool) or not hasattr(scene_id, "__index__"):
        return f"a scene id must be an integer in [0, {MAX_SCENE_ID}], got {scene_id!r}"
    value = scene_id.__index__()
    if not 0 <= value <= MAX_SCENE_ID:
        return f"a scene id must be in [0, {MAX_SCENE_ID}], got {value}"
    return None


def check_scene_id(scene_id: object) -> int:
    """``scene_id`` as an int; MomaError naming it unless it is in [0, MAX_SCENE_ID]."""
    problem = scene_id_problem(scene_id)
    if problem:
        raise MomaError(problem)
    return int(scene_id)  # type: ignore[call-overload]


def scene_range_problem(first: int, count: int, limit: int = MAX_SCENES) -> str | None:
    """Why ``count`` scenes from ``first`` are not a valid request of at most ``limit``
    scenes (None if they are)."""
    problem = scene_id_problem(first)
    if problem:
        return problem
    if not 1 <= count <= limit:
        return f"the number of scenes must be in [1, {limit:,}], got {count:,}"
    if first + count - 1 > MAX_SCENE_ID:
        return f"scenes {first}..{first + count - 1} end past the last scene id {MAX_SCENE_ID}"
    return None


def check_scene_range(first: int, count: int) -> None:
    """MomaError unless ids ``first .. first + count - 1`` are valid and at most
    :data:`MAX_SCENES` of them."""
    problem = scene_range_problem(first, count)
    if problem:
        raise MomaError(problem)
