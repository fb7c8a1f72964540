"""Frequency-domain learning (FDL), FTIN paper Sec. 2.2, structured like FreTS.

``(B, C_res, L_res) -> (B, C_fre, L_out)``:

1. token embedding ``x[..., None] * W1`` with ``W1 (1 x d)``             -> ``(B, C_res, L_res, d)``
2. channel learner: ``rfft`` over channels (norm="ortho"), complex MLP, ``irfft(n=C_res)``
3. temporal learner: the same over time, ``irfft(n=L_res)`` (L_res is often odd: 7 for L = 200)
4. residual: the embedded tokens are added back (config ``residual``)
5. output FC + activation, one of two structures (``output``, an ``FDLOutput``):

   * ``"mixed"`` (default, the original structure): flatten ``(L_res x d)`` per channel, as the
     paper writes it, and one Kronecker-structured FC + activation      -> ``(B, C_fre, L_fre)``.
     Its L_fre outputs are learned mixtures of *all* time steps: they carry no time order.
   * ``"ordered"``: keep the time axis; flatten ``(C_res x d)`` per time step and one dense FC
     ``C_res d -> C_fre`` + activation, shared by the L_res steps (a 1x1 conv)
     -> ``(B, C_fre, L_res)``: step ``t`` of the output depends on step ``t`` of the residual sum
     only, so a sequence model after FDL scans the encoder's time order. ``out_length`` is unused.

Decisions (the paper leaves them open):

* The complex MLP is the paper's equation, a true complex matrix product
  ``sigma(Re(y) W_r - Im(y) W_i + B_r) + j sigma(Re(y) W_i + Im(y) W_r + B_i)`` with full ``d x d``
  matrices, not FreTS's diagonal-only einsum (one batched complex GEMM, see ``ComplexLinear``).
* Layout: tokens live as ``(B, d, ..., n)`` with the FFT axis last and contiguous, (B, d, L_res, C_res)
  for the channel learner and (B, d, C_res, L_res) for the temporal one: pocketfft is several times
  slower on strided axes, and d next to the batch axis makes the complex product a plain GEMM.
  The paper's ``(C_res, L_res, d)`` order is restored for the final flatten and for the taps.
* Channel and temporal learners have their own weights; ``n_layers`` complex layers each.
* FreTS's soft-shrink sparsity is not in the paper's equation and is left out.
* Init: ``W_r, W_i ~ N(0, 1 / (2d))`` so a layer roughly preserves the spectrum's variance; biases 0.
* ``"mixed"``: step 5's FC is stored factored, as a temporal map ``fc_time`` ``(L_res x d) -> L_fre``
  (``A``, bias ``a``) shared by all channels (as in FreTS) and a channel map ``fc_channel``
  ``C_res -> C_fre`` (``G``, bias ``g``), with **no activation between them and one after**. The
  pair is exactly ONE fully connected layer + activation (the paper's) whose weight is structured.
  With ``X`` the flattened ``(C_res, L_res d)`` input and ``vec`` the row-major flatten::

      Y = sigma(G (X A^T + 1 a^T) + g 1^T)                              # (C_fre, L_fre)
      vec(Y) = sigma(W vec(X) + b),  W = kron(G, A)                     # (C_fre L_fre, C_res L_res d)
                                     b = kron(G 1, a) + kron(g, 1)      # (C_fre L_fre,)

  i.e. ``W[(f, m), (c, i)] = G[f, c] A[m, i]`` (``tests/models/test_fdl.py`` builds this dense ``W``
  and compares). The Kronecker structure (rank one in the Kronecker sense) keeps the layer small
  even with ``C_res = 512`` (at FTIN's defaults and window 100, a dense ``C_fre L_fre x C_res L_res d``
  FC would have 2.1 M weights, the factored one has 8.5 k) and lets ``C_fre`` shrink the features
  the sLSTM scans; the price is that every output slot ``m`` applies the same time mixture ``A[m]``
  to every channel, and that the slots have no time order.
* ``"ordered"``: ``fc`` is a dense ``Linear(C_res d, C_fre)`` applied at each time step, flattening
  ``(C_res x d)`` in that order (``c d + k``). It reads the paper's "flatten + FC + activation" per
  time step instead of per channel: the paper leaves open which axis a following sequence model
  scans, and only this reading leaves one with an order. ``C_res d C_fre`` weights
  (65.6 k with bias at FTIN's defaults, for any window; about 8 times the factored pair's).
"""

