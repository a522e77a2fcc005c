"""An adapter for ``python benchmarks/moglow_speed.py --compare FILE``: motionlab itself.

``--compare`` times another MoGlow implementation beside motionlab's, with the same
shapes and the same harness, in interleaved rounds. The other implementation is reached
through an *adapter*: a Python file you write (nothing of it is copied into motionlab)
that defines the two functions below. This one wraps motionlab's own model, so

    python benchmarks/moglow_speed.py --compare benchmarks/compare_motionlab.py

prints ratios near 1 (the harness timing the same code twice) and shows what an adapter
for, say, the MoGlow authors' public code has to do: import it, build its model with the
sizes of ``config`` (``config.steps`` flow steps, ``config.lstm_layers`` LSTM layers of
``config.hidden`` units per coupling, ``config.history`` frames of history, 63 pose + 3
control features per frame; the authors' code calls these K, hidden_channels, num_layers,
seqlen), and return callables.

* ``training_step(config, batch, frames)``: a callable that runs one optimiser step
  (forward, backward, Adam) on a batch of ``batch`` windows of ``frames`` frames of 66
  features, float32, on the CPU. Build the model, optimiser and data once, outside it.
* ``streaming_step(config, streams)``: a callable that takes the control of one frame,
  ``(streams, 3)``, and generates the next pose of each of ``streams`` characters (a
  model's real-time sampler), float32.
"""
from __future__ import annotations

import torch

from motionlab import training
from motionlab.models.moglow import MoGlow, MoGlowConfig


def _windows(n: int, frames: int) -> torch.Tensor:
    x = torch.randn(n, frames, 66, generator=torch.Generator().manual_seed(0))
    x[..., [0, 2]] = 0.0                                # the hips' root-local x and z
    return x


def training_step(config: MoGlowConfig, batch: int, frames: int, precision: str = "fp32"):
    """(motionlab only: ``precision="bf16"`` trains in bfloat16 mixed precision.)"""
    torch.manual_seed(0)
    model = MoGlow(config)
    optimizer = training.adam(model.parameters(), lr=1e-4)
    x = _windows(batch, frames)
    low = training.PRECISIONS[precision]

    def step() -> None:
        with torch.autocast("cpu", dtype=low, enabled=low is not None):
            loss = model.loss(x)["loss"]
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
    return step


def streaming_step(config: MoGlowConfig, streams: int, weights: torch.dtype = torch.float32):
    """(motionlab only: ``weights=torch.bfloat16`` streams with bfloat16 weights.)"""
    torch.manual_seed(0)
    model = MoGlow(config)
    model.loss(_windows(4, config.history + 2))        # ActNorm's data-dependent initialisation
    model.eval()
    stream = model.stream(_windows(streams, config.history), temperature=0.8,
                          generator=torch.Generator().manual_seed(0), weights=weights)
    return stream.step
