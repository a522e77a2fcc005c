"""motionlab.engine.recurrent.lstm: the written-out LSTM computes what nn.LSTM does."""
import pytest
import torch
from torch import nn

from motionlab import cpu, training
from motionlab.models.moglow import LSTMCouplingNet, MoGlow, MoGlowConfig
from motionlab.engine.recurrent import can_use, lstm, pays_off, run

onednn_bf16_lstm = pytest.mark.skipif(not cpu.onednn_lstm(torch.bfloat16),
                                      reason=f"oneDNN builds no bfloat16 LSTM here ({cpu.summary()})")


def _pair(inputs=5, extra=7, hidden=6, layers=2, batch=3, frames=4, dtype=torch.float32, seed=0):
    torch.manual_seed(seed)
    module = nn.LSTM(inputs + extra, hidden, layers, batch_first=True).to(dtype)
    a = torch.randn(batch, frames, inputs, dtype=dtype, requires_grad=True)
    b = torch.randn(batch, frames, extra, dtype=dtype)
    return module, a, b


def _grads(module, a, b, out):
    # the same random weighting of the outputs whatever their dtype (bfloat16 outputs are
    # compared with float32 ones)
    dtype = torch.float64 if out.dtype == torch.float64 else torch.float32
    weights = torch.randn(out.shape, generator=torch.Generator().manual_seed(1), dtype=dtype)
    (out.to(dtype) * weights).sum().backward()
    grads = {name: p.grad.clone() for name, p in module.named_parameters()}
    grads["inputs"] = a.grad.clone()
    if b.requires_grad:
        grads["extra"] = b.grad.clone()
    module.zero_grad(set_to_none=True)
    a.grad = b.grad = None
    return grads


@pytest.mark.parametrize("layers", [1, 2])
@pytest.mark.parametrize("extra_grad", [False, True])
@pytest.mark.parametrize("frames", [4, 19])           # 19: a longer sequence
def test_matches_nn_lstm_in_float64(layers, extra_grad, frames):
    module, a, b = _pair(layers=layers, frames=frames, dtype=torch.float64)
    b.requires_grad_(extra_grad)
    expected_out = module(torch.cat([a, b], -1))[0]
    expected = _grads(module, a, b, expected_out)
    out = lstm(module, a, b)
    got = _grads(module, a, b, out)
    assert out.shape == expected_out.shape and out.dtype == torch.float64
    torch.testing.assert_close(out, expected_out, rtol=1e-10, atol=1e-12)
    assert got.keys() == expected.keys()
    for name in expected:
        torch.testing.assert_close(got[name], expected[name], rtol=1e-9, atol=1e-11, msg=name)


def test_gradcheck():
    """Finite differences in float64 of the outputs by the inputs, the extra and every weight."""
    module, a, b = _pair(inputs=2, extra=3, hidden=3, layers=2, batch=2, frames=3, dtype=torch.float64)
    b.requires_grad_(True)
    names = [name for name, _ in module.named_parameters()]
    params = [p.detach().clone().requires_grad_(True) for p in module.parameters()]
    assert torch.autograd.gradcheck(lambda a, b, *params: _functional_lstm(module, names, params, a, b),
                                    (a, b, *params), eps=1e-6, atol=1e-6)


def _functional_lstm(module, names, params, a, b):
    """``lstm`` with the module's weights replaced by ``params`` (so gradcheck can vary them)."""
    copy = nn.LSTM(module.input_size, module.hidden_size, module.num_layers, batch_first=True).double()
    for name, value in zip(names, params):
        delattr(copy, name)
        setattr(copy, name, value)
    return lstm(copy, a, b)


def test_without_an_extra():
    module, a, _ = _pair(inputs=12, extra=0, dtype=torch.float64)
    expected_out = module(a)[0]
    expected = _grads(module, a, torch.zeros(0), expected_out)
    got = _grads(module, a, torch.zeros(0), lstm(module, a))
    for name in expected:
        torch.testing.assert_close(got[name], expected[name], msg=name)


def test_no_gradient_for_an_extra_that_needs_none():
    module, a, b = _pair()
    lstm(module, a, b).sum().backward()
    assert a.grad is not None and b.grad is None


@pytest.mark.parametrize("frames", [1, 2])
def test_short_sequences(frames):
    module, a, b = _pair(frames=frames, dtype=torch.float64)
    torch.testing.assert_close(lstm(module, a, b), module(torch.cat([a, b], -1))[0])