from __future__ import annotations

import math
from enum import Enum

import torch
import torch.nn.functional as F
from torch import nn


class Activation(str, Enum):
    RELU = "relu"
    GELU = "gelu"
    IDENTITY = "identity"  # for tests and for a linear FDL


def apply_activation(x: torch.Tensor, activation: Activation) -> torch.Tensor:
    if activation is Activation.RELU:
        return F.relu(x)
    if activation is Activation.GELU:
        return F.gelu(x)
    return x


def parse_activation(value: str | Activation, argument: str = "activation") -> Activation:
    try:
        return Activation(value)
    except ValueError:
        valid = ", ".join(a.value for a in Activation)
        raise ValueError(f"{argument} must be one of {valid}, got {value!r}") from None


class FDLOutput(str, Enum):
    """Structure of FDL's output FC (module docstring, step 5)."""

    MIXED = "mixed"  # (B, C_fre, L_fre): Kronecker FC over (L_res x d) per channel; no time order
    ORDERED = "ordered"  # (B, C_fre, L_res): dense FC over (C_res x d) per time step; time order kept


def parse_fdl_output(value: str | FDLOutput, argument: str = "output") -> FDLOutput:
    try:
        return FDLOutput(value)
    except ValueError:
        valid = ", ".join(repr(o.value) for o in FDLOutput)
        raise ValueError(
            f"{argument} must be one of {valid} ('mixed': L_fre time-mixed outputs, "
            f"'ordered': the encoder's L_res time steps kept in order), got {value!r}"
        ) from None


class ComplexLinear(nn.Module):
    """``y -> sigma(y W + B)`` over axis 1 of a complex ``(B, d, ...)`` tensor, ``W = W_r + jW_i``.

    ``W`` is ``d x d`` (input x output), as in the paper's row-vector equation; the activation acts on
    the real and imaginary parts separately. The embedding axis d sits right after the batch axis so
    that the product is one batched complex GEMM ``W^T (d x d) @ (d x rest)`` per sample, with no copy
    of the spectrum (the FFT axis stays last and contiguous for pocketfft).
    """

    def __init__(self, dim: int, activation: Activation = Activation.RELU) -> None:
        super().__init__()
        std = 1.0 / math.sqrt(2 * dim)
        self.weight_real = nn.Parameter(torch.randn(dim, dim) * std)  # W_r (d_in, d_out)
        self.weight_imag = nn.Parameter(torch.randn(dim, dim) * std)  # W_i (d_in, d_out)
        self.bias_real = nn.Parameter(torch.zeros(dim))
        self.bias_imag = nn.Parameter(torch.zeros(dim))
        self.activation = activation
        self.dim = dim

    def forward(self, spectrum: torch.Tensor) -> torch.Tensor:
        batch, dim = spectrum.shape[:2]
        if dim != self.dim:
            raise ValueError(
                f"ComplexLinear expects d = {self.dim} on axis 1, got shape {tuple(spectrum.shape)}"
            )
        weight_t = torch.complex(self.weight_real, self.weight_imag).transpose(0, 1)  # W^T (d_out, d_in)
        bias = torch.complex(self.bias_real, self.bias_imag).view(1, dim, 1)  # (1, d, 1)
        flat = spectrum.reshape(batch, dim, -1)  # (B, d, rest) complex
        out = torch.baddbmm(bias, weight_t.expand(batch, dim, dim), flat)  # (B, d, rest) = W^T y + B
        # In place on the fresh product (baddbmm's backward does not need it): every new B x d x ...
        # tensor costs page faults on CPU, more than the arithmetic itself.
        if self.activation is Activation.RELU:
            torch.view_as_real(out).relu_()
        elif self.activation is not Activation.IDENTITY:
            out = torch.view_as_complex(apply_activation(torch.view_as_real(out), self.activation))
        return out.view(spectrum.shape)  # (B, d, ...) complex


