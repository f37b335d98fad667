"""The one registry of models: NavAff, its ablations and the baselines, by name."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from momakitchen.models.base import AffordanceModel, Backbone
from momakitchen.models.baselines import H3DNetBackbone, PointNet2Backbone, VoteNetBackbone
from momakitchen.models.config import ModelConfig
from momakitchen.models.navaff import NavAffBackbone
from momakitchen.registry import Registry


@dataclass(frozen=True)
class ModelEntry:
    """A registered model.

    Attributes:
        name: registry key.
        build_backbone: ``ModelConfig -> Backbone``.
        head_uses_robot: whether the head is always conditioned on the robot descriptor
            (the baselines; NavAff reads the robot through its attention tokens instead,
            and through its head too with ``ModelConfig.robot_head``).
        description: one line for listings and docs.
        unused_config: ``ModelConfig`` fields the architecture never reads, so a run may
            resume under a preset that has changed them since.
    """

    name: str
    build_backbone: Callable[[ModelConfig], Backbone]
    head_uses_robot: bool
    description: str
    unused_config: frozenset[str] = frozenset()


MODELS: Registry[ModelEntry] = Registry("model")


def register_model(entry: ModelEntry, *, replace: bool = False) -> ModelEntry:
    """Add a model to the registry; refuses to silently replace an existing name."""
    return MODELS.register(entry, replace=replace)


def model_names() -> tuple[str, ...]:
    """Registered model names, in registration order."""
    return MODELS.names()


def get_model_entry(name: str) -> ModelEntry:
    """The entry of model ``name``; MomaError naming it and listing the known models."""
    return MODELS.get_entry(name)


def build_model(name: str, config: ModelConfig | None = None) -> AffordanceModel:
    """Build a registered model (backbone + head + weighted-MSE loss)."""
    entry = get_model_entry(name)
    cfg = config if config is not None else ModelConfig()
    head_robot = entry.head_uses_robot or (
        cfg.robot_head and "robot_head" not in entry.unused_config
    )
    return AffordanceModel(name, cfg, entry.build_backbone(cfg), head_robot)


# The baselines have no attention and no separate floor encoder; their head always
# reads the robot.
_BASELINE_UNUSED = frozenset(
    {
        "embed_dim",
        "num_heads",
        "num_robot_tokens",
        "attention_layers",
        "floor_npoints",
        "robot_head",
    }
)
for _entry in (
    ModelEntry("navaff", NavAffBackbone, False, "NavAff (visual alignment, global + robot keys)"),
    ModelEntry(
        "pointnet2", PointNet2Backbone, True, "PointNet++ segmentation baseline", _BASELINE_UNUSED
    ),
    ModelEntry(
        "votenet",
        VoteNetBackbone,
        True,
        "VoteNet-style (voting kept, no box heads)",
        _BASELINE_UNUSED,
    ),
    ModelEntry(
        "h3dnet",
        H3DNetBackbone,
        True,
        "H3DNet-style (primitives kept, no box heads)",
        _BASELINE_UNUSED,
    ),
    ModelEntry(
        "navaff-no-robot",
        lambda c: NavAffBackbone(c, use_robot=False),
        False,
        "NavAff without robot tokens",
        frozenset({"robot_head"}),
    ),
    ModelEntry(
        "navaff-no-vam",
        lambda c: NavAffBackbone(c, use_alignment=False),
        False,
        "NavAff without visual alignment (target channel, floor-to-target offsets)",
    ),
    ModelEntry(
        "navaff-no-global",
        lambda c: NavAffBackbone(c, use_global=False),
        False,
        "NavAff without the global cloud (robot tokens as keys, no target cue)",
    ),
):
    register_model(_entry)
