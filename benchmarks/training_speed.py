"""Training steps per second of every model at laptop size, in float32 and in bfloat16 mixed precision.

    python benchmarks/training_speed.py [--threads 2] [--batch 32] [--rounds 3] [--steps 5]
    python benchmarks/training_speed.py --rounds 5 --steps 10     # the README's table

One training step is what ``motionlab.training.train`` does per batch: the loss (for the
bf16 column under ``torch.autocast(dtype=torch.bfloat16)``, as ``--precision bf16``
trains), the backward pass, gradient clipping at 1 and a fused Adam step (what
``training.adam`` picks on the CPU). Batches of ``--batch``
windows of random normalised features, of each model's default (laptop) window; DFN is
timed in each of its three stages (§5.6). The two precisions run in interleaved rounds on
the same model, and the table gives each one's median over the rounds, so that a busy
moment of the machine does not favour either.

Run it with another checkout's ``motionlab`` first on ``PYTHONPATH`` to compare two
versions of the library on the same machine (the README's before/after table).
"""
from __future__ import annotations

import argparse
import statistics
import time
from contextlib import nullcontext
from pathlib import Path

import torch

import motionlab
from motionlab import models as registry
from motionlab.models.dfn import STAGES

CLIP = 1.0


def batch(model, size: int) -> torch.Tensor:
    frames = getattr(model.config, "window", 80)
    x = 0.5 * torch.randn(size, frames, 66, generator=torch.Generator().manual_seed(0))
    x[..., [0, 2]] = 0.0                              # the hips' root-local x and z are always 0
    return x


def steps_per_second(model, x: torch.Tensor, precision: torch.dtype | None, steps: int) -> float:
    parameters = [p for p in model.parameters() if p.requires_grad]
    optimizer = torch.optim.Adam(parameters, lr=1e-4, fused=True)

    def step():
        with torch.autocast("cpu", dtype=precision) if precision is not None else nullcontext():
            loss = model.loss(x)["loss"]
        optimizer.zero_grad(set_to_none=True)
        loss.float().backward()
        torch.nn.utils.clip_grad_norm_(parameters, CLIP)
        optimizer.step()
    step()                                              # warm-up (and ActNorm's initialisation)
    began = time.perf_counter()
    for _ in range(steps):
        step()
    return steps / (time.perf_counter() - began)


def models(batch_size: int):
    """``(label, model, batch)`` for every trainable model (VAE: on 1280 conv features)."""
    for name, card in registry.cards().items():
        torch.manual_seed(0)
        model = card.model(card.config())
        if name == "vae":
            yield name, model, torch.randn(batch_size, model.config.n_inputs)
        elif name == "dfn":
            x = batch(model, batch_size)
            for stage in STAGES:
                model.set_stage(stage, x)
                yield f"dfn ({stage})", model, x
        else:
            yield name, model, batch(model, batch_size)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps", type=int, default=5, help="timed steps per round")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    # older checkouts, timed through PYTHONPATH, have no motionlab.cpu (nor training.adam's
    # choice, hence the fused Adam above): then PyTorch's own reading of the CPU
    try:
        from motionlab import cpu
        kernels = cpu.summary()
    except ImportError:
        native = torch.backends.mkldnn.is_available() and torch.ops.mkldnn._is_mkldnn_bf16_supported()
        kernels = f"native bfloat16 products: {native}"
    print(f"torch {torch.__version__}, {args.threads} threads, batch {args.batch}, median of {args.rounds} "
          f"interleaved rounds of {args.steps} steps; motionlab from {Path(motionlab.__file__).parent}; "
          f"{kernels}\n")
    print("| model | steps/s, float32 | steps/s, bf16 mixed | ratio |")
    print("|---|---|---|---|")
    precisions = {"fp32": None, "bf16": torch.bfloat16}
    for label, model, x in models(args.batch):
        rates: dict[str, list[float]] = {name: [] for name in precisions}
        for _ in range(args.rounds):
            for name, dtype in precisions.items():
                rates[name].append(steps_per_second(model, x, dtype, args.steps))
        fp32, bf16 = (statistics.median(rates[name]) for name in precisions)
        print(f"| {label} | {fp32:.1f} | {bf16:.1f} | {bf16 / fp32:.2f} |")


if __name__ == "__main__":
    main()
