"""Autoregressive LSTM baselines for Habibie et al. 2017 (Tables 1-2): LSTM-3LR.

Fragkiadaki et al.'s LSTM-3LR (2015), the strongest recurrent baseline of Habibie's
Tables 1 and 2: a stack of LSTM layers reads one frame at a time and a linear read-out
predicts the next frame. It is trained with teacher forcing (the true frame goes in at
every step) and generates by feeding its own predictions back, after being *primed* with
the first frames of a real sequence::

    h_t = LSTM^3(input_t, h_{t-1});   x^_{t+1} = W h_t + b;   loss = mean ||x^_{t+1} - x_{t+1}||^2

Two variants, chosen by :attr:`LSTMConfig.control`:

* ``"predicted"``: the input is the frame ``x_t`` (pose and control, 66 values) and the
  model predicts all of ``x_{t+1}``, control included. This is how Habibie adapts the
  baselines that know no control (§4.3, Table 1). At test time the predicted control may be
  replaced by the true one (``predict(..., control=...)``): Habibie's Table 2 protocol.
* ``"given"``: the model is *trained* with the control: its input is ``x_t`` and the next
  frame's control ``C_{t+1}``, and it predicts only the pose of ``x_{t+1}``.

One option of ours: ``skeleton=True`` puts each predicted pose onto the bones of the frame it
was predicted from (:class:`~motionlab.models.skeleton_output.SkeletonOutput`, the read-out
giving only the bones' directions), in training and in generation alike, so a primed sequence
keeps its body's bone lengths however long it runs; the free read-out stretches them.

Tensors are ``(batch, frames, features)`` in the normalised units of
:class:`motionlab.data.Normalizer`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from .. import checks
from ..engine import recurrent
from ..representation import N_POSE
from .base import Generated, GenerativeModel, check_tensor, eval_mode, normalizer_for
from .modelcard import NO_CLIP, ModelCard, choice
from .skeleton_output import SkeletonOutput


@dataclass(frozen=True)
class LSTMConfig:
    """Sizes and options. Defaults: a laptop-sized LSTM-3LR at 20 fps; :meth:`paper` is
    Fragkiadaki et al.'s (three layers of 1000 units).

    Attributes:
        n_pose: pose features per frame (63).
        n_control: control features per frame (3).
        window: frames per training window.
        fps: frames per second of the data the model expects.
        control: ``"predicted"`` (no control input: predict it with the pose) or
            ``"given"`` (the next frame's control is an input; predict the pose only).
        hidden: LSTM units per layer.
        layers: stacked LSTM layers (3 in LSTM-3LR).
        input_noise: standard deviation (normalised units) of Gaussian noise added to the
            input frames while training, so that the model learns to recover from its own
            errors when it runs on its predictions (Fragkiadaki et al. §3.1).
        skeleton: each predicted pose is put onto the body of the frame it was predicted
            from (:class:`~motionlab.models.skeleton_output.SkeletonOutput`: bone directions
            the read-out's, lengths the input frame's), so a primed sequence keeps its
            body's bones however long it runs (ours; off: Fragkiadaki's free read-out).
    """

    n_pose: int = 63
    n_control: int = 3
    window: int = 80
    fps: float = 20.0
    control: str = "predicted"
    hidden: int = 128
    layers: int = 3
    input_noise: float = 0.05
    skeleton: bool = False

    def __post_init__(self):
        checks.config(self, non_negative_fields=("input_noise",))
        if self.control not in ("predicted", "given"):
            raise ValueError(f"control: expected 'predicted' or 'given', got {self.control!r}")
        for name in ("n_pose", "n_control", "hidden", "layers"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: must be >= 1, got {getattr(self, name)}")
        if self.window < 2:
            raise ValueError(f"window: needs >= 2 frames (a frame and its successor), got {self.window}")
        if self.input_noise < 0:
            raise ValueError(f"input_noise: must be >= 0, got {self.input_noise}")
        if self.skeleton and (self.n_pose, self.n_control) != (N_POSE, 3):
            raise ValueError(f"skeleton: needs the locomotion features ({N_POSE} pose values and 3 controls), "
                             f"got n_pose={self.n_pose}, n_control={self.n_control}")

    @property
    def n_features(self) -> int:
        return self.n_pose + self.n_control

    @classmethod
    def paper(cls, **changes) -> "LSTMConfig":
        """LSTM-3LR as Habibie compares with it: 3 layers of 1000 units, 240-frame
        windows at 60 fps."""
        return replace(cls(window=240, fps=60.0, hidden=1000, layers=3), **changes)


class MotionLSTM(GenerativeModel, nn.Module):
    """LSTM-3LR: next-frame prediction with stacked LSTMs and a linear read-out.

    ``forward(frames, next_control, state)`` -> predictions ``(batch, frames, outputs)``
    and the LSTM state; :meth:`sample` primes and runs it on its own output (normalised
    tensors), :meth:`generate` does the same in the data's units.
    """

    continues_motion = True

    @property
    def follows_control(self) -> bool:
        return self.config.control == "given"

    def __init__(self, config: LSTMConfig = LSTMConfig()):
        super().__init__()
        self.config = config
        given = config.control == "given"
        inputs = config.n_features + (config.n_control if given else 0)
        outputs = config.n_pose if given else config.n_features
        self.lstm = nn.LSTM(inputs, config.hidden, config.layers, batch_first=True)
        self.readout = nn.Linear(config.hidden, outputs)
        self.skeleton = SkeletonOutput() if config.skeleton else None

    def _check(self, x: torch.Tensor, name: str, features: int, min_frames: int = 1, finite: bool = True) -> None:
        check_tensor(x, name, features, min_frames, finite=finite)

    def forward(self, frames: torch.Tensor, next_control: torch.Tensor | None = None,
                state: tuple[torch.Tensor, torch.Tensor] | None = None, lengths: torch.Tensor | None = None):
        """Predict frame ``t + 1`` from frames ``<= t``.

        Args:
            frames: ``(batch, steps, n_features)``, frames ``t``.
            next_control: ``(batch, steps, n_control)``, the controls of frames ``t + 1``
                (``control="given"`` only).
            state: the LSTM's ``(h, c)`` to continue from (``None``: zeros).
            lengths: ``skeleton=True`` only: the bones ``(batch, 1 or steps, 20)`` in metres
                the predictions keep (``None``: each input frame's own).

        Returns ``(predictions, state)``; predictions are ``(batch, steps, n_pose)`` for
        ``control="given"`` and ``(batch, steps, n_features)`` otherwise.
        """
        inputs = frames
        if self.config.control == "given":
            if next_control is None or next_control.shape[:2] != frames.shape[:2]:
                raise ValueError("next_control: a control='given' model needs (batch, steps, "
                                 f"{self.config.n_control}) next-frame controls, got "
                                 f"{None if next_control is None else tuple(next_control.shape)}")
            inputs = torch.cat([frames, next_control], dim=-1)
        hidden, state = recurrent.run(self.lstm, inputs, state)
        prediction = self.readout(hidden)
        if self.skeleton is not None:
            lengths = self._lengths(frames, last=False) if lengths is None else lengths
            prediction = self.skeleton(prediction, self.normalizer, lengths)
        return prediction, state

    def _lengths(self, frames: torch.Tensor, last: bool = True) -> torch.Tensor | None:
        """``skeleton=True``: the bones ``(batch, 1, 20)`` of each sequence's last frame, which
        every frame generated from it keeps (``last=False``: every frame's, ``(batch, steps,
        20)``: the clean input frames of a teacher-forced window); ``None`` otherwise."""
        if self.skeleton is None:
            return None
        normalizer = normalizer_for(self, "skeleton", "the skeleton output layer measures bones")
        return self.skeleton.pose_lengths(frames[:, -1:] if last else frames, normalizer)

    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Teacher-forced next-frame mean squared error (normalised units) on windows
        ``(batch, frames, n_features)``: the pose only for ``control="given"``, pose and
        control otherwise. Logged: ``pose_mse`` (and ``control_mse`` when predicted)."""
        self._check(batch, "batch", self.config.n_features, min_frames=2, finite=False)   # NaN: the loop's guard
        n_pose = self.config.n_pose
        inputs = batch[:, :-1]
        if self.training and self.config.input_noise > 0:
            inputs = inputs + self.config.input_noise * torch.randn_like(inputs)
        prediction, _ = self(inputs, batch[:, 1:, n_pose:], lengths=self._lengths(batch[:, :-1], last=False))
        target = batch[:, 1:]
        pose_mse = F.mse_loss(prediction[..., :n_pose], target[..., :n_pose])
        if self.config.control == "given":
            return {"loss": pose_mse, "pose_mse": pose_mse.detach()}
        control_mse = F.mse_loss(prediction[..., n_pose:], target[..., n_pose:])
        return {"loss": F.mse_loss(prediction, target), "pose_mse": pose_mse.detach(),
                "control_mse": control_mse.detach()}

    @torch.no_grad()
    def sample(self, prefix: torch.Tensor, frames: int, control: torch.Tensor | None = None,
               generator: torch.Generator | None = None) -> torch.Tensor:
        """Continue the sequences ``prefix`` ``(batch, k, n_features)`` to ``frames`` frames.

        The model reads the ``k`` prefix frames, then runs on its own predictions. It is
        deterministic: ``generator`` is accepted for the common signature and not used.

        Args:
            prefix: the first ``k >= 1`` frames (normalised); returned unchanged.
            frames: the total length of the result, ``>= k``.
            control: ``(batch, >= frames, n_control)`` true controls. Required for
                ``control="given"``; for ``control="predicted"`` optional: if given, each
                predicted control is replaced by the true one before it is fed back
                (Habibie's Table 2 protocol for the baselines).

        Returns ``(batch, frames, n_features)`` normalised features, the prefix first.
        """
        cfg = self.config
        self._check(prefix, "prefix", cfg.n_features)
        k = prefix.shape[1]
        if frames < k:
            raise ValueError(f"frames: must be >= the {k} prefix frames, got {frames}")
        if control is not None:
            self._check(control, "control", cfg.n_control, min_frames=frames)
            if control.shape[0] != prefix.shape[0]:
                raise ValueError(f"control: expected {prefix.shape[0]} sequences like prefix, got {control.shape[0]}")
        elif cfg.control == "given":
            raise ValueError("control: a control='given' model needs the control signal for all frames")
        given = cfg.control == "given"
        with eval_mode(self):
            _, state = self(prefix[:, :-1], control[:, 1:k] if given else None) if k > 1 else (None, None)
            out = [prefix]
            current = prefix[:, -1:]
            lengths = self._lengths(prefix)
            for t in range(k, frames):
                prediction, state = self(current, control[:, t:t + 1] if given else None, state, lengths)
                if given:
                    current = torch.cat([prediction, control[:, t:t + 1]], dim=-1)
                elif control is not None:
                    current = torch.cat([prediction[..., :cfg.n_pose], control[:, t:t + 1]], dim=-1)
                else:
                    current = prediction
                out.append(current)
        return torch.cat(out, dim=1)

    def stream(self, history: torch.Tensor, temperature: float = 1.0, generator: torch.Generator | None = None,
               normalizer=None, weights: torch.dtype = torch.float32) -> "LSTMStream":
        """An :class:`LSTMStream` that continues ``history`` one control frame at a time (the
        same signature as ``MoGlow.stream``; the LSTM is deterministic, so ``temperature``,
        ``generator`` and ``weights`` change nothing)."""
        return LSTMStream(self, history, normalizer, temperature)

    def generate(self, control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0) -> Generated:
        """Continue ``prefix`` (required, ``k >= 1`` frames); see :mod:`motionlab.models.base`.

        A ``control="given"`` model follows ``control`` (required; ``frames`` is its length).
        A ``control="predicted"`` model predicts its own control; given a ``control``, the
        true one replaces each prediction before it is fed back (Habibie's Table 2), else
        give ``frames``. The LSTM is deterministic: ``temperature`` and ``seed`` change
        nothing, and ``n > 1`` repeats one answer.
        """
        n, _ = self._check_common(n, temperature, seed)
        prefix = self._normalized_prefix(prefix, n)
        k = prefix.shape[1]
        if control is not None:
            control = self._normalized_control(control, n, frames)
            frames = control.shape[1]
            control = torch.cat([prefix[..., self.config.n_pose:], control], dim=1)
        elif self.follows_control:
            self._normalized_control(None, n)
        frames = checks.whole(frames, "frames", 1)
        device = next(self.parameters()).device
        motion = self.sample(prefix.to(device), k + frames, None if control is None else control.to(device))
        return self._result(motion[:, k:])


