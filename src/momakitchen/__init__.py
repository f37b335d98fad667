"""momakitchen: affordance-grounded last-mile navigation for mobile manipulation.

Pipeline stages live in sub-packages: ``assets`` (procedural URDF), ``scene`` (layouts and
configurations, pure data), ``robots``, ``sim`` (PyBullet worlds, trials, labels),
``perception``, ``data``, ``models``, ``train``, ``eval``, ``deploy`` and ``cli``.

``momakitchen.predict(...)`` runs the bundled model on a robot's RGB-D frame (see
:func:`momakitchen.deploy.predict.predict`).
"""

from momakitchen.errors import MomaError
from momakitchen.version import __version__

__all__ = ["MomaError", "__version__", "predict"]


def __getattr__(name: str):
    # Lazy: importing momakitchen imports neither torch nor the simulator.
    if name == "predict":
        from momakitchen.deploy.predict import predict

        return predict
    raise AttributeError(f"module 'momakitchen' has no attribute {name!r}")
