"""motionlab: deep generative models of human motion, the library behind the course.

Modules load on first use, so ``import motionlab`` is instant and ``motionlab.data``
(which needs torch) costs nothing until you touch it:

    import motionlab
    clips = motionlab.data.load("../shared/mocap/cmu", fps=20)
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["asfamc", "bvh", "checkpoints", "checks", "claims", "clip", "cmu_locomotion", "colab",
           "comparison", "contacts", "cpu", "data", "download", "engine", "experiments", "files",
           "filters", "live", "metrics", "models", "pretrained", "progress", "recipes",
           "representation", "rotations", "skeleton", "synthetic", "text", "train", "training",
           "viz", "widgets"]
"""Every module and subpackage of the library (tests/test_package.py keeps it complete)."""


def __getattr__(name: str):
    # One import statement per module of __all__: nothing is ever imported by a computed or
    # given name, so no input can make the package load anything but its own modules.
    match name:
        case "asfamc":
            import motionlab.asfamc as module
        case "bvh":
            import motionlab.bvh as module
        case "checkpoints":
            import motionlab.checkpoints as module
        case "checks":
            import motionlab.checks as module
        case "claims":
            import motionlab.claims as module
        case "clip":
            import motionlab.clip as module
        case "cmu_locomotion":
            import motionlab.cmu_locomotion as module
        case "colab":
            import motionlab.colab as module
        case "comparison":
            import motionlab.comparison as module
        case "contacts":
            import motionlab.contacts as module
        case "cpu":
            import motionlab.cpu as module
        case "data":
            import motionlab.data as module
        case "download":
            import motionlab.download as module
        case "engine":
            import motionlab.engine as module
        case "experiments":
            import motionlab.experiments as module
        case "files":
            import motionlab.files as module
        case "filters":
            import motionlab.filters as module
        case "live":
            import motionlab.live as module
        case "metrics":
            import motionlab.metrics as module
        case "models":
            import motionlab.models as module
        case "pretrained":
            import motionlab.pretrained as module
        case "progress":
            import motionlab.progress as module
        case "recipes":
            import motionlab.recipes as module
        case "representation":
            import motionlab.representation as module
        case "rotations":
            import motionlab.rotations as module
        case "skeleton":
            import motionlab.skeleton as module
        case "synthetic":
            import motionlab.synthetic as module
        case "text":
            import motionlab.text as module
        case "train":
            import motionlab.train as module
        case "training":
            import motionlab.training as module
        case "viz":
            import motionlab.viz as module
        case "widgets":
            import motionlab.widgets as module
        case _:
            raise AttributeError(f"module 'motionlab' has no attribute {name!r}")
    globals()[name] = module
    return module


def __dir__():
    return sorted(list(globals()) + __all__)
