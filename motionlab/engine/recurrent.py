"""An LSTM written out, forwards and backwards, for training MoGlow on the CPU.

``nn.LSTM`` on the CPU runs oneDNN's LSTM kernels. MoGlow's coupling networks read a small
half-pose beside a large conditioning vector (30 or 31 values beside 643), and there
oneDNN's kernels do more than they need to:

* they compute the gradient of the *whole* input, although the conditioning comes from
  the data and needs none: 29 % of the arithmetic of the laptop model's one-layer,
  64-unit LSTMs, 10 % of the paper's two layers of 512;
* in bfloat16 they run at about half the rate of the machine's large bfloat16 products.

:func:`lstm` computes the same function as ``nn.LSTM``, from the module's own weights (so
checkpoints are unchanged), with the classic schedule: one large product for the input
part of every frame's gates, then a loop over time with only ``h_{t-1} W_hh^T`` and the
element-wise gates in it; backwards the same loop in reverse, then the weight gradients
as large products. Under ``torch.autocast("cpu", dtype=torch.bfloat16)`` the products run
in bfloat16 (their results rounded to it); the gates are summed and activated, and the cell
state kept, in float32. The equations (Hochreiter & Schmidhuber 1997, with the forget
gate; PyTorch's gate order ``i, f, g, o``)::

    [i, f, g, o] = x_t W_ih^T + b_ih + h_{t-1} W_hh^T + b_hh
    i, f, o = sigmoid(i, f, o);  g = tanh(g)
    c_t = f * c_{t-1} + i * g
    h_t = o * tanh(c_t)

starting from ``h_0 = c_0 = 0``. The loop costs a few dozen small operations per frame, so
it pays only where it saves enough (:func:`pays_off`): in a MoGlow training step it was
faster at the laptop size in float32 and bfloat16 and at the paper size in bfloat16, but
not at the paper size in float32, where oneDNN's kernel runs at the machine's float32
product rate, so there MoGlow keeps ``nn.LSTM``; LSTM-3LR (no inputs without a gradient)
was slower with it and keeps ``nn.LSTM`` too. ``benchmarks/moglow_speed.py`` measures both
paths on the machine at hand. On a GPU, cuDNN is used as before.

Every ``nn.LSTM`` of the library runs through :func:`run` (or :func:`from_zero_state`):
oneDNN has no bfloat16 or float16 LSTM on many CPUs (AVX2 laptops among them), and there
``nn.LSTM`` under autocast raises instead of computing; :func:`run` then uses PyTorch's
own LSTM cells (autocast still lowers their products; their outputs are float32).
"""
from __future__ import annotations

from contextlib import nullcontext

import torch
from torch import nn
from torch.autograd.function import once_differentiable

from .. import cpu


def can_use(module: nn.LSTM, inputs: torch.Tensor) -> bool:
    """Whether :func:`lstm` computes what ``module(inputs)`` does: a plain batch-first LSTM
    with biases (no dropout between layers, no projection, one direction) on the CPU."""
    return (inputs.device.type == "cpu" and module.batch_first and module.bias and not module.bidirectional
            and module.proj_size == 0 and (module.dropout == 0 or not module.training))


def product_dtype(inputs: torch.Tensor) -> torch.dtype:
    """The dtype the LSTM's products run in: CPU autocast's for float32 inputs (autocast
    leaves other dtypes alone), else the inputs'."""
    if torch.is_autocast_enabled("cpu") and inputs.dtype == torch.float32:
        return torch.get_autocast_dtype("cpu")
    return inputs.dtype


