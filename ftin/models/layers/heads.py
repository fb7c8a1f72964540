"""MLP velocity head shared by FTIN, its ablations and any model that ends in flatten -> FC layers.

Decision: the layout mirrors RoNIN ResNet's FC head (Linear -> ReLU -> Dropout per hidden layer, then a
plain Linear to the output) so that ablations differ from the baseline only in what feeds the head.
Weights keep PyTorch's default init; callers that want RoNIN's N(0, 0.01) apply ``init_resnet_weights``.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn


class MLPHead(nn.Module):
    """``(B, in_features) -> (B, out_dim)`` through ``hidden`` Linear + ReLU + Dropout layers."""

    def __init__(
        self, in_features: int, out_dim: int, hidden: Sequence[int] = (512, 512), dropout: float = 0.5
    ) -> None:
        super().__init__()
        if in_features < 1 or out_dim < 1:
            raise ValueError(f"MLPHead needs in_features >= 1 and out_dim >= 1, got {in_features}, {out_dim}")
        if not 0.0 <= dropout < 1.0:
            raise ValueError(f"MLPHead dropout must be in [0, 1), got {dropout}")
        layers: list[nn.Module] = []
        width = in_features
        for size in hidden:
            if size < 1:
                raise ValueError(f"MLPHead hidden sizes must be >= 1, got {tuple(hidden)}")
            layers += [nn.Linear(width, size), nn.ReLU(inplace=True), nn.Dropout(dropout)]
            width = size
        layers.append(nn.Linear(width, out_dim))
        self.net = nn.Sequential(*layers)
        self.in_features = in_features

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x.flatten(1))  # (B, in_features) -> (B, out_dim)
