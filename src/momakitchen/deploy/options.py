"""The options of one prediction, as one object: :func:`momakitchen.predict` takes it
whole (``options=``) or field by field (keyword arguments), and the command line, the bag
reader and the server pass it on unchanged."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypedDict

from momakitchen.errors import MomaError
from momakitchen.models.inference import MC_SAMPLES, PICK_RADIUS


@dataclass(frozen=True)
class PredictOptions:
    """How :func:`momakitchen.predict` ranks and returns poses.

    Attributes:
        top_k, min_spread: number of poses (1-50) and their minimum spacing (m).
        pick_radius: rank the poses by the map averaged over this radius (m, 0-1; 0, the
            default: the raw map).
        mc_samples: MC-dropout passes for the uncertainty (0: none).
        threads: torch threads for the model while it runs (the previous setting is
            restored). One is fastest for a single frame: the model is many small
            operations, and a second thread mostly waits (BENCHMARKS.md). None: leave
            torch's setting.
        metric_depth: False for depth known only up to scale (a monocular depth
            network): the calibrated camera height then fixes the scale, read from the
            floor, instead of the floor correcting the height.
        opens: the robot will open the target (a door's or a drawer's handle), not pick
            it up. A model whose dexterity weight reads picks only
            (``ModelConfig.index_picks_only``, the shipped ``body``) leaves the weight off
            for it; other models read nothing of it.
    """

    top_k: int = 5
    min_spread: float = 0.2
    pick_radius: float = PICK_RADIUS
    mc_samples: int = MC_SAMPLES
    threads: int | None = 1
    metric_depth: bool = True
    opens: bool = False

    def __post_init__(self) -> None:
        if not 1 <= self.top_k <= 50:
            raise MomaError(f"top_k must be in [1, 50], got {self.top_k}")
        if self.mc_samples < 0:
            raise MomaError(f"mc_samples must be >= 0, got {self.mc_samples}")
        if not 0.0 <= self.pick_radius <= 1.0:
            raise MomaError(f"pick_radius must be in [0, 1] m, got {self.pick_radius}")
        if self.threads is not None and self.threads < 1:
            raise MomaError(f"threads must be >= 1 or None, got {self.threads}")
        if not isinstance(self.opens, bool):
            raise MomaError(f"opens must be true or false, got {self.opens!r}")


class PredictFields(TypedDict, total=False):
    """:class:`PredictOptions`' fields as keyword arguments of :func:`momakitchen.predict`."""

    top_k: int
    min_spread: float
    pick_radius: float
    mc_samples: int
    threads: int | None
    metric_depth: bool
    opens: bool
