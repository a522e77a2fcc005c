"""A contact head beside a flow: an exact joint likelihood of pose and foot contacts.

Production characters (PFNN, Learned Motion Matching) and HuMoR predict foot contacts
beside the pose. For a flow this must not cost its exact likelihood. With a head, the
model is a joint density over the pose ``x`` and the contact labels ``c`` of a window,
given its control ``u``::

    p(x, c | u) = p(c | u) · p(x | c, u)

* ``p(c | u)``, this head: the labels of the ankles and toes (four 0/1 values per frame,
  one of 16 states) drawn frame by frame, ``p(c_t | c_{<t}, u)``: a GRU over the previous
  frame's state and a convolution over the control around frame ``t``. A product of
  categoricals, so its log-likelihood is exact.
* ``p(x | c, u)``: the flow, whose coupling networks see the labels (``±1``) beside the
  control. An exact flow density for every ``c``.

The labels are a function of the motion (:func:`motionlab.contacts.contact_labels`: a foot
joint low and slow in the data), so a window has one ``c(x)``, and ``p(x | u) = Σ_c p(x, c |
u) ≥ p(x, c(x) | u)``: the joint likelihood at the data's own labels is a lower bound on the
pose's, and its negative an upper bound on the NLL, comparable with a plain flow's.

Sampling draws the labels first (the rhythm of the steps), then the pose given them: the
flow learned where a foot is when it is planted and when it is not, and the swing foot is
drawn as a swing.

Two flows have the option (``contact_head=True``): Glow (:mod:`~motionlab.models.glow`),
whose head reads the window's control around each frame, and MoGlow
(:mod:`~motionlab.models.moglow`), whose head reads each frame's own conditioning (the
history and the controls), so that it draws one frame's contacts at a time and streams with
the flow (``MoGlowStream.contacts``).
"""
from __future__ import annotations

import torch
from torch import nn

from ..skeleton import FEET

N_CONTACTS = len(FEET)
"""Labels per frame: left ankle, left toe, right ankle, right toe (:data:`FEET` order)."""

STATES = 2 ** N_CONTACTS
"""The labels of a frame as one of 16 states, ``Σ_j c_j 2^j``."""


class DataContacts:
    """Mixin for a flow with a contact head: the data's own labels, its training targets."""

    def data_contacts(self, batch: torch.Tensor) -> torch.Tensor:
        """The contact labels of normalised data windows ``(batch, frames, 66)``: ``(batch,
        frames, 4)``, 1 where an ankle or toe is planted (:func:`motionlab.contacts.contact_labels`,
        in the data's units through ``model.normalizer``; the last frame takes the one before's)."""
        from .. import contacts
        if getattr(self, "normalizer", None) is None:
            raise ValueError("contact_head: the data's contacts are measured in metres and need the model's "
                             "normaliser; train with training.train on a MotionData (it sets model.normalizer) "
                             "or set model.normalizer")
        labels = contacts.contact_labels(self.normalizer.denormalize(batch.float()), self.config.fps)
        return torch.cat([labels, labels[:, -1:]], 1)

    @staticmethod
    def with_contacts(cond: torch.Tensor, labels: torch.Tensor | None) -> torch.Tensor:
        """The coupling networks' conditioning ``cond`` and, with a contact head, the labels as ``±1``."""
        return cond if labels is None else torch.cat([cond, 2 * labels.to(cond.dtype) - 1], -1)


def check_config(config) -> None:
    """``ValueError`` naming ``contact_head`` where a config cannot have one: the contacts are
    the feet's in the locomotion features (66: 63 pose values, 3 controls), given the control."""
    if config.contact_head and not (getattr(config, "conditional", True)
                                    and (config.n_features, config.n_control) == (66, 3)):
        raise ValueError("contact_head: the contacts are the feet's in the locomotion features, given the "
                         f"control; needs conditional=True, 66 features and 3 controls, got "
                         f"conditional={getattr(config, 'conditional', True)}, {config.n_features} and {config.n_control}")


