"""The generation config: everything that determines a scene's generated data.

It is recorded in each dataset's manifest, so readers (``check``, ``stats``, MSR) rebuild
it from there; it is plain data and loads no simulator.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

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
    """

    episodes: int = 10
    lateral: tuple[float, float] = (0.0, 1.5)
    forward: tuple[float, float] = (1.5, 3.8)
    min_target_pixels: int = 20
    max_tries: int = 40

    def __post_init__(self) -> None:
        if not 1 <= self.episodes <= 100:
            raise MomaError(f"episodes per configuration must be in [1, 100], got {self.episodes}")
        for name in ("lateral", "forward"):
            lo, hi = getattr(self, name)
            if not 0 <= lo <= hi <= 10:
                raise MomaError(f"{name} must satisfy 0 <= min <= max <= 10 m, got {(lo, hi)}")
        if self.min_target_pixels < 1 or self.max_tries < 1:
            raise MomaError("min_target_pixels and max_tries must be >= 1")


@dataclass(frozen=True)
class GenerationConfig:
    """Everything that determines the generated data of a scene (with its ``scene_id``)."""

    scene: SceneConfig = field(default_factory=SceneConfig)
    trial: TrialConfig = field(default_factory=TrialConfig)
    dense: DenseMapConfig = field(default_factory=DenseMapConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    views: ViewConfig = field(default_factory=ViewConfig)
    cloud: CloudConfig = field(default_factory=CloudConfig)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> GenerationConfig:
        def build(kind, values):
            return kind(**{k: tuple(v) if isinstance(v, list) else v for k, v in values.items()})

        kinds = {"scene": SceneConfig, "trial": TrialConfig, "dense": DenseMapConfig,
                 "camera": CameraConfig, "views": ViewConfig, "cloud": CloudConfig}
        unknown = set(data) - set(kinds)
        if unknown:
            raise MomaError(f"unknown generation config section(s): {sorted(unknown)}")
        return cls(**{k: build(kinds[k], v) for k, v in data.items()})
