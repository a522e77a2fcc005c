"""motionlab: deep generative models of human motion, the library behind the course.

Modules load on first use, so ``import motionlab`` is instant and ``motionlab.data``
(which needs torch) costs nothing until you touch it:

    import motionlab
    clips = motionlab.data.load("../shared/mocap/cmu", fps=20)
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

__all__ = ["amc", "animations", "asf", "asfamc", "bvh", "bvh_file", "checkpoints", "checks", "claims",
           "clip", "cmu_locomotion", "colab", "comparison", "contact_detection", "contacts", "cpu",
           "data", "download", "download_checks", "download_http", "engine", "experiments", "files",
           "filters", "gait", "live", "metrics", "models", "pretrained", "progress", "recipes",
           "representation", "rotations", "skeleton", "stickfigure", "synthetic", "text", "train",
           "training", "viz", "widgets"]
"""Every module and subpackage of the library (tests/test_package.py keeps it complete)."""


def __getattr__(name: str):
    # Only a name of __all__ (a fixed list, written here) is ever imported: no input can make
    # the package load anything but its own modules.
    if name not in __all__:
        raise AttributeError(f"module 'motionlab' has no attribute {name!r}")
    module = importlib.import_module(f"{__name__}.{name}")
    globals()[name] = module
    return module


def __dir__():
    return sorted(list(globals()) + __all__)
