"""Models defined outside the package: found by name and used like the built-in ones.

A plug-in is a ``torch.nn.Module`` class whose constructor takes a
:class:`~momakitchen.models.config.ModelConfig` and whose ``forward`` maps a batch (the
contract of :mod:`momakitchen.data.batch`) to the affordance of every floor point:

Shapes:
    - input: ``batch["global_xyz"]`` (B, Ng, 3), ``global_rgb`` (B, Ng, 3),
      ``global_align`` (B, Ng), ``global_mask`` (B, Ng), ``floor_xyz`` (B, Nf, 3),
      ``floor_mask`` (B, Nf), ``robot`` (B, D); at inference also ``context_xyz``
      (B, Nc, 3) / ``context_mask`` (B, Nc), the floor at the training density
    - output: (B, Nf) float in [0, 1]

The package masks padded floor points, adds the weighted-MSE loss of the config, checks the
output's shape and range, and runs MC dropout through the module's ``nn.Dropout`` layers.
A class derived from :class:`~momakitchen.models.base.Backbone` (per-point features
(B, Nf, ``out_channels``)) gets the built-in per-point head instead, robot-conditioned as
the baselines' head is.

Two ways to name one, in ``train --model`` and so in the checkpoint's ``config.json``:

- ``package.module:ClassName``: imported as written;
- an entry point of the group ``momakitchen.models`` of an installed distribution
  (``[project.entry-points."momakitchen.models"] mymodel = "package.module:ClassName"``).
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import inspect
from collections.abc import Callable
from typing import Any

import torch
from torch import nn

from momakitchen.errors import MomaError
from momakitchen.models.base import AffordanceModel, Backbone
from momakitchen.models.config import ModelConfig
from momakitchen.models.loss import WeightedMSELoss

GROUP = "momakitchen.models"


class PluginImportError(MomaError):
    """A plug-in model whose module cannot be imported: ``model`` the name it was asked
    by, ``module`` the module that failed, ``reason`` the import's error in one line."""

    def __init__(self, message: str, model: str, module: str, reason: str) -> None:
        super().__init__(message)
        self.model, self.module, self.reason = model, module, reason


def _one_line(exc: BaseException) -> str:
    text = " ".join(f"{type(exc).__name__}: {exc}".split())
    return text if len(text) < 200 else text[:197] + "..."


@functools.cache
def entry_points() -> dict[str, list[importlib.metadata.EntryPoint]]:
    """The installed entry points of :data:`GROUP`, by name (a name may be claimed by
    several distributions: an error when it is used). Read once per process (scanning the
    installed distributions takes tens of milliseconds);
    :func:`momakitchen.models.registry.refresh_plugins` reads them again.
    """
    found: dict[str, list[importlib.metadata.EntryPoint]] = {}
    for ep in importlib.metadata.entry_points(group=GROUP):
        found.setdefault(ep.name, []).append(ep)
    return found


