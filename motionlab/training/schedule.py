"""The learning-rate schedule of :func:`motionlab.training.train`: a linear warm-up, then a
cosine decay (or a constant rate), as a factor of the peak learning rate."""
from __future__ import annotations

import math


def lr_factor(step: int, total_steps: int, warmup_steps: int = 0, schedule: str = "cosine",
              min_lr_ratio: float = 0.1) -> float:
    """The learning rate of step ``step`` (counted from 0) as a fraction of the peak rate.

    For the first ``warmup_steps`` steps the factor rises linearly, ``1 / warmup_steps`` at
    step 0 to 1 at the last warm-up step (small steps while Adam's estimates of the
    gradient's moments are still noisy). Then ``"constant"`` stays at 1, and ``"cosine"``
    falls along half a cosine from 1 right after warm-up to ``min_lr_ratio`` at
    ``total_steps`` (Loshchilov & Hutter 2017, SGDR, without restarts).

    ``torch.optim.lr_scheduler.LambdaLR`` multiplies the optimiser's learning rate by it.
    """
    if step < warmup_steps:
        return (step + 1) / warmup_steps
    if schedule == "constant":
        return 1.0
    progress = (step - warmup_steps) / max(1, total_steps - warmup_steps)
    return min_lr_ratio + (1 - min_lr_ratio) * 0.5 * (1 + math.cos(math.pi * progress))
