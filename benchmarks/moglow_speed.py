"""MoGlow speed against the machine's own limits: training steps, one stream, 64 streams.

    python benchmarks/moglow_speed.py [--threads 2] [--frames 100] [--skip-paper-training]

For the laptop configuration and the paper's (§5.2: K = 16 steps, 2 LSTM layers of 512
units, τ = 10) it prints, in float32 and with bfloat16 streaming weights:

* the time of one training step on a batch of 100 windows of 70 predicted frames (80 with
  the history), and the process's peak memory while it runs;
* frames per second of the streaming sampler (:class:`MoGlowStream`) for one stream and
  for 64 streams at once (a crowd of characters);

and beside each figure the limit this machine puts on it, measured by the script itself:

* **one stream** reads every weight once per frame, so it cannot beat
  ``weight bytes / memory bandwidth``; the bandwidth is that of a matrix-vector product
  streaming 240 MB of distinct matrices of the model's shape (what the stream does);
* **64 streams** and **training** are arithmetic: ``2 x weight elements`` floating-point
  operations per frame and stream forwards (every weight matrix is used once; the
  element-wise work is far smaller), three times that for a training frame (the backward
  pass costs twice the forward). Their limits divide by the measured matrix-product rate:
  the best float32 rate (large products) for both; for bfloat16 streams the rate of
  64-row bfloat16 products.

The weights are untrained: speed does not depend on their values. Run it on a quiet
machine; the figures vary by 10-20 % from run to run on a shared one.
"""
from __future__ import annotations

import argparse
import multiprocessing
import resource
import time

import torch
import torch.nn.functional as F

from motionlab.models.moglow import MoGlow, MoGlowConfig

TRAIN_BATCH, TRAIN_FRAMES = 100, 70          # the paper's batches (§5.2): 100 windows, 70 predicted frames
CROWD = 64
# Paper-size targets, set on another 2-core machine (AVX-512 with AVX512-BF16):
# (what, stream weights, one stream or 64, frames per second)
TARGETS = (("1 stream, float32", "float32", "one", 58), ("1 stream, bfloat16", "bfloat16", "one", 100),
           ("64 streams, float32", "float32", "crowd", 1500))


def windows(n: int, frames: int) -> torch.Tensor:
    x = torch.randn(n, frames, 66, generator=torch.Generator().manual_seed(0))
    x[..., [0, 2]] = 0.0
    return x


def weight_elements(model: MoGlow) -> int:
    """Elements of every weight matrix (LSTM ``W_ih``, ``W_hh``, output layers, 1x1 maps):
    each is used once per frame, one multiply-add each."""
    return sum(p.numel() for p in model.parameters() if p.ndim == 2)


def best_time(work, repeats: int = 5) -> float:
    work()
    times = []
    for _ in range(repeats):
        began = time.perf_counter()
        work()
        times.append(time.perf_counter() - began)
    return min(times)


def machine_limits() -> dict[str, float]:
    """What this machine can do, measured: matrix-vector bandwidth (GB/s) over 240 MB of
    distinct weights, and matrix-product rates (GFLOP/s): large float32 products (the best
    this machine's BLAS does) and 64-row bfloat16 ones."""
    shape = (4 * 512, 1205)                        # a paper-size LSTM layer: [W_ih W_hh], 4H x (in + H)
    matrices = [torch.randn(shape) for _ in range(24)]
    nbytes = sum(m.numel() * 4 for m in matrices)
    row, rows = torch.randn(1, shape[1]), torch.randn(CROWD, shape[1])
    gemv = best_time(lambda: [F.linear(row, m) for m in matrices])
    crowd = best_time(lambda: [F.linear(rows, m) for m in matrices])
    big_x, big_w = torch.randn(TRAIN_BATCH * TRAIN_FRAMES, shape[1]), matrices[0]
    large = best_time(lambda: F.linear(big_x, big_w), 3)
    half = [m.to(torch.bfloat16) for m in matrices[:4]]
    half_rows = rows.to(torch.bfloat16)
    bf16 = best_time(lambda: [F.linear(half_rows, m) for m in half], 2)
    return {"bandwidth (GB/s)": nbytes / gemv / 1e9,
            "large float32 (GFLOP/s)": 2 * big_x.shape[0] * big_w.numel() / large / 1e9,
            "64-row float32 (GFLOP/s)": 2 * CROWD * nbytes / 4 / crowd / 1e9,
            "64-row bfloat16 (GFLOP/s)": 2 * CROWD * 4 * big_w.numel() / bf16 / 1e9}


