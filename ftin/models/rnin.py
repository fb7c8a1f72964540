"""RNIN's network (Chen et al., ISMAR 2021, "RNIN-VIO"): a ResNet encoder per 1 s sub-window and an
LSTM over the sequence of sub-windows, with mean and log-std heads.

Structure as the public reference (100 Hz, 1 s sub-windows of 100 samples): conv7/s2 + BN + ReLU with
no maxpool, ResBlocks [2, 2, 2, 2] (64..512), 1x1 conv 512 -> 128 + BN, flatten (128 x 7 = 896),
LSTM(896 -> 256, 1 layer), then two heads per sub-window, each FC 256 -> 256 -> 256 -> 3 (ReLU,
dropout 0.2). 5,358,342 parameters with 3 outputs; the count does not depend on how many sub-windows
the LSTM sees, only on ``sub_window`` (which sets the flatten size).

Decisions:
* The reference feeds (B, 10, 6, 100): 10 consecutive, non-overlapping 1 s windows, one displacement
  (and log-std) per window. Here the input is one window (B, 6, L) with L a multiple of ``sub_window``;
  it is cut into L / sub_window consecutive sub-windows that the LSTM runs over (zero initial state per
  window, as the reference starts every sequence of 10). The layer sizes do not depend on L, so
  ``window`` is not in the config: ``--window 10*rate --stride 0.1*rate`` with ``sub_window = rate``
  (``--model-kwargs '{"sub_window": 100}'`` at 100 Hz) reproduces the reference's sequences of ten 1 s
  sub-windows every 0.1 s. With one sub-window the LSTM sees one step and the network reduces to a
  ResNet + LSTM cell + heads: short windows give it no sequence to exploit.
* Parts (``ftin.models.base``): ``target_parts(L) = L / sub_window``; ``forward_parts`` returns each
  sub-window's velocity (its displacement / its duration) and log-std, (B, n, D). Training supervises
  every sub-window with the reference's loss (``train_loss = "rnin_displacement"``: per-sub-window
  displacement error plus 8 x the error of their cumulative sum, ``ftin.train.losses``), and inference
  uses, as the reference's test, only the last sub-window of every window after the first
  (``ftin.infer``). ``forward`` returns the mean over the sub-windows, which equals the whole window's
  displacement / duration, i.e. the window's velocity (for the dashboard and generic callers).
* Uncertainty: each sub-window's head gives a log-std s_i of its velocity. ``forward`` treats the n
  estimates as independent: the mean has variance sum(exp(2 s_i)) / n**2, so its
  ``log_std = 0.5 * logsumexp(2 s) - log n`` (exactly s for a single sub-window). The reference's
  default configuration never trains the covariance (its NLL starts after more epochs than it runs),
  and neither does its loss here; the head is kept for parity of structure and parameter count.
* LSTM initialisation as the reference: orthogonal weights, zero biases, forget-gate bias 1.

Feature taps (detached, only when a ``features`` dict is passed): ``backbone`` (B, n, 128, L_res), the
encoder code of every sub-window, ``per_window_velocity`` and ``per_window_log_std`` (B, n, D).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import nn

from ftin.models.base import VelocityModel, VelocityOutput
from ftin.models.layers.checks import check_input, make_config, require_ranges
from ftin.models.layers.heads import MLPHead
from ftin.models.layers.resnet1d import ResNet1DBackbone, init_resnet_weights
from ftin.models.registry import ModelCfg, Parts, Windows, register_model

IN_CHANNELS = 6  # gyro xyz, acc xyz


@dataclass(frozen=True)
class RNINConfig:
    sub_window: int = 100  # samples per LSTM step (1 s at the reference's 100 Hz); sets the flatten size
    out_dim: int = 3
    trans_channels: int = 128
    lstm_size: int = 256
    lstm_layers: int = 1
    fc_dim: int = 256
    dropout: float = 0.2

    def __post_init__(self) -> None:
        require_ranges(self, "rnin", {"sub_window": 1, "out_dim": 1, "lstm_layers": 1}, ("dropout",))


class RNINNet(VelocityModel):
    """``(B, 6, n * sub_window) -> VelocityOutput(velocity (B, D), log_std (B, D))``."""

    has_uncertainty = True
    train_loss = "rnin_displacement"

    def __init__(self, config: RNINConfig) -> None:
        super().__init__(**asdict(config))
        self.sub_window = config.sub_window
        self.min_window = config.sub_window
        self.window_multiple = config.sub_window
        self.backbone = ResNet1DBackbone(IN_CHANNELS, stem_maxpool=False)
        self.transition = nn.Sequential(
            nn.Conv1d(self.backbone.out_channels, config.trans_channels, 1, bias=False),
            nn.BatchNorm1d(config.trans_channels),
        )
        code_size = config.trans_channels * self.backbone.output_length(config.sub_window)
        self.lstm = nn.LSTM(code_size, config.lstm_size, config.lstm_layers, batch_first=True)
        hidden = (config.fc_dim, config.fc_dim)
        self.mean_head = MLPHead(config.lstm_size, config.out_dim, hidden=hidden, dropout=config.dropout)
        self.log_std_head = MLPHead(config.lstm_size, config.out_dim, hidden=hidden, dropout=config.dropout)
        init_resnet_weights(self)
        self._init_lstm()

    def _init_lstm(self) -> None:
        for name, param in self.lstm.named_parameters():
            if name.startswith("weight"):
                nn.init.orthogonal_(param)
            else:
                nn.init.zeros_(param)
                if name.startswith("bias_hh"):  # gate order i, f, g, o: remember by default
                    size = param.shape[0] // 4
                    nn.init.ones_(param[size : 2 * size])

    def target_parts(self, window: int) -> int:
        """One part per sub-window."""
        if window < self.sub_window or window % self.sub_window:
            raise ValueError(f"rnin: window {window} is not a multiple of sub_window {self.sub_window}")
        return window // self.sub_window

    def forward_parts(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        """``(B, 6, n * sub_window) -> velocity, log_std (B, n, D)``: one per sub-window."""
        length = check_input(x, "rnin", min_window=self.min_window, window_multiple=self.window_multiple)
        batch, n = x.shape[0], length // self.sub_window
        # (B, 6, n * S) -> (B, 6, n, S) -> (B, n, 6, S) -> (B * n, 6, S): one ResNet pass per sub-window
        subs = x.reshape(batch, IN_CHANNELS, n, self.sub_window).transpose(1, 2)
        subs = subs.reshape(batch * n, IN_CHANNELS, self.sub_window)
        code = self.transition(self.backbone(subs))  # (B * n, 128, L_res)
        hidden, _ = self.lstm(code.reshape(batch, n, -1))  # (B, n, lstm_size), zero initial state
        flat = hidden.reshape(batch * n, -1)
        velocity = self.mean_head(flat).reshape(batch, n, -1)  # (B, n, D)
        log_std = self.log_std_head(flat).reshape(batch, n, -1)  # (B, n, D)
        if features is not None:
            features["backbone"] = code.reshape(batch, n, *code.shape[1:]).detach()  # (B, n, 128, L_res)
            features["per_window_velocity"] = velocity.detach()
            features["per_window_log_std"] = log_std.detach()
        return VelocityOutput(velocity, log_std)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        parts = self.forward_parts(x, features)  # (B, n, D)
        n = parts.velocity.shape[1]
        mean_log_std = 0.5 * torch.logsumexp(2.0 * parts.log_std, dim=1) - math.log(n)  # (B, D)
        return VelocityOutput(parts.velocity.mean(dim=1), mean_log_std)


def rnin_train_options(rate_hz: int) -> dict[str, Any]:
    """RNIN's reference recipe: sequences of ten 1 s sub-windows through its LSTM, 32 sequences a
    batch, its displacement loss without the NLL (``mse``: the reference never reaches the NLL)."""
    return {"window": 10 * rate_hz, "batch_size": 32, "loss": "mse", "model_kwargs": {"sub_window": rate_hz}}


@register_model(
    "rnin",
    ModelCfg(
        RNINConfig,
        window=100,  # one 1 s sub-window; the reference's sequences of ten: window 10 * sub_window
        rate_hz=100.0,
        windows=Windows.MULTIPLE,
        window_multiple="sub_window",
        uncertainty=True,
        parts=Parts.SUB_WINDOW,
        train_loss="rnin_displacement",
    ),
    label="RNIN",
    train_options=rnin_train_options,
)
def rnin(**cfg) -> RNINNet:
    return RNINNet(make_config(RNINConfig, "rnin", cfg))
