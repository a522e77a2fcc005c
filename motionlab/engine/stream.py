"""MoGlow's real-time sampler: the engine that runs a trained :class:`~motionlab.models.moglow.MoGlow`
one frame at a time (§4.2, Fig. 3), with every weight laid out once for this machine's
fastest product kernel. The model itself, as the paper writes it, is
:mod:`motionlab.models.moglow`; this file holds no equation that is not there.
"""
from __future__ import annotations

import math
from contextlib import nullcontext
from dataclasses import dataclass
from functools import partial

import numpy as np
import torch

from .. import cpu
from ..models.contact_head import labels_of
from ..models.flows import _LOG_SIGMOID_SHIFT, SCALE_SHIFT

@dataclass(eq=False)
class _StreamCoupling:
    """One coupling as :class:`MoGlowStream` runs it: its weights, laid out for the stream's
    product kernel, and the buffers each frame overwrites in place (``B`` streams, ``L``
    LSTM layers of ``H`` units, ``D = n_lo + n_hi`` modelled values).

    The LSTM's input and hidden states share one ``(B, n_lo + L·H)`` buffer
    ``[b_lo, h_1, ..., h_L]`` in the weights' dtype: ``lo`` is this frame's ``b_lo``,
    ``layer_inputs[l]`` the slice layer ``l`` multiplies (``[b_lo, h_1]`` for the first,
    ``[h_{l-1}, h_l]`` after it), and ``hidden[l]`` where it writes its new ``h_l``.
    """

    lo: torch.Tensor                     # (B, n_lo), a view of the buffer
    layer_inputs: list[torch.Tensor]     # per layer, a view of the buffer
    hidden: list[torch.Tensor]           # per layer, (B, H), a view of the buffer
    cells: list[torch.Tensor]            # per layer, c_l, (B, H) float32
    operands: list[torch.Tensor]         # per layer, [W_ih W_hh] as (in, 4H); the first's without the conditioning
    biases: list[torch.Tensor | None]    # per layer, (4H,) float32; the first's is in cond_gates
    cond_gates: torch.Tensor             # (B, 4H) float32: the conditioning's part of the first layer's gates
    output: torch.Tensor                 # (H, 2 n_hi): the output layer, giving [t' / σ(2), -h_s' - 2]
    output_bias: torch.Tensor            # (2 n_hi,)
    output_out: torch.Tensor             # (B, 2 n_hi) float32: the output layer's result, [shift, exponent]
    shift: torch.Tensor                  # (B, n_hi), a view of output_out: t' / σ(2)
    exponent: torch.Tensor               # (B, n_hi), a view of output_out: -h_s' - 2 (exp'd in place)
    unmix: torch.Tensor                  # (D, D): W^-1 and ActNorm^-1 as one affine map, σ(2) in the hi rows
    unmix_bias: torch.Tensor             # (D,)


