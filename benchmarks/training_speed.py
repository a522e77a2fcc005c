"""Training steps per second of every model at laptop size, with the ordinary and the fused Adam.

    python benchmarks/training_speed.py [--threads 2] [--batch 32] [--rounds 3] [--steps 5]
    python benchmarks/training_speed.py --rounds 5 --steps 10     # the README's table

One training step is what ``motionlab.training.train`` does per batch: the loss, the
backward pass, gradient clipping at 1 and an Adam step. Batches of ``--batch`` windows of
random normalised features, of each model's default (laptop) window; DFN is timed in each
of its three stages (§5.6). The two optimisers run in interleaved rounds on the same model,
and the table gives each one's median over the rounds, so that a busy moment of the
machine does not favour either.

``training.adam`` uses PyTorch's fused Adam where it exists for the weights' device: one
pass over the weights per step, instead of several element-wise operations per weight
tensor. The update rule is the same. It helps where the optimiser is a large share of a
step: most for the VAE (a million weights, a quick forward pass), about a tenth for the
flows and the VAE-LSTM.
"""
from __future__ import annotations

import argparse
import statistics
import time

import torch

from motionlab.models import MODELS, classes
from motionlab.models.dfn import STAGES

CLIP = 1.0


def batch(model, size: int) -> torch.Tensor:
    frames = getattr(model.config, "window", 80)
    x = 0.5 * torch.randn(size, frames, 66, generator=torch.Generator().manual_seed(0))
    x[..., [0, 2]] = 0.0                              # the hips' root-local x and z are always 0
    return x


def steps_per_second(model, x: torch.Tensor, optimizer, steps: int) -> float:
    parameters = [p for p in model.parameters() if p.requires_grad]

    def step():
        loss = model.loss(x)["loss"]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(parameters, CLIP)
        optimizer.step()
    step()                                              # warm-up (and ActNorm's initialisation)
    began = time.perf_counter()
    for _ in range(steps):
        step()
    return steps / (time.perf_counter() - began)


def models(batch_size: int):
    """``(label, model, batch)`` for every trainable model (VAE: on 1280 conv features)."""
    for name in MODELS:
        model_class, config_class = classes(name)
        torch.manual_seed(0)
        model = model_class(config_class())
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
    print(f"torch {torch.__version__}, {args.threads} threads, batch {args.batch}, "
          f"median of {args.rounds} interleaved rounds of {args.steps} steps\n")
    print("| model | weight tensors | steps/s, Adam | steps/s, fused Adam | ratio |")
    print("|---|---|---|---|---|")
    for label, model, x in models(args.batch):
        parameters = [p for p in model.parameters() if p.requires_grad]
        optimizers = {"plain": torch.optim.Adam(parameters, lr=1e-4),
                      "fused": torch.optim.Adam(parameters, lr=1e-4, fused=True)}
        rates: dict[str, list[float]] = {name: [] for name in optimizers}
        for _ in range(args.rounds):
            for name, optimizer in optimizers.items():
                rates[name].append(steps_per_second(model, x, optimizer, args.steps))
        plain, fused = (statistics.median(rates[name]) for name in ("plain", "fused"))
        print(f"| {label} | {len(parameters)} | {plain:.1f} | {fused:.1f} | {fused / plain:.2f} |")


if __name__ == "__main__":
    main()
