"""External URDF assets (PartNet-Mobility layout) mapped onto our categories.

A folder laid out as ``<category>/<id>/mobility.urdf`` (PartNet-Mobility) is scanned into
:class:`ExternalAsset` s whose category is one of ours: PartNet names are mapped
(``StorageFurniture`` -> ``cabinet``, ``Refrigerator`` -> ``fridge``, ...) and our own names
are accepted as they are.

Each file is measured once in a temporary PyBullet DIRECT client (bounding box, mass,
movable joints); the measurement is kept in memory, so building instances afterwards is
pure Python. Building writes a small wrapper URDF to the cache: a new root link with a fixed
joint that moves the asset into our frame convention (see ``registry``), mesh paths made
absolute so that the wrapper can live anywhere. The returned :class:`AssetModel` carries
that ``path`` and the uniform ``scale`` to pass to ``loadURDF(globalScaling=...)``:
furniture and appliances fill their envelope, other objects are scaled to a size typical
of their category (PartNet-Mobility models are normalised, not metric).

``register_external_assets(folder)`` makes the categories draw a share of their instances
from the folder (``ProceduralCategory.sample``); the parameters of such an instance are an
:class:`ExternalParams` that round-trips through JSON like any other.

What an external file cannot tell us is approximated: a handle at the centre of the front
face of each moving link (normal +y, 3 cm wide), and for rigid targets side and top grasps
across the bounding box where it is narrow enough for the gripper.
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
from momakitchen.fileio import existing_dir
from momakitchen.frames import float3

# PartNet-Mobility category names -> ours. PartNet's Faucet is a bare tap, not a sink
# counter, so it is not mapped (scaling it to a counter envelope would make a giant tap).
PARTNET_CATEGORIES: dict[str, str] = {
    "StorageFurniture": "cabinet",
    "Refrigerator": "fridge",
    "Microwave": "microwave",
    "Dishwasher": "dishwasher",
    "Oven": "oven",
    "Bottle": "bottle",
    "KitchenPot": "pot",
    "Chair": "chair",
    "Table": "table",
    "Cart": "cart",
    "TrashCan": "bin",
}
URDF_NAME = "mobility.urdf"
ROOT_LINK = "momakitchen_root"
SOURCE = "external"
# Size (m) an external object is scaled to: ("height" | "extent", low, high); "extent" is
# the largest side of the bounding box.
TYPICAL_SIZE: dict[str, tuple[str, float, float]] = {
    "bottle": ("height", 0.22, 0.34),
    "pot": ("extent", 0.26, 0.38),
    "fruit": ("extent", 0.06, 0.085),
    "medicine_bottle": ("height", 0.06, 0.12),
    "vegetable": ("extent", 0.08, 0.22),
    "chair": ("height", 0.8, 1.0),
    "table": ("height", 0.72, 0.78),
    "bin": ("height", 0.4, 0.7),
    "trolley": ("height", 0.75, 0.92),
    "cart": ("height", 0.85, 1.0),
}
MAX_GRASP_WIDTH = 0.075
HAND_SIZED = ("bottle", "fruit", "medicine_bottle", "vegetable")


@dataclass(frozen=True)
class ExternalAsset:
    """One external URDF file and the category it stands for."""

    category: str
    source_category: str
    asset_id: str
    path: str


@dataclass(frozen=True)
class ExternalParams:
    """Parameters of an external instance (JSON round trip: :meth:`from_dict`).

    ``target``: size of the governing dimension (``TYPICAL_SIZE``) for objects and
    obstacles; ``envelope`` for furniture and appliances; ``scale`` > 0 overrides both.
    ``rpy`` rotates the file's frame into ours (z up, +y front) before measuring.
    """

    category: str
    path: str
    target: float = 0.0
    envelope: tuple[float, float, float] | None = None
    scale: float = 0.0
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = SOURCE

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ExternalParams:
        fields = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - fields
        if unknown:
            raise MomaError(f"external asset parameters: unknown field(s) {sorted(unknown)}")
        values: dict[str, Any] = {
            k: tuple(v) if isinstance(v, list) else v for k, v in data.items()
        }
        return cls(**values)


def category_of(folder_name: str) -> str | None:
    """Our category for a folder name (PartNet name or one of ours), None if unknown."""
    if folder_name in CATEGORIES:
        return folder_name
    return PARTNET_CATEGORIES.get(folder_name)


def scan_folder(root: str | Path) -> list[ExternalAsset]:
    """All ``<category>/<id>/mobility.urdf`` files under ``root`` whose category we know,
    sorted (deterministic). Unknown category folders are skipped."""
    root = existing_dir(root, "external asset folder")
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


# ----------------------------------------------------------------------------- parsing


def _parse(path: Path) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise MomaError(f"external asset {str(path)!r}: cannot parse URDF ({exc})") from None
    if root.tag != "robot":
        raise MomaError(
            f"external asset {str(path)!r}: root element is <{root.tag}>, expected <robot>"
        )
    return root


def _absolute_meshes(root: ET.Element, path: Path) -> None:
    """Check every mesh exists and make its filename absolute (in place)."""
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        target = (path.parent / name.removeprefix("package://")).resolve()
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


def _wrapper(
    root: ET.Element, root_link: str, offset: np.ndarray, rpy: tuple[float, float, float]
) -> str:
    """The URDF with a new root link placing the old root at ``offset`` (unscaled units)."""
    root = ET.fromstring(ET.tostring(root))  # leave the caller's tree alone
    link = ET.Element("link", {"name": ROOT_LINK})
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", {"value": "0.001"})
    ET.SubElement(
        inertial,
        "inertia",
        {"ixx": "1e-06", "ixy": "0", "ixz": "0", "iyy": "1e-06", "iyz": "0", "izz": "1e-06"},
    )
    joint = ET.Element("joint", {"name": f"{ROOT_LINK}_fixed", "type": "fixed"})
    ET.SubElement(joint, "parent", {"link": ROOT_LINK})
    ET.SubElement(joint, "child", {"link": root_link})
    ET.SubElement(
        joint,
        "origin",
        {"xyz": " ".join(fmt(v) for v in offset), "rpy": " ".join(fmt(v) for v in rpy)},
    )
    root.insert(0, link)
    root.append(joint)
    return ET.tostring(root, encoding="unicode") + "\n"


# ----------------------------------------------------------------------------- measuring


@dataclass(frozen=True)
class Measurement:
    """What PyBullet reports about a file, rotated into our axes, at scale 1."""

    text: ET.Element
    root_link: str
    lo: np.ndarray
    hi: np.ndarray
    mass: float
    # (joint name, type, child link, lower, upper, front-centre and rotation in link frame)
    joints: tuple[tuple[str, str, str, float, float, np.ndarray, np.ndarray], ...]


_MEASURED: dict[tuple[str, tuple[float, float, float]], Measurement] = {}


def measure(path: str, rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Measurement:
    """Parse, check and measure a file (memoised: PyBullet runs once per file)."""
    key = (str(path), float3(rpy))
    if key in _MEASURED:
        return _MEASURED[key]
    from momakitchen.bullet import p as pb

    file = Path(path)
    root = _parse(file)
    _absolute_meshes(root, file)
    root_link = _root_link(root, file)
    probe = cached_urdf(_wrapper(root, root_link, np.zeros(3), rpy), "external-probe")
    client = pb.connect(pb.DIRECT)
    try:
        try:
            body = pb.loadURDF(str(probe), useFixedBase=True, physicsClientId=client)
        except pb.error as exc:
            raise MomaError(
                f"external asset {str(path)!r}: PyBullet cannot load it ({exc})"
            ) from None
        n = pb.getNumJoints(body, physicsClientId=client)
        # links without collision shapes (our wrapper root, PartNet's empty base) report a
        # box around their origin: leave them out
        boxes = [
            pb.getAABB(body, k, physicsClientId=client)
            for k in range(-1, n)
            if pb.getCollisionShapeData(body, k, physicsClientId=client)
        ]
        if not boxes:
            raise MomaError(f"external asset {str(path)!r}: has no collision geometry")
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
            state = pb.getLinkState(body, k, computeForwardKinematics=True, physicsClientId=client)
            rot = np.asarray(pb.getMatrixFromQuaternion(state[5])).reshape(3, 3)
            local = rot.T @ (front - np.asarray(state[4]))
            kind = "revolute" if info[2] == pb.JOINT_REVOLUTE else "prismatic"
            joints.append(
                (
                    info[1].decode(),
                    kind,
                    info[12].decode(),
                    float(info[8]),
                    float(info[9]),
                    local,
                    rot,
                )
            )
    finally:
        pb.disconnect(client)
    m = Measurement(root, root_link, lo, hi, float(mass), tuple(joints))
    _MEASURED[key] = m
    return m


# ----------------------------------------------------------------------------- building


def _scale(params: ExternalParams, kind: str, size: np.ndarray) -> float:
    if params.scale > 0:
        return params.scale
    if kind in ("furniture", "appliance") and params.envelope is not None:
        return float(np.min(np.asarray(params.envelope) / size))
    scale = 1.0
    if params.target > 0 and params.category in TYPICAL_SIZE:
        dim = TYPICAL_SIZE[params.category][0]
        scale = float(params.target / (size[2] if dim == "height" else size.max()))
    if params.category in HAND_SIZED:
        # these targets are graspable by definition: keep the narrow side within the gripper
        scale = min(scale, 0.95 * MAX_GRASP_WIDTH / float(min(size[0], size[1])))
    return scale


def _object_grasps(size: tuple[float, float, float]) -> tuple[GraspFrame, ...]:
    """Grasps across the bounding box of an external rigid object, where it fits."""
    w, d, h = size
    out = []
    if d <= MAX_GRASP_WIDTH:
        out.append(
            GraspFrame(
                ROOT_LINK, (w / 2, 0.0, h / 2), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), d, "side+x"
            )
        )
    if w <= MAX_GRASP_WIDTH:
        out.append(
            GraspFrame(
                ROOT_LINK, (0.0, d / 2, h / 2), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), w, "side+y"
            )
        )
    if min(w, d) <= MAX_GRASP_WIDTH:
        closing = (1.0, 0.0, 0.0) if w <= d else (0.0, 1.0, 0.0)
        out.append(GraspFrame(ROOT_LINK, (0.0, 0.0, h), (0.0, 0.0, 1.0), closing, min(w, d), "top"))
    else:
        # too wide for the gripper (a pot): straddle the rim at the +x edge from above
        out.append(
            GraspFrame(
                ROOT_LINK, (w / 2 - 0.015, 0.0, h), (0.0, 0.0, 1.0), (1.0, 0.0, 0.0), 0.03, "rim+x"
            )
        )
    return tuple(out)


def build_external(params: ExternalParams) -> AssetModel:
    """Build an :class:`AssetModel` from an external URDF file (see the module docstring)."""
    if params.category not in CATEGORIES:
        raise MomaError(f"external asset {params.path!r}: unknown category {params.category!r}")
    kind = CATEGORIES[params.category].kind
    m = measure(params.path, params.rpy)
    size = m.hi - m.lo
    if np.any(size <= 0):
        raise MomaError(f"external asset {params.path!r}: has no collision geometry")
    scale = _scale(params, kind, size)
    # our origin: furniture/appliance at the centre of the back edge on the floor, others at
    # the centre of the footprint, bottom of the object
    if kind in ("furniture", "appliance"):
        anchor = np.array([(m.lo[0] + m.hi[0]) / 2, m.lo[1], m.lo[2]])
    else:
        anchor = np.array([(m.lo[0] + m.hi[0]) / 2, (m.lo[1] + m.hi[1]) / 2, m.lo[2]])
    text = _wrapper(m.text, m.root_link, -anchor, params.rpy)
    file = cached_urdf(text, f"external-{params.category}")
    arts = []
    for name, jtype, child, lower, upper, local, rot in m.joints:
        grasp = GraspFrame(
            child,
            tuple(float(v) for v in local * scale),  # type: ignore[arg-type]
            tuple(float(v) for v in rot.T @ (0.0, 1.0, 0.0)),  # type: ignore
            tuple(float(v) for v in rot.T @ (0.0, 0.0, 1.0)),  # type: ignore
            0.03,
            "handle",
        )
        direction = 1 if upper >= -lower else -1
        travel = (upper if direction > 0 else -lower) * (scale if jtype == "prismatic" else 1.0)
        part = "door" if jtype == "revolute" else "drawer"
        arts.append(Articulation(name, jtype, part, grasp, direction, float(travel)))
    scaled = tuple(round(float(v), 6) for v in size * scale)
    w, d, h = scaled
    areas: tuple[Rect, ...] = ()
    if kind == "furniture" and params.category != "fridge":
        areas = (Rect(-w / 2 + 0.01, w / 2 - 0.01, 0.01, d - 0.01, h),)
    grasps = _object_grasps(scaled) if kind == "rigid" else ()  # type: ignore[arg-type]
    return AssetModel(
        category=params.category,
        urdf=text,
        size=scaled,  # type: ignore[arg-type]
        mass=round(m.mass * scale**3, 6),
        grasps=grasps,
        articulations=tuple(arts),
        placement_areas=areas,
        path=str(file),
        scale=scale,
    )


# ----------------------------------------------------------------------------- registry


_REGISTERED: dict[str, tuple[ExternalAsset, ...]] = {}
_SHARE: list[float] = [0.5]


def register_external_assets(root: str | Path, share: float = 0.5) -> list[ExternalAsset]:
    """Let the categories draw ``share`` of their instances from the folder ``root``.

    Every file is parsed, checked and measured now, so a broken one fails here with a
    :class:`MomaError` naming it. Replaces any folder registered before.
    """
    if not 0.0 < share <= 1.0:
        raise MomaError(f"external asset share must be in (0, 1], got {share}")
    assets = scan_folder(root)
    if not assets:
        raise MomaError(
            f"external asset folder {str(root)!r} holds no "
            f"<category>/<id>/{URDF_NAME} of a known category"
        )
    for a in assets:
        measure(a.path)
    by_category: dict[str, list[ExternalAsset]] = {}
    for a in assets:
        by_category.setdefault(a.category, []).append(a)
    _REGISTERED.clear()
    _REGISTERED.update({k: tuple(v) for k, v in by_category.items()})
    _SHARE[0] = share
    return assets


def clear_external_assets() -> None:
    """Back to procedural instances only."""
    _REGISTERED.clear()


def registered(category: str) -> tuple[ExternalAsset, ...]:
    return _REGISTERED.get(category, ())


def sample_external(
    assets: list[ExternalAsset] | tuple[ExternalAsset, ...],
    category: str,
    rng: np.random.Generator,
    envelope: Envelope | None = None,
) -> ExternalParams:
    """Pick one external asset of ``category`` uniformly, with a target size (objects) or
    the envelope (furniture, appliances). Pure data."""
    pool = [a for a in assets if a.category == category]
    if not pool:
        raise MomaError(f"no external asset of category {category!r}")
    asset = pool[int(rng.integers(len(pool)))]
    env = None if envelope is None else (envelope.width, envelope.depth, envelope.height)
    target = 0.0
    if category in TYPICAL_SIZE:
        _, lo, hi = TYPICAL_SIZE[category]
        target = round(float(rng.uniform(lo, hi)), 4)
    return ExternalParams(category=category, path=asset.path, target=target, envelope=env)


def maybe_sample(
    category: str, rng: np.random.Generator, envelope: Envelope | None
) -> ExternalParams | None:
    """An external draw for ``share`` of the calls when the category has registered assets;
    None (and no random numbers consumed) otherwise."""
    pool = _REGISTERED.get(category)
    if not pool or rng.random() >= _SHARE[0]:
        return None
    return sample_external(pool, category, rng, envelope)


def load_folder(root: str | Path) -> list[AssetModel]:
    """Build every asset of a folder at its natural scale (1.0); raises a MomaError naming
    the first broken file."""
    return [
        build_external(ExternalParams(a.category, a.path, scale=1.0)) for a in scan_folder(root)
    ]
