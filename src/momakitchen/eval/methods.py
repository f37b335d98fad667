"""The methods every track scores besides a trained model: one declaration each, light
to import (the command line builds its choices from them without loading torch)."""

from __future__ import annotations

# Baselines: ``random`` (a floor point within the arm's reach: the paper's Random),
# ``nearest`` (the free point nearest the target: conventional navigation) and ``oracle``
# (the ground-truth map's best point).
BASELINES = ("random", "nearest", "oracle")
# Classical base placement (``ring``, ``reachability``: docs/PLACEMENT.md): methods that
# take what a model takes, one RGB-D frame, and no training. Spelled out:
# momakitchen.placement.methods.CLASSICAL_METHODS imports numpy (a test keeps them equal).
CLASSICAL = ("ring", "reachability")
# What ``--method`` names.
METHODS = (*BASELINES, *CLASSICAL)
