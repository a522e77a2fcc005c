"""motionlab: deep generative models of human motion, the library behind the course.

Modules load on first use, so ``import motionlab`` is instant and ``motionlab.data``
(which needs torch) costs nothing until you touch it:

    import motionlab
    clips = motionlab.data.load("../shared/mocap/cmu", fps=20)
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

__all__ = ["asfamc", "bvh", "checks", "claims", "clip", "cmu_locomotion", "colab", "data", "download", "experiments", "filters", "metrics", "models",
           "pretrained", "representation", "rotations", "skeleton", "synthetic", "training", "viz", "widgets"]


def __getattr__(name: str):
    if name in __all__:        # only the fixed names above: never a name taken from a file or input
        module = importlib.import_module(f".{name}", __name__)
        globals()[name] = module
        return module
    raise AttributeError(f"module 'motionlab' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
