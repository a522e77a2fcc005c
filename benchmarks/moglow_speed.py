"""MoGlow speed against the machine's own limits: training steps, one stream, 64 streams.

    python benchmarks/moglow_speed.py [--threads 2] [--frames 100] [--skip-paper-training] [--nll-epochs 10]
    python benchmarks/moglow_speed.py --compare ADAPTER.py [--rounds 4]   # beside another implementation

For the laptop configuration and the paper's (§5.2: K = 16 steps, 2 LSTM layers of 512
units, τ = 10) it prints, in float32 and in bfloat16:

* the time of one training step on a batch of 100 windows of 70 predicted frames (80 with
  the history), in float32 and in bfloat16 mixed precision (``--precision bf16``: the
  coupling networks under autocast, the flow's transforms and likelihood in float32), the
  time its LSTMs take alone (forwards and backwards, nothing else: what the LSTM kernels
  themselves allow), both as MoGlow trains them on the CPU (the written-out LSTM of
  :mod:`motionlab.engine.recurrent`) and with ``nn.LSTM``'s oneDNN kernels, and the peak
  memory of the process that ran the step;
* frames per second of the streaming sampler (:class:`MoGlowStream`) with float32 and with
  bfloat16 weights, for one stream and for 64 streams at once (a crowd of characters);

and beside each figure the limit this machine puts on it, measured by the script itself:

* **one stream** reads every weight once per frame, so it cannot beat
  ``weight bytes / memory bandwidth``; the bandwidth is that of a plain sum over 240 MB of
  distinct matrices of the model's shape, and the script also prints what the one-row
  products the stream runs reach over the same matrices (the kernel's own limit);
* **64 streams** and **training** are arithmetic: ``2 x weight elements`` floating-point
  operations per frame and stream forwards (every weight matrix is used once; the
  element-wise work is far smaller), three times that for a training frame (the backward
  pass costs twice the forward). Their limits divide by the measured matrix-product rate
  of their precision: for 64 streams the best of large and 64-row products; for training
  the large-product rate, except for the LSTMs' recurrent products (forwards and the
  gradient of their input), which must run frame by frame on 100 rows and get the rate
  of such products. The rates vary by 10-20 % between runs, so a step may come out a
  little under its "limit".

Last, it trains the laptop model for ``--nll-epochs`` epochs on built-in data twice from
the same seed, in float32 and in bfloat16, and prints both validation curves and test
NLLs: bfloat16 must follow float32 within ``NLL_TOLERANCE`` bits per frame.

The speed measurements use untrained weights: speed does not depend on their values. Run
it on a quiet machine; the figures vary by 10-20 % from run to run on a shared one.

``--compare ADAPTER.py`` instead times another MoGlow implementation beside motionlab's,
float32, at the laptop and the paper sizes: a training step (100 windows of 80 frames), one
stream and 64 streams, in ``--rounds`` interleaved rounds (the median is printed). The
other implementation is reached through an adapter file you write; its contract, and an
adapter for motionlab itself (which must come out even), are in
``benchmarks/compare_motionlab.py``. motionlab's side goes through that adapter too.
"""
from __future__ import annotations

import argparse
import importlib.util
import multiprocessing
import resource
import statistics
import time
from contextlib import nullcontext
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from motionlab import data, training
from motionlab.engine import recurrent
from motionlab import cpu
from motionlab.cpu import native_bfloat16, onednn_disabled
from motionlab.models.moglow import LSTMCouplingNet, MoGlow, MoGlowConfig

TRAIN_BATCH, TRAIN_FRAMES = 100, 70          # the paper's batches (§5.2): 100 windows, 70 predicted frames
CROWD = 64
NLL_TOLERANCE = 1.0                          # bits/frame: bfloat16 training follows the float32 curve this closely
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


def recurrent_elements(model: MoGlow) -> int:
    """Elements of the LSTMs' recurrent matrices ``W_hh``: in training, one product per
    frame of a batch-row input, ``h_{t-1}`` waiting for the frame before it."""
    return sum(p.numel() for name, p in model.named_parameters() if "weight_hh" in name)


