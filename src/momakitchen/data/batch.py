"""The sample / batch contract between datasets and models, and the collate function.

Every torch Dataset of episodes in this package (the synthetic factory in
:mod:`momakitchen.data.synthetic` and the HDF5-backed dataset) returns **samples** with the
keys below; :class:`EpisodeCollator` turns a list of samples into a **batch** with fixed
point counts, padding with masks or sampling down.

Sample (one episode, variable point counts ``ng``/``nf``; tensors or NumPy arrays):

==================  ===========  =========  ===============================================
key                 shape        dtype      meaning
==================  ===========  =========  ===============================================
``global_xyz``      (ng, 3)      float32    first-person cloud in the viewpoint's robot base
                                            frame (x forward, y left, z up, z = 0 floor)
``global_rgb``      (ng, 3)      float32    colour in [0, 1]
``global_align``    (ng,)        float32    visual-alignment channel: -1 obstacle, 0 other,
                                            +1 target
``floor_xyz``       (nf, 3)      float32    floor points (same frame)
``floor_label``     (nf,)        float32    dense affordance map in [0, 1] (optional at
                                            inference time)
``robot``           (D,)         float32    ``robot_descriptor(spec)``, D = DESCRIPTOR_DIM
``scene_id``        int                     metadata (not tensors)
``config_index``    int
``episode_index``   int
``robot_name``      str
==================  ===========  =========  ===============================================

A sample may also carry ``global_mask`` (ng,) / ``floor_mask`` (nf,) booleans; points whose
mask is False are dropped before collation, and ``target_opens`` (bool): whether the robot
opens its target (a door's or a drawer's handle) rather than picking it, for a model that
weighs the two apart (``ModelConfig.index_picks_only``); left out or None: not said.

Batch (after :class:`EpisodeCollator`, ``B`` samples, ``Ng``/``Nf`` fixed point counts):

- ``global_xyz`` (B, Ng, 3), ``global_rgb`` (B, Ng, 3), ``global_align`` (B, Ng) float32
- ``global_mask`` (B, Ng) bool: True = real point, False = padding. A cloud sampled down
  keeps some of its target points (alignment +1) whatever the draw.
- ``floor_xyz`` (B, Nf, 3) float32, ``floor_mask`` (B, Nf) bool
- ``floor_label`` (B, Nf) float32 (present when every sample has labels; 0 on padding)
- ``robot`` (B, D) float32
- ``context_xyz`` (B, Nc, 3) float32, ``context_mask`` (B, Nc) bool (only with
  ``num_context``): the floor points the model encodes, while it predicts every point of
  ``floor_xyz``. Training samples each floor cloud down to ``Nf`` points; at inference
  every floor point is predicted, so the model encodes the same density it was trained on
  (the points training would have drawn) and interpolates to the rest.
- ``obstacle_xyz`` (B, No, 3) float32, ``obstacle_mask`` (B, No) bool (only with
  ``obstacles``): each view's points that may block a base, taken from its whole cloud
  before it is sampled down (:func:`~momakitchen.perception.footprint.base_obstacles`),
  for a model's footprint gate (``ModelConfig.footprint_gate``); No = the largest count.
- ``target_opens`` (B,) bool (only when a sample says): True where the robot opens its
  target; False where it picks it or the sample does not say
- ``scene_id``, ``config_index``, ``episode_index``: lists of int; ``robot_name``: list of str

Padding entries are zeros. Real points always come first in each row (masks are prefix
masks), but models must rely on the masks only.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from momakitchen.errors import MomaError
from momakitchen.robots.spec import DESCRIPTOR_DIM

GLOBAL_KEYS = ("global_xyz", "global_rgb", "global_align")
FLOOR_KEYS = ("floor_xyz", "floor_label")
META_KEYS = ("scene_id", "config_index", "episode_index", "robot_name")
TENSOR_KEYS = (
    "global_xyz",
    "global_rgb",
    "global_align",
    "global_mask",
    "floor_xyz",
    "floor_mask",
    "floor_label",
    "robot",
)

Batch = dict[str, Any]


def _as_array(value: Any, key: str) -> np.ndarray:
    if isinstance(value, torch.Tensor):
        value = value.detach().cpu().numpy()
    try:
        return np.asarray(value, dtype=np.float32)
    except (TypeError, ValueError) as exc:
        raise MomaError(f"sample field {key!r} is not numeric: {exc}") from None


def validate_sample(sample: Mapping[str, Any]) -> dict[str, Any]:
    """Check a sample against the contract and return it as float32 NumPy arrays.

    Points flagged False by an optional ``global_mask`` / ``floor_mask`` are removed.
    Raises :class:`MomaError` naming the bad field and shape.
    """
    out: dict[str, Any] = {}
    for key in (*GLOBAL_KEYS, "floor_xyz", "robot"):
        if key not in sample:
            raise MomaError(f"sample is missing field {key!r}; it has {sorted(sample)}")
    for key in META_KEYS:
        out[key] = sample.get(key, -1 if key != "robot_name" else "")
    opens = sample.get("target_opens")
    if opens is not None:
        if not isinstance(opens, (bool, np.bool_)):
            raise MomaError(f"sample field 'target_opens' must be true or false, got {opens!r}")
        out["target_opens"] = bool(opens)
    xyz = _as_array(sample["global_xyz"], "global_xyz")
    if xyz.ndim != 2 or xyz.shape[1] != 3:
        raise MomaError(f"global_xyz must have shape (ng, 3), got {xyz.shape}")
    ng = xyz.shape[0]
    rgb = _as_array(sample["global_rgb"], "global_rgb")
    align = _as_array(sample["global_align"], "global_align")
    if rgb.shape != (ng, 3):
        raise MomaError(f"global_rgb must have shape ({ng}, 3), got {rgb.shape}")
    if align.shape != (ng,):
        raise MomaError(f"global_align must have shape ({ng},), got {align.shape}")
    gmask = np.ones(ng, dtype=bool)
    if "global_mask" in sample:
        gmask = np.asarray(_as_array(sample["global_mask"], "global_mask"), dtype=bool)
        if gmask.shape != (ng,):
            raise MomaError(f"global_mask must have shape ({ng},), got {gmask.shape}")
    fxyz = _as_array(sample["floor_xyz"], "floor_xyz")
    if fxyz.ndim != 2 or fxyz.shape[1] != 3:
        raise MomaError(f"floor_xyz must have shape (nf, 3), got {fxyz.shape}")
    nf = fxyz.shape[0]
    fmask = np.ones(nf, dtype=bool)
    if "floor_mask" in sample:
        fmask = np.asarray(_as_array(sample["floor_mask"], "floor_mask"), dtype=bool)
        if fmask.shape != (nf,):
            raise MomaError(f"floor_mask must have shape ({nf},), got {fmask.shape}")
    robot = _as_array(sample["robot"], "robot")
    if robot.shape != (DESCRIPTOR_DIM,):
        raise MomaError(f"robot descriptor must have shape ({DESCRIPTOR_DIM},), got {robot.shape}")
    # (a mask that keeps everything is not applied: no copies)
    out["global_xyz"], out["global_rgb"], out["global_align"] = (
        (xyz, rgb, align) if gmask.all() else (xyz[gmask], rgb[gmask], align[gmask])
    )
    out["floor_xyz"] = fxyz if fmask.all() else fxyz[fmask]
    out["robot"] = robot
    if "floor_label" in sample and sample["floor_label"] is not None:
        label = _as_array(sample["floor_label"], "floor_label")
        if label.shape != (nf,):
            raise MomaError(f"floor_label must have shape ({nf},), got {label.shape}")
        out["floor_label"] = label[fmask]
    if out["global_xyz"].shape[0] == 0 or out["floor_xyz"].shape[0] == 0:
        raise MomaError(
            f"episode (scene {out['scene_id']}, configuration {out['config_index']}, "
            f"episode {out['episode_index']}) has no global or no floor points"
        )
    return out


def _sample_seed(seed: int, sample: Mapping[str, Any], position: int) -> np.random.Generator:
    """A generator that depends on the seed and the episode identity, not the batch."""
    ident = [int(seed) & 0xFFFFFFFF]
    for key in ("scene_id", "config_index", "episode_index"):
        value = sample.get(key, -1)
        ident.append(int(value) & 0xFFFFFFFF if int(value) >= 0 else 0xFFFFFFFF)
    if all(v == 0xFFFFFFFF for v in ident[1:]):
        ident.append(position)
    return np.random.default_rng(ident)


def _fit(n_real: int, n_out: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of the points kept when fitting ``n_real`` points into ``n_out`` slots."""
    if n_real <= n_out:
        return np.arange(n_real)
    return np.sort(rng.choice(n_real, size=n_out, replace=False))


