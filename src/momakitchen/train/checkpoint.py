"""Checkpoints: safetensors weights + JSON config; never a pickled model.

A run directory holds:

- ``config.json``: format, model name, preset, the full :class:`TrainConfig`, the robot
  descriptor version and names, and the preprocessing (cloud voxels, floor threshold,
  depth range) of the data it was trained on; a run without it used the defaults; and
  ``train_data``: the checksum of the training shards each part of the run read, from
  which step (a run resumed on the same scenes made again on another machine, whose
  bytes can differ, says so);
- ``model.safetensors``: the model's ``state_dict`` at the last checkpoint (an epoch's
  end, or within one: ``TrainConfig.checkpoint_minutes``); its
  metadata records the SHA-256 of its tensor data, checked (with the weights' finiteness)
  whenever it is loaded;
- ``trainer_state.safetensors`` + ``trainer_state.json``: optimiser moments, RNG state,
  epoch, step and history (and within an epoch, its batches done so far and their
  loss), for resuming;
- ``log.csv`` and ``loss_curve.png``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import torch
from safetensors import SafetensorError
from safetensors.torch import load as st_load
from safetensors.torch import save as st_save
from torch.utils.data import ConcatDataset, Subset

from momakitchen import codec
from momakitchen.data.config import Preprocessing, manifest_preprocessing, manifest_view_distance
from momakitchen.data.manifest import split_checksum
from momakitchen.errors import MomaError
from momakitchen.fileio import atomic_write_bytes, atomic_write_text, dumps_strict, existing_dir
from momakitchen.models.base import AffordanceModel
from momakitchen.models.registry import build_model
from momakitchen.robots.spec import DESCRIPTOR_LAYOUTS
from momakitchen.train.config import TrainConfig

FORMAT = "momakitchen-checkpoint"
FORMAT_VERSION = 1
CONFIG_FILE = "config.json"
WEIGHTS_FILE = "model.safetensors"
STATE_FILE = "trainer_state.safetensors"
STATE_JSON = "trainer_state.json"
# The checkpoints shipped inside the package, by the name every ``--checkpoint`` takes
# (each directory's CARD.md says how it was made): the bundled model, used when none is
# given, and the body-aware model, which reads the robot's reachability.
BUNDLED = "bundled"
BODY = "body"
_SHIPPED_DIR = Path(__file__).resolve().parent.parent / "checkpoints"
SHIPPED_CHECKPOINTS: dict[str, Path] = {
    BUNDLED: _SHIPPED_DIR / "navaff",
    BODY: _SHIPPED_DIR / "body",
}
DEFAULT_CHECKPOINT = SHIPPED_CHECKPOINTS[BUNDLED]


def resolve_run_dir(run_dir: str | os.PathLike) -> Path:
    """A run directory as given, or a shipped model's for its name (``bundled``, ``body``)."""
    name = str(run_dir)
    return shipped_checkpoint(name) if name in SHIPPED_CHECKPOINTS else Path(run_dir)


def run_label(run: LoadedRun) -> str:
    """What a run is reported as: a shipped model's name (its model's name would not tell
    it from any run of that model), else its model's name."""
    where = run.run_dir.resolve()
    names = [n for n, d in SHIPPED_CHECKPOINTS.items() if d.resolve() == where]
    return names[0] if names else run.config.model


def shipped_checkpoint(name: str) -> Path:
    """The run directory of the shipped model ``name`` (a key of SHIPPED_CHECKPOINTS)."""
    run_dir = SHIPPED_CHECKPOINTS[name]
    if not (run_dir / WEIGHTS_FILE).is_file():
        raise MomaError(
            f"the {name} checkpoint is missing from {run_dir}; "
            "pass a run directory from `momakitchen train`"
        )
    return run_dir


def default_checkpoint() -> Path:
    """The bundled NavAff run directory."""
    return shipped_checkpoint(BUNDLED)


