"""The Glow building blocks: invertibility, exact log-determinants, initialisation, prior."""
from functools import partial

import pytest
import torch

from motionlab.models.flows import (ActNorm, AffineCoupling, ConvCouplingNet, FlowSequence, FlowStep,
                                    GaussianPrior, InvertibleLinear, MLPCouplingNet, MultiScaleFlow,
                                    squeeze, unsqueeze)

CONV = partial(ConvCouplingNet, hidden=16)
MLP = partial(MLPCouplingNet, hidden=16)


def _randomise(module, scale=0.1):
    """Move every parameter away from its (identity-like) initial value, so that couplings
    really scale and shift and the checks below test something."""
    with torch.no_grad():
        for p in module.parameters():
            p.add_(scale * torch.randn_like(p))
    return module


def _blocks(channels=5, cond_channels=0):
    """One of each block type (conditioned where it can be), with random parameters."""
    torch.manual_seed(0)
    blocks = {
        "actnorm": ActNorm(channels),
        "linear": InvertibleLinear(channels),
        "coupling_conv": AffineCoupling(channels, CONV, cond_channels),
        "coupling_mlp": AffineCoupling(channels, MLP, cond_channels),
        "step": FlowStep(channels, CONV, cond_channels),
        "sequence": FlowSequence([FlowStep(channels, MLP, cond_channels) for _ in range(3)]),
        "multiscale": MultiScaleFlow(channels, levels=3, steps=2, make_network=CONV, cond_channels=cond_channels),
    }
    for block in blocks.values():
        for actnorm in [m for m in block.modules() if isinstance(m, ActNorm)]:
            actnorm.initialized.fill_(True)           # skip the data-dependent start: random instead
        _randomise(block)
    return blocks


BLOCKS = list(_blocks())
CASES = [(name, 0) for name in BLOCKS] + [(name, 2) for name in BLOCKS if name not in ("actnorm", "linear")]


@pytest.mark.parametrize("name, cond_channels", CASES)
def test_every_block_inverts_to_float32_precision(name, cond_channels):
    block = _blocks(channels=7, cond_channels=cond_channels)[name]
    x = torch.randn(6, 16, 7)
    cond = torch.randn(6, 16, cond_channels) if cond_channels else None
    z, logdet = block(x, cond)
    assert logdet.shape == (6,)
    assert torch.isfinite(z).all() and torch.isfinite(logdet).all()
    assert (block.inverse(z, cond) - x).abs().max() < 1e-4
    assert not torch.allclose(z.reshape(6, -1), x.reshape(6, -1), atol=1e-2)   # not a do-nothing block


def _brute_force_logdet(block, x, cond):
    """``ln |det ∂z/∂x|`` of each example from the full Jacobian (float64)."""
    result = []
    for i in range(len(x)):
        c = None if cond is None else cond[i:i + 1]
        f = lambda xi: block(xi.reshape(1, *x.shape[1:]), c)[0].reshape(-1)  # noqa: E731
        jacobian = torch.autograd.functional.jacobian(f, x[i].reshape(-1), vectorize=True)
        result.append(torch.linalg.slogdet(jacobian)[1])
    return torch.stack(result)


@pytest.mark.parametrize("name, cond_channels", CASES)
def test_logdet_equals_the_brute_force_jacobian(name, cond_channels):
    block = _blocks(channels=5, cond_channels=cond_channels)[name].double()
    x = torch.randn(2, 4, 5, dtype=torch.float64)
    cond = torch.randn(2, 4, cond_channels, dtype=torch.float64) if cond_channels else None
    _, logdet = block(x, cond)
    expected = _brute_force_logdet(block, x, cond)
    assert torch.allclose(logdet, expected, atol=1e-8), (logdet, expected)
    assert expected.abs().min() > 1e-3                 # a non-trivial volume change


def test_actnorm_initialisation_standardises_the_first_batch():
    torch.manual_seed(0)
    actnorm = ActNorm(4)
    first = torch.randn(8, 30, 4) * torch.tensor([0.1, 1.0, 5.0, 20.0]) + torch.tensor([3.0, -1.0, 0.0, 7.0])
    z, logdet = actnorm(first)
    assert bool(actnorm.initialized)
    assert torch.allclose(z.mean(dim=(0, 1)), torch.zeros(4), atol=1e-5)
    assert torch.allclose(z.std(dim=(0, 1), unbiased=False), torch.ones(4), atol=1e-4)
    expected = -30 * torch.log(first.std(dim=(0, 1), unbiased=False)).sum()
    assert torch.allclose(logdet, expected.expand(8), rtol=1e-4)
    # later batches do not re-initialise: the parameters are now trainable weights
    second = 3 * torch.randn(8, 30, 4)
    assert torch.allclose(actnorm(second)[0], second * actnorm.log_scale.exp() + actnorm.bias)
    # and the flag is saved with the weights
    fresh = ActNorm(4)
    fresh.load_state_dict(actnorm.state_dict())
    assert bool(fresh.initialized) and torch.equal(fresh(second)[0], actnorm(second)[0])