@onednn_bf16_lstm
def test_bfloat16_autocast_follows_float32():
    """Under CPU autocast the products run in bfloat16 (8 significant bits) and the gates
    and cell state in float32: the outputs and gradients stay within the error oneDNN's own
    bfloat16 LSTM makes on the same module, plus a margin of the same size."""
    module, a, b = _pair(inputs=31, extra=200, hidden=64, layers=2, batch=8, frames=30)
    exact_out = module(torch.cat([a, b], -1))[0]
    exact = _grads(module, a, b, exact_out)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        ours_out = lstm(module, a, b)
        theirs_out = module(torch.cat([a, b], -1))[0]
    assert ours_out.dtype == theirs_out.dtype == torch.bfloat16
    ours, theirs = _grads(module, a, b, ours_out), _grads(module, a, b, theirs_out)
    ours_error = (ours_out.float() - exact_out).abs().max()
    theirs_error = (theirs_out.float() - exact_out).abs().max()
    assert ours_error <= 2 * theirs_error + 1e-3, (ours_error, theirs_error)
    for name in exact:
        scale = exact[name].abs().max()
        ours_error = (ours[name] - exact[name]).abs().max() / scale
        theirs_error = (theirs[name] - exact[name]).abs().max() / scale
        assert ours_error <= 2 * theirs_error + 0.01, (name, ours_error, theirs_error)


def test_bfloat16_autocast_follows_float32_on_any_cpu():
    """Where oneDNN has no bfloat16 LSTM to compare with (AVX2), the bound is bfloat16's own:
    the products' operands are rounded to 8 significant bits (relative error <= 2^-9), so
    outputs (in (-1, 1)) and gradients stay within a few roundings' worth of float32."""
    module, a, b = _pair(inputs=31, extra=200, hidden=64, layers=2, batch=8, frames=30)
    exact_out = module(torch.cat([a, b], -1))[0]
    exact = _grads(module, a, b, exact_out)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        ours_out = lstm(module, a, b)
    assert ours_out.dtype == torch.bfloat16
    ours = _grads(module, a, b, ours_out)
    assert (ours_out.float() - exact_out).abs().max() < 16 * 2 ** -9
    for name in exact:
        error = (ours[name] - exact[name]).abs().max() / exact[name].abs().max()
        assert error < 16 * 2 ** -9, (name, error)


@pytest.mark.parametrize("dtype", [torch.bfloat16, torch.float16])
def test_run_falls_back_to_pytorchs_own_lstm_where_onednn_has_none(monkeypatch, dtype):
    # as on an AVX2 laptop, whatever this CPU is: oneDNN is switched off around nn.LSTM, and
    # PyTorch's own LSTM cells run it (their products lowered by autocast, outputs float32)
    monkeypatch.setattr(cpu, "onednn_lstm", lambda d: d == torch.float32)
    module, a, b = _pair()
    onednn_during = []
    module.register_forward_pre_hook(lambda *_: onednn_during.append(torch.backends.mkldnn.enabled))
    x = torch.cat([a, b], -1)
    with torch.autocast("cpu", dtype=dtype):
        out, (h, c) = run(module, x)
    assert onednn_during == [not torch.backends.mkldnn.is_available() and torch.backends.mkldnn.enabled]
    assert torch.backends.mkldnn.enabled                          # restored
    assert out.dtype == torch.float32
    bits = 8 if dtype == torch.bfloat16 else 11                  # significant bits of the products
    torch.testing.assert_close(out, module(x)[0], rtol=0, atol=16 * 2.0 ** -(bits + 1))
    out.sum().backward()
    assert a.grad is not None and torch.isfinite(a.grad).all()


@pytest.mark.parametrize("precision", ["bf16", "fp16"])
@pytest.mark.parametrize("make", ["lstm_3lr", "moglow_nn_lstm", "moglow_carrying"])
def test_every_library_lstm_runs_under_autocast_on_this_cpu(make, precision):
    """The library never hands oneDNN an LSTM it cannot build: LSTM-3LR, MoGlow's couplings
    through nn.LSTM, and MoGlow's carried state while sampling, under both autocasts."""
    from motionlab.models.lstm import LSTMConfig, MotionLSTM
    low = training.PRECISIONS[precision]
    torch.manual_seed(0)
    if make == "lstm_3lr":
        model = MotionLSTM(LSTMConfig(window=12, hidden=8, layers=2))
        x = torch.randn(4, 12, 66)
        with torch.autocast("cpu", dtype=low):
            loss = model.loss(x)["loss"]
        loss.backward()
        assert torch.isfinite(loss)
        return
    model = MoGlow(MoGlowConfig(window=12, history=3, steps=2, hidden=8, dropout=0.0))
    x = torch.randn(4, 12, 66)
    x[..., [0, 2]] = 0.0
    model.loss(x)                                                  # ActNorm's initialisation
    networks = [m for m in model.modules() if isinstance(m, LSTMCouplingNet)]
    if make == "moglow_nn_lstm":
        for network in networks:
            network.written_out = False
        with torch.autocast("cpu", dtype=low):
            loss = model.loss(x)["loss"]
        loss.backward()
        assert torch.isfinite(loss)
    else:
        with torch.no_grad(), torch.autocast("cpu", dtype=low):
            poses = model.sample(x[:, 3:, -3:], x[:, :3], temperature=0.5)
        assert torch.isfinite(poses).all()


def test_retain_graph_gives_the_same_gradients_twice():
    module, a, b = _pair()
    out = lstm(module, a, b).sum()
    out.backward(retain_graph=True)
    first = a.grad.clone()
    a.grad = None
    out.backward()
    torch.testing.assert_close(a.grad, first)