def write_run_config(
    run_dir: Path,
    config: TrainConfig,
    preprocessing: Preprocessing | None = None,
    shards: str | None = None,
    view_distance: float | None = None,
) -> None:
    """Write ``config.json`` (``preprocessing``: that of the training data; None: the
    defaults; ``shards``: the training shards' checksum, :func:`dataset_shards`;
    ``view_distance``: how far from the target its farthest training views stand, m,
    :func:`dataset_view_distance`)."""
    info: dict[str, Any] = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "model": config.model,
        "preset": config.preset,
        "descriptor_version": config.model_config.descriptor_version,
        "descriptor_names": list(DESCRIPTOR_LAYOUTS[config.model_config.descriptor_version]),
        "train_config": config.to_dict(),
        "preprocessing": codec.to_dict(preprocessing or Preprocessing()),
    }
    if shards is not None:
        info["train_data"] = [{"from_step": 0, "shards_sha256": shards}]
    if view_distance is not None:
        info["view_distance"] = round(float(view_distance), 3)
    _write_info(run_dir, info)


def _write_info(run_dir: Path, info: dict[str, Any]) -> None:
    atomic_write_text(Path(run_dir) / CONFIG_FILE, dumps_strict(info, indent=2) + "\n")


def record_train_data(run_dir: Path, shards: str | None, step: int) -> str | None:
    """A run resumed at ``step`` on training shards with checksum ``shards``: when they
    are not the bytes the run read so far (or those were not recorded), ``config.json``'s
    ``train_data`` gains an entry from ``step`` and the return value says so in one line;
    None when nothing changed (or the data have no manifest to name their bytes)."""
    if shards is None:
        return None
    _, info = read_run_config(run_dir)
    parts = info.get("train_data") or [{"from_step": 0, "shards_sha256": None}]
    before = parts[-1].get("shards_sha256")
    if before == shards:
        return None
    info["train_data"] = [*parts, {"from_step": int(step), "shards_sha256": shards}]
    _write_info(run_dir, info)
    was = "were not recorded" if before is None else f"were {before[:12]}"
    return (
        f"resuming at step {step} on training shards {shards[:12]}, not the bytes the run "
        f"read so far (they {was}): the same scenes made on another machine can differ in "
        "their last bits (docs/DATASET.md); config.json's train_data records from which step"
    )


def dataset_shards(dataset: Any) -> str | None:
    """One SHA-256 naming the bytes of the shards behind ``dataset`` (an
    :class:`~momakitchen.data.EpisodeDataset`, or a ``Subset`` / ``ConcatDataset`` of
    such): its split's :func:`~momakitchen.data.manifest.split_checksum`; None for data
    without a manifest (synthetic or in-memory)."""
    if isinstance(dataset, Subset):
        return dataset_shards(dataset.dataset)
    if isinstance(dataset, ConcatDataset):
        parts = [dataset_shards(d) for d in dataset.datasets]
        if any(p is None for p in parts):
            return None
        return hashlib.sha256(" ".join(cast(list[str], parts)).encode()).hexdigest()
    manifest = getattr(dataset, "manifest", None)
    if not isinstance(manifest, dict) or not isinstance(manifest.get("shards"), dict):
        return None
    return split_checksum(manifest, getattr(dataset, "split", "all"))


def read_run_config(run_dir: Path) -> tuple[TrainConfig, dict[str, Any]]:
    """Read and check ``config.json`` of a run; MomaError if missing or incompatible."""
    path = existing_dir(run_dir, "checkpoint directory") / CONFIG_FILE
    if not path.is_file():
        raise MomaError(f"{str(run_dir)!r} is not a run directory: {CONFIG_FILE} is missing")
    try:
        info = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise MomaError(f"cannot read {path}: {exc}") from None
    if not isinstance(info, dict) or info.get("format") != FORMAT:
        raise MomaError(f"{path} is not a momakitchen checkpoint config")
    version = info.get("descriptor_version")
    if isinstance(version, bool) or version not in DESCRIPTOR_LAYOUTS:
        raise MomaError(
            f"checkpoint {str(run_dir)!r} uses robot descriptor version {version!r}, this "
            f"version of momakitchen knows {sorted(DESCRIPTOR_LAYOUTS)}"
        )
    train_config = info.get("train_config")
    if isinstance(train_config, dict) and isinstance(train_config.get("model_config"), dict):
        # Runs made before models recorded it read the checkpoint's version.
        model_config = train_config["model_config"]
        if model_config.setdefault("descriptor_version", version) != version:
            raise MomaError(
                f"{path}: descriptor_version {version} but model_config.descriptor_version "
                f"{model_config['descriptor_version']!r}"
            )
    model = train_config.get("model") if isinstance(train_config, dict) else None
    if isinstance(model, str) and model:  # a plug-in not importable here is not a bad config
        from momakitchen.models.registry import check_loadable

        check_loadable(model, f"checkpoint {str(run_dir)!r}")
    try:
        return TrainConfig.from_dict(info["train_config"]), info
    except (KeyError, MomaError) as exc:
        raise MomaError(f"{path}: bad training config ({exc})") from None


