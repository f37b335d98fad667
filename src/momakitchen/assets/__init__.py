"""Procedural assets (URDF generated from seeded parameters) and external asset folders."""

# Importing the category modules registers them (one registry, populated on import).
from momakitchen.assets import appliances, cabinets, obstacles, rigid  # noqa: F401
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
