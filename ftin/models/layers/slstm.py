"""sLSTM (scalar LSTM) from xLSTM (Beck et al., 2024), our own CPU-friendly implementation.

Cell, per head and step, with pre-activations ``g~ = W_g x_t + R_g h_{t-1} + b_g`` for g in i, f, z, o:

    log f_t = logsigmoid(f~)   (or f~ itself for the exponential forget gate)
    m_t = max(log f_t + m_{t-1}, i~)                      stabiliser
    i'_t = exp(i~ - m_t),  f'_t = exp(log f_t + m_{t-1} - m_t)
    c_t = f'_t c_{t-1} + i'_t tanh(z~)                    cell
    n_t = f'_t n_{t-1} + i'_t                             normaliser
    h_t = sigmoid(o~) * c_t / n_t

This equals the unstabilised recurrence (``i = exp(i~)``, ``f = sigmoid(f~)``, no ``m``) exactly,
since ``c_t`` and ``n_t`` are both scaled by ``exp(-m_t)`` and ``h_t`` only sees their ratio.

Decisions:

* The empty state has ``c = n = 0`` and ``m = EMPTY_STABILISER`` (a huge negative number, not -inf so
  no ``inf - inf`` can appear): the first step then takes ``m_1 = i~_1``, so ``i'_1 = 1`` and, by
  induction (either ``i'`` or ``f'`` is 1 at each step), ``n_t >= 1``: the division never blows up.
  This is what xLSTM's reference does with its "first step" special case, without the branch.
* Recurrent weights are block-diagonal per head: ``R`` holds ``heads`` blocks of ``(hd x 4 hd)``
  (the four gates' ``hd x hd`` blocks side by side); off-block weights do not exist. The input
  projection is one dense ``Linear(in, 4 * hidden)`` (xLSTM uses head-wise projections and a causal
  conv in front of i and f; we leave both out to keep the model small and the loop cheap).
* Speed: the input projection runs for all steps at once; the loop does one batched matmul
  (``baddbmm``) and a few element-wise ops per step on a ``(heads, 4 hd, B)`` layout, batch last so
  that every gate's slice is dense memory (strided slices made exp/tanh ~2x slower).
* Forget-gate bias starts in [3, 6] (per unit, linearly spaced), so ``f ~ 1``: long memory at init.
"""

from __future__ import annotations

import math
from enum import Enum
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import nn

EMPTY_STABILISER = -1.0e30


class ForgetGate(str, Enum):
    SIGMOID = "sigmoid"  # log f = logsigmoid(f~)
    EXP = "exp"  # log f = f~


class SLSTMState(NamedTuple):
    """Recurrent state, each ``(B, hidden)``; pass it back in to continue a sequence."""

    c: torch.Tensor
    n: torch.Tensor
    m: torch.Tensor
    h: torch.Tensor

    @classmethod
    def empty(cls, batch: int, hidden: int, like: torch.Tensor) -> SLSTMState:
        zeros = like.new_zeros(batch, hidden)
        return cls(zeros, zeros, torch.full_like(zeros, EMPTY_STABILISER), zeros)


class SLSTM(nn.Module):
    """sLSTM layer: ``(B, T, in_features) -> (B, T, hidden)``, returning the final state too."""

    def __init__(
        self,
        in_features: int,
        hidden: int,
        heads: int = 4,
        forget_gate: str | ForgetGate = ForgetGate.SIGMOID,
    ) -> None:
        super().__init__()
        if heads < 1 or hidden % heads != 0:
            raise ValueError(f"sLSTM hidden ({hidden}) must be a positive multiple of heads ({heads})")
        try:
            self.forget_gate = ForgetGate(forget_gate)
        except ValueError:
            raise ValueError(f"forget_gate must be 'sigmoid' or 'exp', got {forget_gate!r}") from None
        self.hidden, self.heads, self.head_dim = hidden, heads, hidden // heads
        hd = self.head_dim
        # Gate layout along the last axis of the projections, per head: [i | f | z | o], hd each.
        self.input_proj = nn.Linear(in_features, 4 * hidden)
        self.recurrent = nn.Parameter(torch.randn(heads, hd, 4 * hd) / math.sqrt(hd))  # (H, hd, 4 hd)
        self.reset_gate_bias()

    def reset_gate_bias(self) -> None:
        with torch.no_grad():
            bias = self.input_proj.bias.view(self.heads, 4, self.head_dim)  # (H, gate, hd)
            bias.zero_()
            bias[:, 1] = torch.linspace(3.0, 6.0, self.hidden).view(self.heads, self.head_dim)

    def forward(self, x: torch.Tensor, state: SLSTMState | None = None) -> tuple[torch.Tensor, SLSTMState]:
        batch, steps, _ = x.shape
        H, hd = self.heads, self.head_dim
        if state is None:
            state = SLSTMState.empty(batch, self.hidden, x)
        # Batch last in the loop, so each gate's slice of a step is one contiguous (H, hd, B) block and
        # the element-wise ops run on dense memory. All input projections at once:
        # (B, T, 4 hidden) -> (T, H, 4 hd, B), one contiguous slab per step.
        pre = self.input_proj(x).view(batch, steps, H, 4 * hd).permute(1, 2, 3, 0).contiguous()
        recurrent_t = self.recurrent.transpose(1, 2)  # (H, 4 hd, hd): R^T per head
        c, n, m, h = (s.reshape(batch, H, hd).permute(1, 2, 0) for s in state)  # (H, hd, B) each
        outputs = []
        for t in range(steps):
            raw = torch.baddbmm(pre[t], recurrent_t, h)  # (H, 4 hd, B) = W x_t + b + R h_{t-1}
            i_raw, f_raw, z_raw, o_raw = raw.split(hd, dim=1)  # (H, hd, B) each, contiguous per head
            log_f = F.logsigmoid(f_raw) if self.forget_gate is ForgetGate.SIGMOID else f_raw
            log_f_plus_m = log_f + m
            m = torch.maximum(log_f_plus_m, i_raw)
            i_gate = torch.exp(i_raw - m)
            f_gate = torch.exp(log_f_plus_m - m)
            c = f_gate * c + i_gate * torch.tanh(z_raw)
            n = f_gate * n + i_gate
            h = torch.sigmoid(o_raw) * (c / n)
            outputs.append(h)
        out = torch.stack(outputs) if outputs else x.new_zeros(0, H, hd, batch)  # (T, H, hd, B)
        out = out.permute(3, 0, 1, 2).reshape(batch, steps, self.hidden)  # (B, T, hidden)

        def merge(s: torch.Tensor) -> torch.Tensor:
            return s.permute(2, 0, 1).reshape(batch, self.hidden)  # (H, hd, B) -> (B, hidden)

        return out, SLSTMState(merge(c), merge(n), merge(m), merge(h))

    def recurrent_dense(self) -> torch.Tensor:
        """The full ``(4, hidden, hidden)`` recurrent matrices (input x output), zeros off the head blocks."""
        H, hd = self.heads, self.head_dim
        dense = self.recurrent.new_zeros(4, self.hidden, self.hidden)
        for head in range(H):
            rows = slice(head * hd, (head + 1) * hd)
            for gate in range(4):
                dense[gate, rows, rows] = self.recurrent[head, :, gate * hd : (gate + 1) * hd]
        return dense


