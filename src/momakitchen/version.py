"""The package version (recorded in datasets, checkpoints and reports)."""

__version__ = "0.2.0"
