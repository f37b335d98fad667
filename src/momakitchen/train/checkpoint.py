"""Checkpoints: safetensors weights + JSON config; never a pickled model.

A run directory holds:

- ``config.json``: format, model name, preset, the full :class:`TrainConfig`, the robot
  descriptor version and names;
- ``model.safetensors``: the model's ``state_dict`` after the last finished epoch;
- ``trainer_state.safetensors`` + ``trainer_state.json``: optimiser moments, RNG state,
  epoch, step and history, for resuming;
- ``log.csv`` and ``loss_curve.png``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load as st_load
from safetensors.torch import save as st_save

from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_bytes, atomic_write_text
from momakitchen.models.base import AffordanceModel
from momakitchen.models.registry import build_model
from momakitchen.robots.spec import DESCRIPTOR_NAMES, DESCRIPTOR_VERSION
from momakitchen.train.config import TrainConfig

FORMAT = "momakitchen-checkpoint"
FORMAT_VERSION = 1
CONFIG_FILE = "config.json"
WEIGHTS_FILE = "model.safetensors"
STATE_FILE = "trainer_state.safetensors"
STATE_JSON = "trainer_state.json"
# The checkpoint shipped inside the package (see its CARD.md).
DEFAULT_CHECKPOINT = Path(__file__).resolve().parent.parent / "checkpoints" / "navaff"


def default_checkpoint() -> Path:
    """The bundled NavAff run directory."""
    if not (DEFAULT_CHECKPOINT / "model.safetensors").is_file():
        raise MomaError(f"the bundled checkpoint is missing from {DEFAULT_CHECKPOINT}; "
                        "pass a run directory from `momakitchen train`")
    return DEFAULT_CHECKPOINT


def write_run_config(run_dir: Path, config: TrainConfig) -> None:
    info = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "model": config.model,
        "preset": config.preset,
        "descriptor_version": DESCRIPTOR_VERSION,
        "descriptor_names": list(DESCRIPTOR_NAMES),
        "train_config": config.to_dict(),
    }
    atomic_write_text(Path(run_dir) / CONFIG_FILE, json.dumps(info, indent=2) + "\n")


def read_run_config(run_dir: Path) -> tuple[TrainConfig, dict[str, Any]]:
    """Read and check ``config.json`` of a run; MomaError if missing or incompatible."""
    path = Path(run_dir) / CONFIG_FILE
    if not Path(run_dir).is_dir():
        raise MomaError(f"checkpoint directory {str(run_dir)!r} does not exist")
    if not path.is_file():
        raise MomaError(f"{str(run_dir)!r} is not a run directory: {CONFIG_FILE} is missing")
    try:
        info = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise MomaError(f"cannot read {path}: {exc}") from None
    if info.get("format") != FORMAT:
        raise MomaError(f"{path} is not a momakitchen checkpoint config")
    if info.get("descriptor_version") != DESCRIPTOR_VERSION:
        raise MomaError(
            f"checkpoint {str(run_dir)!r} uses robot descriptor version "
            f"{info.get('descriptor_version')}, this version of momakitchen uses "
            f"{DESCRIPTOR_VERSION}"
        )
    return TrainConfig.from_dict(info["train_config"]), info


def save_weights(path: Path, model: torch.nn.Module) -> None:
    state = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    atomic_write_bytes(Path(path), st_save(state, metadata={"format": FORMAT}))


def load_weights(path: Path, model: torch.nn.Module) -> None:
    path = Path(path)
    if not path.is_file():
        raise MomaError(f"checkpoint weights {str(path)!r} are missing")
    state = st_load(path.read_bytes())
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        first = str(exc).splitlines()[0]
        raise MomaError(f"weights in {str(path)!r} do not fit the model: {first}") from None


def save_trainer_state(
    run_dir: Path, optimizer: torch.optim.Optimizer, progress: dict[str, Any]
) -> None:
    """Optimiser tensors and the torch RNG into safetensors, the rest into JSON."""
    opt = optimizer.state_dict()
    tensors: dict[str, torch.Tensor] = {"rng.torch": torch.get_rng_state()}
    scalars: dict[str, dict[str, Any]] = {}
    for pid, st in opt["state"].items():
        for name, value in st.items():
            if isinstance(value, torch.Tensor):
                tensors[f"opt.{pid}.{name}"] = value.detach().cpu().contiguous()
            else:
                scalars.setdefault(str(pid), {})[name] = value
    groups = []
    for g in opt["param_groups"]:
        groups.append({k: (list(v) if isinstance(v, tuple) else v) for k, v in g.items()})
    atomic_write_bytes(Path(run_dir) / STATE_FILE, st_save(tensors))
    body = {"progress": progress, "param_groups": groups, "scalars": scalars}
    atomic_write_text(Path(run_dir) / STATE_JSON, json.dumps(body, indent=1) + "\n")


def load_trainer_state(run_dir: Path, optimizer: torch.optim.Optimizer) -> dict[str, Any]:
    """Restore the optimiser and the torch RNG; returns the saved progress dict."""
    body = json.loads((Path(run_dir) / STATE_JSON).read_text())
    tensors = st_load((Path(run_dir) / STATE_FILE).read_bytes())
    state: dict[int, dict[str, Any]] = {}
    for key, value in tensors.items():
        if key.startswith("opt."):
            _, pid, name = key.split(".", 2)
            state.setdefault(int(pid), {})[name] = value
    for pid, extra in body["scalars"].items():
        state.setdefault(int(pid), {}).update(extra)
    groups = [
        {k: (tuple(v) if k == "betas" else v) for k, v in g.items()} for g in body["param_groups"]
    ]
    optimizer.load_state_dict({"state": state, "param_groups": groups})
    torch.set_rng_state(tensors["rng.torch"])
    return body["progress"]


def has_checkpoint(run_dir: Path) -> bool:
    run_dir = Path(run_dir)
    return (run_dir / WEIGHTS_FILE).is_file() and (run_dir / STATE_JSON).is_file()


@dataclass
class LoadedRun:
    """A model loaded from a run directory (in eval mode) with its training config."""

    model: AffordanceModel
    config: TrainConfig
    run_dir: Path


def load_checkpoint(run_dir: str | Path, model: str | None = None) -> LoadedRun:
    """Load a trained model from ``run_dir``.

    Args:
        run_dir: a directory written by :func:`momakitchen.train.train`.
        model: if given, the model name the caller expects; a checkpoint of another model
            raises MomaError naming both.
    """
    run_dir = Path(run_dir)
    config, _ = read_run_config(run_dir)
    if model is not None and model != config.model:
        raise MomaError(
            f"checkpoint {str(run_dir)!r} holds model {config.model!r}, not {model!r}"
        )
    net = build_model(config.model, config.model_config)
    load_weights(run_dir / WEIGHTS_FILE, net)
    net.eval()
    return LoadedRun(net, config, run_dir)
