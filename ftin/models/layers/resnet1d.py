"""The RoNIN-style ResNet-1D backbone, shared by FTIN, its ablations, RoNIN ResNet, TLIO and RNIN."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn


class BasicBlock1D(nn.Module):
    """Two 3-tap convolutions with batch norm and an identity (or 1x1 projection) shortcut."""

    def __init__(self, in_channels: int, out_channels: int, stride: int = 1) -> None:
        super().__init__()
        self.conv1 = nn.Conv1d(in_channels, out_channels, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm1d(out_channels)
        self.conv2 = nn.Conv1d(out_channels, out_channels, 3, padding=1, bias=False)
        self.bn2 = nn.BatchNorm1d(out_channels)
        self.relu = nn.ReLU(inplace=True)
        self.shortcut: nn.Module = nn.Identity()
        if stride != 1 or in_channels != out_channels:
            self.shortcut = nn.Sequential(
                nn.Conv1d(in_channels, out_channels, 1, stride=stride, bias=False),
                nn.BatchNorm1d(out_channels),
            )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.bn2(self.conv2(out))
        return self.relu(out + self.shortcut(x))


class ResNet1DBackbone(nn.Module):
    """Stem (conv7/s2 + BN + ReLU [+ maxpool3/s2]) then groups of ``BasicBlock1D``.

    ``(B, in_channels, L) -> (B, channels[-1], L_res)``; with the defaults L = 200 gives L_res = 7
    (200 -> 100 stem -> 50 maxpool -> 50, 25, 13, 7 through the groups).
    """

    def __init__(
        self,
        in_channels: int = 6,
        channels: Sequence[int] = (64, 128, 256, 512),
        blocks_per_group: Sequence[int] = (2, 2, 2, 2),
        strides: Sequence[int] = (1, 2, 2, 2),
        stem_maxpool: bool = True,
    ) -> None:
        super().__init__()
        if not len(channels) == len(blocks_per_group) == len(strides):
            raise ValueError("channels, blocks_per_group and strides need the same length")
        stem: list[nn.Module] = [
            nn.Conv1d(in_channels, channels[0], 7, stride=2, padding=3, bias=False),
            nn.BatchNorm1d(channels[0]),
            nn.ReLU(inplace=True),
        ]
        if stem_maxpool:
            stem.append(nn.MaxPool1d(3, stride=2, padding=1))
        self.stem = nn.Sequential(*stem)
        groups: list[nn.Module] = []
        width = channels[0]
        for out_channels, n_blocks, stride in zip(channels, blocks_per_group, strides, strict=True):
            blocks = [BasicBlock1D(width, out_channels, stride)]
            blocks += [BasicBlock1D(out_channels, out_channels) for _ in range(n_blocks - 1)]
            groups.append(nn.Sequential(*blocks))
            width = out_channels
        self.groups = nn.Sequential(*groups)
        self.out_channels = width
        self.stem_maxpool = stem_maxpool
        self.strides = tuple(strides)
        init_resnet_weights(self)

    def output_length(self, window: int) -> int:
        """L_res for an input of length ``window`` (each stride-2 stage is ceil(L / 2))."""
        length = (window + 1) // 2
        if self.stem_maxpool:
            length = (length + 1) // 2
        for stride in self.strides:
            length = (length + stride - 1) // stride
        return length

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.groups(self.stem(x))  # (B, C_res, L_res)


def init_resnet_weights(module: nn.Module) -> None:
    """RoNIN's initialisation: Kaiming-normal (fan_out) convs, BN 1/0, Linear N(0, 0.01)."""
    for m in module.modules():
        if isinstance(m, nn.Conv1d):
            nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
        elif isinstance(m, nn.BatchNorm1d):
            nn.init.constant_(m.weight, 1.0)
            nn.init.constant_(m.bias, 0.0)
        elif isinstance(m, nn.Linear):
            nn.init.normal_(m.weight, 0.0, 0.01)
            if m.bias is not None:
                nn.init.constant_(m.bias, 0.0)