class GatedFeedForward(nn.Module):
    """``down(gelu(gate(x)) * up(x))``, hidden width ``round(proj_factor * dim)`` (xLSTM: 4/3)."""

    def __init__(self, dim: int, proj_factor: float = 4 / 3, dropout: float = 0.0) -> None:
        super().__init__()
        inner = max(1, round(proj_factor * dim))
        self.gate_up = nn.Linear(dim, 2 * inner)
        self.down = nn.Linear(inner, dim)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        gate, up = self.gate_up(x).chunk(2, dim=-1)  # (..., inner) each
        return self.dropout(self.down(F.gelu(gate) * up))


class SLSTMBlock(nn.Module):
    """xLSTM's sLSTM residual block: ``x + GN(sLSTM(LN(x)))``, then ``+ FFN(LN(.))``.

    GN is a per-head layer norm (group norm with one group per head). ``residual=False`` drops both
    skip connections (an ablation switch; the xLSTM block always has them).
    """

    def __init__(
        self,
        dim: int,
        heads: int = 4,
        proj_factor: float = 4 / 3,
        dropout: float = 0.0,
        forget_gate: str | ForgetGate = ForgetGate.SIGMOID,
        residual: bool = True,
    ) -> None:
        super().__init__()
        self.norm_in = nn.LayerNorm(dim)
        self.cell = SLSTM(dim, dim, heads, forget_gate)
        self.head_norm = nn.GroupNorm(heads, dim)
        self.norm_ffn = nn.LayerNorm(dim)
        self.ffn = GatedFeedForward(dim, proj_factor, dropout)
        self.dropout = nn.Dropout(dropout)
        self.residual = residual

    def forward(self, x: torch.Tensor, state: SLSTMState | None = None) -> tuple[torch.Tensor, SLSTMState]:
        batch, steps, dim = x.shape
        h, state = self.cell(self.norm_in(x), state)  # (B, T, dim)
        h = self.head_norm(h.reshape(batch * steps, dim)).view(batch, steps, dim)  # per-head norm
        y = self.dropout(h) + (x if self.residual else 0.0)
        z = self.ffn(self.norm_ffn(y))
        return z + (y if self.residual else 0.0), state


class SLSTMStack(nn.Module):
    """``n_blocks`` sLSTM blocks over ``(B, T, dim)``; the state is one ``SLSTMState`` per block."""

    def __init__(self, dim: int, n_blocks: int = 1, **block_kwargs) -> None:
        super().__init__()
        if n_blocks < 1:
            raise ValueError(f"SLSTMStack needs n_blocks >= 1, got {n_blocks}")
        self.blocks = nn.ModuleList(SLSTMBlock(dim, **block_kwargs) for _ in range(n_blocks))
        self.norm_out = nn.LayerNorm(dim)

    def forward(
        self, x: torch.Tensor, states: list[SLSTMState] | None = None
    ) -> tuple[torch.Tensor, list[SLSTMState]]:
        if states is not None and len(states) != len(self.blocks):
            raise ValueError(f"expected {len(self.blocks)} sLSTM states (one per block), got {len(states)}")
        new_states = []
        for k, block in enumerate(self.blocks):
            x, state = block(x, None if states is None else states[k])
            new_states.append(state)
        return self.norm_out(x), new_states
