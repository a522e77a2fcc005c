"""MoGlow speed: training step time and real-time sampling rate (issue: MoGlow, §4-5).

Prints, for the laptop configuration and the paper's (§5.2: K = 16 steps, 2 LSTM layers of
512 units, τ = 10), the time of one training step on a batch of 100 windows of 70
predicted frames (80 with the history), and how many frames per second the streaming
sampler produces for one stream and for 64 streams at once (a batch of characters). The
weights are untrained: speed does not depend on their values.

    python benchmarks/moglow_speed.py [--threads 2] [--frames 200] [--skip-paper-training]

For reference, the authors' public implementation on this kind of 2-core machine at the
paper size: 19.3 s per training step, 16.4 frames/s for one stream, ~600 frames/s in
total for 64 streams; the target here is 50 frames/s for one stream (real time is 20) and
1,500 frames/s for 64.
"""
from __future__ import annotations

import argparse
import time

import torch

from motionlab.models.moglow import MoGlow, MoGlowConfig


def windows(n: int, frames: int) -> torch.Tensor:
    x = torch.randn(n, frames, 66, generator=torch.Generator().manual_seed(0))
    x[..., [0, 2]] = 0.0
    return x


def training_step_s(config: MoGlowConfig, batch: int = 100, repeats: int = 3) -> float:
    torch.manual_seed(0)
    model = MoGlow(config)
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-4)
    x = windows(batch, config.history + 70)
    times = []
    for _ in range(repeats + 1):                      # the first step also initialises ActNorm
        began = time.perf_counter()
        loss = model.loss(x)["loss"]
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        times.append(time.perf_counter() - began)
    return min(times[1:])


def sampling(config: MoGlowConfig, streams: int, frames: int, weights=torch.float32) -> dict[str, float]:
    torch.manual_seed(0)
    model = MoGlow(config)
    model.loss(windows(4, config.history + 2))         # ActNorm's initialisation
    model.eval()
    start = windows(streams, config.history)
    control = torch.zeros(streams, 3)
    stream = model.stream(start, temperature=0.8, generator=torch.Generator().manual_seed(0), weights=weights)
    for _ in range(5):                                 # warm-up
        stream.step(control)
    latencies = []
    began = time.perf_counter()
    for _ in range(frames):
        t = time.perf_counter()
        stream.step(control)
        latencies.append(time.perf_counter() - t)
    elapsed = time.perf_counter() - began
    latencies.sort()
    return {"frames/s": streams * frames / elapsed, "steps/s": frames / elapsed,
            "median ms": 1000 * latencies[len(latencies) // 2], "p99 ms": 1000 * latencies[int(0.99 * len(latencies))]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--frames", type=int, default=200, help="frames to generate per timing")
    parser.add_argument("--skip-paper-training", action="store_true", help="skip the paper-size training step")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    configs = {"laptop": MoGlowConfig(), "paper (§5.2)": MoGlowConfig.paper()}
    print(f"torch {torch.__version__}, {args.threads} threads\n")
    print(f"{'config':22}{'weights (MB)':>13}{'train step (s)':>16}{'1 stream (fps)':>16}"
          f"{'latency ms (med/p99)':>22}{'64 streams (fps)':>18}{'x real time':>13}")
    for name, config in configs.items():
        megabytes = 4 * sum(p.numel() for p in MoGlow(config).parameters()) / 1e6
        train = float("nan") if (args.skip_paper_training and name != "laptop") else training_step_s(config)
        for dtype in (torch.float32, torch.bfloat16):
            one = sampling(config, 1, args.frames, dtype)
            many = sampling(config, 64, max(20, args.frames // 4), dtype)
            label = f"{name}, {str(dtype).replace('torch.', '')}"
            print(f"{label:22}{megabytes:13.1f}{train:16.2f}{one['frames/s']:16.1f}"
                  f"{one['median ms']:11.2f} / {one['p99 ms']:<8.2f}{many['frames/s']:18.0f}"
                  f"{one['frames/s'] / config.fps:13.1f}")
            train = float("nan")                      # one training time per config
    print("\nweights (MB) as float32; bfloat16: the LSTM products of the stream in bfloat16 (MoGlowStream weights=)")

if __name__ == "__main__":
    main()