def pays_off(module: nn.LSTM, extra_width: int, dtype: torch.dtype) -> bool:
    """Whether :func:`lstm` was measured faster than ``nn.LSTM`` on the CPU for an LSTM
    whose last ``extra_width`` inputs need no gradient (MoGlow's couplings): in bfloat16
    when there are such inputs; in float32 when the input gradient it skips is at least a
    fifth of the LSTM's arithmetic (MoGlow laptop: 29 % of it, faster; paper: 10 %, not;
    ``benchmarks/moglow_speed.py`` measures it).
    Without such inputs (LSTM-3LR) it was slower. In float16, where oneDNN has no CPU LSTM
    kernel here (``nn.LSTM`` fails), it is the one that runs."""
    if dtype == torch.float16:
        return True
    if extra_width == 0:
        return False
    if dtype == torch.bfloat16:
        return True
    size, first = 4 * module.hidden_size, module.input_size + module.hidden_size
    products = 3 * size * (first + 2 * module.hidden_size * (module.num_layers - 1))   # per frame and row
    return size * extra_width >= products / 5


def run(module: nn.LSTM, inputs: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor] | None = None):
    """``module(inputs, state)``, on any CPU: where oneDNN cannot build the LSTM that
    autocast asks for (bfloat16 or float16 on a CPU without such kernels, see
    :func:`motionlab.cpu.onednn_lstm`), PyTorch's own LSTM cells run it instead (autocast
    still lowers their products; their outputs are float32). Returns what ``nn.LSTM``
    returns."""
    fallback = (inputs.device.type == "cpu" and torch.backends.mkldnn.enabled
                and not cpu.onednn_lstm(product_dtype(inputs)))
    with cpu.onednn_disabled() if fallback else nullcontext():
        return module(inputs, state)


def from_zero_state(module: nn.LSTM, inputs: torch.Tensor, extra: torch.Tensor | None = None) -> torch.Tensor:
    """``module``'s last-layer outputs ``(batch, frames, hidden)`` from a zero state over
    ``torch.cat([inputs, extra], -1)``: through :func:`lstm` where that is measured faster
    (:func:`can_use` and :func:`pays_off`; ``extra`` counts as needing no gradient unless it
    requires one), else through ``module`` itself (:func:`run`)."""
    needless = 0 if extra is None or extra.requires_grad else extra.shape[-1]
    if can_use(module, inputs) and pays_off(module, needless, product_dtype(inputs)):
        return lstm(module, inputs, extra)
    return run(module, inputs if extra is None else torch.cat([inputs, extra], dim=-1))[0]


def lstm(module: nn.LSTM, inputs: torch.Tensor, extra: torch.Tensor | None = None) -> torch.Tensor:
    """The last layer's ``h_t`` at every frame, ``(batch, frames, hidden)``, of ``module``
    run from a zero state over ``torch.cat([inputs, extra], -1)``.

    Args:
        module: a batch-first ``nn.LSTM`` (see :func:`can_use`); its weights are used as they
            are.
        inputs: ``(batch, frames, a)``.
        extra: ``(batch, frames, b)`` more input features, or ``None``. Kept apart so that
            its gradient is computed only if it requires one (MoGlow's conditioning does not).

    Float32 inputs under CPU autocast to bfloat16 give bfloat16, as ``nn.LSTM`` does;
    otherwise the inputs' dtype.
    """
    if not can_use(module, inputs):
        raise ValueError("lstm: expected a batch-first nn.LSTM with biases, one direction, no projection and no "
                         f"dropout, on the CPU; got {module} on {inputs.device}")
    width = inputs.shape[-1] + (0 if extra is None else extra.shape[-1])
    if inputs.ndim != 3 or (extra is not None and extra.shape[:2] != inputs.shape[:2]) or width != module.input_size:
        raise ValueError(f"lstm: expected inputs (batch, frames, a) and extra (batch, frames, b) with a + b = "
                         f"{module.input_size}, got {tuple(inputs.shape)} and "
                         f"{None if extra is None else tuple(extra.shape)}")
    dtype = product_dtype(inputs)
    hidden = inputs.transpose(0, 1)                             # time-major: every frame's rows together
    extra = None if extra is None else extra.transpose(0, 1)
    for layer in range(module.num_layers):
        weights = [getattr(module, f"{name}_l{layer}") for name in ("weight_ih", "weight_hh", "bias_ih", "bias_hh")]
        hidden = _LSTMLayer.apply(hidden, extra, *weights, dtype)
        extra = None
    return hidden.transpose(0, 1)