class LSTMStream:
    """LSTM-3LR in real time (a ``control="given"`` model): feed one control frame, get the
    frame back, as :meth:`MotionLSTM.sample` makes it (frame ``t`` from frame ``t - 1`` and
    control ``t``), carrying the LSTM's state between calls.

    >>> stream = model.stream(history, normalizer=model.normalizer)   # (batch, k, 66) data units
    >>> frame = stream.step(control)                                   # (batch, 3) -> (batch, 66)
    """

    def __init__(self, model: MotionLSTM, history, normalizer=None, temperature: float = 1.0):
        if model.config.control != "given":
            raise ValueError("model: only a control='given' LSTM follows a stream of controls")
        self.model, self.temperature = model, float(temperature)
        self.n_pose = model.config.n_pose
        device = next(model.parameters()).device
        self._mean, self._std = ((None, None) if normalizer is None else
                                 (torch.as_tensor(np.asarray(normalizer.mean), dtype=torch.float32, device=device),
                                  torch.as_tensor(np.asarray(normalizer.std), dtype=torch.float32, device=device)))
        history = torch.as_tensor(history, dtype=torch.float32, device=device)
        model._check(history, "history", model.config.n_features)
        if self._mean is not None:
            history = (history - self._mean) / self._std
        with torch.no_grad(), eval_mode(model):
            self.state = model(history[:, :-1], history[:, 1:, self.n_pose:])[1] if history.shape[1] > 1 else None
        self.current = history[:, -1:]
        self.lengths = model._lengths(history)

    def step(self, control) -> torch.Tensor:
        """The next frame ``(batch, n_features)`` for this frame's ``control`` ``(batch, 3)``
        (or ``(3,)``), in the data's units when the stream has a normaliser."""
        control = torch.as_tensor(control, dtype=torch.float32, device=self.current.device)
        control = control.expand(self.current.shape[0], -1) if control.ndim == 1 else control
        if control.shape != (self.current.shape[0], self.model.config.n_control) or not torch.isfinite(control).all():
            raise ValueError(f"control: expected finite ({self.current.shape[0]}, {self.model.config.n_control}), "
                             f"got {tuple(control.shape)}")
        if self._mean is not None:
            control = (control - self._mean[self.n_pose:]) / self._std[self.n_pose:]
        with torch.no_grad(), eval_mode(self.model):
            pose, self.state = self.model(self.current, control[:, None], self.state, self.lengths)
        self.current = torch.cat([pose, control[:, None]], dim=-1)
        frame = self.current[:, 0]
        return frame if self._mean is None else frame * self._std + self._mean


# ------------------------------------------------------------------------ training

BASELINE = ("Habibie 2017 gives no training details for its LSTM-3LR baseline (§4.3, "
            "Tables 1-2): its VAE-LSTM value, §4.2")

CARD = ModelCard("lstm", MotionLSTM, LSTMConfig, schedule={
    "optimizer": choice("Adam", BASELINE),
    "lr": choice(5e-4, BASELINE),
    "epochs": choice(5000, BASELINE),
    "batch_size": choice(32, "not in the paper: motionlab's default"),
    "schedule": choice("constant", "not in the paper: one learning rate, as for VAE-LSTM"),
    "grad_clip": choice(1.0, NO_CLIP),
})
