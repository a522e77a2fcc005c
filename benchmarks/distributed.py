"""Training across processes: MoGlow at the paper's size, one process against DDP.

Runs the command line (`python -m motionlab.train moglow --paper`) on the built-in data as
one process and under `torchrun` with N processes (gloo on CPU, NCCL on GPUs), each
twice: for a few steps and for more. The difference in wall time over the difference in
steps is the time of one training step, with start-up, data preparation, validation and
saving taken out. The global batch is the paper's (100 windows) in every row.

    python benchmarks/distributed.py [--processes 2] [--steps 2 7] [--device cpu]

On a CPU the processes share its cores: each gets cores / processes threads
(OMP_NUM_THREADS), so the rows compare one process on all cores with N processes on a
share each, the same hardware either way.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def run(processes: int, steps: int, threads: int, device: str, folder: Path) -> float:
    """Wall-clock seconds of one command-line run of ``steps`` steps."""
    command = ["-m", "motionlab.train", "moglow", "--paper", "--max-steps", str(steps), "--synthetic-clips", "60",
               "--device", device, "--out", str(folder / f"moglow_{processes}_{steps}.pt")]
    if processes > 1:
        command = ["-m", "torch.distributed.run", "--standalone", f"--nproc_per_node={processes}", *command]
    env = {**os.environ, "OMP_NUM_THREADS": str(threads)}
    began = time.perf_counter()
    result = subprocess.run([sys.executable, *command], capture_output=True, text=True, env=env)
    if result.returncode:
        raise SystemExit(result.stdout[-2000:] + result.stderr[-2000:])
    return time.perf_counter() - began


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--steps", type=int, nargs=2, default=[2, 7], metavar=("FEW", "MORE"))
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    few, more = args.steps
    print(f"MoGlow --paper (K=16, 2 x 512 LSTM, tau=10), global batch 100 windows, device {args.device}, "
          f"{cores} cores\n")
    print("| processes | threads each | s/step | steps/s | windows/s |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for processes in (1, args.processes):
            threads = max(1, cores // processes)
            short = run(processes, few, threads, args.device, Path(folder))
            long = run(processes, more, threads, args.device, Path(folder))
            step = (long - short) / (more - few)
            print(f"| {processes} | {threads} | {step:.2f} | {1 / step:.3f} | {100 / step:.1f} |", flush=True)


if __name__ == "__main__":
    main()
