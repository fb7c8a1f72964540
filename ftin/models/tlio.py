"""TLIO's network (Liu et al., RA-L 2020): the RoNIN ResNet-1D backbone with two heads, mean and log-std.

Structure as the public reference: conv7/s2 + BN + ReLU + maxpool, BasicBlock1D groups [2, 2, 2, 2]
(64..512), then two identical, independent heads, each 1x1 conv 512 -> 128 + BN, flatten,
FC 128 * L_res -> 512 -> 512 -> 3 (ReLU, dropout 0.5). 5,424,646 parameters at 6 x 200 with 3 outputs.

Decisions:
* TLIO predicts the 3-D displacement over its 1 s window and the log-std of that displacement. Here
  the same structure predicts the window's mean velocity (displacement / window duration) and the
  log-std of that velocity, so it shares the training loop and inference with every other model.
  For TLIO's 1 s window the two are numerically the same quantity.
* ``out_dim`` defaults to 3 as TLIO (3-D); pass ``out_dim=2`` for horizontal-only datasets.
* ``log_std`` is returned raw (natural log of the standard deviation, per axis). TLIO clamps it and
  detaches it during the first epochs inside its loss; that belongs to the loss, not ``forward``.
* The heads' flatten size depends on the window, so the model is built for ``window`` (default 200,
  TLIO's 1 s at 200 Hz); L_res is the backbone's true output length (7 for 200).

Feature tap (detached, only when a ``features`` dict is passed): ``backbone`` (B, 512, L_res).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch

from ftin.models.base import VelocityOutput
from ftin.models.layers.checks import make_config, require_ranges
from ftin.models.layers.resnet1d import init_resnet_weights
from ftin.models.registry import ModelCfg, register_model
from ftin.models.ronin import FixedWindowResNet


@dataclass(frozen=True)
class TLIOConfig:
    window: int = 200  # input length L; both heads' input size depends on it
    out_dim: int = 3
    trans_channels: int = 128
    fc_dim: int = 512
    dropout: float = 0.5

    def __post_init__(self) -> None:
        require_ranges(self, "tlio", {"window": 1, "out_dim": 1}, ("dropout",))


class TLIONet(FixedWindowResNet):
    """``(B, 6, window) -> VelocityOutput(velocity (B, D), log_std (B, D))``."""

    has_uncertainty = True
    model_name = "tlio"

    def __init__(self, config: TLIOConfig) -> None:
        super().__init__(config)
        self.mean_head = self._head(config)
        self.log_std_head = self._head(config)
        init_resnet_weights(self)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        h = self._encode(x, features)  # (B, 512, L_res)
        return VelocityOutput(self.mean_head(h), self.log_std_head(h))  # (B, D), (B, D)


def tlio_train_options(rate_hz: int) -> dict[str, Any]:
    """TLIO's reference trains MSE first, then its Gaussian NLL: here after 5 epochs (< the earliest
    early stop), at any rate."""
    return {"nll_warmup_epochs": 5}


@register_model(
    "tlio",
    ModelCfg(TLIOConfig, window=200, rate_hz=200.0, uncertainty=True),
    label="TLIO",
    train_options=tlio_train_options,
)
def tlio(**cfg) -> TLIONet:
    return TLIONet(make_config(TLIOConfig, "tlio", cfg))
