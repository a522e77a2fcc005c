"""An adapter for ``benchmarks/moglow_speed.py --compare``: the MoGlow authors' public code.

That code is github.com/simonalexanderson/StyleGestures (folder ``glow/``). Nothing of it is
in motionlab: clone it yourself, install its one extra dependency, and point this adapter
at it::

    git clone https://github.com/simonalexanderson/StyleGestures /tmp/StyleGestures
    pip install scipy                      # its invertible 1x1 map calls scipy.linalg.lu
    MOGLOW_AUTHORS_CODE=/tmp/StyleGestures python benchmarks/moglow_speed.py --compare benchmarks/compare_authors.py

The README's comparison ran this on the authors' files as published (glow/models.py at
commit b397239, modules.py 5fffee4, thops.py and utils.py 1f6ff73), unchanged; their
``config.py`` is not needed: the settings below are passed as a namespace.

Built as hparams/paper_version/locomotion.json builds it, with motionlab's sizes:
``K = config.steps``, ``hidden_channels = config.hidden``, ``num_layers = config.lstm_layers``,
``seqlen = config.history``, flow_coupling "affine", flow_permutation "invconv",
LU_decomposed true, network_model "LSTM", distribution "normal", Adam (lr 1e-4).
Their ``FlowNet`` passes ``num_layers=2`` to every step whatever the settings say, so for
other layer counts (the laptop config's 1) each coupling network is rebuilt with their own
factory ``f``.

Shapes. Per predicted frame the flow runs over ``x_channels`` pose values and the coupling
networks see ``cond = seqlen * x_channels + (seqlen + 1) * 3`` values (the ``seqlen``
previous poses, then the control of those frames and of the current one: the authors'
MotionDataset layout, which is motionlab's too). ``x_channels`` is motionlab's 61 modelled
values (the 63 pose features less the hips' root-local x and z, always 0), so both models
have the same shapes and the same parameter count (803,356 at laptop size, 73,146,480 at
the paper's). ``AUTHORS_MOGLOW_POSE=63`` gives the authors' own layout instead (cond 663).

* ``training_step``: their Trainer.train's step: ``init_lstm_hidden``, the history dropout
  of their MotionDataset (each history frame of each predicted frame kept with probability
  1 - dropout, vectorised over the batch here), ``z, nll = graph(x, cond)`` (teacher forcing
  over the window), ``Glow.loss_generative(nll)``, backward, Adam step. No gradient
  clipping (motionlab's adapter has none; ``CLIP_GRADIENTS = True`` adds theirs).
* ``streaming_step``: their Generator.generate_sample loop, one frame per call: the
  conditioning from the last ``seqlen`` poses and ``seqlen + 1`` controls (their
  ``__prepare_cond``, numpy), ``graph(z=None, cond=cond, eps_std=0.8, reverse=True)`` with
  the LSTM state carried from call to call, the new pose appended to the history.

ActNorm's data-dependent initialisation is done, as their trainer does it, by one forward
pass in training mode before anything is timed.
"""
from __future__ import annotations

import contextlib
import importlib
import io
import os
import sys
import types
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import torch

_CODE = os.environ.get("MOGLOW_AUTHORS_CODE", "")
if not (Path(_CODE) / "glow" / "models.py").is_file():
    raise ValueError("compare_authors.py: set MOGLOW_AUTHORS_CODE to a clone of "
                     f"github.com/simonalexanderson/StyleGestures (a folder with glow/models.py); got {_CODE!r}")


def _authors_package(name: str = "authors_moglow_glow"):
    """The authors' ``glow/`` package, imported under its own name (motionlab's benchmarks/
    folder, first on sys.path when moglow_speed.py runs, has a glow.py of its own)."""
    if name not in sys.modules:
        package = types.ModuleType(name)
        package.__path__ = [str(Path(_CODE) / "glow")]      # a package without an __init__.py
        sys.modules[name] = package
    return importlib.import_module(f"{name}.models"), importlib.import_module(f"{name}.utils")


glow_models, glow_utils = _authors_package()

CLIP_GRADIENTS = False
EPS_STD = 0.8
N_POSE, N_CONTROL = 63, 3
CONSTANT = (0, 2)                                   # the hips' root-local x and z (motionlab leaves them out)
FULL_POSE = os.environ.get("AUTHORS_MOGLOW_POSE", "61") == "63"
MODELLED = list(range(N_POSE)) if FULL_POSE else [i for i in range(N_POSE) if i not in CONSTANT]


def hparams(config, batch_size: int) -> SimpleNamespace:
    """What Glow reads of hparams/paper_version/locomotion.json, with ``config``'s sizes."""
    return SimpleNamespace(
        Glow=SimpleNamespace(hidden_channels=config.hidden, K=config.steps, actnorm_scale=1.0,
                             flow_permutation="invconv", flow_coupling="affine", network_model="LSTM",
                             num_layers=config.lstm_layers, LU_decomposed=True, distribution="normal"),
        Data=SimpleNamespace(seqlen=config.history, n_lookahead=0, dropout=config.dropout),
        Device=SimpleNamespace(glow=["cpu"], data="cpu"),
        Train=SimpleNamespace(batch_size=batch_size),
        Optim=SimpleNamespace(args=dict(lr=1e-4, betas=(0.9, 0.999), eps=1e-8)))


def channels(config) -> tuple[int, int]:
    """``(x_channels, cond_channels)`` per predicted frame."""
    x = len(MODELLED)
    return x, config.history * x + (config.history + 1) * N_CONTROL