def test_invertible_linear_starts_orthogonal_and_stays_lu():
    torch.manual_seed(0)
    linear = InvertibleLinear(6)
    w = linear.weight()
    assert torch.allclose(w @ w.T, torch.eye(6), atol=1e-5)
    p, lower, upper = linear.factors()
    assert torch.equal(torch.triu(lower, 1), torch.zeros(6, 6)) and torch.equal(torch.diagonal(lower), torch.ones(6))
    assert torch.equal(torch.tril(upper, -1), torch.zeros(6, 6))
    _randomise(linear)
    x = torch.randn(3, 10, 6)
    _, logdet = linear(x)
    assert torch.allclose(logdet, 10 * torch.linalg.slogdet(linear.weight())[1].expand(3), atol=1e-4)


@pytest.mark.parametrize("network", [CONV, MLP])
def test_coupling_starts_as_the_identity(network):
    torch.manual_seed(0)
    coupling = AffineCoupling(7, network, cond_channels=3)
    x, cond = torch.randn(2, 8, 7), torch.randn(2, 8, 3)
    z, logdet = coupling(x, cond)
    assert torch.equal(z, x) and torch.equal(logdet, torch.zeros(2))
    step = FlowStep(7, network, cond_channels=3)
    assert all(key.startswith("blocks.") for key in step.state_dict())     # each weight saved once
    step.actnorm.initialized.fill_(True)              # ActNorm at its identity parameters
    z, logdet = step(x, cond)
    assert torch.allclose(z, x @ step.linear.weight().T) and torch.allclose(logdet, torch.zeros(2), atol=1e-5)


def test_coupling_scale_is_positive_and_bounded():
    torch.manual_seed(0)
    coupling = _randomise(AffineCoupling(4, MLP), scale=30.0)      # huge network outputs
    x = 10 * torch.randn(4, 50, 4)
    shift, log_scale = coupling._shift_and_log_scale(x[..., :2], None)
    assert torch.isfinite(log_scale).all()
    assert log_scale.max() <= torch.log(1 / torch.sigmoid(torch.tensor(2.0))) + 1e-6
    z, logdet = coupling(x)
    assert torch.isfinite(z).all() and torch.isfinite(logdet).all()


def test_coupling_conv_sees_exactly_one_frame_either_side():
    torch.manual_seed(0)
    coupling = _randomise(AffineCoupling(4, CONV))
    x = torch.randn(1, 12, 4)
    nudged = x.clone()
    nudged[0, 6, :2] += 1.0                                          # change b_lo at frame 6
    changed = (coupling(nudged)[0] - coupling(x)[0]).abs().sum(-1)[0] > 0
    assert changed.nonzero().flatten().tolist() == [5, 6, 7]         # eq. 8: b_lo at t-1 .. t+1


def test_squeeze_halves_time_and_splits_in_the_hierarchy():
    x = torch.arange(2 * 6 * 3, dtype=torch.float32).reshape(2, 6, 3)
    s = squeeze(x)
    assert s.shape == (2, 3, 6) and torch.equal(s[0, 1], torch.cat([x[0, 2], x[0, 3]]))
    assert torch.equal(unsqueeze(s), x)
    flow = MultiScaleFlow(66, levels=4, steps=1, make_network=CONV, cond_channels=3)
    shapes = flow.level_shapes(80)
    # §3.3.4: z_{Kl+1} in R^{T/2 x 2 ceil(D/2)}; the control is squeezed, never split
    assert [(s["frames"], s["channels"], s["cond_channels"], s["split"]) for s in shapes] == \
        [(80, 66, 3, 33), (40, 66, 6, 33), (20, 66, 12, 33), (10, 66, 24, 0)]
    odd = MultiScaleFlow(63, levels=3, steps=1, make_network=CONV)
    assert [(s["channels"], s["split"]) for s in odd.level_shapes(8)] == [(63, 31), (64, 32), (64, 0)]
    z, _ = odd(torch.randn(2, 8, 63))
    assert z.shape == (2, 8 * 63)


