"""The methods every track scores besides a model: one declaration, light to import (the
command line builds its choices from it without loading torch)."""

from __future__ import annotations

# Baselines: ``random`` (a floor point within the arm's reach: the paper's Random),
# ``nearest`` (the free point nearest the target: conventional navigation) and ``oracle``
# (the ground-truth map's best point).
BASELINES = ("random", "nearest", "oracle")