def build(config, batch_size: int) -> glow_models.Glow:
    """The authors' Glow with ``config``'s sizes, on the CPU, float32."""
    x_channels, cond_channels = channels(config)
    hp = hparams(config, batch_size)
    with contextlib.redirect_stdout(io.StringIO()):                # their FlowStep prints per step
        graph = glow_models.Glow(x_channels, cond_channels, hp)
        if config.lstm_layers != 2:
            # FlowNet passes num_layers=2 to every FlowStep whatever hparams says; rebuild each
            # coupling network with their own factory f() and the configured layer count
            for step in graph.flow.layers:
                step.f = glow_models.f(x_channels // 2, 2 * (x_channels - x_channels // 2), config.hidden,
                                       cond_channels, "LSTM", config.lstm_layers)
    return graph.float().cpu()


def _windows(n: int, frames: int) -> torch.Tensor:
    x = torch.randn(n, frames, N_POSE + N_CONTROL, generator=torch.Generator().manual_seed(0))
    if not FULL_POSE:
        x[..., list(CONSTANT)] = 0.0
    return x


def dataset_tensors(config, windows: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``x (B, x_channels, T - tau)`` and the undropped ``cond (B, cond_channels, T - tau)``
    of the authors' MotionDataset for these windows (``concat_sequence``, then C and T swapped)."""
    tau = config.history
    poses, control = windows[..., MODELLED], windows[..., N_POSE:]
    history = poses[:, :-1].unfold(1, tau, 1).transpose(2, 3).flatten(2)      # frame-major, as concat_sequence
    controls = control.unfold(1, tau + 1, 1).transpose(2, 3).flatten(2)
    cond = torch.cat([history, controls], dim=2)
    return poses[:, tau:].transpose(1, 2).contiguous(), cond.transpose(1, 2).contiguous()


def initialise_actnorm(graph, config, windows: torch.Tensor) -> None:
    """As their Trainer does at global_step 0: one forward pass in training mode (ActNorm
    initialises itself from it), then the LSTM state reset."""
    x, cond = dataset_tensors(config, windows)
    graph.train()
    graph.init_lstm_hidden()
    with torch.no_grad():
        graph(x, cond)
    graph.init_lstm_hidden()
    assert all(m.inited for m in graph.modules() if type(m).__name__ == "ActNorm2d")


def training_step(config, batch: int, frames: int):
    torch.manual_seed(0)
    np.random.seed(0)
    graph = build(config, batch)
    hp = graph.hparams
    optim = torch.optim.Adam(graph.parameters(), **hp.Optim.args)      # their builder's build_adam
    windows = _windows(batch, frames)
    x, cond = dataset_tensors(config, windows)
    initialise_actnorm(graph, config, windows)
    x_channels = x.shape[1]
    tau, keep = config.history, 1.0 - config.dropout

    def step() -> None:
        graph.train()
        # MotionDataset.__getitem__'s dropout: keep_pose (seqlen, T) per window, each history
        # frame's x_channels values together; the control never dropped
        if config.dropout > 0:
            keep_pose = torch.rand(batch, tau, x.shape[2]) < keep
            mask = torch.cat([keep_pose.repeat_interleave(x_channels, dim=1),
                              torch.ones(batch, cond.shape[1] - tau * x_channels, x.shape[2], dtype=torch.bool)],
                             dim=1)
            cond_masked = cond * mask
        else:
            cond_masked = cond
        graph.init_lstm_hidden()
        z, nll = graph(x=x, cond=cond_masked)
        loss = glow_models.Glow.loss_generative(nll)
        graph.zero_grad()
        optim.zero_grad()
        loss.backward()
        if CLIP_GRADIENTS:
            torch.nn.utils.clip_grad_value_(graph.parameters(), 5)
            torch.nn.utils.clip_grad_norm_(graph.parameters(), 100)
        optim.step()
    return step


def streaming_step(config, streams: int):
    torch.manual_seed(0)
    np.random.seed(0)
    graph = build(config, streams)                    # z_shape = [Train.batch_size, x_channels, 1]
    initialise_actnorm(graph, config, _windows(4, config.history + 2))
    graph.eval()
    graph.init_lstm_hidden()                          # h = 0 before the first generated frame
    prepare_cond = getattr(glow_utils, "__prepare_cond")   # = Generator.prepare_cond
    start = _windows(streams, config.history).numpy()
    state = {"autoreg": start[..., MODELLED].astype(np.float32),          # (streams, seqlen, x_channels)
             "control": start[..., N_POSE:].astype(np.float32)}           # (streams, seqlen, 3)

    def step(control) -> torch.Tensor:
        control = np.asarray(control, dtype=np.float32).reshape(streams, 1, N_CONTROL)
        window = np.concatenate((state["control"], control), axis=1)     # c_{t-seqlen .. t}
        cond = prepare_cond(state["autoreg"].copy(), window.copy(), "cpu")
        sampled = graph(z=None, cond=cond, eps_std=EPS_STD, reverse=True)
        sampled = sampled.cpu().numpy()[:, :, 0]
        state["autoreg"] = np.concatenate((state["autoreg"][:, 1:, :].copy(), sampled[:, None, :]), axis=1)
        state["control"] = window[:, 1:]
        frame = np.zeros((streams, N_POSE + N_CONTROL), dtype=np.float32)
        frame[:, MODELLED] = sampled
        frame[:, N_POSE:] = control[:, 0]
        return torch.from_numpy(frame)
    return step