def test_prior_density_and_temperature():
    prior = GaussianPrior()
    z = torch.randn(3, 10, 4)
    expected = torch.distributions.Normal(0.0, 1.0).log_prob(z).sum(dim=(1, 2))
    assert torch.allclose(prior.log_prob(z), expected)
    assert torch.equal(prior.sample((5, 7), temperature=0.0), torch.zeros(5, 7))    # the mode
    g = lambda: torch.Generator().manual_seed(1)  # noqa: E731
    one, half = prior.sample((4000, 10), 1.0, g()), prior.sample((4000, 10), 0.5, g())
    assert torch.allclose(half, 0.5 * one)                                          # honoured exactly
    assert abs(one.std().item() - 1.0) < 0.02 and abs(half.std().item() - 0.5) < 0.01
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="temperature"):
            prior.sample((2, 3), temperature=bad)


def test_shape_and_conditioning_errors():
    with pytest.raises(ValueError, match=r"x: expected \(batch, time, 4\)"):
        ActNorm(4)(torch.randn(2, 5, 3))
    with pytest.raises(ValueError, match=r"z: expected \(batch, time, 4\)"):
        InvertibleLinear(4).inverse(torch.randn(2, 4))
    with pytest.raises(ValueError, match="channels: a coupling needs at least 2"):
        AffineCoupling(1, MLP)
    coupling = AffineCoupling(4, MLP, cond_channels=2)
    with pytest.raises(ValueError, match="cond: this block is conditioned"):
        coupling(torch.randn(2, 5, 4))
    with pytest.raises(ValueError, match=r"cond: expected batch and time \(2, 5\)"):
        coupling(torch.randn(2, 5, 4), torch.randn(2, 6, 2))
    with pytest.raises(ValueError, match="cond: this block has no conditioning"):
        AffineCoupling(4, MLP)(torch.randn(2, 5, 4), torch.randn(2, 5, 2))
    with pytest.raises(ValueError, match="make_network: the network returned"):
        AffineCoupling(4, lambda i, c, o: nn_returning(o + 1))(torch.randn(1, 3, 4))
    flow = MultiScaleFlow(4, levels=3, steps=1, make_network=MLP)
    with pytest.raises(ValueError, match=r"x: 10 frames is not a multiple of 2\^\(levels - 1\) = 4"):
        flow(torch.randn(1, 10, 4))
    with pytest.raises(ValueError, match=r"z: expected \(batch, frames \* 4\)"):
        flow.inverse(torch.randn(1, 10))
    with pytest.raises(ValueError, match="width: must be odd"):
        ConvCouplingNet(2, 0, 4, width=2)
    with pytest.raises(ValueError, match="x: expected \\(batch, even time"):
        squeeze(torch.randn(1, 5, 2))


def nn_returning(channels):
    class Wrong(torch.nn.Module):
        def forward(self, lo, cond=None):
            return torch.zeros(lo.shape[:2] + (channels,))
    return Wrong()


class _CountingLSTMNet(torch.nn.Module):
    """A stateful coupling network in the style MoGlow needs: an LSTM over time whose state
    carries over from one call to the next."""

    def __init__(self, in_channels, cond_channels, out_channels):
        super().__init__()
        self.lstm = torch.nn.LSTM(in_channels + cond_channels, 8, batch_first=True)
        self.out = torch.nn.Linear(8, out_channels)
        torch.nn.init.zeros_(self.out.weight), torch.nn.init.zeros_(self.out.bias)
        self.state = None

    def forward(self, lo, cond=None):
        h, self.state = self.lstm(torch.cat([lo, cond], -1), self.state)
        return self.out(h)


def test_a_recurrent_network_generates_frame_by_frame_like_the_whole_sequence():
    """What MoGlow relies on: the network is called once per forward/inverse, so a stateful
    network run one frame at a time inverts a flow trained on whole sequences."""
    torch.manual_seed(0)
    flow = FlowSequence([FlowStep(6, _CountingLSTMNet, cond_channels=3) for _ in range(3)])
    x, cond = torch.randn(2, 10, 6), torch.randn(2, 10, 3)
    flow(x, cond)                                       # ActNorm initialisation
    _randomise(flow)
    nets = [m for m in flow.modules() if isinstance(m, _CountingLSTMNet)]
    for net in nets:
        net.state = None
    z, _ = flow(x, cond)
    for net in nets:
        net.state = None
    frames = [flow.inverse(z[:, t:t + 1], cond[:, t:t + 1]) for t in range(10)]
    assert (torch.cat(frames, 1) - x).abs().max() < 1e-4
