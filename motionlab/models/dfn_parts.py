"""The generic parts of Dynamic Future Net (:mod:`motionlab.models.dfn`), so that the model
file reads top to bottom beside Chen et al. 2020:

* building blocks: :func:`mlp` (the paper's "n-layer MLP") and :class:`GaussianHead`;
* rotations: :func:`quaternion_to_matrix` and :class:`ForwardKinematics`, §5.1's layer from
  joint rotations to joint positions at fixed bone lengths;
* :class:`StagedTraining`, what the library wraps around the paper's networks: the stage to
  train next (§5.6) and its loss, the contact term, reconstruction, ``generate``.

Every name here is importable from :mod:`motionlab.models.dfn` too.
"""
from __future__ import annotations

import torch
from torch import nn

from .. import checks
from ..rotations import parent_first
from ..skeleton import LOCOMOTION
from .base import Generated, check_tensor, generator_for

# ----------------------------------------------------------------------------------------
# Building blocks
# ----------------------------------------------------------------------------------------

def mlp(sizes: list[int]) -> nn.Sequential:
    """Linear layers between ``sizes`` with LeakyReLU between them (none after the last).

    *Choice*: the paper's "n-layer MLP" is read as n linear layers ("three-layer MLP with
    hidden dimension 256" = ``[in, 256, 256, out]``); "n hidden layers" as n + 1 linear
    layers.
    """
    layers: list[nn.Module] = []
    for k, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if k < len(sizes) - 2:
            layers.append(nn.LeakyReLU(0.2))
    return nn.Sequential(*layers)


class GaussianHead(nn.Module):
    """An MLP that outputs a diagonal Gaussian: ``(..., in) -> mu, log_var`` each ``(..., out)``."""

    def __init__(self, sizes: list[int]):
        super().__init__()
        self.net = mlp(sizes[:-1] + [2 * sizes[-1]])

    def forward(self, *inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        mu, log_var = self.net(torch.cat(inputs, dim=-1)).chunk(2, dim=-1)
        # Choice: log sigma^2 within [-8, 4] so exp() can neither vanish nor blow up.
        return mu, log_var.clamp(-8.0, 4.0)


# ----------------------------------------------------------------------------------------
# Rotations: §5.1's forward-kinematics layer
# ----------------------------------------------------------------------------------------

def quaternion_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """Rotation matrices ``(..., 3, 3)`` of quaternions ``(..., 4)`` as ``(w, x, y, z)``, any
    length (each is normalised first)."""
    w, x, y, z = (q / q.norm(dim=-1, keepdim=True).clamp_min(1e-8)).unbind(-1)
    return torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
                       -1).reshape(q.shape[:-1] + (3, 3))