class _LSTMLayer(torch.autograd.Function):
    """One layer over time-major input ``(frames, batch, a)`` (+ ``(frames, batch, b)``).

    The ``g`` rows of the weights are doubled, so that one sigmoid over all four gates gives
    ``g = tanh(p) = 2 sigmoid(2p) - 1`` too (:func:`_tanh_`); the backward pass works with
    these doubled pre-activations and doubles the ``g`` rows of the weights' gradients.
    """

    @staticmethod
    def forward(ctx, inputs, extra, weight_ih, weight_hh, bias_ih, bias_hh, dtype):
        with torch.autocast("cpu", enabled=False):
            frames, batch, _ = inputs.shape
            size = weight_hh.shape[1]
            x = inputs.to(dtype).contiguous() if extra is None else torch.cat([inputs.to(dtype), extra.to(dtype)], 2)
            w_ih, w_hh, bias = (_double_g_rows(w, dtype, size) for w in (weight_ih, weight_hh, bias_ih + bias_hh))
            # the input part of every frame's gates in one large product
            projected = torch.addmm(bias, x.view(frames * batch, -1), w_ih.t())
            exact = _state_dtype(dtype)                             # float32 under autocast
            gates = projected.view(frames, batch, 4 * size).to(exact)  # activated in place
            cells = torch.empty(frames, batch, size, dtype=exact)
            tanh_cells = torch.empty_like(cells)
            outputs = torch.empty(frames, batch, size, dtype=dtype)
            w_hh_t = w_hh.t()
            steps = zip(gates.unbind(0), gates[..., :size].unbind(0), gates[..., size:2 * size].unbind(0),
                        gates[..., 2 * size:3 * size].unbind(0), gates[..., 3 * size:].unbind(0),
                        cells.unbind(0), tanh_cells.unbind(0), outputs.unbind(0))
            c_prev = h_prev = None                                   # h_0 = c_0 = 0
            for g, i, f, c_in, o, c, tanh_c, h in steps:
                if h_prev is not None:
                    if dtype == exact:
                        g.addmm_(h_prev, w_hh_t)
                    else:
                        g.add_(torch.mm(h_prev, w_hh_t))
                g.sigmoid_()                                         # i, f, o; and g from its doubled rows:
                c_in.mul_(2).sub_(1)                                 # g = 2 sigmoid(2p) - 1 = tanh(p)
                torch.mul(i, c_in, out=c)                            # c_t = f c_{t-1} + i g
                if c_prev is not None:
                    c.addcmul_(f, c_prev)
                _tanh_(tanh_c.copy_(c))
                torch.mul(o, tanh_c, out=h)                          # h_t = o tanh(c_t)
                c_prev, h_prev = c, h
        ctx.save_for_backward(x, w_ih, w_hh, gates, cells, tanh_cells, outputs)
        ctx.split = inputs.shape[2]
        ctx.dtypes = inputs.dtype, None if extra is None else extra.dtype
        ctx.weight_dtype = weight_ih.dtype
        return outputs

    @staticmethod
    @once_differentiable
    def backward(ctx, grad_outputs):
        with torch.autocast("cpu", enabled=False):               # the dtypes below are chosen by hand
            return _LSTMLayer._backward(ctx, grad_outputs)

    @staticmethod
    def _backward(ctx, grad_outputs):
        x, w_ih, w_hh, gates, cells, tanh_cells, outputs = ctx.saved_tensors
        frames, batch, size = cells.shape
        dtype, exact = w_ih.dtype, cells.dtype
        # d loss / d (doubled) gate pre-activations, every frame
        grad_gates = torch.empty(frames, batch, 4 * size, dtype=dtype)
        d = None if dtype == exact else torch.empty(batch, 4 * size, dtype=exact)   # scratch in the exact dtype
        slope = torch.empty(batch, 4 * size, dtype=exact)       # each gate's derivative by its pre-activation
        slope_g = slope[:, 2 * size:3 * size]
        factor = torch.empty(batch, size, dtype=exact)
        grad_h = torch.zeros(batch, size, dtype=exact)          # d loss / d h_t
        grad_c = torch.zeros(batch, size, dtype=exact)          # d loss / d c_t
        grad_bias = torch.zeros(batch, 4 * size, dtype=exact)
        steps = zip(range(frames - 1, -1, -1), reversed(gates.unbind(0)), reversed(tanh_cells.unbind(0)),
                    reversed(grad_outputs.unbind(0)), reversed(grad_gates.unbind(0)))
        for t, g, tanh_c, grad_out, grad_g in steps:
            i, f, c_in, o = g.split(size, 1)
            d_t = grad_g if d is None else d                    # written straight into grad_gates in float32
            d_i, d_f, d_g, d_o = d_t.split(size, 1)
            grad_h.add_(grad_out)
            # sigmoid' = s (1 - s) for i, f, o; for the doubled g rows (1 - g^2) / 2
            torch.mul(g, g, out=slope).neg_().add_(g)
            slope_g.add_(1).sub_(c_in).mul_(0.5)
            torch.mul(tanh_c, tanh_c, out=factor).neg_().add_(1).mul_(o)
            grad_c.addcmul_(grad_h, factor)                     # through h_t = o tanh(c_t)
            torch.mul(grad_c, c_in, out=d_i)
            if t:
                torch.mul(grad_c, cells[t - 1], out=d_f)
            else:
                d_f.zero_()
            torch.mul(grad_c, i, out=d_g)
            torch.mul(grad_h, tanh_c, out=d_o)
            d_t.mul_(slope)
            grad_bias.add_(d_t)
            grad_c.mul_(f)                                      # on to c_{t-1}
            if d is not None:
                grad_g.copy_(d)
            if t:
                grad_h = torch.mm(grad_g, w_hh).to(exact)
        flat = grad_gates.view(frames * batch, 4 * size)
        grad_w_hh = torch.mm(flat[batch:].t(), outputs[:-1].reshape((frames - 1) * batch, size))
        grad_w_ih = torch.mm(flat.t(), x.view(frames * batch, -1))
        grad_inputs = grad_extra = None
        split = ctx.split
        if ctx.needs_input_grad[0]:
            grad_inputs = torch.mm(flat, w_ih[:, :split]).view(frames, batch, split).to(ctx.dtypes[0])
        if ctx.needs_input_grad[1]:
            grad_extra = torch.mm(flat, w_ih[:, split:]).view(frames, batch, -1).to(ctx.dtypes[1])
        grad_bias, grad_w_ih, grad_w_hh = (_double_g_rows(grad, ctx.weight_dtype, size, copy=False)
                                           for grad in (grad_bias.sum(0), grad_w_ih, grad_w_hh))
        return grad_inputs, grad_extra, grad_w_ih, grad_w_hh, grad_bias, grad_bias, None


def _state_dtype(dtype: torch.dtype) -> torch.dtype:
    """The dtype of the gates and the cell state: float32 when the products run in a 16-bit
    format, else the products' own (float64 in the gradient tests)."""
    return torch.float32 if dtype in (torch.bfloat16, torch.float16) else dtype


def _double_g_rows(weight: torch.Tensor, dtype: torch.dtype, size: int, copy: bool = True) -> torch.Tensor:
    """``weight`` (``(4 size, ...)`` or ``(4 size,)``, gate order ``i, f, g, o``) in ``dtype``
    with its ``g`` rows doubled (exact in any binary float format); a new tensor when
    ``copy``, else in place where the dtype already matches."""
    out = weight.to(dtype, copy=copy)
    out[2 * size:3 * size].mul_(2)
    return out


def _tanh_(x: torch.Tensor) -> torch.Tensor:
    """``tanh`` in place as ``2 sigmoid(2x) - 1``: the same values to within about 1e-7
    (absolute) in a quarter of the time of ``torch.tanh`` on the CPU we measured, whose
    sigmoid kernel is far faster than its tanh."""
    return x.mul_(2).sigmoid_().mul_(2).sub_(1)
