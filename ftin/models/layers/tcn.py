"""Causal temporal convolution network (Bai et al. 2018), the body of RoNIN TCN.

Each level is a residual block of two dilated causal convolutions (weight norm, PReLU, dropout);
level ``i`` uses dilation ``2**i``, so ``n`` levels of kernel ``k`` see
``1 + 2 (k - 1) (2**n - 1)`` past frames (253 for RoNIN's k = 3, 6 levels).

Decisions:
* Causality comes from left-padding by ``(k - 1) * dilation`` before an unpadded convolution; this is
  the same computation as the reference's "pad both sides, then chop the right end".
* Weight norm uses ``torch.nn.utils.parametrizations.weight_norm`` (g per output channel, as the
  reference). The reference's N(0, 0.01) re-initialisation of the convolution weights is undone by
  its old-style weight-norm hook on the first forward pass, so PyTorch's default initialisation is
  what actually trains there; we keep the default too.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import nn
from torch.nn.utils.parametrizations import weight_norm


class CausalConv1d(nn.Module):
    """Dilated convolution whose output at frame t sees inputs up to t only; keeps the length."""

    def __init__(self, in_channels: int, out_channels: int, kernel_size: int, dilation: int) -> None:
        super().__init__()
        self.left_pad = (kernel_size - 1) * dilation
        self.conv = weight_norm(nn.Conv1d(in_channels, out_channels, kernel_size, dilation=dilation))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.conv(F.pad(x, (self.left_pad, 0)))  # (B, C_out, L)


class TemporalBlock(nn.Module):
    """Two causal convolutions with PReLU and dropout, plus a (1x1-projected) residual, then PReLU."""

    def __init__(
        self, in_channels: int, out_channels: int, kernel_size: int, dilation: int, dropout: float
    ) -> None:
        super().__init__()
        self.net = nn.Sequential(
            CausalConv1d(in_channels, out_channels, kernel_size, dilation),
            nn.PReLU(),
            nn.Dropout(dropout),
            CausalConv1d(out_channels, out_channels, kernel_size, dilation),
            nn.PReLU(),
            nn.Dropout(dropout),
        )
        self.shortcut: nn.Module = (
            nn.Conv1d(in_channels, out_channels, 1) if in_channels != out_channels else nn.Identity()
        )
        if isinstance(self.shortcut, nn.Conv1d):
            nn.init.normal_(self.shortcut.weight, 0.0, 0.01)  # as the reference (no weight norm here)
        self.activation = nn.PReLU()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.activation(self.net(x) + self.shortcut(x))


class TemporalConvNet(nn.Module):
    """``(B, in_channels, L) -> (B, channels[-1], L)``, causal, dilation doubling per level."""

    def __init__(
        self, in_channels: int, channels: Sequence[int], kernel_size: int = 3, dropout: float = 0.2
    ) -> None:
        super().__init__()
        levels: list[nn.Module] = []
        width = in_channels
        for i, out_channels in enumerate(channels):
            levels.append(TemporalBlock(width, out_channels, kernel_size, 2**i, dropout))
            width = out_channels
        self.levels = nn.Sequential(*levels)
        self.out_channels = width
        self.receptive_field = 1 + 2 * (kernel_size - 1) * (2 ** len(channels) - 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.levels(x)