def run_preprocessing(info: dict[str, Any], run_dir: Path | str = "") -> Preprocessing:
    """The preprocessing recorded in a run's ``config.json`` (as returned by
    :func:`read_run_config`); the defaults if the run records none (older runs, such as
    the bundled one, were all trained on default clouds)."""
    data = info.get("preprocessing")
    if data is None:
        return Preprocessing()
    try:
        return codec.from_dict(Preprocessing, data, where="preprocessing")
    except MomaError as exc:
        raise MomaError(f"checkpoint {str(run_dir)!r}: {exc}") from None


def dataset_preprocessing(dataset: Any) -> Preprocessing | None:
    """The preprocessing recorded in the manifest of the dataset behind ``dataset`` (an
    :class:`~momakitchen.data.EpisodeDataset`, or a ``Subset`` / ``ConcatDataset`` of such
    with one preprocessing); None if no manifest records one (synthetic or in-memory data).
    """
    if isinstance(dataset, Subset):
        return dataset_preprocessing(dataset.dataset)
    if isinstance(dataset, ConcatDataset):
        found = {dataset_preprocessing(d) for d in dataset.datasets} - {None}
        if len(found) > 1:
            raise MomaError(
                "the datasets combined were built with different preprocessing: "
                + "; ".join(sorted(p.describe() for p in found if p))
            )
        return found.pop() if found else None
    manifest = getattr(dataset, "manifest", None)
    if not isinstance(manifest, dict):
        return None
    root = getattr(dataset, "root", "dataset")
    try:
        return manifest_preprocessing(manifest)
    except MomaError as exc:
        raise MomaError(f"{root}: {exc}") from None


def dataset_view_distance(dataset: Any) -> float | None:
    """How far from the target (m) the farthest views of the datasets behind ``dataset``
    stand (as :func:`dataset_preprocessing` finds them), from their manifests; None
    without a manifest that says (synthetic or in-memory data)."""
    if isinstance(dataset, Subset):
        return dataset_view_distance(dataset.dataset)
    if isinstance(dataset, ConcatDataset):
        found = [dataset_view_distance(d) for d in dataset.datasets]
        known = [f for f in found if f is not None]
        return max(known) if known else None
    manifest = getattr(dataset, "manifest", None)
    return manifest_view_distance(manifest) if isinstance(manifest, dict) else None


def check_preprocessing(run: LoadedRun, data: Preprocessing | None, what: str = "dataset") -> None:
    """MomaError unless data built with preprocessing ``data`` suits ``run`` (trained on
    the same preprocessing); data that records none (None) passes."""
    if data is not None and data != run.preprocessing:
        raise MomaError(
            f"the {what} was built with cloud preprocessing {data.describe()}, but checkpoint "
            f"{str(run.run_dir)!r} was trained with {run.preprocessing.describe()}; "
            "use data generated with the same cloud and camera settings"
        )


# The metadata key of a safetensors file's checksum: the SHA-256 of its tensor data (the
# bytes after the header). It lives in the file itself, so that weights and checksum are
# written in one atomic rename and travel together; files written before it carry none.
CHECKSUM_KEY = "sha256"


def _data_block(raw: bytes) -> tuple[dict[str, Any], bytes]:
    """The header (JSON object) and the tensor data of a serialised safetensors file; raises
    ValueError if the layout is broken."""
    if len(raw) < 8:
        raise ValueError("shorter than a safetensors header")
    (size,) = struct.unpack("<Q", raw[:8])
    if size > len(raw) - 8:
        raise ValueError("header longer than the file")
    header = json.loads(raw[8 : 8 + size])
    if not isinstance(header, dict):
        raise ValueError("header is not a JSON object")
    return header, raw[8 + size :]


def safetensors_bytes(tensors: dict[str, torch.Tensor], metadata: dict[str, str]) -> bytes:
    """``tensors`` serialised as safetensors with ``metadata`` plus the checksum of their
    data (:data:`CHECKSUM_KEY`)."""
    plain = st_save(tensors, metadata=metadata)
    digest = hashlib.sha256(_data_block(plain)[1]).hexdigest()
    return st_save(tensors, metadata={**metadata, CHECKSUM_KEY: digest})


