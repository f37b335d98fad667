"""The one registry of models: NavAff, its ablations and the baselines, by name, and
models defined outside the package (:mod:`momakitchen.models.plugins`), found on first use
by an entry-point name or a ``package.module:ClassName`` path."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

from momakitchen.errors import MomaError
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
        build_backbone: ``ModelConfig -> Backbone`` (a plug-in network with ``plugin``).
        head_uses_robot: whether the head is always conditioned on the robot descriptor
            (the baselines; NavAff reads the robot through its attention tokens instead,
            and through its head too with ``ModelConfig.robot_head``).
        description: one line for listings and docs.
        unused_config: ``ModelConfig`` fields the architecture never reads, so a run may
            resume under a preset that has changed them since.
        plugin: ``build_backbone`` makes a whole network that returns the affordance
            (B, Nf) itself, wrapped in :class:`~momakitchen.models.plugins.PluginModel`.
    """

    name: str
    build_backbone: Callable[[ModelConfig], Backbone]
    head_uses_robot: bool
    description: str
    unused_config: frozenset[str] = frozenset()
    plugin: bool = False


MODELS: Registry[ModelEntry] = Registry("model")
# Plug-in models already looked up in this process (kept apart from MODELS, whose names
# are those every installation has).
PLUGINS: dict[str, ModelEntry] = {}


def register_model(entry: ModelEntry, *, replace: bool = False) -> ModelEntry:
    """Add a model to the registry; refuses to silently replace an existing name."""
    return MODELS.register(entry, replace=replace)


def model_names() -> tuple[str, ...]:
    """Registered model names, in registration order (plug-ins not included: see
    :func:`momakitchen.models.plugins.plugin_names`)."""
    return MODELS.names()


def get_model_entry(name: str) -> ModelEntry:
    """The entry of model ``name``: a built-in one, else a plug-in found by its
    ``package.module:ClassName`` path or its entry point (group ``momakitchen.models``),
    registered on first use. MomaError naming it and listing the known models when there
    is none, or when the plug-in fails to import, is no model class, or claims a built-in
    name. A plug-in is imported once per process."""
    from momakitchen.models import plugins

    if not isinstance(name, str) or not name:
        raise MomaError(f"model name must be a non-empty string, got {name!r}")
    entry = MODELS.get(name)
    if entry is not None:
        if name in BUILTIN_MODELS:
            plugins.check_no_clash(name)
        return entry
    if name in PLUGINS:
        return PLUGINS[name]
    obj = plugins.load_plugin(name)
    if obj is None:
        known = [*BUILTIN_MODELS, *plugins.plugin_names()]
        raise MomaError(
            f"unknown model {name!r}; known models: {', '.join(known)} (or "
            "package.module:ClassName, see docs/METHODS.md)"
        )
    build, is_backbone, description = plugins.plugin_class(name, obj)
    # A Backbone gets the built-in head (robot-conditioned, as the baselines'); any other
    # module is the whole network (plugin=True).
    # (build_backbone's type names the built-in case; with plugin=True it is any module.)
    builder = cast(Callable[[ModelConfig], Backbone], build)
    PLUGINS[name] = ModelEntry(name, builder, is_backbone, description, plugin=not is_backbone)
    return PLUGINS[name]


def is_plugin(name: str) -> bool:
    """Whether model ``name`` is a plug-in (found outside the package)."""
    get_model_entry(name)
    return name in PLUGINS


def refresh_plugins() -> None:
    """Forget the entry points and plug-ins read so far (after installing or removing a
    distribution in-process)."""
    import importlib

    from momakitchen.models import plugins

    importlib.invalidate_caches()
    plugins.entry_points.cache_clear()
    PLUGINS.clear()


def build_model(name: str, config: ModelConfig | None = None) -> AffordanceModel:
    """Build a registered model (backbone + head + weighted-MSE loss)."""
    entry = get_model_entry(name)
    cfg = config if config is not None else ModelConfig()
    head_robot = entry.head_uses_robot or (
        cfg.robot_head and "robot_head" not in entry.unused_config
    )
    if entry.plugin:
        from momakitchen.models.plugins import PluginModel

        return PluginModel(name, cfg, entry.build_backbone(cfg))
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

# The names shipped with the package (a plug-in may not reuse one).
BUILTIN_MODELS = MODELS.names()


def check_loadable(name: str, where: str) -> None:
    """MomaError, in one line, unless model ``name`` (of a run: ``where`` names it, e.g.
    ``checkpoint 'runs/mine'``) can be built here: for a plug-in whose module does not
    import, the module and the import's error; for a name neither built in nor installed,
    what the registry says. Checked before the run's training config, whose errors would
    otherwise read as a bad config."""
    from momakitchen.models.plugins import PluginImportError

    try:
        get_model_entry(name)
    except PluginImportError as exc:
        raise MomaError(
            f"{where} was trained with the plug-in model {name!r}, whose module "
            f"{exc.module!r} cannot be imported here ({exc.reason}): install the package "
            "that provides it where the run is loaded"
        ) from None
    except MomaError as exc:
        if "unknown model" not in str(exc):
            raise
        raise MomaError(
            f"{where} was trained with model {name!r}, not installed here: {exc}"
        ) from None
