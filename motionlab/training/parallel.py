"""Training over several processes (``torchrun``): which process this is, joining the
process group, each process's share of the data, the ``DistributedDataParallel`` wrapper,
and the means and gathers the processes agree on."""
from __future__ import annotations

import os

import torch
from torch import nn


def distributed() -> tuple[int, int]:
    """``(rank, world_size)`` of this process: ``(0, 1)`` unless ``torch.distributed`` is
    initialised (:func:`init_distributed`, under ``torchrun``)."""
    if joined():
        return torch.distributed.get_rank(), torch.distributed.get_world_size()
    return 0, 1


def init_distributed() -> bool:
    """Join the process group when this process was started by ``torchrun`` (``WORLD_SIZE``
    and ``LOCAL_RANK`` set): NCCL when there is a GPU (each process takes GPU
    ``LOCAL_RANK``), gloo on CPU. Returns whether it did; :func:`motionlab.training.train`
    then trains with ``DistributedDataParallel``."""
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


def joined() -> bool:
    """Whether this process is in a process group: :func:`motionlab.training.train` then
    shares the data out over the processes and trains with ``DistributedDataParallel``."""
    return torch.distributed.is_available() and torch.distributed.is_initialized()


def shard(train_set, batch_size: int, rank: int, world: int, seed: int):
    """``(loader, sampler)``: this process's share of every epoch, ``batch_size // world``
    windows a batch (``batch_size`` is the global batch); each epoch's shuffle is the same
    in every process once the sampler is told the epoch (``sampler.set_epoch``)."""
    sampler = torch.utils.data.DistributedSampler(train_set, num_replicas=world, rank=rank, shuffle=True,
                                                  seed=seed, drop_last=True)
    share = len(sampler)
    loader = torch.utils.data.DataLoader(train_set, batch_size=batch_size // world, sampler=sampler,
                                         drop_last=share > batch_size // world)
    return loader, sampler


def data_parallel(model: nn.Module, device: torch.device) -> nn.Module:
    """``model.loss`` wrapped in ``DistributedDataParallel``, which averages its gradients
    over the processes."""
    return torch.nn.parallel.DistributedDataParallel(
        _Loss(model), device_ids=[device.index or torch.cuda.current_device()] if device.type == "cuda" else None)


def mean_over_processes(values: dict[str, torch.Tensor], world: int) -> dict[str, torch.Tensor]:
    """The mean of each scalar in ``values`` over the ``world`` processes (the same in every one)."""
    stacked = torch.stack(list(values.values()))
    torch.distributed.all_reduce(stacked)
    return dict(zip(values, stacked / world))


def gathered(value, world: int):
    """Every process's ``value``, a list in rank order, when there are several; else ``value``."""
    if world == 1:
        return value
    everyone = [None] * world
    torch.distributed.all_gather_object(everyone, value)
    return everyone
