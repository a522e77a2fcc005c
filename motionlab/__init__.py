"""motionlab: deep generative models of human motion, the library behind the course.

Modules load on first use, so ``import motionlab`` is instant and ``motionlab.data``
(which needs torch) costs nothing until you touch it:

    import motionlab
    clips = motionlab.data.load("../shared/mocap/cmu", fps=20)
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["amc", "animations", "asf", "asfamc", "bvh", "bvh_file", "checkpoints", "checks", "claims",
           "clip", "cmu_locomotion", "colab", "comparison", "contact_detection", "contacts", "cpu",
           "data", "download", "download_checks", "download_http", "engine", "experiments", "files",
           "filters", "gait", "live", "metrics", "models", "pretrained", "progress", "recipes",
           "representation", "rotations", "skeleton", "stickfigure", "synthetic", "text", "train",
           "training", "viz", "widgets"]
"""Every module and subpackage of the library (tests/test_package.py keeps it complete)."""


def __getattr__(name: str):
    # Each module is named here, in the code: an import statement per name, never a name
    # built from input, so nothing but the package's own modules can load. (`import
    # motionlab.x`, not `from . import x`, which would ask this function again.)
    match name:
        case "amc": import motionlab.amc as module
        case "animations": import motionlab.animations as module
        case "asf": import motionlab.asf as module
        case "asfamc": import motionlab.asfamc as module
        case "bvh": import motionlab.bvh as module
        case "bvh_file": import motionlab.bvh_file as module
        case "checkpoints": import motionlab.checkpoints as module
        case "checks": import motionlab.checks as module
        case "claims": import motionlab.claims as module
        case "clip": import motionlab.clip as module
        case "cmu_locomotion": import motionlab.cmu_locomotion as module
        case "colab": import motionlab.colab as module
        case "comparison": import motionlab.comparison as module
        case "contact_detection": import motionlab.contact_detection as module
        case "contacts": import motionlab.contacts as module
        case "cpu": import motionlab.cpu as module
        case "data": import motionlab.data as module
        case "download": import motionlab.download as module
        case "download_checks": import motionlab.download_checks as module
        case "download_http": import motionlab.download_http as module
        case "engine": import motionlab.engine as module
        case "experiments": import motionlab.experiments as module
        case "files": import motionlab.files as module
        case "filters": import motionlab.filters as module
        case "gait": import motionlab.gait as module
        case "live": import motionlab.live as module
        case "metrics": import motionlab.metrics as module
        case "models": import motionlab.models as module
        case "pretrained": import motionlab.pretrained as module
        case "progress": import motionlab.progress as module
        case "recipes": import motionlab.recipes as module
        case "representation": import motionlab.representation as module
        case "rotations": import motionlab.rotations as module
        case "skeleton": import motionlab.skeleton as module
        case "stickfigure": import motionlab.stickfigure as module
        case "synthetic": import motionlab.synthetic as module
        case "text": import motionlab.text as module
        case "train": import motionlab.train as module
        case "training": import motionlab.training as module
        case "viz": import motionlab.viz as module
        case "widgets": import motionlab.widgets as module
        case _:
            raise AttributeError(f"module 'motionlab' has no attribute {name!r}")
    globals()[name] = module
    return module


def __dir__():
    return sorted(list(globals()) + __all__)