def states(labels: torch.Tensor) -> torch.Tensor:
    """0/1 labels ``(..., N_CONTACTS)`` to state indices ``(...)`` (long)."""
    weights = 2 ** torch.arange(N_CONTACTS, device=labels.device)
    return (labels.round().long() * weights).sum(-1)


def labels_of(index: torch.Tensor) -> torch.Tensor:
    """State indices ``(...)`` back to 0/1 labels ``(..., N_CONTACTS)`` (float)."""
    return ((index[..., None] >> torch.arange(N_CONTACTS, device=index.device)) & 1).float()


class ContactHead(nn.Module):
    """``p(c_1..T | u_1..T)``: each frame's contact state given the earlier ones and a context.

    The context is what the model conditions on, per frame: Glow's control (``width`` 5: two
    convolutions see the control around the frame), or MoGlow's conditioning of the frame
    (``width`` 1: per frame, so the head is causal and streams).

    Args:
        n_inputs: context values per frame.
        hidden: channels of the context's layers and of the GRU.
        width: frames of context each of the two convolutions sees (odd).
    """

    def __init__(self, n_inputs: int, hidden: int = 64, width: int = 5):
        super().__init__()
        self.context = nn.Sequential(nn.Conv1d(n_inputs, hidden, width, padding=width // 2), nn.ReLU(),
                                     nn.Conv1d(hidden, hidden, width, padding=width // 2), nn.ReLU())
        self.embed = nn.Embedding(STATES + 1, hidden)          # the 16 states and a start token
        self.rnn = nn.GRU(2 * hidden, hidden, batch_first=True)
        self.out = nn.Linear(hidden, STATES)

    def context_of(self, inputs: torch.Tensor) -> torch.Tensor:
        """The context ``(n, frames, n_inputs)`` through the head's layers: ``(n, frames, hidden)``."""
        return self.context(inputs.transpose(1, 2)).transpose(1, 2)

    def log_prob(self, labels: torch.Tensor, inputs: torch.Tensor) -> torch.Tensor:
        """``ln p(c | u)`` of each window, nats, ``(n,)``: labels ``(n, frames, 4)`` (0/1),
        context ``(n, frames, n_inputs)``. Teacher-forced: each frame sees the true states
        before it."""
        index = states(labels)
        start = torch.full_like(index[:, :1], STATES)
        previous = torch.cat([start, index[:, :-1]], 1)
        hidden, _ = self.rnn(torch.cat([self.embed(previous), self.context_of(inputs)], -1))
        logits = torch.log_softmax(self.out(hidden), -1)
        return logits.gather(-1, index[..., None])[..., 0].sum(1)

    def start(self, n: int, device=None) -> tuple[torch.Tensor, None]:
        """The state before the first frame of ``n`` sequences: ``(previous state, GRU state)``."""
        return torch.full((n,), STATES, dtype=torch.long, device=device), None

    @torch.no_grad()
    def step(self, context: torch.Tensor, carried, generator: torch.Generator | None = None):
        """One frame: ``context`` ``(n, hidden)`` (this frame's row of :meth:`context_of`) and the
        ``carried`` state (:meth:`start`) -> the frame's labels ``(n, 4)`` (0/1) and the new state."""
        previous, hidden = carried
        output, hidden = self.rnn(torch.cat([self.embed(previous), context], -1)[:, None], hidden)
        probs = torch.softmax(self.out(output[:, 0]).float(), -1)
        state = torch.multinomial(probs.cpu(), 1, generator=generator)[:, 0].to(context.device)
        return labels_of(state), (state, hidden)

    @torch.no_grad()
    def sample(self, inputs: torch.Tensor, generator: torch.Generator | None = None) -> torch.Tensor:
        """Labels ``(n, frames, 4)`` (0/1 floats) drawn frame by frame for the context
        ``(n, frames, n_inputs)``."""
        context = self.context_of(inputs)
        carried, drawn = self.start(len(inputs), inputs.device), []
        for t in range(inputs.shape[1]):
            labels, carried = self.step(context[:, t], carried, generator)
            drawn.append(labels)
        return torch.stack(drawn, 1)
