"""The generation config: everything that determines a scene's generated data.

It is recorded in each dataset's manifest, so readers (``check``, ``stats``, MSR) rebuild
it from there; it is plain data and loads no simulator.

:data:`PRESETS` names frozen overrides of the defaults (``momakitchen generate --preset``);
:func:`preset_config` builds one, with a config file's fields on top, and the config
records the preset's name (``GenerationConfig.preset``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from momakitchen import codec
from momakitchen.data.coverage import COVERAGE_RADIUS
from momakitchen.errors import MomaError
from momakitchen.perception.camera import CameraConfig
from momakitchen.perception.clouds import CloudConfig
from momakitchen.scene.configuration import SceneConfig
from momakitchen.sim.config import DenseMapConfig, TrialConfig


@dataclass(frozen=True)
class ViewConfig:
    """Viewpoint sampling (metres).

    Attributes:
        episodes: views per configuration.
        lateral: range of the sideways offset from the target (alternating sides).
        forward: range of the distance in front of the target (increasing over episodes).
        min_target_pixels: a view is kept only if this many pixels show the target.
        max_tries: attempts per view before the configuration gives up on it.
        target_row: the head camera turns toward the target and pitches down so that the
            target appears this far down the image (fraction of its height; 0.5 centres
            it): the floor in front of the target, where the robot would stand, is in view.
        coverage_radius: a view of a configuration with successful trials is kept only
            if its floor cloud comes this close to a successful trial position; while
            views fail this, later attempts stand farther back (0: no check).
        max_distance: the camera stands at most this far from the target (m; a depth
            sensor's working range, see ``momakitchen robustness --list``; 0: no limit).
        distance: with an upper bound above 0, views are placed by their distance from
            the target (stratified over this range, increasing over episodes) and their
            direction (uniform within ``max_angle`` degrees of the target's front,
            alternating sides), as a driven robot's starts are, instead of by ``forward``
            and ``lateral``: in a room 3.6-5 m deep, only a view from the side stands
            more than about 4 m away. (0, 0): off.
        max_angle: see ``distance``.
        far_share: with ``distance`` on, at least this share of a configuration's views
            (the last ones) stand ``far_from`` m or more from the target wherever the room
            holds such a viewpoint (within ``max_angle`` of the target's front, the base
            inside the room and clear of furniture and obstacles); the others are
            stratified below ``far_from``. Where the room holds none, the views are placed
            as without it. 0: off (stratified over the whole range).
        far_from: see ``far_share`` (3.8 m: where the driven track's far starts begin).
    """

    episodes: int = 10
    lateral: tuple[float, float] = (0.0, 1.5)
    forward: tuple[float, float] = (1.5, 3.8)
    min_target_pixels: int = 20
    max_tries: int = 40
    target_row: float = 0.15
    coverage_radius: float = COVERAGE_RADIUS
    max_distance: float = 0.0
    distance: tuple[float, float] = field(default=(0.0, 0.0), metadata=codec.OMIT_IF_DEFAULT)
    max_angle: float = field(default=45.0, metadata=codec.OMIT_IF_DEFAULT)
    far_share: float = field(default=0.0, metadata=codec.OMIT_IF_DEFAULT)
    far_from: float = field(default=3.8, metadata=codec.OMIT_IF_DEFAULT)

    @property
    def farthest(self) -> float:
        """The farthest a view stands from its target (m), on the floor."""
        if self.distance[1] > 0:
            return float(self.distance[1])
        return math.hypot(self.forward[1], self.lateral[1])

    def __post_init__(self) -> None:
        lo, hi = self.distance
        if (lo, hi) != (0.0, 0.0) and not 0.5 <= lo <= hi <= 10:
            raise MomaError(
                f"views.distance must be (0, 0) (off) or satisfy 0.5 <= min <= max <= 10 m, "
                f"got {self.distance}"
            )
        if not (math.isfinite(self.max_angle) and 0.0 <= self.max_angle <= 90.0):
            raise MomaError(f"views.max_angle must be in [0, 90] degrees, got {self.max_angle!r}")
        if not (math.isfinite(self.far_share) and 0.0 <= self.far_share <= 1.0):
            raise MomaError(f"views.far_share must be in [0, 1], got {self.far_share!r}")
        if self.far_share > 0 and not lo < self.far_from < hi:
            raise MomaError(
                f"views.far_share needs views.distance on and views.far_from inside it: "
                f"far_from {self.far_from!r}, distance {self.distance}"
            )
        if self.max_distance != 0.0 and not 1.0 <= self.max_distance <= 20.0:
            raise MomaError(
                f"views.max_distance must be 0 (no limit) or in [1, 20] m, got {self.max_distance}"
            )
        if not 1 <= self.episodes <= 100:
            raise MomaError(f"episodes per configuration must be in [1, 100], got {self.episodes}")
        for name in ("lateral", "forward"):
            lo, hi = getattr(self, name)
            if not 0 <= lo <= hi <= 10:
                raise MomaError(f"{name} must satisfy 0 <= min <= max <= 10 m, got {(lo, hi)}")
        if self.min_target_pixels < 1 or self.max_tries < 1:
            raise MomaError("min_target_pixels and max_tries must be >= 1")
        if not 0.02 <= self.target_row <= 0.98:
            raise MomaError(f"target_row must be in [0.02, 0.98], got {self.target_row}")
        if not 0.0 <= self.coverage_radius <= 1.0:
            raise MomaError(f"coverage_radius must be in [0, 1] m, got {self.coverage_radius}")


@dataclass(frozen=True)
class GenerationConfig:
    """Everything that determines the generated data of a scene (with its ``scene_id``).

    ``preset`` names the :data:`PRESETS` entry the values started from ("": the defaults;
    written only when set, so a default dataset's manifest keeps its bytes). It is a
    record, not a switch: the sections hold the values (:func:`preset_config` sets both).
    """

    scene: SceneConfig = field(default_factory=SceneConfig)
    trial: TrialConfig = field(default_factory=TrialConfig)
    dense: DenseMapConfig = field(default_factory=DenseMapConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    views: ViewConfig = field(default_factory=ViewConfig)
    cloud: CloudConfig = field(default_factory=CloudConfig)
    preset: str = field(default="", metadata=codec.OMIT_IF_DEFAULT)

    def __post_init__(self) -> None:
        if self.preset and self.preset not in PRESETS:
            raise MomaError(f"preset: {unknown_preset(self.preset)}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready sections (see :func:`momakitchen.codec.to_dict`)."""
        return codec.to_dict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, where: str = "config") -> GenerationConfig:
        """Inverse of :meth:`to_dict`: any subset of sections and fields, the rest default
        (see :func:`momakitchen.codec.from_dict`)."""
        return codec.from_dict(cls, data, where=where)


def _frozen(data: Mapping[str, Any]) -> Mapping[str, Any]:
    return MappingProxyType(
        {k: _frozen(v) if isinstance(v, Mapping) else v for k, v in data.items()}
    )


# Named generation presets: overrides of the defaults, by section and field (as a config
# file writes them). Frozen: a dataset's manifest names its preset, and the name must keep
# meaning the same values (tests/data/test_presets.py pins them).
PRESETS: Mapping[str, Mapping[str, Any]] = _frozen(
    {
        "default": {},
        # The cases of MoMa-Kitchen's figure 1, where geometry is a weak guide to where the
        # base stops, as scene properties (docs/DATASET.md, "Presets", with the measured
        # figures): an obstacle where a base facing the target would stop, more
        # articulated targets, weighted towards doors that swing over the floor and
        # handles low or high, objects deeper on the counter, and every registered arm
        # (reach 0.63-1.30 m) at mounts drawn over 0.3-1.3 m.
        "hard": {
            "scene": {
                "obstacles": (1, 3),
                "stance_obstacles": 1,
                "stance_band": (0.5, 0.8),
                "rigid_target_prob": 0.25,
                "hard_part_weight": 3.0,
                "object_depth": 0.45,
                "robots": (
                    "panda",
                    "flexiv",
                    "ur5e",
                    "xarm6",
                    "realman",
                    "elephant",
                    "ur10e",
                    "gen3",
                ),
                "mount_height": (0.3, 1.3),
            },
        },
    }
)


def unknown_preset(name: str) -> str:
    """The one-line message for a preset name that :data:`PRESETS` lacks."""
    return f"unknown preset {name!r}; known presets: {', '.join(PRESETS)}"


def preset_config(
    name: str = "default", overrides: Mapping[str, Any] | None = None, *, where: str = "config"
) -> GenerationConfig:
    """The generation config of preset ``name`` with ``overrides`` (sections and fields, as
    a config file holds them; e.g. ``{"views": {"episodes": 2}}``) on top, field by field.

    ``GenerationConfig.preset`` records ``name`` ("" for ``default``, whose datasets are
    those made without a preset). MomaError for an unknown preset (naming the known ones),
    an ``overrides`` that sets ``preset`` itself, or a bad field (``where`` names it).
    """
    if name not in PRESETS:
        raise MomaError(unknown_preset(name))
    data = dict(overrides or {})
    if "preset" in data:
        raise MomaError(
            f"{where}: 'preset' is not a field to set: name the preset (generate --preset NAME)"
        )
    merged = codec.merge(PRESETS[name], data)
    merged["preset"] = "" if name == "default" else name
    return GenerationConfig.from_dict(merged, where=where)


# The config class whose manifests record how clouds were built (see manifest_preprocessing).
GENERATION_CONFIG_CLASS = f"{GenerationConfig.__module__}.{GenerationConfig.__qualname__}"


@dataclass(frozen=True)
class Preprocessing:
    """How an episode's clouds are built from its RGB-D frame: what a trained model depends
    on besides its weights (recorded in checkpoints, compared with datasets).

    Attributes:
        cloud: voxel sizes and the floor height threshold.
        max_depth: pixels farther than this (m) are left out of the clouds.
    """

    cloud: CloudConfig = field(default_factory=CloudConfig)
    max_depth: float = CameraConfig().max_depth

    def __post_init__(self) -> None:
        if not (math.isfinite(self.max_depth) and self.max_depth > 0):
            raise MomaError(
                f"Preprocessing.max_depth must be a positive number of metres, "
                f"got {self.max_depth!r}"
            )

    def describe(self) -> str:
        """One line naming every value (for messages)."""
        c = self.cloud
        return (
            f"voxel={c.voxel}, floor_voxel={c.floor_voxel}, floor_z={c.floor_z}, "
            f"max_depth={self.max_depth}"
        )


def manifest_preprocessing(manifest: dict[str, Any]) -> Preprocessing | None:
    """The preprocessing recorded in a dataset manifest's generation config (missing fields
    default), or None if the dataset's producer records none (e.g. synthetic records).

    Only the ``cloud`` and ``camera`` sections are read, so a manifest need not hold a
    complete, current generation config.
    """
    if manifest.get("config_class") != GENERATION_CONFIG_CLASS:
        return None
    config = manifest.get("config")
    if not isinstance(config, dict):
        raise MomaError(f"manifest 'config' must be a mapping, got {config!r}")
    cloud = codec.from_dict(CloudConfig, config.get("cloud", {}), where="config.cloud")
    camera = config.get("camera", {})
    if not isinstance(camera, dict):
        raise MomaError(f"manifest config.camera must be a mapping, got {camera!r}")
    max_depth = codec.from_dict(CameraConfig, camera, where="config.camera").max_depth
    return Preprocessing(cloud, max_depth)


def manifest_view_distance(manifest: dict[str, Any]) -> float | None:
    """How far (m) from its target the farthest view of a dataset stands at most, from its
    manifest's ``views`` (:attr:`ViewConfig.farthest`); None if the dataset's producer
    records no generation config (e.g. synthetic records)."""
    if manifest.get("config_class") != GENERATION_CONFIG_CLASS:
        return None
    config = manifest.get("config")
    views = config.get("views", {}) if isinstance(config, dict) else None
    if not isinstance(views, dict):
        raise MomaError(f"manifest config.views must be a mapping, got {views!r}")
    return codec.from_dict(ViewConfig, views, where="config.views").farthest
