"""RoNIN's fully connected output block, also TLIO's ``FcBlock``: the head of the ResNet baselines.

``(B, C_res, L_res) -> 1x1 conv to trans_channels + BN (no activation, as the references)
-> flatten (trans_channels * L_res) -> MLPHead (Linear, ReLU, Dropout per hidden layer) -> (B, out_dim)``.
The flatten size depends on ``L_res``, so the head is tied to one window length.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn

from ftin.models.layers.heads import MLPHead


class ConvFlattenHead(nn.Module):
    def __init__(
        self,
        in_channels: int,
        length: int,
        out_dim: int,
        trans_channels: int = 128,
        hidden: Sequence[int] = (512, 512),
        dropout: float = 0.5,
    ) -> None:
        super().__init__()
        self.transition = nn.Sequential(
            nn.Conv1d(in_channels, trans_channels, 1, bias=False),
            nn.BatchNorm1d(trans_channels),
        )
        self.mlp = MLPHead(trans_channels * length, out_dim, hidden=hidden, dropout=dropout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.mlp(self.transition(x).flatten(1))  # (B, trans * L_res) -> (B, out_dim)
