"""Mixed-precision training (TrainConfig.precision, --precision): the coupling networks may
compute in bfloat16, but a flow's transform, log-determinants and likelihood stay float32,
and a short bf16 run follows the float32 one."""
import numpy as np
import pytest
import torch

from motionlab import cpu, training
from motionlab.models.conv_ae import ConvAEConfig, ConvAutoencoder
from motionlab.models.glow import Glow, GlowConfig
from motionlab.models.moglow import MoGlow, MoGlowConfig

GLOW = GlowConfig(window=16, levels=2, steps=2, hidden=16)
MOGLOW = MoGlowConfig(window=16, history=4, steps=2, hidden=16, dropout=0.0)
bf16_cpu = pytest.mark.skipif(not torch.backends.mkldnn.is_available(), reason="no oneDNN: CPU bfloat16 autocast")


def windows(n, frames, seed=0):
    """Random normalised windows, with the hips' root-local x and z at 0 as in real data."""
    x = torch.randn(n, frames, 66, generator=torch.Generator().manual_seed(seed))
    x[..., [0, 2]] = 0.0
    return x


@bf16_cpu
@pytest.mark.parametrize("make", [lambda: Glow(GLOW), lambda: MoGlow(MOGLOW)], ids=["glow", "moglow"])
def test_a_flow_under_bf16_autocast_keeps_its_likelihood_in_float32(make):
    torch.manual_seed(0)
    model = make()
    batch = windows(8, 16)
    model.loss(batch)                                   # ActNorm's data-dependent initialisation
    with torch.no_grad():
        exact = model.loss(batch)["loss"]
        with torch.autocast("cpu", dtype=torch.bfloat16):
            mixed = model.loss(batch)["loss"]
    assert mixed.dtype == torch.float32
    # the networks' bf16 rounding (3 significant digits) moves the NLL a little, not its scale
    assert abs(float(mixed) - float(exact)) < 0.02 * abs(float(exact)) + 0.02


@pytest.mark.skipif(not cpu.onednn_lstm(torch.bfloat16), reason=f"oneDNN builds no bfloat16 LSTM here ({cpu.summary()})")
def test_onednns_lstm_computes_in_bfloat16_under_autocast():
    # where oneDNN has a bfloat16 LSTM (AVX-512 and newer), nn.LSTM itself runs in bfloat16
    from motionlab.models.moglow import LSTMCouplingNet
    network = LSTMCouplingNet(3, 5, 6, hidden=8)
    lo, cond = torch.randn(2, 7, 3), torch.randn(2, 7, 5)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        hidden, _ = network.lstm(torch.cat([lo, cond], -1))
    assert hidden.dtype == torch.bfloat16
    exact, _ = network.lstm(torch.cat([lo, cond], -1))
    torch.testing.assert_close(hidden.float(), exact, atol=0.02, rtol=0.02)      # bfloat16: ~3 digits


@bf16_cpu
def test_moglow_coupling_lstm_computes_in_bfloat16_under_autocast():
    # the LSTM is most of MoGlow's arithmetic: under autocast it runs in bfloat16 on any CPU
    # (the written-out LSTM of motionlab.engine.recurrent, whatever oneDNN can build)
    from motionlab.engine import recurrent
    from motionlab.models.moglow import LSTMCouplingNet
    network = LSTMCouplingNet(3, 5, 6, hidden=8)
    lo, cond = torch.randn(2, 7, 3), torch.randn(2, 7, 5)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        hidden = recurrent.from_zero_state(network.lstm, lo, cond)
        assert hidden.dtype == torch.bfloat16
        assert network(lo, cond).shape == (2, 7, 6)
    exact, _ = network.lstm(torch.cat([lo, cond], -1))
    assert exact.dtype == torch.float32
    torch.testing.assert_close(hidden.float(), exact, atol=0.02, rtol=0.02)      # bfloat16: ~3 digits


