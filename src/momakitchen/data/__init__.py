"""Datasets: the sample / batch contract (:mod:`.batch`), synthetic episodes (:mod:`.synthetic`).

On disk (:mod:`.shard`, :mod:`.manifest`): one HDF5 shard per scene plus ``manifest.json``;
:mod:`.generator` writes them, :mod:`.integrity` checks them, :mod:`.reference` converts
from/to the reference release layout, :class:`EpisodeDataset` reads them for torch.
Names are imported lazily so that the generator's workers do not import torch.
"""

from __future__ import annotations

from typing import Any

_LAZY = {
    "EpisodeDataset": "momakitchen.data.torch_dataset",
    "EpisodeDatasets": "momakitchen.data.torch_dataset",
    "SceneShard": "momakitchen.data.shard",
    "write_shard": "momakitchen.data.shard",
    "SCHEMA_VERSION": "momakitchen.data.shard",
    "load_manifest": "momakitchen.data.manifest",
    "scene_split": "momakitchen.data.manifest",
    "GenerateRequest": "momakitchen.data.generator",
    "generate_dataset": "momakitchen.data.generator",
    "check_dataset": "momakitchen.data.integrity",
    "dataset_stats": "momakitchen.data.integrity",
    "export_reference": "momakitchen.data.reference",
    "import_reference": "momakitchen.data.reference",
    "SyntheticSceneConfig": "momakitchen.data.synthetic_scene",
    "synthetic_scene_records": "momakitchen.data.synthetic_scene",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'momakitchen.data' has no attribute {name!r}")