def _origin(ep: importlib.metadata.EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    name = getattr(dist, "name", None) if dist is not None else None
    where = f" of distribution {name!r}" if name else ""
    return f"entry point {ep.name!r} = {ep.value!r}{where}"


def check_no_clash(name: str) -> None:
    """MomaError if an installed entry point claims the built-in model name ``name``."""
    eps = entry_points().get(name)
    if eps:
        raise MomaError(
            f"model name {name!r} of {_origin(eps[0])} clashes with the built-in model "
            f"{name!r}; rename the entry point (group {GROUP!r})"
        )


def plugin_names() -> tuple[str, ...]:
    """Names of the installed plug-in models (entry points of :data:`GROUP`), sorted."""
    return tuple(sorted(entry_points()))


def load_plugin(name: str) -> Any:
    """The object a plug-in name refers to (``package.module:Name`` or an entry-point
    name); MomaError naming it when it cannot be found or imported, or None when ``name``
    is neither a ``module:attribute`` path nor an installed entry point."""
    if ":" in name:
        module_name, _, attr = name.partition(":")
        if not module_name or not attr:
            raise MomaError(f"model {name!r}: expected package.module:ClassName")
        try:
            module = importlib.import_module(module_name)
        except Exception as exc:  # any import-time failure of foreign code
            reason = _one_line(exc)
            raise PluginImportError(
                f"model {name!r}: cannot import {module_name!r} ({reason})",
                name,
                module_name,
                reason,
            ) from None
        obj: Any = module
        for part in attr.split("."):
            if not hasattr(obj, part):
                raise MomaError(f"model {name!r}: module {module_name!r} has no {attr!r}")
            obj = getattr(obj, part)
        return obj
    eps = entry_points().get(name)
    if not eps:
        return None
    if len(eps) > 1:
        raise MomaError(
            f"model {name!r} is claimed by several entry points: "
            + "; ".join(_origin(ep) for ep in eps)
        )
    try:
        return eps[0].load()
    except Exception as exc:  # any import-time failure of foreign code
        reason = _one_line(exc)
        raise PluginImportError(
            f"model {name!r}: {_origin(eps[0])} fails to import ({reason})",
            name,
            eps[0].value.partition(":")[0],
            reason,
        ) from None


def plugin_class(name: str, obj: Any) -> tuple[Callable[[ModelConfig], nn.Module], bool, str]:
    """What the registry needs of the plug-in class ``obj`` found under ``name``: a builder
    ``ModelConfig -> module``, whether the class is a :class:`Backbone` (it then gets the
    built-in head) and a one-line description; MomaError unless it is a
    ``torch.nn.Module`` subclass."""
    if not (inspect.isclass(obj) and issubclass(obj, nn.Module)):
        raise MomaError(
            f"model {name!r} is {type(obj).__name__} {obj!r}, not a torch.nn.Module "
            "subclass taking a ModelConfig (see docs/METHODS.md)"
        )
    doc = (inspect.getdoc(obj) or obj.__name__).strip().splitlines()[0]
    description = str(getattr(obj, "description", doc))
    return _construct(name, obj), issubclass(obj, Backbone), description


def _construct(name: str, cls: type[nn.Module]) -> Callable[[ModelConfig], nn.Module]:
    def build(config: ModelConfig) -> nn.Module:
        try:
            module = cls(config)
        except Exception as exc:  # foreign constructor
            raise MomaError(
                f"model {name!r}: {cls.__name__}(ModelConfig) fails ({_one_line(exc)})"
            ) from None
        if isinstance(module, Backbone) and not isinstance(
            getattr(module, "out_channels", None), int
        ):
            raise MomaError(f"model {name!r}: a Backbone must set out_channels (an int)")
        return module

    return build


def probe_plugin(name: str, model: nn.Module, batch: dict[str, Any]) -> None:
    """Run ``model`` (plug-in ``name``, built) once on ``batch`` (a collated batch of a
    few episodes), so that one that does not follow the interface fails with one line
    before any work is written: MomaError naming it and what went wrong."""
    if not any(p.requires_grad for p in model.parameters()):
        raise MomaError(
            f"model {name!r} has no parameters to train; a method without weights is "
            "scored from a predictions file (docs/METHODS.md)"
        )
    model.eval()
    try:
        with torch.no_grad():
            pred = model(batch)["pred"]
    except MomaError:
        raise
    except Exception as exc:  # foreign code
        raise MomaError(f"model {name!r} fails on a batch ({_one_line(exc)})") from None
    if tuple(pred.shape) != tuple(batch["floor_xyz"].shape[:2]):  # a Backbone's head
        raise MomaError(f"model {name!r} gives maps of shape {tuple(pred.shape)}")


class PluginModel(AffordanceModel):
    """A plug-in network (per-floor-point affordance) wrapped as a registered model:
    ``model(batch)`` returns ``{"pred": (B, Nf)}`` (0 on padded floor points), plus
    ``loss`` and ``mse`` when the batch carries ``floor_label``.

    Its state dict is the network's under ``net.``; it has no head of its own.
    """

    def __init__(self, name: str, config: ModelConfig, net: nn.Module) -> None:
        # Not AffordanceModel.__init__: that builds a head, which a plug-in does not have
        # (unused parameters would also break DDP).
        nn.Module.__init__(self)
        self.name = name
        self.config = config
        self.net = net
        # The collators ask the backbone for its geometry plan: a plug-in has none.
        self.backbone = Backbone()
        self.criterion = WeightedMSELoss(
            config.lambda_zero,
            config.zero_weight_prob,
            kl_weight=config.kl_weight,
            peak_weight=config.peak_weight,
            peak_temperature=config.peak_temperature,
        )

    def _predict(self, batch: dict[str, Any]) -> torch.Tensor:
        inputs = {k: v for k, v in batch.items() if k not in ("floor_label", "plan")}
        pred = self.net(inputs)
        expected = tuple(batch["floor_xyz"].shape[:2])
        if not isinstance(pred, torch.Tensor) or tuple(pred.shape) != expected:
            got = tuple(pred.shape) if isinstance(pred, torch.Tensor) else type(pred).__name__
            raise MomaError(
                f"model {self.name!r} returned {got} for a batch of floor points "
                f"{expected}; forward(batch) must return (B, Nf) affordance in [0, 1]"
            )
        with torch.no_grad():
            real = pred.detach()[batch["floor_mask"]]
            if real.numel() and not (
                torch.isfinite(real).all() and real.min() >= 0 and real.max() <= 1
            ):
                raise MomaError(
                    f"model {self.name!r} returned values outside [0, 1] (min "
                    f"{float(real.min()):.4g}, max {float(real.max()):.4g}); end forward "
                    "with a sigmoid"
                )
        return pred * batch["floor_mask"].to(pred.dtype)

    def forward(self, batch: dict[str, Any]) -> dict[str, torch.Tensor]:
        pred = self._predict(batch)
        out = {"pred": pred}
        if "floor_label" in batch:
            out.update(self.criterion(pred, batch["floor_label"], batch["floor_mask"]))
        return out

    @torch.no_grad()
    def sample_predictions(self, batch: dict[str, Any], samples: int) -> torch.Tensor:
        """``samples`` predictions of one episode with the network's dropout layers active
        (everything else, e.g. batch norm, in eval mode). Shapes: (samples, Nf)."""
        if batch["floor_xyz"].shape[0] != 1:
            raise ValueError("sample_predictions takes a batch of one episode")
        was_training = self.training
        try:
            self.eval()
            for m in self.net.modules():
                if isinstance(m, nn.modules.dropout._DropoutNd):
                    m.train()
            return torch.cat([self._predict(batch) for _ in range(samples)])
        finally:
            self.train(was_training)