class FrequencyMLP(nn.Module):
    """``n_layers`` complex layers on the spectrum of the last axis: rfft -> layers -> irfft."""

    def __init__(self, dim: int, n_layers: int, activation: Activation) -> None:
        super().__init__()
        self.layers = nn.ModuleList(ComplexLinear(dim, activation) for _ in range(n_layers))

    def forward(self, tokens: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(B, d, ..., n)`` real -> (same shape, real; spectrum ``(B, d, ..., n // 2 + 1)`` pre-MLP)."""
        n = tokens.shape[-1]
        spectrum = torch.fft.rfft(tokens, dim=-1, norm="ortho")  # (B, d, ..., n // 2 + 1) complex
        mixed = spectrum
        for layer in self.layers:
            mixed = layer(mixed)
        return torch.fft.irfft(mixed, n=n, dim=-1, norm="ortho"), spectrum  # (B, d, ..., n) real


class FrequencyDomainLearning(nn.Module):
    """FDL block: ``(B, C_res, L_res) -> (B, C_fre, L_out)`` (see the module docstring).

    ``L_out`` (``self.out_length``) is ``out_length`` (L_fre) with ``output="mixed"`` and ``in_length``
    (L_res) with ``output="ordered"``, where the ``out_length`` argument is not used.

    Feature taps (when ``features`` is a dict), all detached, with ``d`` kept (no reduction):
    ``fdl_channel_spectrum`` ``(B, C_res // 2 + 1, L_res, d)`` = ``|rfft|`` over channels of the
    embedded tokens, and ``fdl_temporal_spectrum`` ``(B, C_res, L_res // 2 + 1, d)`` = ``|rfft|`` over
    time of the channel learner's output, both taken right before their complex MLP.
    """

    def __init__(
        self,
        in_channels: int,
        in_length: int,
        embed_dim: int = 8,
        out_channels: int = 64,
        out_length: int = 8,
        n_layers: int = 1,
        activation: str | Activation = Activation.RELU,
        residual: bool = True,
        output: str | FDLOutput = FDLOutput.MIXED,
    ) -> None:
        super().__init__()
        for name, value in [
            ("in_channels", in_channels),
            ("in_length", in_length),
            ("embed_dim", embed_dim),
            ("out_channels", out_channels),
            ("out_length", out_length),
        ]:
            if value < 1:
                raise ValueError(f"FrequencyDomainLearning {name} must be >= 1, got {value}")
        if n_layers < 0:
            raise ValueError(f"FrequencyDomainLearning n_layers must be >= 0, got {n_layers}")
        self.activation = parse_activation(activation)
        self.in_channels, self.in_length, self.embed_dim = in_channels, in_length, embed_dim
        self.residual = residual
        self.embedding = nn.Parameter(torch.randn(1, embed_dim))  # W1 (1 x d)
        self.channel_mlp = FrequencyMLP(embed_dim, n_layers, self.activation)
        self.temporal_mlp = FrequencyMLP(embed_dim, n_layers, self.activation)
        self.output = parse_fdl_output(output)
        self.out_channels = out_channels
        if self.output is FDLOutput.MIXED:
            # One FC with weight kron(fc_channel, fc_time) (module docstring), stored factored.
            self.out_length = out_length
            self.fc_time = nn.Linear(in_length * embed_dim, out_length)
            self.fc_channel = nn.Linear(in_channels, out_channels)
        else:
            self.out_length = in_length  # out_length is not used: the time steps are kept
            self.fc = nn.Linear(in_channels * embed_dim, out_channels)  # per step, (C_res x d) -> C_fre

    def embed(self, x: torch.Tensor) -> torch.Tensor:
        """Token embedding in the channel learner's layout: ``(B, C_res, L_res) -> (B, d, L_res, C_res)``."""
        w1 = self.embedding[0].view(-1, 1, 1)  # W1 as (d, 1, 1)
        return w1 * x.transpose(1, 2).contiguous().unsqueeze(1)  # (d,1,1) * (B,1,L_res,C_res)

    def learn_channels(self, tokens: torch.Tensor, features: dict | None = None) -> torch.Tensor:
        """``(B, d, L_res, C_res) -> (B, d, L_res, C_res)`` through the spectrum over channels."""
        mixed, spectrum = self.channel_mlp(tokens)  # spectrum (B, d, L_res, C_res // 2 + 1)
        if features is not None:
            features["fdl_channel_spectrum"] = spectrum.abs().detach().permute(0, 3, 2, 1)  # (B, Cf, L, d)
        return mixed

    def learn_time(self, tokens: torch.Tensor, features: dict | None = None) -> torch.Tensor:
        """``(B, d, C_res, L_res) -> (B, d, C_res, L_res)`` through the spectrum over time."""
        mixed, spectrum = self.temporal_mlp(tokens)  # spectrum (B, d, C_res, L_res // 2 + 1)
        if features is not None:
            features["fdl_temporal_spectrum"] = spectrum.abs().detach().permute(0, 2, 3, 1)  # (B, C, Lf, d)
        return mixed

    def forward(self, x: torch.Tensor, features: dict | None = None) -> torch.Tensor:
        if x.dim() != 3 or x.shape[1:] != (self.in_channels, self.in_length):
            raise ValueError(
                f"FDL input must be (B, {self.in_channels}, {self.in_length}) (C_res, L_res), "
                f"got {tuple(x.shape)}; was the model built for another window length?"
            )
        tokens = self.embed(x)  # (B, d, L_res, C_res): channels last for the channel rfft
        # (B, d, C_res, L_res): a contiguous copy, since pocketfft is ~3x slower on the strided view.
        mixed = self.learn_channels(tokens, features).transpose(2, 3).contiguous()
        mixed = self.learn_time(mixed, features)  # (B, d, C_res, L_res)
        if self.residual:
            # + tokens, re-expanded in this layout instead of transposing the stored ones;
            # in place on irfft's fresh output (its backward does not need it).
            mixed = mixed.addcmul_(x.unsqueeze(1), self.embedding[0].view(-1, 1, 1))
        return self.project(mixed)  # (B, C_fre, L_out)

    def project(self, mixed: torch.Tensor) -> torch.Tensor:
        """Step 5, the output FC + activation: ``(B, d, C_res, L_res) -> (B, C_fre, L_out)``."""
        if self.output is FDLOutput.ORDERED:
            flat = mixed.permute(0, 3, 2, 1).flatten(2)  # (B, L_res, C_res, d) -> (B, L_res, C_res * d)
            out = self.fc(flat)  # (B, L_res, C_fre): the same FC at every time step
            return apply_activation(out, self.activation).transpose(1, 2)  # (B, C_fre, L_res)
        flat = mixed.permute(0, 2, 3, 1).flatten(2)  # (B, C_res, L_res, d) -> (B, C_res, L_res * d)
        out = self.fc_time(flat)  # (B, C_res, L_fre)
        out = self.fc_channel(out.transpose(1, 2))  # (B, L_fre, C_res) -> (B, L_fre, C_fre)
        return apply_activation(out, self.activation).transpose(1, 2)  # (B, C_fre, L_fre)
