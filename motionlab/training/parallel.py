"""Training over several processes (``torchrun``): which process this is, joining the
process group, and what ``DistributedDataParallel`` wraps."""
from __future__ import annotations

import os

import torch
from torch import nn


def distributed() -> tuple[int, int]:
    """``(rank, world_size)`` of this process: ``(0, 1)`` unless ``torch.distributed`` is
    initialised (:func:`init_distributed`, under ``torchrun``)."""
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


def init_distributed() -> bool:
    """Join the process group when this process was started by ``torchrun`` (``WORLD_SIZE``
    and ``LOCAL_RANK`` set): NCCL when there is a GPU (each process takes GPU
    ``LOCAL_RANK``), gloo on CPU. Returns whether it did; :func:`train` then trains with
    ``DistributedDataParallel``."""
    if "WORLD_SIZE" not in os.environ or torch.distributed.is_initialized():
        return torch.distributed.is_initialized()
    gpu = torch.cuda.is_available()
    if gpu:
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", 0)))
    torch.distributed.init_process_group("nccl" if gpu else "gloo")
    return True


class _Loss(nn.Module):
    """``model.loss`` as a forward pass: DistributedDataParallel averages the gradients of
    what its module's forward computes, and every motionlab model trains through ``loss``."""

    def __init__(self, model: nn.Module):
        super().__init__()
        self.model = model

    def forward(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.model.loss(batch)