def recurrent_rate(hidden: int, dtype: torch.dtype) -> float:
    """GFLOP/s of the recurrent product of training, ``(100, H) x (H, 4H)`` with the same
    matrix frame after frame (it stays in the cache), in ``dtype``."""
    matrix = torch.randn(4 * hidden, hidden).to(dtype)
    rows = torch.randn(TRAIN_BATCH, hidden).to(dtype)
    repeats = 50
    seconds = best_time(lambda: [F.linear(rows, matrix) for _ in range(repeats)])
    return 2 * TRAIN_BATCH * matrix.numel() * repeats / seconds / 1e9


def conditioning_elements(model: MoGlow) -> int:
    """Elements of the first LSTM layers' input matrices that read the conditioning: they
    need no input gradient (the conditioning is data)."""
    nets = [m for m in model.modules() if isinstance(m, LSTMCouplingNet)]
    return sum(4 * net.lstm.hidden_size * model.cond_channels for net in nets)


def training_limit(model: MoGlow, large: float, hundred_rows: float) -> float:
    """Seconds a training step cannot beat: every weight matrix takes 3 products per frame
    (forwards, the gradient of its input, the gradient of its weights; the conditioning
    needs no input gradient), at the large-product rate ``large`` (GFLOP/s), except the
    recurrent ones' forward and input-gradient products, which must go frame by frame at
    the 100-row rate ``hundred_rows`` (GFLOP/s)."""
    frames = TRAIN_BATCH * TRAIN_FRAMES
    hh = recurrent_elements(model)
    other = weight_elements(model) - hh
    return 2 * frames * ((3 * other - conditioning_elements(model)) / large + hh / large + 2 * hh / hundred_rows) / 1e9


def best_time(work, repeats: int = 5) -> float:
    work()
    times = []
    for _ in range(repeats):
        began = time.perf_counter()
        work()
        times.append(time.perf_counter() - began)
    return min(times)


def machine_limits() -> dict[str, float]:
    """What this machine can do, measured over matrices of a paper-size LSTM layer's shape:

    * the memory bandwidth (GB/s): a plain sum over 240 MB of distinct matrices, which reads
      every byte once and does next to no arithmetic (the better of float32 and bfloat16);
    * what the one-row products that one stream runs reach over the same matrices, in GB/s
      of weights read: float32 against weights stored transposed (oneDNN), bfloat16 with
      PyTorch's own kernel (oneDNN disabled, as :class:`MoGlowStream` does on a CPU with
      native bfloat16);
    * matrix-product rates (GFLOP/s): large products (100 x 70 rows, as in training) in
      float32 and in bfloat16, and 64-row products (64 streams) over the same 240 MB.
    """
    shape = (4 * 512, 1205)                        # a paper-size LSTM layer: [W_ih W_hh], 4H x (in + H)
    rates, read = {}, []
    for dtype, name, count in ((torch.float32, "float32", 24), (torch.bfloat16, "bfloat16", 48)):
        matrices = [torch.randn(shape).to(dtype) for _ in range(count)]            # 240 MB either way
        nbytes = sum(m.numel() * m.element_size() for m in matrices)
        row, rows = torch.randn(1, shape[1]).to(dtype), torch.randn(CROWD, shape[1]).to(dtype)
        big = torch.randn(TRAIN_BATCH * TRAIN_FRAMES, shape[1]).to(dtype)
        read.append(nbytes / best_time(lambda: [m.sum() for m in matrices]) / 1e9)
        if dtype == torch.float32:
            transposed = [m.T.contiguous() for m in matrices]
            one_row = best_time(lambda: [row @ m for m in transposed])
            del transposed
        else:
            with onednn_disabled():
                one_row = best_time(lambda: [F.linear(row, m) for m in matrices])
        rates[f"one-row product, {name} (GB/s)"] = nbytes / one_row / 1e9
        elements = sum(m.numel() for m in matrices)
        rates[f"64-row {name} (GFLOP/s)"] = 2 * CROWD * elements / best_time(
            lambda: [F.linear(rows, m) for m in matrices], 2) / 1e9
        rates[f"large {name} (GFLOP/s)"] = 2 * big.shape[0] * matrices[0].numel() / best_time(
            lambda: F.linear(big, matrices[0]), 8) / 1e9
    return {"bandwidth (GB/s)": max(read), **rates}


