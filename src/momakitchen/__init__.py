"""momakitchen: affordance-grounded last-mile navigation for mobile manipulation.

Pipeline stages live in sub-packages, in the order imports may run: ``assets`` (procedural
URDF), ``robots``, ``scene`` (layouts and configurations, pure data), ``sim`` (PyBullet
worlds, trials, labels),
``perception``, ``data``, ``models``, ``train``, ``eval``, ``generation`` (the dataset
producer and the simulator demo), ``deploy`` (real-robot inference) and ``cli``.

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
