"""Procedural assets (URDF generated from seeded parameters) and external asset folders."""

from momakitchen.assets.registry import (
    CATEGORIES,
    Articulation,
    AssetCategory,
    AssetModel,
    Envelope,
    GraspFrame,
    Rect,
    categories_of_kind,
    get_category,
    register_category,
)

__all__ = [
    "CATEGORIES",
    "Articulation",
    "AssetCategory",
    "AssetModel",
    "Envelope",
    "GraspFrame",
    "Rect",
    "categories_of_kind",
    "get_category",
    "register_category",
]