def training_step(config: MoGlowConfig, repeats: int = 2) -> tuple[float, float]:
    """Seconds of one training step (best of ``repeats``) and the peak memory (MB) of the
    process that ran it."""
    torch.manual_seed(0)
    model = MoGlow(config)
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-4)
    x = windows(TRAIN_BATCH, config.history + TRAIN_FRAMES)

    def step():
        loss = model.loss(x)["loss"]
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    seconds = best_time(step, repeats)              # the first, untimed step also initialises ActNorm
    return seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _training_in_child(config: MoGlowConfig, threads: int, queue) -> None:
    torch.set_num_threads(threads)
    queue.put(training_step(config))


def training_step_alone(config: MoGlowConfig, threads: int) -> tuple[float, float]:
    """:func:`training_step` in a fresh process, so that its peak memory is its own."""
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_training_in_child, args=(config, threads, queue))
    child.start()
    result = queue.get()
    child.join()
    return result


def sampling_fps(config: MoGlowConfig, streams: int, frames: int, weights=torch.float32) -> float:
    """Frames per second in all of ``streams`` characters streamed at once."""
    torch.manual_seed(0)
    model = MoGlow(config)
    model.loss(windows(4, config.history + 2))         # ActNorm's initialisation
    model.eval()
    stream = model.stream(windows(streams, config.history), temperature=0.8,
                          generator=torch.Generator().manual_seed(0), weights=weights)
    control = torch.zeros(streams, 3)
    for _ in range(3):                                 # warm-up
        stream.step(control)
    began = time.perf_counter()
    for _ in range(frames):
        stream.step(control)
    return streams * frames / (time.perf_counter() - began)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--frames", type=int, default=100, help="frames per stream and timing")
    parser.add_argument("--skip-paper-training", action="store_true",
                        help="skip the paper-size training step (about two minutes)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(f"torch {torch.__version__}, {args.threads} threads, CPU capability "
          f"{torch.backends.cpu.get_cpu_capability()}\n")
    limits = machine_limits()
    print("This machine, measured: " + ", ".join(f"{name} {value:.1f}" for name, value in limits.items()) + "\n")

    print("| config | weights (MB, float32) | training step (s) | its limit (s) | peak memory (MB) "
          "| stream weights | 1 stream (fps) | its limit (fps) | 64 streams (fps) | their limit (fps) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    measured = {}
    for name, config in {"laptop": MoGlowConfig(), "paper (§5.2)": MoGlowConfig.paper()}.items():
        elements = weight_elements(MoGlow(config))
        flops = 2 * elements                                                   # per frame, forwards
        if args.skip_paper_training and name != "laptop":
            train = peak = train_limit = float("nan")
        else:
            train, peak = training_step_alone(config, args.threads)
            train_limit = 3 * flops * TRAIN_BATCH * TRAIN_FRAMES / (limits["large float32 (GFLOP/s)"] * 1e9)
        for dtype, size in ((torch.float32, 4), (torch.bfloat16, 2)):
            one = sampling_fps(config, 1, args.frames, dtype)
            crowd = sampling_fps(config, CROWD, max(10, args.frames // 5), dtype)
            rate = limits["large float32 (GFLOP/s)"] if dtype == torch.float32 else limits["64-row bfloat16 (GFLOP/s)"]
            one_limit = limits["bandwidth (GB/s)"] * 1e9 / (size * elements)
            crowd_limit = rate * 1e9 / flops
            label = str(dtype).replace("torch.", "")
            measured[(name, label)] = {"one": (one, one_limit), "crowd": (crowd, crowd_limit)}
            first = dtype == torch.float32
            print(f"| {name if first else ''} | {f'{4 * elements / 1e6:.1f}' if first else ''} "
                  f"| {f'{train:.2f}' if first else ''} | {f'{train_limit:.2f}' if first else ''} "
                  f"| {f'{peak:.0f}' if first else ''} | {label} | {one:.1f} | {one_limit:.0f} "
                  f"| {crowd:.0f} | {crowd_limit:.0f} |")
    print("\nPaper-size targets (set on another 2-core machine), measured here, and this machine's limit:")
    for what, label, streams, target in TARGETS:
        fps, limit = measured[("paper (§5.2)", label)][streams]
        print(f"  {what}: target {target} fps, measured {fps:.0f}, limit {limit:.0f}")
    print("\nLimits: one stream = bandwidth / weight bytes; 64 streams = matrix-product rate / (2 x weight "
          "elements) per frame; training step = 3 x 2 x weight elements x 100 x 70 frames / large float32 rate. "
          "bfloat16 streams use the 64-row bfloat16 rate: without native bfloat16 arithmetic (AVX512-BF16, AMX) "
          "it is emulated, far below float32. The laptop model's 3 MB of weights stay in the cache: its "
          "limits are far above what the per-operation overhead of small products allows.")


if __name__ == "__main__":
    main()