def training_step(config: MoGlowConfig, precision: str = "fp32", repeats: int = 2) -> tuple[float, float]:
    """Seconds of one training step (best of ``repeats``) and the peak memory (MB) of the
    process that ran it. ``precision``: ``"fp32"``, or ``"bf16"`` under autocast as
    ``TrainConfig(precision="bf16")`` trains (the flow's transforms stay float32)."""
    torch.manual_seed(0)
    model = MoGlow(config)
    optimizer = training.adam(model.parameters(), lr=1e-4)
    x = windows(TRAIN_BATCH, config.history + TRAIN_FRAMES)
    low = training.PRECISIONS[precision]

    def step():
        with torch.autocast("cpu", dtype=low) if low is not None else nullcontext():
            loss = model.loss(x)["loss"]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
    seconds = best_time(step, repeats)              # the first, untimed step also initialises ActNorm
    return seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def lstm_seconds(config: MoGlowConfig, precision: str = "fp32", repeats: int = 2, written_out: bool = True) -> float:
    """Seconds the LSTMs of one training step take alone (best of ``repeats``): forwards and
    backwards, with the gradient of the half-pose they read but not of the conditioning, of
    the ``config.steps`` coupling LSTMs over the step's 100 windows of 70 frames, and
    nothing else of the model. ``written_out``: as MoGlow trains them on the CPU (through
    :func:`motionlab.engine.recurrent.from_zero_state`); ``False``: ``nn.LSTM``'s own
    kernels (:func:`motionlab.engine.recurrent.run`: PyTorch's own LSTM cells where oneDNN has
    no LSTM in ``precision``, see :func:`motionlab.cpu.onednn_lstm`)."""
    torch.manual_seed(0)
    model = MoGlow(config)
    lstms = [m.lstm for m in model.modules() if isinstance(m, LSTMCouplingNet)]
    cond = torch.randn(TRAIN_BATCH, TRAIN_FRAMES, model.cond_channels)
    half = torch.randn(TRAIN_BATCH, TRAIN_FRAMES, lstms[0].input_size - model.cond_channels, requires_grad=True)
    low = training.PRECISIONS[precision]

    def run(lstm):
        if written_out:
            return recurrent.from_zero_state(lstm, half, cond)
        return recurrent.run(lstm, torch.cat([half, cond], -1))[0]     # PyTorch's own cells where oneDNN has no such LSTM

    def work():
        with torch.autocast("cpu", dtype=low) if low is not None else nullcontext():
            total = sum(run(lstm).float().mean() for lstm in lstms)
        total.backward()
    return best_time(work, repeats)


def _training_in_child(config: MoGlowConfig, precision: str, threads: int, queue) -> None:
    torch.set_num_threads(threads)
    queue.put(training_step(config, precision))


def training_step_alone(config: MoGlowConfig, precision: str, threads: int) -> tuple[float, float]:
    """:func:`training_step` in a fresh process, so that its peak memory is its own."""
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    child = context.Process(target=_training_in_child, args=(config, precision, threads, queue))
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
    return streaming_rate(stream.step, streams, frames)


def streaming_rate(step, streams: int, frames: int) -> float:
    """Frames per second of ``step`` (control ``(streams, 3)`` -> the next frame of every
    stream) over ``frames`` calls, after three untimed ones, counting every stream's frame."""
    control = torch.zeros(streams, 3)
    for _ in range(3):                                 # warm-up
        step(control)
    began = time.perf_counter()
    for _ in range(frames):
        step(control)
    return streams * frames / (time.perf_counter() - began)


