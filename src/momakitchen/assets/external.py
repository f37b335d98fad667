"""External URDF assets (PartNet-Mobility layout) mapped onto our categories.

A folder laid out as ``<category>/<id>/mobility.urdf`` (PartNet-Mobility) is scanned into
:class:`ExternalAsset` s whose category is one of ours: PartNet names are mapped
(``StorageFurniture`` -> ``cabinet``, ``Refrigerator`` -> ``fridge``, ...) and our own names
are accepted as they are. Building an instance measures the file once in a temporary
PyBullet DIRECT client (bounding box, movable joints), chooses a uniform scale (furniture
and appliances fit their envelope), and writes a small wrapper URDF: a new root link with a
fixed joint that moves the asset into our frame convention (see ``registry``), mesh paths
made absolute so the wrapper can live in the cache. The returned :class:`AssetModel` carries
that ``path`` and the ``scale`` to pass to ``loadURDF(globalScaling=...)``.

What an external file cannot tell us is approximated: a handle is placed at the centre of
the front face of each moving link (normal +y), with a nominal 3 cm grasp width.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momakitchen.assets.cache import cached_urdf
from momakitchen.assets.registry import (
    CATEGORIES,
    Articulation,
    AssetModel,
    Envelope,
    GraspFrame,
    Rect,
)
from momakitchen.assets.urdf import fmt
from momakitchen.errors import MomaError

# PartNet-Mobility category names -> ours.
PARTNET_CATEGORIES: dict[str, str] = {
    "StorageFurniture": "cabinet",
    "Refrigerator": "fridge",
    "Microwave": "microwave",
    "Dishwasher": "dishwasher",
    "Oven": "oven",
    "Faucet": "sink",
    "Bottle": "bottle",
    "KitchenPot": "pot",
    "Chair": "chair",
    "Table": "table",
    "Cart": "cart",
    "TrashCan": "bin",
}
URDF_NAME = "mobility.urdf"
ROOT_LINK = "momakitchen_root"


@dataclass(frozen=True)
class ExternalAsset:
    """One external URDF file and the category it stands for."""

    category: str
    source_category: str
    asset_id: str
    path: str


@dataclass(frozen=True)
class ExternalParams:
    """Parameters of an external instance (JSON round trip: ``ExternalParams(**asdict(p))``).

    ``scale`` 0 means: choose it (fit the envelope for furniture and appliances, 1 else).
    ``rpy`` rotates the file's frame into ours (z up, +y front) before measuring.
    """

    category: str
    path: str
    scale: float = 0.0
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    envelope: tuple[float, float, float] | None = None

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ExternalParams:
        fields = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - fields
        if unknown:
            raise MomaError(f"external asset parameters: unknown field(s) {sorted(unknown)}")
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls(**values)


def category_of(folder_name: str) -> str | None:
    """Our category for a folder name (PartNet name or one of ours), None if unknown."""
    if folder_name in CATEGORIES:
        return folder_name
    return PARTNET_CATEGORIES.get(folder_name)


def scan_folder(root: str | Path) -> list[ExternalAsset]:
    """All ``<category>/<id>/mobility.urdf`` files under ``root`` whose category we know,
    sorted (deterministic). Unknown category folders are skipped."""
    root = Path(root)
    if not root.is_dir():
        raise MomaError(f"external asset folder {str(root)!r} does not exist")
    out = []
    for cat_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        ours = category_of(cat_dir.name)
        if ours is None:
            continue
        for item in sorted(p for p in cat_dir.iterdir() if p.is_dir()):
            urdf = item / URDF_NAME
            if urdf.is_file():
                out.append(ExternalAsset(ours, cat_dir.name, item.name, str(urdf.resolve())))
    return out


def _parse(path: Path) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise MomaError(f"external asset {str(path)!r}: cannot parse URDF ({exc})") from None
    if root.tag != "robot":
        raise MomaError(f"external asset {str(path)!r}: root element is <{root.tag}>, "
                        "expected <robot>")
    return root


def _absolute_meshes(root: ET.Element, path: Path) -> None:
    """Check every mesh exists and make its filename absolute (in place)."""
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        rel = name.removeprefix("package://")
        target = (path.parent / rel).resolve()
        if not name or not target.is_file():
            raise MomaError(f"external asset {str(path)!r}: mesh {name!r} not found")
        mesh.set("filename", str(target))


def _root_link(root: ET.Element, path: Path) -> str:
    links = [e.get("name") for e in root.findall("link")]
    children = {c.get("link") for j in root.findall("joint") for c in j.findall("child")}
    roots = [n for n in links if n not in children]
    if len(roots) != 1 or roots[0] is None:
        raise MomaError(f"external asset {str(path)!r}: expected one root link, found {roots}")
    return roots[0]


@dataclass(frozen=True)
class _Measure:
    lo: np.ndarray
    hi: np.ndarray
    mass: float
    joints: tuple[tuple[str, str, str, float, float, np.ndarray, np.ndarray], ...]
    # (joint name, type, child link, lower, upper, front-centre in link frame, link rotation)


def _measure(urdf_path: Path, label: str) -> _Measure:
    """Bounding box and movable joints of a URDF file in a temporary DIRECT client."""
    import pybullet as pb

    client = pb.connect(pb.DIRECT)
    try:
        try:
            body = pb.loadURDF(str(urdf_path), useFixedBase=True, physicsClientId=client)
        except pb.error as exc:
            raise MomaError(f"external asset {label!r}: PyBullet cannot load it ({exc})") from None
        n = pb.getNumJoints(body, physicsClientId=client)
        # links without collision shapes (our wrapper root, PartNet's empty base) report a
        # box around their origin: leave them out
        boxes = [pb.getAABB(body, k, physicsClientId=client) for k in range(-1, n)
                 if pb.getCollisionShapeData(body, k, physicsClientId=client)]
        if not boxes:
            raise MomaError(f"external asset {label!r}: has no collision geometry")
        lo = np.min([b[0] for b in boxes], axis=0)
        hi = np.max([b[1] for b in boxes], axis=0)
        mass = sum(pb.getDynamicsInfo(body, k, physicsClientId=client)[0] for k in range(-1, n))
        joints = []
        for k in range(n):
            info = pb.getJointInfo(body, k, physicsClientId=client)
            if info[2] not in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC):
                continue
            a, b = (np.asarray(v) for v in pb.getAABB(body, k, physicsClientId=client))
            front = np.array([(a[0] + b[0]) / 2, b[1], (a[2] + b[2]) / 2])
            state = pb.getLinkState(body, k, computeForwardKinematics=True,
                                    physicsClientId=client)
            pos, orn = np.asarray(state[4]), state[5]
            rot = np.asarray(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
            local = rot.T @ (front - pos)
            kind = "revolute" if info[2] == pb.JOINT_REVOLUTE else "prismatic"
            joints.append((info[1].decode(), kind, info[12].decode(), float(info[8]),
                           float(info[9]), local, rot))
        return _Measure(lo, hi, float(mass), tuple(joints))
    finally:
        pb.disconnect(client)


def _wrapper(root: ET.Element, root_link: str, offset: np.ndarray,
             rpy: tuple[float, float, float]) -> str:
    """The URDF with a new root link placing the old root at ``offset`` (unscaled units)."""
    link = ET.Element("link", {"name": ROOT_LINK})
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", {"value": "0.001"})
    ET.SubElement(inertial, "inertia", {"ixx": "1e-06", "ixy": "0", "ixz": "0", "iyy": "1e-06",
                                        "iyz": "0", "izz": "1e-06"})
    joint = ET.Element("joint", {"name": f"{ROOT_LINK}_fixed", "type": "fixed"})
    ET.SubElement(joint, "parent", {"link": ROOT_LINK})
    ET.SubElement(joint, "child", {"link": root_link})
    ET.SubElement(joint, "origin", {"xyz": " ".join(fmt(v) for v in offset),
                                    "rpy": " ".join(fmt(v) for v in rpy)})
    root.insert(0, link)
    root.append(joint)
    return ET.tostring(root, encoding="unicode") + "\n"


def build_external(params: ExternalParams) -> AssetModel:
    """Build an :class:`AssetModel` from an external URDF file (see the module docstring)."""
    if params.category not in CATEGORIES:
        raise MomaError(f"external asset {params.path!r}: unknown category {params.category!r}")
    kind = CATEGORIES[params.category].kind
    path = Path(params.path)
    root = _parse(path)
    _absolute_meshes(root, path)
    root_link = _root_link(root, path)
    # Measure the file as rotated into our frame (wrapper with zero offset first).
    probe = _wrapper(ET.fromstring(ET.tostring(root)), root_link, np.zeros(3), params.rpy)
    m = _measure(cached_urdf(probe, f"external-probe-{params.category}"), params.path)
    size = m.hi - m.lo
    if np.any(size <= 0):
        raise MomaError(f"external asset {params.path!r}: has no collision geometry")
    scale = params.scale
    if scale <= 0:
        if params.envelope is not None and kind in ("furniture", "appliance"):
            env = np.asarray(params.envelope)
            scale = float(np.min(env / size))
        else:
            scale = 1.0
    # our origin: furniture/appliance at the centre of the back edge on the floor, others at
    # the centre of the footprint, bottom of the object
    if kind in ("furniture", "appliance"):
        anchor = np.array([(m.lo[0] + m.hi[0]) / 2, m.lo[1], m.lo[2]])
    else:
        anchor = np.array([(m.lo[0] + m.hi[0]) / 2, (m.lo[1] + m.hi[1]) / 2, m.lo[2]])
    text = _wrapper(root, root_link, -anchor, params.rpy)
    file = cached_urdf(text, f"external-{params.category}")
    arts = []
    for name, jtype, child, lower, upper, local, rot in m.joints:
        normal = rot.T @ np.array([0.0, 1.0, 0.0])
        closing = rot.T @ np.array([0.0, 0.0, 1.0])
        part = "lever" if params.category == "sink" else (
            "door" if jtype == "revolute" else "drawer")
        grasp = GraspFrame(child, tuple(float(v) for v in local * scale),  # type: ignore[arg-type]
                           tuple(float(v) for v in normal),  # type: ignore[arg-type]
                           tuple(float(v) for v in closing), 0.03, "handle")  # type: ignore
        direction = 1 if upper >= -lower else -1
        travel = upper if direction > 0 else -lower
        if jtype == "prismatic":
            travel *= scale
        arts.append(Articulation(name, jtype, part, grasp, direction, float(travel)))
    scaled = tuple(float(v) for v in size * scale)
    areas: tuple[Rect, ...] = ()
    if kind == "furniture" and params.category != "fridge":
        w, d, h = scaled
        areas = (Rect(-w / 2 + 0.01, w / 2 - 0.01, 0.01, d - 0.01, h),)
    return AssetModel(
        category=params.category, urdf=text, size=scaled,  # type: ignore[arg-type]
        mass=round(m.mass, 6), articulations=tuple(arts), placement_areas=areas, path=str(file),
        scale=scale,
    )


def sample_external(assets: list[ExternalAsset], category: str, rng: np.random.Generator,
                    envelope: Envelope | None = None) -> ExternalParams:
    """Pick one external asset of ``category`` (uniformly) as parameters for
    :func:`build_external`."""
    pool = [a for a in assets if a.category == category]
    if not pool:
        raise MomaError(f"no external asset of category {category!r}")
    asset = pool[int(rng.integers(len(pool)))]
    env = None if envelope is None else (envelope.width, envelope.depth, envelope.height)
    return ExternalParams(category=category, path=asset.path, envelope=env)


def load_folder(root: str | Path) -> list[AssetModel]:
    """Build every asset of a folder at its natural scale (1.0); raises a MomaError naming
    the first broken file."""
    return [build_external(ExternalParams(a.category, a.path, scale=1.0))
            for a in scan_folder(root)]