# A global cloud sampled down with no target point left gets up to this many back.
TARGET_KEEP = 16


def _keep_target(kept: np.ndarray, align: np.ndarray) -> np.ndarray:
    """``kept`` (sorted global indices) with target points (alignment > 0) swapped in for
    evenly spaced others when the draw left none, so that a model never sees a view
    without its target (a few pixels of a small fruit among 100,000 points). Draws
    nothing from the generator: every other episode is sampled exactly as before."""
    target = np.flatnonzero(np.asarray(align) > 0)
    if len(target) == 0 or len(kept) == len(align) or (np.asarray(align)[kept] > 0).any():
        return kept
    k = min(len(target), TARGET_KEEP, len(kept))
    out = kept.copy()
    out[np.linspace(0, len(kept) - 1, k).astype(np.int64)] = target[
        np.linspace(0, len(target) - 1, k).astype(np.int64)
    ]
    return np.sort(out)


@dataclass(frozen=True)
class EpisodeCollator:
    """Collate samples into a fixed-size batch (see the module docstring for shapes).

    Attributes:
        num_global: Ng, the global point count of the batch. ``None``: the largest in the
            batch (pad only).
        num_floor: Nf, the floor point count. ``None``: the largest in the batch.
        seed: clouds larger than the target count are sampled down without replacement by
            a generator seeded from ``(seed, scene_id, config_index, episode_index)``, so
            the same episode is always reduced the same way whatever batch it lands in.
        num_context: Nc, adds the floor context (``context_xyz``, ``context_mask``): each
            floor cloud sampled down to this many points as ``num_floor=num_context``
            would sample it. ``None``: no context (the model encodes ``floor_xyz``).
        obstacles: add ``obstacle_xyz`` and ``obstacle_mask`` from each whole cloud.
    """

    num_global: int | None = None
    num_floor: int | None = None
    seed: int = 0
    num_context: int | None = None
    obstacles: bool = False

    def __post_init__(self) -> None:
        for name in ("num_global", "num_floor", "num_context"):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, int) or value < 1):
                raise MomaError(f"EpisodeCollator.{name} must be a positive int, got {value!r}")

    def __call__(self, samples: Sequence[Mapping[str, Any]]) -> Batch:
        return collate_episodes(
            samples, self.num_global, self.num_floor, self.seed, self.num_context, self.obstacles
        )