def save_weights(path: Path, model: torch.nn.Module) -> None:
    state = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    atomic_write_bytes(Path(path), safetensors_bytes(state, {"format": FORMAT}))


def _safetensors(path: Path, what: str) -> dict[str, torch.Tensor]:
    """The tensors of a safetensors file; MomaError naming the file if it is missing,
    unreadable (truncated, damaged or not safetensors), its data does not match the
    checksum its metadata records (one flipped byte), or a floating-point tensor holds NaN
    or infinity (weights that would make every prediction NaN)."""
    if not path.is_file():
        raise MomaError(f"{what} {str(path)!r} are missing")
    try:
        raw = path.read_bytes()
        tensors = st_load(raw)
        header, data = _data_block(raw)
    except (SafetensorError, OSError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:120]
        raise MomaError(
            f"{what} {str(path)!r} are unreadable (truncated or damaged?): {reason}"
        ) from None
    recorded = (header.get("__metadata__") or {}).get(CHECKSUM_KEY)
    if recorded is not None and hashlib.sha256(data).hexdigest() != recorded:
        raise MomaError(
            f"{what} {str(path)!r} are damaged: their data does not match the SHA-256 "
            "recorded when they were written"
        )
    for name, tensor in tensors.items():
        if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all()):
            bad = int((~torch.isfinite(tensor)).sum())
            raise MomaError(
                f"{what} {str(path)!r} are damaged: tensor {name!r} holds {bad} NaN or "
                "infinite value(s)"
            )
    return tensors


def widen_descriptor_inputs(
    state: dict[str, torch.Tensor], model: torch.nn.Module, from_dim: int
) -> dict[str, torch.Tensor]:
    """``state`` (the weights of a model that read ``from_dim`` descriptor columns) made
    to fit ``model``, which reads more: the first layer of each module that reads the
    descriptor (those with a ``descriptor_dim``) gains zero input columns, so the widened
    model predicts what the original did until training gives the new columns a use."""
    out = dict(state)
    for prefix, module in model.named_modules():
        dim = getattr(module, "descriptor_dim", None)
        if not isinstance(dim, int) or dim <= from_dim:
            continue
        first = next(m for m in module.modules() if isinstance(m, torch.nn.Linear))
        key = next(f"{prefix}.{n}" for n, p in module.named_parameters() if p is first.weight)
        weight = out.get(key)
        if weight is not None and weight.ndim == 2 and weight.shape[1] == from_dim:
            pad = weight.new_zeros(weight.shape[0], dim - from_dim)
            out[key] = torch.cat([weight, pad], dim=1)
    return out


def widen_reach_inputs(state: dict[str, torch.Tensor], model: torch.nn.Module) -> None:
    """``state`` (the weights of a model that did not read the robot's reachability)
    made to fit ``model``, which does, in place: each backbone with ``widen_for_reach``
    gives the reachability channels zero input columns."""
    for prefix, module in model.named_modules():
        widen = getattr(module, "widen_for_reach", None)
        if callable(widen):
            widen(state, f"{prefix}." if prefix else "")


def load_weights(
    path: Path,
    model: torch.nn.Module,
    descriptor_from: int | None = None,
    reach_from_none: bool = False,
) -> None:
    """Load ``model``'s weights from a safetensors file; MomaError naming the file when it
    is missing, unreadable, or holds tensors other than the model's (names or shapes: a
    ``config.json`` describing another model than the weights). ``descriptor_from``: the
    weights are those of a model that read that many descriptor columns, widened to the
    model's (:func:`widen_descriptor_inputs`). ``reach_from_none``: the weights are
    those of a model that did not read the robot's reachability
    (:func:`widen_reach_inputs`)."""
    path = Path(path)
    state = _safetensors(path, "checkpoint weights")
    if descriptor_from is not None:
        state = widen_descriptor_inputs(state, model, descriptor_from)
    if reach_from_none:
        widen_reach_inputs(state, model)
    expected = model.state_dict()
    problems = [f"tensor {k!r} is missing" for k in expected if k not in state]
    problems += [f"unexpected tensor {k!r}" for k in state if k not in expected]
    problems += [
        f"tensor {k!r} has shape {tuple(v.shape)}, the model's is {tuple(expected[k].shape)}"
        for k, v in state.items()
        if k in expected and v.shape != expected[k].shape
    ]
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        name = getattr(model, "name", None)
        described = f"the {name} model" if name else "the model"
        raise MomaError(
            f"checkpoint weights {str(path)!r} do not fit {described} described by "
            f"{CONFIG_FILE}: {problems[0]}{more}"
        )
    model.load_state_dict(state, strict=True)


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
    atomic_write_bytes(Path(run_dir) / STATE_FILE, safetensors_bytes(tensors, {}))
    body = {"progress": progress, "param_groups": groups, "scalars": scalars}
    # a diverged loss is null in the file (load_trainer_state restores it as NaN)
    atomic_write_text(
        Path(run_dir) / STATE_JSON, dumps_strict(body, indent=1, null_non_finite=True) + "\n"
    )