def test_refuses_what_it_does_not_compute():
    module, a, b = _pair()
    with pytest.raises(ValueError, match="a \\+ b = 12"):
        lstm(module, a, b[..., :3])
    with pytest.raises(ValueError, match="batch-first"):
        lstm(nn.LSTM(12, 6, batch_first=False), a, b)
    with pytest.raises(ValueError, match="one direction"):
        lstm(nn.LSTM(12, 6, batch_first=True, bidirectional=True), a, b)
    dropout = nn.LSTM(12, 6, 2, batch_first=True, dropout=0.5)
    assert not can_use(dropout, a) and can_use(dropout.eval(), a)


def test_moglow_training_step_is_the_same_with_either_lstm():
    """The coupling networks train through ``lstm``; switching it off (nn.LSTM) gives the
    same loss and gradients to float32 rounding."""
    config = MoGlowConfig(steps=2, hidden=16, lstm_layers=2, window=20)
    torch.manual_seed(0)
    model = MoGlow(config)
    x = torch.randn(4, 20, 66)
    x[..., [0, 2]] = 0.0
    model.loss(x)                                          # ActNorm's initialisation
    results = []
    for written_out in (True, False):
        for module in model.modules():
            if isinstance(module, LSTMCouplingNet):
                module.written_out = written_out
        torch.manual_seed(1)                               # the same history dropout
        loss = model.loss(x)["loss"]
        model.zero_grad(set_to_none=True)
        loss.backward()
        results.append((loss.detach(), [p.grad.clone() for p in model.parameters()]))
    (loss_a, grads_a), (loss_b, grads_b) = results
    torch.testing.assert_close(loss_a, loss_b, rtol=1e-5, atol=1e-6)
    for a, b in zip(grads_a, grads_b):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6)


def test_moglow_bf16_training_uses_it():
    """Under the bf16 precision of training, MoGlow's coupling LSTMs compute in bfloat16
    through ``lstm`` (not ``nn.LSTM``); the network's output layer then computes in float32."""
    config = MoGlowConfig(steps=1, hidden=8)
    model = MoGlow(config)
    net = next(m for m in model.modules() if isinstance(m, LSTMCouplingNet))
    seen, hidden = [], []
    net.lstm.register_forward_hook(lambda *args: seen.append("nn.LSTM"))
    net.output.register_forward_pre_hook(lambda module, inputs: hidden.append(inputs[0]))
    lo, cond = torch.randn(2, 5, 30), torch.randn(2, 5, net.lstm.input_size - 30)
    with torch.autocast("cpu", dtype=training.PRECISIONS["bf16"]):
        out = net(lo, cond)
    assert seen == [] and out.dtype == torch.float32
    assert torch.equal(hidden[0], hidden[0].to(torch.bfloat16).float())      # the LSTM's output was bfloat16


def test_pays_off_where_measured():
    """The laptop MoGlow's coupling LSTM (64 units beside 673 inputs, 643 of them the
    conditioning) in both precisions; the paper's (2 x 512) only in bfloat16."""
    laptop, paper = nn.LSTM(673, 64, 1, batch_first=True), nn.LSTM(673, 512, 2, batch_first=True)
    assert pays_off(laptop, 643, torch.float32) and pays_off(laptop, 643, torch.bfloat16)
    assert not pays_off(paper, 643, torch.float32) and pays_off(paper, 643, torch.bfloat16)
    three_layers = nn.LSTM(66, 128, 3, batch_first=True)           # LSTM-3LR: measured 2x slower with it
    assert not pays_off(three_layers, 0, torch.float32) and not pays_off(three_layers, 0, torch.bfloat16)


def test_float64_stays_float64_under_autocast():
    """Autocast leaves float64 alone, and so does ``lstm``, as ``nn.LSTM`` does."""
    module, a, b = _pair(dtype=torch.float64)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = lstm(module, a, b)
        expected = module(torch.cat([a, b], -1))[0]
    assert out.dtype == expected.dtype == torch.float64
    torch.testing.assert_close(out, expected)


def test_backward_ignores_an_autocast_around_it():
    module, a, b = _pair(dtype=torch.float32)
    out = lstm(module, a, b)
    (plain,) = torch.autograd.grad(out.sum(), a, retain_graph=True)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        (inside,) = torch.autograd.grad(out.sum(), a)
    torch.testing.assert_close(inside, plain)


def test_no_second_derivative():
    module, a, b = _pair(dtype=torch.float64)
    (grad,) = torch.autograd.grad(lstm(module, a, b).sum(), a, create_graph=True)
    with pytest.raises(RuntimeError, match="once_differentiable|does not require grad|twice"):
        torch.autograd.grad(grad.sum(), a)


def test_a_conditioning_that_needs_a_gradient_gets_it():
    net = LSTMCouplingNet(5, 40, 4, hidden=4)
    nn.init.normal_(net.output.weight)
    lo, cond = torch.randn(2, 3, 5, requires_grad=True), torch.randn(2, 3, 40, requires_grad=True)
    net(lo, cond).sum().backward()
    assert cond.grad is not None and cond.grad.abs().sum() > 0