def collate_episodes(
    samples: Sequence[Mapping[str, Any]],
    num_global: int | None = None,
    num_floor: int | None = None,
    seed: int = 0,
    num_context: int | None = None,
    obstacles: bool = False,
) -> Batch:
    """Stack samples into a batch with fixed point counts and masks.

    Shapes:
        - input: a list of B samples (``global_xyz`` (ng_i, 3), ``floor_xyz`` (nf_i, 3), ...)
        - output: ``global_*`` (B, Ng, ...), ``floor_*`` (B, Nf, ...), ``robot`` (B, D),
          masks (B, Ng) / (B, Nf) bool. Ng = ``num_global`` or max ng_i; Nf likewise;
          with ``num_context``, ``context_xyz`` (B, Nc, 3) and ``context_mask`` (B, Nc);
          with ``obstacles``, ``obstacle_xyz`` (B, No, 3) and ``obstacle_mask`` (B, No).
    """
    if len(samples) == 0:
        raise MomaError("cannot collate an empty list of samples")
    clean = [validate_sample(s) for s in samples]
    ng = num_global or max(s["global_xyz"].shape[0] for s in clean)
    nf = num_floor or max(s["floor_xyz"].shape[0] for s in clean)
    b = len(clean)
    has_label = all("floor_label" in s for s in clean)
    out = {
        "global_xyz": np.zeros((b, ng, 3), np.float32),
        "global_rgb": np.zeros((b, ng, 3), np.float32),
        "global_align": np.zeros((b, ng), np.float32),
        "global_mask": np.zeros((b, ng), bool),
        "floor_xyz": np.zeros((b, nf, 3), np.float32),
        "floor_mask": np.zeros((b, nf), bool),
        "robot": np.stack([s["robot"] for s in clean]).astype(np.float32),
    }
    if has_label:
        out["floor_label"] = np.zeros((b, nf), np.float32)
    if num_context is not None:
        out["context_xyz"] = np.zeros((b, num_context, 3), np.float32)
        out["context_mask"] = np.zeros((b, num_context), bool)
    for i, s in enumerate(clean):
        rng = _sample_seed(seed, s, i)
        gi = _keep_target(_fit(s["global_xyz"].shape[0], ng, rng), s["global_align"])
        ci = None
        if num_context is not None:  # the floor draw of a collation with num_floor=num_context
            ci = _fit(s["floor_xyz"].shape[0], num_context, copy.deepcopy(rng))
        fi = _fit(s["floor_xyz"].shape[0], nf, rng)
        for key in GLOBAL_KEYS:
            out[key][i, : len(gi)] = s[key][gi]
        out["global_mask"][i, : len(gi)] = True
        out["floor_xyz"][i, : len(fi)] = s["floor_xyz"][fi]
        out["floor_mask"][i, : len(fi)] = True
        if has_label:
            out["floor_label"][i, : len(fi)] = s["floor_label"][fi]
        if ci is not None:
            out["context_xyz"][i, : len(ci)] = s["floor_xyz"][ci]
            out["context_mask"][i, : len(ci)] = True
    if obstacles:
        from momakitchen.perception.footprint import base_obstacles

        found = [base_obstacles(s["global_xyz"]) for s in clean]
        no = max(1, *(len(f) for f in found))
        out["obstacle_xyz"] = np.zeros((b, no, 3), np.float32)
        out["obstacle_mask"] = np.zeros((b, no), bool)
        for i, f in enumerate(found):
            out["obstacle_xyz"][i, : len(f)] = f
            out["obstacle_mask"][i, : len(f)] = True
    if any("target_opens" in s for s in clean):
        out["target_opens"] = np.array([s.get("target_opens", False) for s in clean], bool)
    batch: Batch = {k: torch.from_numpy(v) for k, v in out.items()}
    for key in META_KEYS:
        batch[key] = [s[key] for s in clean]
    return batch


def episode_maps(batch: Batch, pred: torch.Tensor) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per-episode 1-D prediction and label arrays over the real floor points.

    Shapes:
        - ``pred``: (B, Nf); ``batch["floor_label"]``, ``batch["floor_mask"]``: (B, Nf)
        - output: two lists of B arrays of shape (nf_i,)
    """
    mask = batch["floor_mask"].cpu().numpy()
    p = pred.detach().cpu().numpy()
    labels = batch.get("floor_label")
    y = labels.cpu().numpy() if labels is not None else None
    preds = [p[i][mask[i]].astype(np.float64) for i in range(p.shape[0])]
    gts = [y[i][mask[i]].astype(np.float64) for i in range(p.shape[0])] if y is not None else []
    return preds, gts