def load_trainer_state(run_dir: Path, optimizer: torch.optim.Optimizer) -> dict[str, Any]:
    """Restore the optimiser and the torch RNG; returns the saved progress dict."""
    path = Path(run_dir) / STATE_JSON
    try:
        body = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise MomaError(f"cannot resume: {str(path)!r} is unreadable ({exc})") from None
    tensors = _safetensors(Path(run_dir) / STATE_FILE, "trainer state tensors")
    try:
        state: dict[int, dict[str, Any]] = {}
        for key, value in tensors.items():
            if key.startswith("opt."):
                _, pid, name = key.split(".", 2)
                state.setdefault(int(pid), {})[name] = value
        for pid, extra in body["scalars"].items():
            state.setdefault(int(pid), {}).update(extra)
        groups = [
            {k: (tuple(v) if k == "betas" else v) for k, v in g.items()}
            for g in body["param_groups"]
        ]
        optimizer.load_state_dict({"state": state, "param_groups": groups})
        torch.set_rng_state(tensors["rng.torch"])
        progress = body["progress"]
        if "epoch_loss_sum" in progress:  # a diverged loss is saved as null (strict JSON)
            progress["epoch_loss_sum"] = [
                math.nan if v is None else v for v in progress["epoch_loss_sum"]
            ]
        return progress
    except (KeyError, TypeError, ValueError, RuntimeError) as exc:
        raise MomaError(
            f"cannot resume from {str(run_dir)!r}: the trainer state does not fit this "
            f"optimiser ({' '.join(str(exc).split())[:120]})"
        ) from None


def has_checkpoint(run_dir: Path) -> bool:
    run_dir = Path(run_dir)
    return (run_dir / WEIGHTS_FILE).is_file() and (run_dir / STATE_JSON).is_file()


def require_checkpoint(run_dir: str | Path) -> None:
    """MomaError unless ``run_dir`` holds a checkpoint to resume from: asked to resume
    a run that has none, training from scratch would be a silent surprise of hours."""
    run_dir = Path(run_dir)
    if not has_checkpoint(run_dir):
        where = "does not exist" if not run_dir.exists() else "holds no checkpoint"
        raise MomaError(
            f"nothing to resume: run directory {str(run_dir)!r} {where} (no {WEIGHTS_FILE} "
            f"and {STATE_JSON}); start the run without --resume"
        )


@dataclass
class LoadedRun:
    """A model loaded from a run directory (in eval mode) with its training config and the
    preprocessing its inputs must have (clouds built as for its training data)."""

    model: AffordanceModel
    config: TrainConfig
    run_dir: Path
    preprocessing: Preprocessing = field(default_factory=Preprocessing)
    # How far from the target its farthest training views stood (m; None: not recorded,
    # runs trained before it was, on the default views).
    view_distance: float | None = None


def load_checkpoint(run_dir: str | os.PathLike, model: str | None = None) -> LoadedRun:
    """Load a trained model from ``run_dir``.

    Args:
        run_dir: a directory written by :func:`momakitchen.train.train`, or ``bundled``.
        model: if given, the model name the caller expects; a checkpoint of another model
            raises MomaError naming both.
    """
    run_dir = resolve_run_dir(run_dir)
    config, info = read_run_config(run_dir)
    preprocessing = run_preprocessing(info, run_dir)
    if model is not None and model != config.model:
        raise MomaError(f"checkpoint {str(run_dir)!r} holds model {config.model!r}, not {model!r}")
    net = build_model(config.model, config.model_config)
    load_weights(run_dir / WEIGHTS_FILE, net)
    net.eval()
    view = info.get("view_distance")
    view_distance = float(view) if isinstance(view, (int, float)) and view > 0 else None
    return LoadedRun(net, config, run_dir, preprocessing, view_distance)