def precision_trajectory(epochs: int, clips: int) -> None:
    """Train the laptop MoGlow twice from the same seed on built-in data, in float32 and in
    bfloat16 mixed precision, and print both runs' validation NLL after every epoch and
    their test NLL at the end (bits per frame, normalised units), with the seconds each took."""
    prepared = data.prepare(data.load("synthetic", n_clips=clips), window_s=4.0)
    print(f"\nLaptop MoGlow, {epochs} epochs on {len(prepared.train.windows)} built-in training windows, "
          "float32 and bfloat16 from the same seed:\n")
    runs = {}
    for precision in ("fp32", "bf16"):
        torch.manual_seed(0)
        model = MoGlow(MoGlowConfig())
        began = time.perf_counter()
        history = training.train(model, prepared, training.TrainConfig(epochs=epochs, lr=1e-3, progress=False,
                                                                        precision=precision))
        seconds = time.perf_counter() - began
        nats = history.series("loss", "val")[1] * model.n_modelled         # nats per value -> per frame
        runs[precision] = (nats / np.log(2), model.nll(prepared.test.windows)["bits/frame"], seconds)
    print("| epoch | " + " | ".join(f"validation, {p} (bits/frame)" for p in runs) + " | difference |")
    print("|---|---|---|---|")
    for epoch, (a, b) in enumerate(zip(runs["fp32"][0], runs["bf16"][0]), 1):
        print(f"| {epoch} | {a:.2f} | {b:.2f} | {b - a:+.2f} |")
    (fp32_curve, fp32, fp32_s), (bf16_curve, bf16, bf16_s) = runs["fp32"], runs["bf16"]
    apart = float(np.abs(bf16_curve - fp32_curve).max())
    print(f"\nTest NLL: float32 {fp32:.2f}, bfloat16 {bf16:.2f} bits/frame ({bf16 - fp32:+.2f}); training "
          f"{fp32_s:.0f} s and {bf16_s:.0f} s. The validation curves are at most {apart:.2f} bits/frame apart: "
          f"{'within' if apart <= NLL_TOLERANCE else 'OUTSIDE'} the tolerance of {NLL_TOLERANCE:g} bits/frame "
          f"(the curves fall by {fp32_curve[0] - fp32_curve[-1]:.0f}).")


