"""momakitchen: affordance-grounded last-mile navigation for mobile manipulation.

Pipeline stages live in sub-packages: ``assets`` (procedural URDF), ``scene`` (layouts and
configurations, pure data), ``robots``, ``sim`` (PyBullet worlds, trials, labels),
``perception``, ``data``, ``models``, ``train``, ``eval`` and ``cli``.
"""

__version__ = "0.1.0"

from momakitchen import bullet as _bullet  # noqa: F401  (imports PyBullet quietly, first)
from momakitchen.errors import MomaError

__all__ = ["MomaError", "__version__"]
