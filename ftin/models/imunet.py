"""IMUNet (Zeinali et al., IEEE Sensors 2024): depthwise-separable residual network for edge devices.

Structure as the public PyTorch reference (ELU inside the blocks, default PyTorch initialisation):
conv7/s2 (6 -> 64) + BN + ReLU + maxpool3/s2, then twelve depthwise-separable residual blocks
(depthwise conv3 + BN + ELU, pointwise conv1 + BN + ELU, residual, ELU): 64, 64, 64 (1x1-projected
shortcut), 64, then 128, 256, 512, 1024 each as a stride-2 projected block followed by a plain one;
then conv k2 (1024 -> 400) + BN, flatten, the "custom layer" ``f - W * raw + b`` (W, b learnable,
one per feature), ELU and a linear layer to the output. 3,661,618 parameters at 6 x 200, 2 outputs.

Decision (window adaptation): the reference's custom layer pairs the 1200 flattened conv features
(400 x 3 at L = 200) element by element with the 1200 flattened raw inputs (6 x 200), which ties it to
6 x 200. Here W and b have one entry per conv feature (400 x L_out, the 1200 of the reference at
L = 200) and the flattened raw input (6 L, channel-major as the reference) is resampled to that size by
adaptive average pooling. Pooling is the identity whenever 6 L equals the feature size, which holds
at L = 200 (and 400, 600, ...), so the reference network is reproduced exactly there; other windows
get the nearest well-defined equivalent. The model is built for ``window`` (the flatten size and
W, b depend on it).

Feature tap (detached, only when a ``features`` dict is passed): ``backbone`` (B, 1024, L_res).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
import torch.nn.functional as F
from torch import nn

from ftin.models.base import VelocityModel, VelocityOutput
from ftin.models.layers.checks import check_input, make_config, require, require_ranges
from ftin.models.registry import ModelCfg, register_model

IN_CHANNELS = 6  # gyro xyz, acc xyz
STEM_CHANNELS = 64
# (out_channels, stride, projected shortcut) per block, in order
BLOCKS: tuple[tuple[int, int, bool], ...] = (
    (64, 1, False), (64, 1, False), (64, 1, True), (64, 1, False),
    (128, 2, True), (128, 1, False), (256, 2, True), (256, 1, False),
    (512, 2, True), (512, 1, False), (1024, 2, True), (1024, 1, False),
)  # fmt: skip


def feature_length(window: int) -> int:
    """Length after the stem, the blocks and the k2 output conv (3 for L = 200)."""
    length = (window + 1) // 2  # conv7/s2
    length = (length + 1) // 2  # maxpool3/s2
    for _, stride, _ in BLOCKS:
        length = (length + stride - 1) // stride
    return length - 1  # conv k2, no padding


# The k2 output conv needs 2 frames: the smallest window that leaves them (65 samples).
MIN_WINDOW = next(w for w in range(1, 4096) if feature_length(w) >= 1)


class DepthwiseSeparableBlock(nn.Module):
    """Depthwise conv3 + BN + ELU, pointwise conv1 + BN + ELU, plus a shortcut, then ELU."""

    def __init__(self, in_channels: int, out_channels: int, stride: int, project: bool) -> None:
        super().__init__()
        if not project and (stride != 1 or in_channels != out_channels):
            raise ValueError("an identity shortcut needs stride 1 and equal channel counts")
        self.depthwise = nn.Conv1d(
            in_channels, in_channels, 3, stride=stride, padding=1, groups=in_channels, bias=False
        )
        self.bn1 = nn.BatchNorm1d(in_channels)
        self.pointwise = nn.Conv1d(in_channels, out_channels, 1, bias=False)
        self.bn2 = nn.BatchNorm1d(out_channels)
        self.activation = nn.ELU()
        self.shortcut: nn.Module = nn.Identity()
        if project:
            self.shortcut = nn.Sequential(
                nn.Conv1d(in_channels, out_channels, 1, stride=stride, bias=False),
                nn.BatchNorm1d(out_channels),
            )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out = self.activation(self.bn1(self.depthwise(x)))
        out = self.activation(self.bn2(self.pointwise(out)))
        return self.activation(out + self.shortcut(x))


class RawInputSkip(nn.Module):
    """The reference's custom layer, ``features - W * raw + b``, with ``raw`` resampled to the features."""

    def __init__(self, size: int) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.randn(1, size))  # reference: standard normal
        self.bias = nn.Parameter(torch.zeros(1, size))

    def forward(self, features: torch.Tensor, raw: torch.Tensor) -> torch.Tensor:
        # (B, 6 L) -> (B, 1, 6 L) -> (B, 1, size) -> (B, size); identity when 6 L == size
        raw = F.adaptive_avg_pool1d(raw.unsqueeze(1), features.shape[1]).squeeze(1)
        return features - self.weight * raw + self.bias


@dataclass(frozen=True)
class IMUNetConfig:
    window: int = 200  # input length L; the flatten size and the custom layer depend on it
    out_dim: int = 2
    head_channels: int = 400  # output conv k2, 1024 -> 400

    def __post_init__(self) -> None:
        require(
            self.window >= MIN_WINDOW,
            "imunet",
            f"window must be >= {MIN_WINDOW} samples (2 frames left for the k2 output conv), "
            f"got {self.window}",
        )
        require_ranges(self, "imunet", {"out_dim": 1, "head_channels": 1})


class IMUNet(VelocityModel):
    """``(B, 6, window) -> velocity (B, out_dim)``."""

    min_window = MIN_WINDOW

    def __init__(self, config: IMUNetConfig) -> None:
        super().__init__(**asdict(config))
        self.window = config.window
        self.stem = nn.Sequential(
            nn.Conv1d(IN_CHANNELS, STEM_CHANNELS, 7, stride=2, padding=3, bias=False),
            nn.BatchNorm1d(STEM_CHANNELS),
            nn.ReLU(),
            nn.MaxPool1d(3, stride=2, padding=1),
        )
        blocks: list[nn.Module] = []
        width = STEM_CHANNELS
        for out_channels, stride, project in BLOCKS:
            blocks.append(DepthwiseSeparableBlock(width, out_channels, stride, project))
            width = out_channels
        self.blocks = nn.Sequential(*blocks)
        self.output_conv = nn.Sequential(
            nn.Conv1d(width, config.head_channels, 2), nn.BatchNorm1d(config.head_channels)
        )
        size = config.head_channels * feature_length(config.window)
        self.raw_skip = RawInputSkip(size)
        self.activation = nn.ELU()
        self.fc = nn.Linear(size, config.out_dim)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        check_input(x, "imunet", window=self.window)
        h = self.blocks(self.stem(x))  # (B, 1024, L_res)
        if features is not None:
            features["backbone"] = h.detach()
        flat = self.output_conv(h).flatten(1)  # (B, 400 * (L_res - 1))
        mixed = self.activation(self.raw_skip(flat, x.flatten(1)))  # raw flattened channel-major (B, 6 L)
        return VelocityOutput(self.fc(mixed))


@register_model(
    "imunet", ModelCfg(IMUNetConfig, window=200, rate_hz=200.0, min_window=MIN_WINDOW), label="IMUNet"
)
def imunet(**cfg) -> IMUNet:
    return IMUNet(make_config(IMUNetConfig, "imunet", cfg))