class ForwardKinematics(nn.Module):
    """§5.1's forward-kinematics layer (after Pavllo et al. 2018): joint rotations and the
    hips' position -> the 21 root-local joint positions, with every bone at its fixed length.

    Each joint ``j`` sits at ``p_j = p_parent + G_parent · o_j``, where ``G_parent`` is the
    parent's rotation composed down from the hips (``G_j = G_parent · R_j``) and ``o_j`` the
    joint's rest offset from its parent, metres (:meth:`fit`). Only joints with children
    need a rotation (a leaf's would move nothing). Tensors: ``rotations`` ``(..., rotated,
    3, 3)``, ``hips`` ``(..., 3)``, result ``(..., 21, 3)``, metres.

    *Choice*: the paper retargets all its data to one skeleton; ours has bodies of several
    sizes, so the rest offsets are the training frames' mean bone directions (in the root
    frame) at their mean lengths: every decoded body is that mean body.
    """

    def __init__(self, skeleton=LOCOMOTION):
        super().__init__()
        self.parents = [int(p) for p in skeleton.parents]
        self.rotated = [j for j in range(len(self.parents)) if j in self.parents]   # joints with children
        self.register_buffer("offsets", torch.zeros(len(self.parents), 3))

    def fit(self, positions: torch.Tensor) -> None:
        """Rest offsets from root-local joint positions ``(..., 21, 3)``, metres."""
        flat = positions.reshape(-1, len(self.parents), 3)
        for j, parent in enumerate(self.parents):
            if parent >= 0:
                bones = flat[:, j] - flat[:, parent]
                direction = bones.mean(0) / bones.mean(0).norm().clamp_min(1e-8)
                self.offsets[j] = direction * bones.norm(dim=-1).mean()

    def forward(self, rotations: torch.Tensor, hips: torch.Tensor) -> torch.Tensor:
        local = dict(zip(self.rotated, rotations.unbind(-3)))
        turn, where = {}, {}
        for j in parent_first(self.parents):                    # as rotations.forward_kinematics walks them
            parent = self.parents[j]
            if parent < 0:
                where[j] = hips
            else:
                where[j] = where[parent] + (turn[parent] @ self.offsets[j].unsqueeze(-1)).squeeze(-1)
            if j in local:
                turn[j] = local[j] if parent < 0 else turn[parent] @ local[j]
        return torch.stack([where[j] for j in range(len(self.parents))], -2)


# ----------------------------------------------------------------------------------------
# Around the paper's networks: stages, the contact term, reconstruction, generate
# ----------------------------------------------------------------------------------------

