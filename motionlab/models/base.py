"""The one generation contract every generative model in motionlab follows.

Each model file is written beside its paper, but they all answer the same call::

    result = model.generate(control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0)
    result.positions      # (n, frames, 21, 3) world joint positions, metres
    result.features       # (n, frames, 66) features in the data's units (m, m/s, rad/s)
    result.fps            # frames per second

* ``control``: the path to follow, ``(frames, 3)`` (the same for all ``n``) or ``(n, frames,
  3)``: forward and sideways velocity (m/s) and turning velocity (rad/s) of every frame to
  generate (:data:`motionlab.representation.CONTROL`). Models without a control input
  (Motegi's VAE, an unconditional Glow, DFN) ignore it and say so in their docstring.
* ``frames``: how many frames to generate (for a controlled model: the control's length).
* ``prefix``: real frames to continue, ``(k, 66)`` or ``(n, k, 66)``, data units, for the
  models that continue motion (LSTM, MoGlow, DFN; the VAE-LSTM draws its first latent from
  it). The result holds only what the model generated: the prefix is never prepended.
* ``n`` samples, the prior's ``temperature`` (1: the model; 0: its most likely path, where
  it has one) and the ``seed`` of the noise, so a call is reproducible.

A bad argument raises ``ValueError`` naming it, and so does a sample that is not finite: a
flow's inverse can overflow at a high temperature (the message names ``temperature``).

Generation works in the data's units because the model carries the
:class:`motionlab.data.Normalizer` of its training data as ``model.normalizer`` (set by
:func:`motionlab.training.train`, :func:`motionlab.training.load_checkpoint` and
:func:`motionlab.pretrained.load`). Under it, each model keeps a low-level sampler called
``sample`` that takes and returns normalised tensors and a ``generator=``.

Conv autoencoders do not generate; they reconstruct (:meth:`ConvAutoencoder.forward`).
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import torch

from .. import checks, contacts
from ..representation import CONTROL, N_POSE, to_positions
from ..skeleton import LOCOMOTION
from .skeleton_output import bone_lengths

N_FEATURES = N_POSE + 3
"""Features per frame: 63 root-local joint coordinates, then the 3 control values."""


@dataclass(frozen=True)
class Generated:
    """What :meth:`generate` returns.

    Attributes:
        features: ``(n, frames, 66)`` in the data's units: root-local joint positions (m),
            then forward/sideways velocity (m/s) and turning velocity (rad/s).
        positions: ``(n, frames, 21, 3)`` world joint positions (m), each sample integrated
            from the origin facing ``+z`` (:func:`motionlab.representation.to_positions`).
        fps: frames per second.
        contacts: the foot contacts a model with a contact head drew for each frame, ``(n,
            frames, 4)`` booleans (ankle and toe of each foot, :data:`motionlab.skeleton.FEET`
            order); ``None`` for the other models.
    """

    features: np.ndarray
    positions: np.ndarray
    fps: float
    contacts: np.ndarray | None = None

    @property
    def seconds(self) -> float:
        """Duration of each sample."""
        return self.features.shape[1] / self.fps

    def __repr__(self) -> str:
        n, frames = self.features.shape[:2]
        return f"Generated({n} samples x {frames} frames at {self.fps:g} fps = {self.seconds:.2f} s)"


@contextmanager
def eval_mode(model: torch.nn.Module):
    """Evaluation mode (no dropout, running statistics) inside the block; the model's own
    mode is restored afterwards, also when the block raises."""
    was_training = model.training
    model.eval()
    try:
        yield model
    finally:
        model.train(was_training)


def check_tensor(x, name: str, features: int | tuple[int, ...], min_frames: int = 1, *, even: bool = False,
                 multiple: int = 1, finite: bool = True, frames_text: str | None = None) -> None:
    """The tensor twin of :func:`motionlab.checks.array`, for the models' batches: ``x`` must be
    a ``(batch, frames, features)`` tensor (``features`` one size or several allowed), with at
    least ``min_frames`` frames, an even number of them (``even``) or a multiple of
    ``multiple``, and (``finite``) no NaN or infinite value; else ``ValueError`` naming ``name``,
    what was expected and what came."""
    allowed = (features,) if isinstance(features, int) else tuple(features)
    want = " or ".join(str(f) for f in allowed)
    frames = frames_text or ("even frames" if even else "frames" if multiple > 1 or min_frames < 1
                             else f"frames >= {min_frames}")
    expected = f"(batch, {frames}, {want})" + (f" with frames a multiple of {multiple}" if multiple > 1 else "")
    if not isinstance(x, torch.Tensor):
        raise ValueError(f"{name}: expected {expected} tensor, got {type(x).__name__}")
    if (x.ndim != 3 or x.shape[-1] not in allowed or x.shape[0] == 0 or x.shape[1] < max(min_frames, 1)
            or (even and x.shape[1] % 2) or x.shape[1] % multiple):
        raise ValueError(f"{name}: expected {expected}, got {tuple(x.shape)}")
    if finite and not torch.isfinite(x).all():
        raise ValueError(f"{name}: contains NaN or infinite values")


def per_frame_nll(nats: float, normalizer=None, features=None) -> dict[str, float]:
    """A negative log-likelihood per frame, ``nats`` in normalised units, as the course reports
    it: ``{"nats/frame", "bits/frame"}``. Given the :class:`motionlab.data.Normalizer` of the
    data and the feature indices the model scores, in the data's units (metres, m/s, rad/s):
    ``+ Σ_d ln σ_d`` over those features, the Jacobian of the normalisation."""
    nats = float(nats)
    if normalizer is not None:
        index = np.asarray(features.cpu() if isinstance(features, torch.Tensor) else features, dtype=int)
        nats += float(np.log(np.asarray(normalizer.std)[index]).sum())
    return {"nats/frame": nats, "bits/frame": nats / math.log(2)}


def generator_for(seed) -> torch.Generator:
    """A CPU ``torch.Generator`` seeded with ``seed`` (a whole number >= 0)."""
    return torch.Generator().manual_seed(checks.whole(seed, "seed", 0))


def normalizer_for(model, option: str, what: str):
    """``model.normalizer``, or a ``ValueError`` naming ``option``, whose ``what`` (e.g. "the
    contact term measures the body") works in the data's units."""
    normalizer = getattr(model, "normalizer", None)
    if normalizer is None:
        raise ValueError(f"{option}: {what} in the data's units and needs {type(model).__name__}'s normaliser; "
                         "train with training.train on a MotionData (it sets model.normalizer) or set "
                         "model.normalizer")
    return normalizer


def _in_data_units(model, term: str, *tensors: torch.Tensor) -> list[torch.Tensor]:
    """Normalised tensors back in the data's units through ``model.normalizer`` (float32)."""
    normalizer = normalizer_for(model, term, f"the {term.split('_')[0]} term measures the body")
    return [normalizer.denormalize(t.float()) for t in tensors]


def contact_term(model, prediction: torch.Tensor, target: torch.Tensor, fps: float) -> torch.Tensor:
    """:func:`motionlab.contacts.contact_velocity_loss` of a reconstruction against its data,
    both normalised ``(batch, frames, 66)``, measured in the data's units through
    ``model.normalizer`` (which :func:`motionlab.training.train` sets from the data before the
    first step): the models train on normalised features, and a foot's world velocity only
    exists in metres. Computed in float32 (under mixed precision too)."""
    return contacts.contact_velocity_loss(*_in_data_units(model, "contact_weight", prediction, target), fps)


def bone_term(model, prediction: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """The squared error of every bone's length in a reconstruction against its data, cm²
    (the mean over bones, frames and the batch), both normalised ``(batch, frames, 66)`` and
    measured in the data's units (:func:`contact_term`'s conversion). Joint coordinates are
    free to stretch a bone; this asks the reconstruction's bones for the data's lengths,
    which :func:`motionlab.contacts.fit_bones` restores only after the fact."""
    prediction, target = _in_data_units(model, "bone_weight", prediction, target)

    def lengths(x: torch.Tensor) -> torch.Tensor:
        return bone_lengths(x[..., :N_POSE].unflatten(-1, (LOCOMOTION.n_joints, 3)))

    return (100 * (lengths(prediction) - lengths(target).detach())).square().mean()


class GenerativeModel:
    """Mixin for the models that generate: the checks and unit conversions of the contract.

    A model sets ``continues_motion`` (does ``prefix`` mean anything to it?) and
    ``follows_control`` and implements ``generate`` with these helpers.
    """

    normalizer = None
    follows_control = False
    continues_motion = False

    def _normalizer(self):
        if self.normalizer is None:
            raise ValueError(f"{type(self).__name__}: no normaliser, so generate() cannot work in the data's units; "
                             "train it with training.train, load it with training.load_checkpoint or "
                             "pretrained.load, or set model.normalizer (or use the low-level sample())")
        return self.normalizer

    @staticmethod
    def _check_common(n, temperature, seed) -> tuple[int, float]:
        """``n`` and ``temperature`` checked (and ``seed``, even where nothing is random)."""
        checks.whole(seed, "seed", 0)
        return checks.whole(n, "n", 1), checks.non_negative(temperature, "temperature")

    def _control_array(self, control, n: int, frames: int | None = None) -> np.ndarray:
        """``control`` ``(frames, 3)`` or ``(n, frames, 3)`` in the data's units, checked,
        as ``(n, frames, 3)``."""
        if control is None:
            raise ValueError(f"control: {type(self).__name__} follows a control path; give (frames, 3) or "
                             f"({n}, frames, 3): forward, sideways (m/s) and turning (rad/s) velocity")
        control = checks.array(control, "control", (..., "frames", 3))
        if control.ndim == 2:
            control = np.broadcast_to(control, (n, *control.shape))
        if control.ndim != 3 or len(control) != n:
            raise ValueError(f"control: expected (frames, 3) or ({n}, frames, 3) for n={n}, got {control.shape}")
        if frames is not None and control.shape[1] != frames:
            raise ValueError(f"frames: {frames} does not match the control's {control.shape[1]} frames")
        return control

    def _prefix_array(self, prefix, n: int, min_frames: int = 1) -> np.ndarray:
        """``prefix`` ``(k, 66)`` or ``(n, k, 66)`` in the data's units, checked, as ``(n, k, 66)``."""
        if prefix is None:
            raise ValueError(f"prefix: {type(self).__name__} continues motion; give at least {min_frames} "
                             f"real frames, (k, {N_FEATURES}) or ({n}, k, {N_FEATURES}) in the data's units")
        prefix = checks.array(prefix, "prefix", (..., "frames", N_FEATURES))
        if prefix.ndim == 2:
            prefix = np.broadcast_to(prefix, (n, *prefix.shape))
        if prefix.ndim != 3 or len(prefix) != n or prefix.shape[1] < min_frames:
            raise ValueError(f"prefix: expected (k >= {min_frames}, {N_FEATURES}) or ({n}, k, {N_FEATURES}), "
                             f"got {prefix.shape}")
        return prefix

    def _normalized_control(self, control, n: int, frames: int | None = None) -> torch.Tensor:
        """:meth:`_control_array`, normalised: a float32 tensor ``(n, frames, 3)``."""
        control = self._control_array(control, n, frames)
        norm = self._normalizer()
        return torch.tensor((control - norm.mean[CONTROL]) / norm.std[CONTROL], dtype=torch.float32)

    def _normalized_prefix(self, prefix, n: int, min_frames: int = 1) -> torch.Tensor:
        """:meth:`_prefix_array`, normalised: a float32 tensor ``(n, k, 66)``."""
        prefix = self._prefix_array(prefix, n, min_frames)
        return torch.tensor(self._normalizer().normalize(prefix), dtype=torch.float32)

    def _refuse_prefix(self, prefix) -> None:
        if prefix is not None:
            raise ValueError(f"prefix: {type(self).__name__} does not continue motion; it draws whole windows")

    def contact_term(self, prediction: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """:func:`contact_term` of this model's reconstruction against its data."""
        return contact_term(self, prediction, target, self.fps)

    def bone_term(self, prediction: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
        """:func:`bone_term` of this model's reconstruction against its data."""
        return bone_term(self, prediction, target)

    def _result(self, normalised: torch.Tensor, contacts: torch.Tensor | None = None) -> Generated:
        """Normalised features ``(n, frames, 66)`` -> :class:`Generated` in the data's units."""
        return self._result_in_data_units(self._normalizer().denormalize(normalised.detach().cpu().double().numpy()),
                                          contacts)

    def _result_in_data_units(self, features, contacts: torch.Tensor | None = None) -> Generated:
        features = np.asarray(features, dtype=np.float64)
        bad = ~np.isfinite(features).reshape(len(features), -1).all(axis=1)
        if bad.any():
            # a flow's inverse divides by its couplings' scales: latents drawn far from the centre (a high
            # temperature) can overflow in a model whose scales get small there
            flow = hasattr(self, "nll")
            raise ValueError(("temperature: " if flow else "generate: ")
                             + f"{type(self).__name__} made {int(bad.sum())} of {len(features)} samples that are "
                             "not finite (NaN or infinite); "
                             + ("a flow's inverse can overflow for latents far from the centre: try a lower "
                                "temperature" if flow else "were its weights trained to a finite loss?"))
        drawn = None if contacts is None else torch.as_tensor(contacts).cpu().numpy() > 0.5
        return Generated(features, to_positions(features, self.fps), float(self.fps), drawn)

    @property
    def fps(self) -> float:
        """Frames per second of the data the model was made for."""
        return self.config.fps