class MoGlowStream:
    """Real-time MoGlow: feed one control frame, get one pose back (§4.2, Fig. 3).

    Holds the last ``τ`` poses and controls and every coupling's LSTM state, and runs the
    flow backwards (coupling inverse -> ``W^-1`` -> ActNorm inverse, step ``K`` to 1) in
    inference mode, one frame per :meth:`step`. Several streams (characters) run at once as
    a batch.

    Generating one frame reads every weight once, so one stream is limited by how fast its
    products read the weights, and then by the hundreds of small operations beside them.
    So at creation the stream precomputes, once, what does not change from frame to frame,
    and keeps the couplings' work in buffers made once, which every frame overwrites in
    place (:class:`_StreamCoupling`):

    * each step's ``W^-1`` joined with its ActNorm inverse into one affine map (matrix
      products, not triangular solves);
    * the first LSTM layer's weights on the conditioning, of all ``K`` couplings, stacked
      into one matrix: the conditioning is the same for every coupling, so one product per
      frame gives that part of every coupling's gates (one product per coupling for several
      streams on a CPU, measured faster there);
    * each layer's remaining weights joined, ``[W_ih W_hh]`` on ``[input, h_{t-1}]``, and
      every coupling's input and hidden states kept side by side in one buffer
      ``[b_lo, h_1, h_2, ...]``, so each layer is one product on a slice of it, and writes
      its new ``h`` into it in place (``nn.LSTM``, called one frame at a time, would repack
      its weights on every call);
    * the output layer's rows rearranged so that the coupling's inverse scale
      ``1 / s' = σ(2) (1 + exp(-h_s' - 2))`` (:data:`~motionlab.models.flows.SCALE_SHIFT`)
      is one exponential, with ``σ(2)`` moved into the next affine map;
    * the weights laid out for the fastest product kernel of this CPU (``_kernel``).

    ``weights=torch.bfloat16`` halves the bytes read per frame: the LSTM products run in
    bfloat16 (the conditioning's part and the rest of each first layer's gates are each
    rounded to bfloat16 before they are added in float32), everything else in float32;
    frames then differ from the float32 ones by about 1e-3 to 1e-2 in normalised units.

    A ``foot_anchor`` model's stream adds each frame's ``m`` (:meth:`MoGlow.anchor`, from
    the frame before and its control) to the flow's output, as :meth:`MoGlow.sample` does;
    a ``bone_coordinates`` model's places its upper body from its bones (:meth:`MoGlow.restore`);
    a ``contact_head`` model's draws each frame's contacts first (:meth:`MoGlow.draw_contacts`)
    and keeps the last frame's as ``stream.contacts`` (for a foot lock, ``FootLock.step``).

    >>> stream = model.stream(history)            # (batch, τ, 66) normalised features
    >>> frame = stream.step(control)              # (batch, 3) -> (batch, 66)

    Args:
        model: a trained :class:`MoGlow` with recurrent couplings.
        history: the ``τ`` frames to start from ``(batch, τ, n_features)`` (normalised, or
            in the data's units when ``normalizer`` is given).
        temperature: the prior's standard deviation.
        generator: a ``torch.Generator`` for the noise.
        normalizer: a :class:`motionlab.data.Normalizer`: take and return features in the
            data's units (metres, m/s, rad/s) instead of normalised ones.
        weights: dtype of the LSTM weights during streaming (``torch.float32`` or
            ``torch.bfloat16``).
    """

    def __init__(self, model, history, temperature: float = 1.0,
                 generator: torch.Generator | None = None, normalizer=None, weights: torch.dtype = torch.float32):
        if weights not in (torch.float32, torch.bfloat16):
            raise ValueError(f"weights: expected torch.float32 or torch.bfloat16, got {weights}")
        self.weights = weights
        if not model.config.recurrent:
            raise ValueError("model: the stream needs recurrent (LSTM) couplings; use MoGlow.sample for a Markov model")
        self.model, self.normalizer, self.generator = model, normalizer, generator
        self.temperature = float(temperature)
        if not (math.isfinite(self.temperature) and self.temperature >= 0):
            raise ValueError(f"temperature: expected a finite number >= 0, got {temperature}")
        device = model.modelled.device
        history = model.check_history(history)
        if normalizer is not None:
            self._mean = torch.as_tensor(np.asarray(normalizer.mean), dtype=torch.float32, device=device)
            self._std = torch.as_tensor(np.asarray(normalizer.std), dtype=torch.float32, device=device)
            history = (history - self._mean) / self._std
            history[..., model.constant] = 0.0
        model.check_features(history, "history", min_frames=model.config.history)
        self.batch = history.shape[0]
        self.poses = history[..., model.modelled].clone()               # (batch, τ, n_modelled)
        self.controls = history[..., model.control].clone()             # (batch, τ, n_control)
        self.frames = 0
        self._history_scale = model.history_scale                        # fixed for the stream's life
        self._anchor_units = model.anchor_units() if model.config.foot_anchor else None
        self._contacts = model.contact_head.start(self.batch, device) if model.contact_head is not None else None
        self.contacts = None        # with a contact head: the last frame's drawn contacts (batch, 4), FEET order
        # How one frame's LSTM products run on a CPU (measured over paper-size layers, see
        # benchmarks/moglow_speed.py). One stream only reads weights, and the kernels differ:
        # * bfloat16, native arithmetic (AVX512-BF16, AMX) for both kernel families
        #   (motionlab.cpu: oneDNN's instruction set and ATen's, each capped by its variable):
        #   PyTorch's own matrix product, not oneDNN's, reads them at about the memory
        #   bandwidth (~22-32 against ~14-17 GB/s);
        # * bfloat16, emulated (AVX2 laptops, or capped): the matrix-vector kernel reads them
        #   faster than a product;
        # * float32: oneDNN's product of the row with the weights stored transposed,
        #   ``(in, 4H)``, reads them faster (~17-21 GB/s) than against ``(4H, in)`` (~14).
        # Several streams are arithmetic: oneDNN's product against ``(4H, in)``.
        one_cpu_stream = self.batch == 1 and device.type == "cpu"
        self._kernel = "product"
        if one_cpu_stream and weights == torch.bfloat16:
            native = cpu.native_bfloat16() and cpu.aten_capability().startswith("AVX512")
            self._kernel = "own product" if native else "matrix-vector"
        elif one_cpu_stream:
            self._kernel = "transposed"
        with torch.inference_mode():
            self._precompute(device)

    def _operand(self, weight: torch.Tensor) -> torch.Tensor:
        """``weight`` ``(out, in)`` as the right-hand operand ``(in, out)`` of this stream's
        products: stored transposed for the ``"transposed"`` kernel, else a view of the
        ``(out, in)`` matrix."""
        weight = weight.to(self.weights)
        return weight.T.contiguous() if self._kernel == "transposed" else weight.contiguous().T

    def _multiply(self, inputs: torch.Tensor, operand: torch.Tensor, out: torch.Tensor) -> None:
        """``out = inputs @ operand`` with this stream's kernel, written into ``out``."""
        if self._kernel == "matrix-vector":                     # one stream: its only row
            torch.mv(operand.T, inputs[0], out=out[0])
        else:
            torch.mm(inputs, operand, out=out)

    def _precompute(self, device: torch.device) -> None:
        """Lay out every coupling's weights and buffers (see the class docstring); the LSTM
        states start at zero (footnote 2)."""
        model, batch = self.model, self.batch
        hidden, layers, n_steps = model.config.hidden, model.config.lstm_layers, model.config.steps
        gates = 4 * hidden
        new = partial(torch.zeros, device=device)
        # torch stores the gates as rows i, f, g, o; reordered to i, f, o, g, the three
        # sigmoid gates are one slice (one sigmoid per layer and frame)
        order = torch.cat([torch.arange(0, 2 * hidden), torch.arange(3 * hidden, 4 * hidden),
                           torch.arange(2 * hidden, 3 * hidden)]).to(device)
        sigma_2 = math.exp(_LOG_SIGMOID_SHIFT)                            # σ(2)
        self._scratch(device)
        # the conditioning's part of every coupling's first-layer gates, one frame's worth
        self._cond_product = new(batch, n_steps * gates, dtype=self.weights)
        self._cond_gates = new(batch, n_steps * gates)
        self._couplings, cond_weights, cond_biases = [], [], []
        for k, step in enumerate(model.flow.blocks):
            actnorm, linear, coupling = step.actnorm, step.linear, step.coupling
            lstm, output = coupling.network.lstm, coupling.network.output
            n_lo, n_hi = coupling.n_lo, coupling.n_hi
            weight_ih = lstm.weight_ih_l0[order]                          # (4H, n_lo + cond)
            cond_weights.append(weight_ih[:, n_lo:])
            cond_biases.append((lstm.bias_ih_l0 + lstm.bias_hh_l0)[order])
            operands = [self._operand(torch.cat([weight_ih[:, :n_lo], lstm.weight_hh_l0[order]], dim=1))]
            biases = [None]
            for layer in range(1, layers):
                operands.append(self._operand(torch.cat([getattr(lstm, f"weight_ih_l{layer}")[order],
                                                         getattr(lstm, f"weight_hh_l{layer}")[order]], dim=1)))
                biases.append((getattr(lstm, f"bias_ih_l{layer}") + getattr(lstm, f"bias_hh_l{layer}"))[order])
            buffer = new(batch, n_lo + layers * hidden, dtype=self.weights)      # [b_lo, h_1, ..., h_L]
            state = [buffer[:, n_lo + layer * hidden:n_lo + (layer + 1) * hidden] for layer in range(layers)]
            inputs = [buffer[:, :n_lo + hidden]] + [buffer[:, n_lo + (layer - 1) * hidden:n_lo + (layer + 1) * hidden]
                                                    for layer in range(1, layers)]
            # the output layer's rows: the shift divided by σ(2), and -h_s' - 2 for the scale
            rows = torch.cat([output.weight[:n_hi] / sigma_2, -output.weight[n_hi:]])
            bias = torch.cat([output.bias[:n_hi] / sigma_2, -output.bias[n_hi:] - SCALE_SHIFT])
            # W^-1 then ActNorm^-1 is one affine map: (x W^-T - b) s = x (W^-T s) - b s; the
            # rows that take the coupled half also take the σ(2) of its inverse scale
            scale = torch.exp(-actnorm.log_scale)
            unmix = torch.linalg.inv(linear.weight().double()).T.float() * scale
            unmix[n_lo:] *= sigma_2
            output_out = new(batch, 2 * n_hi)
            self._couplings.append(_StreamCoupling(
                layer_inputs=inputs, hidden=state, lo=buffer[:, :n_lo],
                cells=[new(batch, hidden) for _ in range(layers)], operands=operands, biases=biases,
                cond_gates=self._cond_gates[:, k * gates:(k + 1) * gates],
                output=rows.T.contiguous(), output_bias=bias, shift=output_out[:, :n_hi],
                exponent=output_out[:, n_hi:], output_out=output_out, unmix=unmix.contiguous(),
                unmix_bias=-actnorm.bias * scale))
        self._cond_operand = self._operand(torch.cat(cond_weights))                 # (cond, K·4H)
        self._cond_bias = torch.cat(cond_biases)
        # several streams on a CPU: one product per coupling (64 float32 rows: 90 GFLOP/s,
        # against 65 for one product over all couplings' columns); else one product
        chunk = gates if batch > 1 and device.type == "cpu" else n_steps * gates
        self._cond_chunks = [(self._cond_operand[:, start:start + chunk], self._cond_product[:, start:start + chunk])
                             for start in range(0, n_steps * gates, chunk)]

    def _scratch(self, device: torch.device) -> None:
        """The buffers every frame reuses, made once by :meth:`_precompute`: the gates and
        views of them, the cell's tanh, and the poses between the flow's steps."""
        model, batch, hidden = self.model, self.batch, self.model.config.hidden
        gates = 4 * hidden
        new = partial(torch.zeros, device=device)
        # scratch shared by every layer: the product, the gates (float32) and views of them,
        # tanh(c), and the last layer's h in float32 for the output layer
        self._product_out = new(batch, gates, dtype=self.weights)
        self._gates = new(batch, gates)
        self._sigmoid_gates, self._cell_gate = self._gates[:, :3 * hidden], self._gates[:, 3 * hidden:]
        self._input_gate, self._forget_gate, self._output_gate = self._gates[:, :3 * hidden].split(hidden, dim=1)
        self._tanh_cell, self._last_hidden = new(batch, hidden), new(batch, hidden)
        # the poses between steps (float32): z in, the coupling's output, then the next z;
        # every step splits them alike (n_lo, n_hi)
        self._z, self._coupled = new(batch, model.n_modelled), new(batch, model.n_modelled)
        n_lo = model.flow.blocks[0].coupling.n_lo
        self._halves = (self._z[:, :n_lo], self._z[:, n_lo:], self._coupled[:, :n_lo], self._coupled[:, n_lo:])

    def _coupling_network(self, coupling: _StreamCoupling) -> None:
        """One coupling's network on this frame's ``b_lo`` (already in its buffer): the LSTM
        layers (eq. 17, carrying their state; gates reordered i, f, o, g), then the output
        layer, into ``coupling.output_out``: ``[t' / σ(2), -h_s' - 2]``."""
        last = len(coupling.cells) - 1
        for layer, (inputs, operand, bias, cell) in enumerate(zip(coupling.layer_inputs, coupling.operands,
                                                                   coupling.biases, coupling.cells)):
            self._multiply(inputs, operand, self._product_out)
            torch.add(self._product_out, coupling.cond_gates if bias is None else bias, out=self._gates)
            self._sigmoid_gates.sigmoid_()
            self._cell_gate.tanh_()
            cell.mul_(self._forget_gate).addcmul_(self._input_gate, self._cell_gate)    # c_t = f c_{t-1} + i g
            torch.tanh(cell, out=self._tanh_cell)
            if layer < last:                                                       # h_t = o tanh(c_t)
                torch.mul(self._output_gate, self._tanh_cell, out=coupling.hidden[layer])
            else:
                torch.mul(self._output_gate, self._tanh_cell, out=self._last_hidden)
                coupling.hidden[layer].copy_(self._last_hidden)
        torch.addmm(coupling.output_bias, self._last_hidden, coupling.output, out=coupling.output_out)

    def _normalized_control(self, control) -> torch.Tensor:
        c = self.model.config.n_control
        control = torch.as_tensor(control, dtype=torch.float32, device=self.poses.device)
        if control.ndim == 1:
            control = control.expand(self.batch, -1)
        if control.shape != (self.batch, c):
            raise ValueError(f"control: expected ({self.batch}, {c}) (or ({c},) for every stream), "
                             f"got {tuple(control.shape)}")
        if not torch.isfinite(control).all():
            raise ValueError("control: contains NaN or infinite values")
        if self.normalizer is not None:
            control = (control - self._mean[self.model.control]) / self._std[self.model.control]
        return control

    def step(self, control, noise: torch.Tensor | None = None) -> torch.Tensor:
        """The next frame for ``control`` ``(batch, n_control)`` (or ``(n_control,)``).

        Args:
            control: this frame's control (normalised, or data units with a normaliser).
            noise: standard-normal ``ε`` ``(batch, n_modelled)`` (default: drawn).

        Returns:
            The new frame's features ``(batch, n_features)``, normalised or in data units.
        """
        model = self.model
        own_products = cpu.onednn_disabled() if self._kernel == "own product" else nullcontext()
        with torch.inference_mode(), own_products:
            control = self._normalized_control(control)
            shape = (self.batch, model.n_modelled)
            if noise is None:
                device = self.generator.device if self.generator is not None else self.poses.device
                noise = torch.randn(shape, generator=self.generator, device=device).to(self.poses.device)
            elif tuple(noise.shape) != shape:
                raise ValueError(f"noise: expected {shape}, got {tuple(noise.shape)}")
            controls = torch.cat([self.controls, control[:, None]], dim=1)       # c_{t-τ .. t}
            cond = model.frame_conditioning(self._history_scale * self.poses, controls, self.poses[:, -1],
                                            self._anchor_units)
            cond, self._contacts = model.draw_contacts(cond, self._contacts, self.generator)   # a contact head's
            if self._contacts is not None:
                self.contacts = labels_of(self._contacts[0]).bool()       # this frame's, (batch, 4)
            cond = cond[:, 0]
            # the conditioning's part of every coupling's first-layer gates, in one product
            # (one per coupling for several streams on a CPU)
            cond = cond.to(self.weights)
            for operand, out in self._cond_chunks:
                self._multiply(cond, operand, out)
            torch.add(self._cond_product, self._cond_bias, out=self._cond_gates)
            torch.mul(noise, self.temperature, out=self._z)
            z_lo, z_hi, coupled_lo, coupled_hi = self._halves
            for coupling in reversed(self._couplings):                           # f_K^-1 ... f_1^-1 undone
                coupling.lo.copy_(z_lo)
                self._coupling_network(coupling)
                # eq. 6 inverted, b_hi = z_hi / s' - t', divided by σ(2) (the unmix multiplies it back):
                # z_hi (1 + e) - t' / σ(2), with e = exp(-h_s' - 2) = 1 / (σ(2) s') - 1
                torch.addcmul(z_hi, z_hi, coupling.exponent.exp_(), out=coupled_hi)
                coupled_hi.sub_(coupling.shift)
                coupled_lo.copy_(z_lo)
                torch.addmm(coupling.unmix_bias, self._coupled, coupling.unmix, out=self._z)   # W^-1, ActNorm^-1
            # the feet's m (and the bones) from x_{t-1} and c_{t-1}
            x = model.restore(self._z.clone(), self.poses[:, -1], self.controls[:, -1], self._anchor_units)
            self.poses = torch.cat([self.poses[:, 1:], x[:, None]], dim=1)
            self.controls = controls[:, 1:]
            self.frames += 1
            frame = self.model.join_features(x[:, None], control[:, None])[:, 0]
            if self.normalizer is not None:
                frame = frame * self._std + self._mean
                frame[:, model.constant] = 0.0
        return frame.clone()

    def run(self, control, noise: torch.Tensor | None = None) -> torch.Tensor:
        """:meth:`step` over a whole control sequence ``(batch, frames, n_control)``:
        ``(batch, frames, n_features)``."""
        control = torch.as_tensor(control, dtype=torch.float32)
        if control.ndim != 3 or control.shape[0] != self.batch:
            raise ValueError(f"control: expected ({self.batch}, frames, {self.model.config.n_control}), "
                             f"got {tuple(control.shape)}")
        frames = [self.step(control[:, t], None if noise is None else noise[:, t]) for t in range(control.shape[1])]
        return torch.stack(frames, dim=1)