@bf16_cpu
def test_the_invertible_1x1_and_the_couplings_compute_in_float32_under_autocast():
    from motionlab.models import flows
    x = windows(4, 8)[..., :6]
    mixing = flows.InvertibleLinear(6)
    coupling = flows.AffineCoupling(6, lambda i, c, o: flows.MLPCouplingNet(i, c, o, hidden=8))
    with torch.autocast("cpu", dtype=torch.bfloat16):
        z, logdet = mixing(x)
        z2, logdet2 = coupling(z)
    assert z.dtype == logdet.dtype == z2.dtype == logdet2.dtype == torch.float32
    torch.testing.assert_close(z, x @ mixing.weight().T)             # the mixing is exact to float32


@bf16_cpu
@pytest.mark.parametrize("kind", ["conv", "mlp", "lstm"])
def test_coupling_networks_compute_their_output_layer_in_float32_under_autocast(kind):
    # the output layer gives the shift and the raw scale, and the coupling's log-determinant
    # is a function of the raw scale (eq. 9): only the hidden layers compute in bfloat16
    from motionlab.models import flows
    from motionlab.models.moglow import LSTMCouplingNet
    make = {"conv": flows.ConvCouplingNet, "mlp": flows.MLPCouplingNet, "lstm": LSTMCouplingNet}[kind]
    torch.manual_seed(0)
    network = make(3, 5, 6, hidden=8)
    last = network.output if kind == "lstm" else network.layers[-1]
    with torch.no_grad():
        last.weight.normal_(0, 1.0)
    hiddens = []
    last.register_forward_hook(lambda module, inputs, output: hiddens.append(inputs[0]))
    lo, cond = torch.randn(2, 7, 3), torch.randn(2, 7, 5)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = network(lo, cond)
    assert out.dtype == torch.float32
    hidden = hiddens[0]
    assert hidden.dtype == torch.float32                                  # the bf16 activations, widened
    assert torch.equal(hidden, hidden.to(torch.bfloat16).float())         # ... from bfloat16
    exact = last(hidden).transpose(1, 2) if kind == "conv" else last(hidden)
    torch.testing.assert_close(out, exact, atol=0, rtol=0)


@bf16_cpu
@pytest.mark.parametrize("make, frames", [(lambda: ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=3)), 16),
                                          (lambda: MoGlow(MOGLOW), 16)], ids=["conv_ae", "moglow"])
def test_a_short_bf16_run_follows_the_float32_run(make, frames):
    data = windows(64, frames)
    losses = {}
    for precision in ("fp32", "bf16"):
        torch.manual_seed(0)
        history = training.train(make(), data, training.TrainConfig(epochs=3, batch_size=16, lr=3e-3,
                                                                     progress=False, precision=precision))
        losses[precision] = history.series("loss")[1]
    assert np.isfinite(losses["bf16"]).all()
    assert losses["bf16"][-1] < losses["bf16"][0]                             # it trains
    # after 12 steps the two runs differ by the bf16 rounding, within 5 % of the loss's scale
    scale = np.abs(losses["fp32"]).max()
    assert np.abs(losses["bf16"] - losses["fp32"]).max() < 0.05 * scale


def test_fp16_with_a_gradient_scaler_and_bad_values(tmp_path):
    model = ConvAutoencoder(ConvAEConfig(window=16, filters=8, width=3))
    state = tmp_path / "run.state"
    history = training.train(model, windows(32, 16), training.TrainConfig(epochs=1, batch_size=8, progress=False,
                                                                           precision="fp16"), state_file=state)
    assert np.isfinite(history.series("loss")[1]).all()
    assert torch.load(state, weights_only=True)["scaler"]["scale"] > 0      # the scaler travels with the state
    with pytest.raises(ValueError, match="precision: expected one of fp32, bf16, fp16"):
        training.TrainConfig(precision="int8")


def test_the_command_line_takes_a_precision():
    from motionlab import train as cli
    args = cli.build_parser().parse_args(["conv_ae", "--precision", "bf16"])
    assert cli.training_plan(args).train_config(100).precision == "bf16"