def load_adapter(path: str | Path):
    """The adapter module at ``path`` (a Python file the user names on the command line),
    checked to define ``training_step`` and ``streaming_step``."""
    path = Path(path)
    if not path.is_file() or path.suffix != ".py":
        raise ValueError(f"--compare: expected a Python file (an adapter, see benchmarks/compare_motionlab.py), "
                         f"got {str(path)!r}")
    spec = importlib.util.spec_from_file_location(f"moglow_speed_adapter_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    missing = [name for name in ("training_step", "streaming_step") if not callable(getattr(module, name, None))]
    if missing:
        raise ValueError(f"{path}: an adapter defines training_step and streaming_step "
                         f"(see benchmarks/compare_motionlab.py); missing: {', '.join(missing)}")
    return module


def compare(other, configs: dict, rounds: int = 4, frames: int = 100, trained=None,
            bf16: bool | None = None) -> list[dict]:
    """Time the adapter ``other`` beside motionlab (through ``compare_motionlab.py``) for each
    of ``configs`` (``{name: MoGlowConfig}``): seconds of a training step (100 windows of 80
    frames; only for the names in ``trained``, default all), frames per second of one
    stream (``frames`` frames) and of 64 (``frames // 5``), each the median of ``rounds``
    interleaved rounds. Both sides run in float32; with ``bf16`` (default: where the CPU
    has native bfloat16 products) motionlab also runs in bfloat16 (mixed-precision
    training, bfloat16 stream weights), timed in the same rounds. Returns one row a
    measure: ``config``, ``measure``, ``unit``, ``other``, ``motionlab``, ``speed-up``
    (motionlab float32 against the other: above 1, motionlab is faster), and with bf16
    ``motionlab bf16`` and ``bf16 speed-up``."""
    ours = load_adapter(Path(__file__).with_name("compare_motionlab.py"))
    bf16 = native_bfloat16() if bf16 is None else bf16
    rows = []
    for name, config in configs.items():
        measures = {}
        if trained is None or name in trained:
            batch, length = TRAIN_BATCH, config.history + TRAIN_FRAMES
            sides = {"other": other.training_step(config, batch, length),
                     "motionlab": ours.training_step(config, batch, length)}
            if bf16:
                sides["motionlab bf16"] = ours.training_step(config, batch, length, precision="bf16")
            measures["training step"] = ("s", sides, None)
        for streams, count in ((1, frames), (CROWD, max(10, frames // 5))):
            sides = {"other": other.streaming_step(config, streams), "motionlab": ours.streaming_step(config, streams)}
            if bf16:
                sides["motionlab bf16"] = ours.streaming_step(config, streams, weights=torch.bfloat16)
            measures[f"{streams} stream{'s' if streams > 1 else ''}"] = ("frames/s", sides, (streams, count))
        for measure, (unit, work, streaming) in measures.items():
            results = {side: [] for side in work}
            for round_ in range(rounds):
                order = list(work.items()) if round_ % 2 == 0 else list(work.items())[::-1]   # who goes first alternates
                for side, step in order:
                    results[side].append(best_time(step, 1) if streaming is None
                                         else streaming_rate(step, *streaming))
            row = {"config": name, "measure": measure, "unit": unit}
            row.update({side: statistics.median(values) for side, values in results.items()})
            for side, key in (("motionlab", "speed-up"), ("motionlab bf16", "bf16 speed-up")):
                if side in row:
                    row[key] = row["other"] / row[side] if streaming is None else row[side] / row["other"]
            rows.append(row)
    return rows


def print_comparison(rows: list[dict], adapter: str, rounds: int) -> None:
    bf16 = any("motionlab bf16" in r for r in rows)
    print(f"motionlab beside {adapter}, median of {rounds} interleaved rounds; the other in float32"
          + (", motionlab in float32 and in bfloat16 (mixed-precision training, bfloat16 stream weights)" if bf16
             else "") + ":\n")
    extra = " | motionlab bf16 | its speed-up" if bf16 else ""
    print(f"| config | measure | other | motionlab | motionlab's speed-up{extra} |")
    print("|---|---|---|---|---|" + ("---|---|" if bf16 else ""))
    for r in rows:
        digits = 2 if r["unit"] == "s" else 0
        line = (f"| {r['config']} | {r['measure']} ({r['unit']}) | {r['other']:,.{digits}f} "
                f"| {r['motionlab']:,.{digits}f} | {r['speed-up']:.2f}x |")
        if bf16:
            line += f" {r['motionlab bf16']:,.{digits}f} | {r['bf16 speed-up']:.2f}x |"
        print(line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--frames", type=int, default=100, help="frames per stream and timing")
    parser.add_argument("--skip-paper-training", action="store_true",
                        help="skip the paper-size training steps and their LSTMs alone (about four minutes)")
    parser.add_argument("--nll-epochs", type=int, default=10,
                        help="epochs of the float32 / bfloat16 NLL comparison (0: skip it)")
    parser.add_argument("--nll-clips", type=int, default=100, help="built-in clips for that comparison")
    parser.add_argument("--compare", metavar="ADAPTER.py",
                        help="time another implementation through this adapter (see compare_motionlab.py) instead")
    parser.add_argument("--rounds", type=int, default=4, help="interleaved rounds of --compare")
    args = parser.parse_args()
    if args.rounds < 1:
        parser.error("--rounds: expected 1 or more")
    torch.set_num_threads(args.threads)
    print(f"torch {torch.__version__}, {args.threads} threads; {cpu.summary()}")
    if not native_bfloat16():
        print("No native bfloat16 arithmetic here: every bfloat16 figure below is of emulated products, slower "
              "than float32" + ("" if cpu.onednn_lstm(torch.bfloat16) else
                                "; oneDNN has no bfloat16 LSTM, so the 'nn.LSTM' column of the bf16 rows times "
                                "PyTorch's own LSTM cells"))
    print()
    if args.compare:
        try:
            other = load_adapter(args.compare)
        except ValueError as error:
            parser.error(str(error))
        configs = {"laptop": MoGlowConfig(), "paper (§5.2)": MoGlowConfig.paper()}
        trained = ("laptop",) if args.skip_paper_training else None
        print_comparison(compare(other, configs, args.rounds, args.frames, trained), args.compare, args.rounds)
        return
    limits = machine_limits()
    print("This machine, measured: " + ", ".join(f"{name} {value:.1f}" for name, value in limits.items()) + "\n")

    print("| config | weights (MB, float32) | precision | training step (s) "
          "| its LSTMs alone: as trained / nn.LSTM (s) | its limit (s) "
          "| peak memory (MB) | 1 stream (fps) | its limit (fps) | 64 streams (fps) | their limit (fps) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    configs = {"laptop": MoGlowConfig(), "paper (§5.2)": MoGlowConfig.paper()}
    # the streams first: after gigabytes of training, one stream reads its weights slower here
    streaming = {(name, dtype): (sampling_fps(config, 1, args.frames, dtype),
                                 sampling_fps(config, CROWD, max(10, args.frames // 5), dtype))
                 for name, config in configs.items() for dtype in (torch.float32, torch.bfloat16)}
    measured, recurrent_rates = {}, []
    for name, config in configs.items():
        model = MoGlow(config)
        elements = weight_elements(model)
        flops = 2 * elements                                                   # per frame, forwards
        for dtype, precision, size in ((torch.float32, "fp32", 4), (torch.bfloat16, "bf16", 2)):
            label = str(dtype).replace("torch.", "")
            large = limits[f"large {label} (GFLOP/s)"]
            if args.skip_paper_training and name != "laptop":
                train = peak = train_limit = lstms = onednn_lstms = float("nan")
            else:
                train, peak = training_step_alone(config, precision, args.threads)
                lstms = lstm_seconds(config, precision, repeats=1)
                onednn_lstms = lstm_seconds(config, precision, repeats=1, written_out=False)
                recurrent_gflops = recurrent_rate(config.hidden, dtype)
                train_limit = training_limit(model, large, recurrent_gflops)
                recurrent_rates.append(f"{name} {label} {recurrent_gflops:.0f}")
            one, crowd = streaming[(name, dtype)]
            one_limit = limits["bandwidth (GB/s)"] * 1e9 / (size * elements)
            crowd_limit = max(large, limits[f"64-row {label} (GFLOP/s)"]) * 1e9 / flops
            measured[(name, label)] = {"one": (one, one_limit), "crowd": (crowd, crowd_limit), "train": train,
                                       "weight bytes": size * elements}
            first = dtype == torch.float32
            print(f"| {name if first else ''} | {f'{4 * elements / 1e6:.1f}' if first else ''} | {label} "
                  f"| {train:.2f} | {lstms:.2f} / {onednn_lstms:.2f} | {train_limit:.2f} | {peak:.0f} "
                  f"| {one:.1f} | {one_limit:.0f} "
                  f"| {crowd:.0f} | {crowd_limit:.0f} |")
    if recurrent_rates:
        print("\nRecurrent products of training, 100 rows x H by H x 4H (GFLOP/s): " + ", ".join(recurrent_rates))
    print("\nPaper-size targets (set on another 2-core machine), measured here, and this machine's limit:")
    for what, label, streams, target in TARGETS:
        paper = measured[("paper (§5.2)", label)]
        fps, limit = paper[streams]
        kernel = ""
        if streams == "one":                     # the stream's one-row product, at the rate it reads weights
            kernel_fps = limits[f"one-row product, {label} (GB/s)"] * 1e9 / paper["weight bytes"]
            kernel = f" (its one-row product alone: {kernel_fps:.0f})"
        print(f"  {what}: target {target} fps, measured {fps:.0f}, limit {limit:.0f}{kernel}")
    fp32, bf16 = (measured[("paper (§5.2)", label)]["train"] for label in ("float32", "bfloat16"))
    print(f"  training step in bfloat16: {bf16 / fp32:.2f} of the float32 step")
    print("\nLimits: one stream = memory bandwidth / weight bytes; 64 streams = the better of the 64-row and large "
          "matrix-product rates / (2 x weight elements) per frame; training step = 2 x (3 x weight elements - "
          "the LSTM input columns that read the conditioning, which needs no gradient) x 100 x 70 frames at the "
          "large-product rate of its precision, except the LSTMs' recurrent products (forwards and the input "
          "gradient), at the rate of 100-row products with the same matrix. "
          "Without native bfloat16 arithmetic "
          "(AVX512-BF16, AMX) bfloat16 products are emulated, far below float32. The laptop model's 3 MB of "
          "weights stay in the cache: its limits are far above what the per-operation overhead of small "
          "products allows.")
    if args.nll_epochs > 0:
        precision_trajectory(args.nll_epochs, args.nll_clips)


if __name__ == "__main__":
    main()
