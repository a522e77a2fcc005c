"""Temporal convolutional autoencoder (Motegi et al. 2018, §III; Holden et al. 2015).

One convolutional layer learns a *motion manifold*: windows of motion are encoded into
half as many frames of ``filters`` features, and decoded back. Motegi §III-A, with
``x`` a window of normalised features, ``*`` convolution over time with filters that span
all features, ``Ψ`` temporal max pooling and ``Ψ'`` upsampling:

    encoder   Φ(x)  = Ψ(ReLU(x * W + b))                (120 x 58 -> 60 x 32 in the paper)
    decoder   Φ'(y) = Ψ'(y) * W' + b'                   (60 x 32 -> 120 x 58)
    cost      C     = Σ_n ||x_n - Φ'(Φ(x_n))||²         (§III-B; here the mean, not the sum)

Holden's options worth teaching are switches on :class:`ConvAEConfig`: dropout on the
input (training the autoencoder to *denoise*, which is what makes projecting corrupted
motion back onto the manifold work), the choice of depooling, and an L1 penalty on the
weights. Tensors are ``(batch, frames, features)`` outside; the convolutions transpose
to ``(batch, channels, frames)`` inside.

One option of ours: ``skeleton=True`` puts the decoder's joints onto a skeleton (each bone
one length per window, :class:`~motionlab.models.skeleton_output.SkeletonOutput`), so that
nothing decoded from the manifold, the VAE's samples included, stretches a bone.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import torch
import torch.nn.functional as F
from torch import nn

from .. import checks
from ..representation import N_POSE
from .base import bone_term, check_tensor, contact_term, eval_mode
from .modelcard import NO_CLIP, ModelCard, choice, paper
from .skeleton_output import SkeletonOutput


@dataclass(frozen=True)
class ConvAEConfig:
    """Sizes and options. Defaults: a laptop-sized model at 20 fps; :meth:`paper` is Motegi's.

    Attributes:
        n_features: features per frame (66: pose + control).
        window: frames per window (must be even: one pooling halves it).
        fps: frames per second of the data the model expects.
        filters: number of convolution filters, the manifold's features per frame.
        width: filter width in frames (odd, so padding keeps the length).
        input_dropout: probability that a joint (all three coordinates) or a control channel
            is zeroed while training (Holden: a denoising autoencoder).
        input_noise: standard deviation of Gaussian noise added to the normalised input
            while training.
        depool: how ``Ψ'`` doubles the frames: ``"nearest"`` (repeat each frame),
            ``"linear"`` (interpolate) or ``"unpool"`` (put each value back where the max
            came from: only possible when decoding a window just encoded).
        l1: weight of the L1 penalty on the convolution weights (Holden: sparse filters).
        contact_weight: weight of the foot-contact velocity term (HuMoR, EDGE, MDM; see
            :meth:`ConvAutoencoder.loss`), per (m/s)² of planted-foot velocity; 0 = off (the
            shipped model).
        bone_weight: weight of the bone-length term (:meth:`ConvAutoencoder.loss`), per cm²
            of squared bone-length error; 0 = off (the shipped model).
        skeleton: the decoder's pose put onto a skeleton, each bone one length per window
            (:class:`~motionlab.models.skeleton_output.SkeletonOutput`: bone directions
            the decoder's, the legs reaching its ankles by two-bone IK); ours, off by default,
            on in the shipped model (``motionlab/recipes.py``). Needs the 66 locomotion
            features and ``model.normalizer``.
    """

    n_features: int = 66
    window: int = 80
    fps: float = 20.0
    filters: int = 32
    width: int = 11
    input_dropout: float = 0.2
    input_noise: float = 0.0
    depool: str = "nearest"
    l1: float = 1e-5
    contact_weight: float = 0.0
    bone_weight: float = 0.0
    skeleton: bool = False

    def __post_init__(self):
        checks.config(self, non_negative_fields=("input_noise", "l1", "contact_weight", "bone_weight"),
                      probability_fields=("input_dropout",))
        if self.window % 2 or self.window < 2:
            raise ValueError(f"window: must be even and >= 2 (pooling halves it), got {self.window}")
        if self.width % 2 == 0:
            raise ValueError(f"width: must be odd so the output keeps its length, got {self.width}")
        if self.depool not in ("nearest", "linear", "unpool"):
            raise ValueError(f"depool: expected 'nearest', 'linear' or 'unpool', got {self.depool!r}")
        if not 0 <= self.input_dropout < 1:
            raise ValueError(f"input_dropout: expected 0 <= p < 1, got {self.input_dropout}")
        if self.skeleton and self.n_features != N_POSE + 3:
            raise ValueError(f"skeleton: needs the {N_POSE + 3} locomotion features, got n_features={self.n_features}")

    @classmethod
    def paper(cls, **changes) -> "ConvAEConfig":
        """Motegi §III-A: 120-frame windows at 30 fps, 32 filters 15 frames wide, plain MSE."""
        return replace(cls(window=120, fps=30.0, filters=32, width=15, input_dropout=0.0, l1=0.0),
                       **changes)


class ConvAutoencoder(nn.Module):
    """Motegi's one-layer temporal convolutional autoencoder.

    ``forward(x)`` reconstructs ``x`` ``(batch, window, n_features)``; :meth:`encode` gives
    the manifold features ``(batch, window // 2, filters)`` and :meth:`decode` maps them
    back. The VAE of notebook 03 is trained on these features.
    """

    def __init__(self, config: ConvAEConfig = ConvAEConfig()):
        super().__init__()
        self.config = config
        pad = config.width // 2
        # Padding repeats the first and last frames: zero padding would look like a sudden
        # stop at both ends of every window, and the reconstruction there suffers.
        # W, b: filters spanning all features, sliding over time (§III-A)
        self.encoder = nn.Conv1d(config.n_features, config.filters, config.width, padding=pad, padding_mode="replicate")
        # W', b': back from the manifold to every feature
        self.decoder = nn.Conv1d(config.filters, config.n_features, config.width, padding=pad, padding_mode="replicate")
        self.skeleton = SkeletonOutput() if config.skeleton else None

    def _check(self, x: torch.Tensor, name: str = "x", even: bool = True, finite: bool = True) -> None:
        """Refuse anything but a (finite) tensor ``(batch, frames, n_features)`` (even frames if ``even``)."""
        check_tensor(x, name, self.config.n_features, even=even, finite=finite,
                     frames_text=None if even else "frames")

    def encode(self, x: torch.Tensor, return_indices: bool = False):
        """Φ(x) = Ψ(ReLU(x * W + b)): ``(batch, frames, n_features)`` -> ``(batch, frames // 2, filters)``."""
        self._check(x)
        return self._encode(x, return_indices)

    def _encode(self, x: torch.Tensor, return_indices: bool = False):
        # unchecked: encode() and forward() check their input once, loss() only its shape
        if self.training:
            x = self._corrupt(x)
        x = x.transpose(1, 2)                                  # (batch, features, frames)
        hidden = F.relu(self.encoder(x))
        pooled, indices = F.max_pool1d(hidden, 2, return_indices=True)   # Ψ
        pooled = pooled.transpose(1, 2)
        return (pooled, indices) if return_indices else pooled

    def corrupt(self, x: torch.Tensor) -> torch.Tensor:
        """Training-time corruption (Holden: a *denoising* autoencoder): whole joints (their
        three coordinates) and control channels are zeroed (set to the data's mean) with
        probability ``input_dropout``, and Gaussian noise of ``input_noise`` standard
        deviations is added."""
        self._check(x, even=False)
        return self._corrupt(x)

    def _corrupt(self, x: torch.Tensor) -> torch.Tensor:
        if self.config.input_dropout > 0:
            n_joints = (x.shape[-1] - 3) // 3
            keep_joint = torch.rand(x.shape[0], 1, n_joints, 1, device=x.device) >= self.config.input_dropout
            keep = torch.cat([keep_joint.expand(-1, -1, -1, 3).reshape(x.shape[0], 1, -1),
                              torch.rand(x.shape[0], 1, 3, device=x.device) >= self.config.input_dropout], -1)
            x = x * keep / (1 - self.config.input_dropout)
        if self.config.input_noise > 0:
            x = x + self.config.input_noise * torch.randn_like(x)
        return x

    def decode(self, y: torch.Tensor, indices: torch.Tensor | None = None) -> torch.Tensor:
        """Φ'(y) = Ψ'(y) * W' + b': ``(batch, frames, filters)`` -> ``(batch, 2 * frames, n_features)``."""
        if not isinstance(y, torch.Tensor) or y.ndim != 3 or y.shape[-1] != self.config.filters or 0 in y.shape[:2]:
            got = tuple(y.shape) if isinstance(y, torch.Tensor) else type(y).__name__
            raise ValueError(f"y: expected (batch, frames, {self.config.filters}) tensor, got {got}")
        if not torch.isfinite(y).all():
            raise ValueError("y: contains NaN or infinite values")
        return self._decode(y, indices)

    def _decode(self, y: torch.Tensor, indices: torch.Tensor | None) -> torch.Tensor:
        # unchecked, for forward(): a model that diverges during training should end in the
        # training loop's NaN-loss message, not in a complaint about its own features
        y = y.transpose(1, 2)
        if self.config.depool == "unpool":
            if indices is None:
                raise ValueError("indices: depool='unpool' needs the pooling indices from encode(x, "
                                 "return_indices=True); decoding new features needs another depool")
            upsampled = F.max_unpool1d(y, indices, 2, output_size=(y.shape[-1] * 2,))
        elif self.config.depool == "linear":
            upsampled = F.interpolate(y, scale_factor=2, mode="linear", align_corners=False)
        else:
            upsampled = F.interpolate(y, scale_factor=2, mode="nearest")
        out = self.decoder(upsampled).transpose(1, 2)
        return out if self.skeleton is None else self.skeleton(out, getattr(self, "normalizer", None))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Reconstruct ``x`` ``(batch, frames, n_features)`` through the manifold."""
        self._check(x)
        return self._reconstruct(x)

    def _reconstruct(self, x: torch.Tensor) -> torch.Tensor:
        if self.config.depool == "unpool":
            y, indices = self._encode(x, return_indices=True)
            return self._decode(y, indices)
        return self._decode(self._encode(x), None)

    def project(self, x: torch.Tensor) -> torch.Tensor:
        """Holden's use of the manifold: map (possibly corrupted) motion to the nearest
        motion the autoencoder can represent. The same as ``forward`` in eval mode."""
        with torch.no_grad(), eval_mode(self):
            return self(x)

    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """Mean squared reconstruction error (§III-B) plus Holden's L1 weight penalty, for a
        ``batch`` ``(batch, even frames, n_features)``.

        With ``contact_weight > 0``, plus that times the foot-contact velocity term (HuMoR,
        EDGE, MDM; :func:`motionlab.contacts.contact_velocity_loss`): where the window's feet
        are planted, their squared world velocity in the reconstructed pose moved along the
        window's own control, in the data's units through ``model.normalizer`` (which
        :func:`motionlab.training.train` sets). Logged as ``contact``."""
        self._check(batch, "batch", finite=False)      # NaN: the training loop's guard stops the run
        out = self._reconstruct(batch)
        reconstruction = F.mse_loss(out, batch)
        l1 = self.encoder.weight.abs().sum() + self.decoder.weight.abs().sum()
        terms = {"loss": reconstruction + self.config.l1 * l1, "mse": reconstruction}
        for name, weight, term in (("contact", self.config.contact_weight,
                                    lambda p, t: contact_term(self, p, t, self.config.fps)),
                                   ("bone", self.config.bone_weight, lambda p, t: bone_term(self, p, t))):
            if weight > 0:
                if self.config.n_features != N_POSE + 3:
                    raise ValueError(f"{name}_weight: needs the {N_POSE + 3} locomotion features, "
                                     f"got n_features={self.config.n_features}")
                value = term(torch.cat([out[..., :N_POSE], batch[..., N_POSE:]], -1), batch)
                terms["loss"] = terms["loss"] + weight * value
                terms[name] = value.detach()
        return terms

    def trace(self, x: torch.Tensor) -> list[tuple[str, tuple[int, ...]]]:
        """The shape of ``x`` at every stage, for a walk-through of the architecture."""
        self._check(x)
        with torch.no_grad():
            inside = x.transpose(1, 2)
            conv = self.encoder(inside)
            pooled = F.max_pool1d(F.relu(conv), 2)
            up = F.interpolate(pooled, scale_factor=2, mode="nearest")
            out = self.decoder(up)
        return [("input window (batch, frames, features)", tuple(x.shape)),
                ("transposed for Conv1d (batch, features, frames)", tuple(inside.shape)),
                (f"conv, {self.config.filters} filters of {self.config.width} frames x all features",
                 tuple(conv.shape)),
                ("ReLU + max pool over 2 frames: the manifold", tuple(pooled.shape)),
                ("depool: twice the frames again", tuple(up.shape)),
                (f"conv back to {self.config.n_features} features", tuple(out.shape)),
                ("transposed back (batch, frames, features)", tuple(out.transpose(1, 2).shape))] \
            + [("put onto a skeleton: every bone one length per window", tuple(out.transpose(1, 2).shape))] \
            * (self.skeleton is not None)


# ------------------------------------------------------------------------ training, as the paper says

def motegi_schedule(section: str) -> dict:
    """Motegi et al. 2018 trains the conv AE (§III-B) and the VAE (§IV-B) alike."""
    return {
        "optimizer": paper("Adam", f"Motegi 2018 §{section}: 'Adam optimization algorithm'"),
        "batch_size": paper(100, f"§{section}: 'the batch size is 100'"),
        "epochs": paper(200, f"§{section}: 'performed for 200 epochs'"),
        "lr": choice(1e-3, "Motegi gives no learning rate: Adam's default (Kingma & Ba 2015)"),
        "schedule": choice("constant", "no decay is mentioned"),
        "grad_clip": choice(1.0, NO_CLIP),
    }


CARD = ModelCard("conv_ae", ConvAutoencoder, ConvAEConfig, schedule=motegi_schedule("III-B"))