class StagedTraining:
    """What the library wraps around DFN's networks (a mixin of
    :class:`~motionlab.models.dfn.DFN`; it holds no weights): the stage to train next and its
    loss (§5.6, with the standardisation of the codes the dynamics model works on), the
    foot-contact term added to the losses on decoded frames, deterministic reconstruction
    through the trained autoencoders, and :meth:`generate`, the library's one generation
    contract. It reads the model's parts (``frame``, ``sequence``, ``dynamics``), its
    standardisation buffers, its per-stage losses and its ``sample``.
    """

    # -- checks --------------------------------------------------------------------------

    def _check(self, x: torch.Tensor, name: str, min_frames: int = 1, finite: bool = True) -> None:
        check_tensor(x, name, self.config.n_features, min_frames, finite=finite)

    # -- stages --------------------------------------------------------------------------

    def set_stage(self, stage: str, windows: torch.Tensor | None = None) -> None:
        """Train ``stage`` next (§5.6): its parameters train, every other one is frozen.

        ``"sequence"`` and ``"dynamics"`` need training ``windows`` ``(n, frames, 66)``: the
        frozen encoders' outputs on them set the standardisation of frame codes (and, for
        ``"dynamics"``, of future summaries). For ``"frame"`` they are optional: given, the
        features they never vary are found and the rotation decoder's skeleton is fitted
        (:meth:`FrameAutoencoder.fit_constants`), in metres when the model has its data's
        ``normalizer`` (:func:`motionlab.training.train_stages` sets it first).
        """
        if stage not in self.stages:
            raise ValueError(f"stage: expected one of {', '.join(self.stages)}, got {stage!r}")
        trained = {"frame": [self.frame], "sequence": [self.sequence],
                   "dynamics": [self.dynamics, self.contact_head]}[stage]      # no head: None
        for p in self.parameters():
            p.requires_grad_(False)
        for p in (p for part in trained if part is not None for p in part.parameters()):
            p.requires_grad_(True)
        if stage == "frame" and windows is not None:
            self._check(windows, "windows")
            pose = {}
            if self.normalizer is not None:             # forward kinematics in metres (§5.1)
                pose = {"pose_mean": self.normalizer.mean[:self.config.n_pose],
                        "pose_std": self.normalizer.std[:self.config.n_pose]}
            self.frame.fit_constants(windows.to(self.code_mean.device), **pose)
        if stage != "frame":
            if windows is None:
                raise ValueError(f"windows: stage {stage!r} needs the training windows to standardise codes")
            self._check(windows, "windows", min_frames=self.config.horizon)
            with torch.no_grad():
                codes = self.frame.encode(windows.to(self.code_mean.device)).reshape(-1, self.config.code)
                self.code_mean.copy_(codes.mean(0))
                self.code_std.copy_(codes.std(0).clamp_min(1e-4))
                if stage == "dynamics":
                    self.summary_mean.zero_(), self.summary_std.fill_(1.0)     # raw summaries first
                    summaries = self.summaries(self.codes(windows.to(self.code_mean.device))).reshape(
                        -1, self.config.summary)
                    self.summary_mean.copy_(summaries.mean(0))
                    self.summary_std.copy_(summaries.std(0).clamp_min(1e-4))
        self.stage = stage


    def _with_contact(self, recon: torch.Tensor, target: torch.Tensor,
                      terms: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """``terms`` with the contact term of ``recon`` against ``target`` added to the loss
        and logged, when ``contact_weight > 0`` (see :meth:`frame_loss`)."""
        if self.config.contact_weight == 0:
            return terms
        contact = self.contact_term(recon, target)
        return {**terms, "loss": terms["loss"] + self.config.contact_weight * contact, "contact": contact.detach()}


    def loss(self, batch: torch.Tensor) -> dict[str, torch.Tensor]:
        """The loss of the current stage (:meth:`set_stage`) on windows ``(batch, frames, 66)``."""
        self._check(batch, "batch", min_frames=self.config.horizon if self.stage != "frame" else 1,
                    finite=False)                     # NaN: the training loop's guard stops the run
        return {"frame": self.frame_loss, "sequence": self.sequence_loss,
                "dynamics": self.dynamics_loss}[self.stage](batch)

    # -- reconstruction and generation ---------------------------------------------------

    @torch.no_grad()
    def reconstruct(self, frames: torch.Tensor, through: str = "frame") -> torch.Tensor:
        """Deterministic reconstruction of ``(batch, frames, 66)``.

        ``through="frame"``: each frame through the frame autoencoder (§5.1).
        ``through="sequence"``: each ``horizon``-frame piece (starting at frames 0, H, 2H,
        ...; the tail that does not fill one is left out) through the frame encoder, the
        sequence autoencoder and the frame decoder (§5.2).
        """
        self._check(frames, "frames")
        given_on, frames = frames.device, frames.to(self.code_mean.device)
        if through == "frame":
            return self.frame.decode(self.frame.encode(frames)).to(given_on)
        if through != "sequence":
            raise ValueError(f"through: expected 'frame' or 'sequence', got {through!r}")
        H = self.config.horizon
        n = frames.shape[1] // H
        if n == 0:
            raise ValueError(f"frames: need at least horizon = {H} frames, got {frames.shape[1]}")
        pieces = self.codes(frames[:, :n * H]).reshape(-1, H, self.config.code)
        return self.frames_from_codes(self.sequence.decode(self.sequence.encode(pieces))).reshape(
            frames.shape[0], n * H, -1).to(given_on)


    def generate(self, control=None, *, frames=None, prefix=None, n=1, temperature=1.0, seed=0) -> Generated:
        """Continue ``prefix`` (required; the paper primes with 8 to 20 frames) by ``frames``
        new frames; see :mod:`motionlab.models.base`.

        DFN has no control input (§6.1: open-loop, diversified motion): ``control`` is
        ignored; the model chooses its own path. Temperature 0 gives the mean path. With a
        contact head, ``Generated.contacts`` holds the contacts drawn for the new frames.
        """
        n, temperature = self._check_common(n, temperature, seed)
        prefix = self._normalized_prefix(prefix, n)
        frames = checks.whole(frames, "frames", 1)
        k = prefix.shape[1]
        out = self.sample(prefix, k + frames, float(temperature), generator_for(seed), latents=True)
        return self._result(out["frames"][:, k:], out.get("contacts"))
