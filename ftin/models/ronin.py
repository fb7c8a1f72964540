"""The three RoNIN baselines (Herath et al., ICRA 2020): ResNet-1D, bilinear LSTM and TCN.

Re-implemented from the structure of the public reference code; parameter counts of the default
configurations equal the reference's at 6 x 200 input and 2 outputs (tests/models/test_param_counts.py).

* ``ronin_resnet``: conv7/s2 + BN + ReLU + maxpool, BasicBlock1D groups [2, 2, 2, 2] with 64..512
  channels, head 1x1 conv 512 -> 128 + BN, flatten, FC 128 * L_res -> 512 -> 512 -> out (ReLU,
  dropout 0.5). 4,634,882 parameters. The head is sized for ``window``; the reference computes
  L_res as ``window // 32 + 1``, which is wrong when the window is a multiple of 32, so we take the
  backbone's true output length (the same 7 for L = 200).
* ``ronin_lstm``: per frame, a bilinear layer mixes the 6 inputs into 24 features, concatenated with
  the input (30) -> 3-layer LSTM(100) -> concat with its input (130) -> Linear 10 -> Linear out
  (no activation between the two linears, as the reference). 216,620 parameters.
* ``ronin_tcn``: causal TCN, kernel 3, channels [32, 64, 128, 256, 72, 36], dilation 2**i, weight norm,
  PReLU, dropout 0.2, then dropout + 1x1 conv to out. Receptive field 253 frames. 540,488 parameters.

LSTM and TCN are sequence-to-sequence, as in the reference (``ronin_lstm_tcn.py``): one velocity per
frame, frame t's being the velocity over ``[t[t], t[t+1]]``. Decisions (interfaces in
``ftin.models.base``):
* Parts: one per frame, ``target_parts(L) = L``; ``forward_parts`` returns the per-frame velocity
  ``(B, L, D)``. Training runs on chunks of ``window`` frames (the reference's 400 every 100 frames:
  ``--window 400 --stride 100``) from zero state, with the reference's ``GlobalPosLoss`` on the
  cumulative sum of the per-frame velocities (``ftin.train.losses``): the whole chunk for the LSTM
  (``train_loss = "ronin_position_full"``), displacements over ``history = receptive field`` frames
  for the TCN (``"ronin_position_part"``; capped at ``window - 2`` for chunks shorter than 255).
* Streaming (``streams = True``): inference runs the whole recording through ``forward_stream`` in
  chunks, which equals the reference's single pass over the sequence (``network(feat)``). The state
  is the LSTM's ``(h, c)``; for the causal TCN, the last ``receptive_field - 1`` input frames (the
  chunk is convolved after them and only its own frames are kept, so every output sees exactly the
  inputs a whole-sequence pass would; ``None`` at the start, where the layers' zero padding applies).
* ``forward`` returns the mean of the per-frame velocities over the window: the displacement over the
  window divided by its duration, i.e. the window's velocity (dashboard, benchmark, generic callers).
  The LSTM is unidirectional and the TCN causal, so early frames of a window see less context,
  exactly as in the reference's training chunks.

Feature taps (detached, only when a ``features`` dict is passed): ``backbone`` (B, 512, L_res) for the
ResNet, ``per_frame_velocity`` (B, L, D) for the LSTM and the TCN.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import torch
from torch import nn

from ftin.models.base import VelocityModel, VelocityOutput
from ftin.models.layers.checks import check_input, make_config, require, require_ranges
from ftin.models.layers.conv_head import ConvFlattenHead
from ftin.models.layers.resnet1d import ResNet1DBackbone, init_resnet_weights
from ftin.models.layers.tcn import TemporalConvNet
from ftin.models.registry import ModelCfg, ModelFactory, Parts, Windows, register_model

IN_CHANNELS = 6  # gyro xyz, acc xyz


# ---------------------------------------------------------------------------------------- ResNet-1D
@dataclass(frozen=True)
class RoninResNetConfig:
    window: int = 200  # input length L; the FC head's input size depends on it
    out_dim: int = 2
    blocks_per_group: tuple[int, ...] = (2, 2, 2, 2)  # RoNIN's "resnet18"; (3, 4, 6, 3) is its "resnet50"
    trans_channels: int = 128  # 1x1 transition conv before the flatten
    fc_dim: int = 512
    dropout: float = 0.5
    uncertainty_head: bool = False  # a log-std head beside the velocity head, TLIO's (its docstring)

    def __post_init__(self) -> None:
        object.__setattr__(self, "blocks_per_group", tuple(int(n) for n in self.blocks_per_group))
        require_ranges(self, "ronin_resnet", {"window": 1, "out_dim": 1})
        require(
            len(self.blocks_per_group) == 4 and min(self.blocks_per_group) >= 1,
            "ronin_resnet",
            f"blocks_per_group needs 4 positive counts, got {self.blocks_per_group}",
        )


class FixedWindowResNet(VelocityModel):
    """RoNIN's ResNet-1D backbone on windows of one length, and ``ConvFlattenHead`` heads sized for that
    length (RoNIN ResNet has one, TLIO a mean and a log-std head). Feature tap: ``backbone``.

    ``config``: a config dataclass with ``window``, ``out_dim``, ``trans_channels``, ``fc_dim`` and
    ``dropout`` (``RoninResNetConfig``, ``TLIOConfig``).
    """

    model_name: ClassVar[str]  # for the input checks' messages

    def __init__(self, config: Any, blocks_per_group: Sequence[int] = (2, 2, 2, 2)) -> None:
        super().__init__(**asdict(config))
        self.window = config.window
        self.backbone = ResNet1DBackbone(IN_CHANNELS, blocks_per_group=blocks_per_group)

    def _head(self, config: Any) -> ConvFlattenHead:
        """A head for the backbone's output at ``window``: ``out_dim``, ``trans_channels``, two hidden
        layers of ``fc_dim`` and ``dropout`` from the config."""
        return ConvFlattenHead(
            self.backbone.out_channels,
            self.backbone.output_length(config.window),
            config.out_dim,
            trans_channels=config.trans_channels,
            hidden=(config.fc_dim, config.fc_dim),
            dropout=config.dropout,
        )

    def _encode(self, x: torch.Tensor, features: dict | None) -> torch.Tensor:
        """``(B, 6, window) -> (B, 512, L_res)``, the backbone's output."""
        check_input(x, self.model_name, window=self.window)
        h = self.backbone(x)
        if features is not None:
            features["backbone"] = h.detach()
        return h


class RoninResNet(FixedWindowResNet):
    """RoNIN ResNet-1D: ``(B, 6, window) -> velocity (B, out_dim)``; with ``uncertainty_head`` also a
    log-std per axis from a second head on the same backbone output (as TLIO's), so a shipped RoNIN
    checkpoint can gain a variance head trained on its frozen backbone (``TrainConfig.train_only``)."""

    model_name = "ronin_resnet"

    def __init__(self, config: RoninResNetConfig) -> None:
        super().__init__(config, config.blocks_per_group)
        self.head = self._head(config)
        self.has_uncertainty = config.uncertainty_head
        if config.uncertainty_head:
            self.log_std_head = self._head(config)
        init_resnet_weights(self)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        h = self._encode(x, features)
        if self.has_uncertainty:
            return VelocityOutput(self.head(h), self.log_std_head(h))  # (B, D), (B, D)
        return VelocityOutput(self.head(h))  # (B, D)


@register_model("ronin_resnet", ModelCfg(RoninResNetConfig, window=200, rate_hz=200.0), label="RoNIN ResNet")
def ronin_resnet(**cfg) -> RoninResNet:
    return RoninResNet(make_config(RoninResNetConfig, "ronin_resnet", cfg))


# ------------------------------------------------------------------------------------ bilinear LSTM
def sequence_train_options(rate_hz: int) -> dict[str, Any]:
    """RoNIN's LSTM and TCN reference recipe, at any rate: 400-frame chunks, 72 a batch."""
    return {"window": 400, "batch_size": 72}


def register_sequence_model(
    name: str, config: type, train_loss: str, label: str
) -> Callable[[ModelFactory], ModelFactory]:
    """Register one of RoNIN's sequence-to-sequence models: any length, one velocity per frame,
    streaming; by default the reference's 400-frame training chunks (``--window 400 --stride 100``)
    of 200 Hz data; trained with ``sequence_train_options``."""
    contract = ModelCfg(
        config,
        window=400,
        rate_hz=200.0,
        windows=Windows.ANY,
        parts=Parts.FRAME,
        streams=True,
        train_loss=train_loss,
    )
    return register_model(name, contract, label=label, train_options=sequence_train_options)


@dataclass(frozen=True)
class RoninLSTMConfig:
    out_dim: int = 2
    hidden_size: int = 100
    num_layers: int = 3
    lstm_dropout: float = 0.0  # between LSTM layers (reference default 0)

    def __post_init__(self) -> None:
        require_ranges(
            self, "ronin_lstm", {"out_dim": 1, "hidden_size": 1, "num_layers": 1}, ("lstm_dropout",)
        )


class PerFrameModel(VelocityModel):
    """Sequence to sequence: one part per frame (``forward_parts``), ``forward`` their mean."""

    streams = True

    def _window_frames(self, x: torch.Tensor) -> torch.Tensor:  # pragma: no cover
        """``(B, 6, L) -> (B, L, D)`` per-frame velocity of one window from a fresh state."""
        raise NotImplementedError

    def target_parts(self, window: int) -> int:
        return window

    def forward_parts(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        per_frame = self._window_frames(x)  # (B, L, D)
        if features is not None:
            features["per_frame_velocity"] = per_frame.detach()
        return VelocityOutput(per_frame)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        return VelocityOutput(self.forward_parts(x, features).velocity.mean(dim=1))  # (B, D)


class RoninLSTM(PerFrameModel):
    """RoNIN bilinear LSTM: per-frame velocity from a unidirectional LSTM (sequence to sequence)."""

    train_loss = "ronin_position_full"

    def __init__(self, config: RoninLSTMConfig) -> None:
        super().__init__(**asdict(config))
        mixed = IN_CHANNELS * 5  # input ++ bilinear(input, input) with 4x the input's width
        self.bilinear = nn.Bilinear(IN_CHANNELS, IN_CHANNELS, IN_CHANNELS * 4)
        self.lstm = nn.LSTM(
            mixed, config.hidden_size, config.num_layers, batch_first=True, dropout=config.lstm_dropout
        )
        self.linear1 = nn.Linear(config.hidden_size + mixed, config.out_dim * 5)
        self.linear2 = nn.Linear(config.out_dim * 5, config.out_dim)

    def _per_frame(self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor] | None):
        check_input(x, "ronin_lstm")
        frames = x.transpose(1, 2)  # (B, T, 6)
        mixed = torch.cat([frames, self.bilinear(frames, frames)], dim=2)  # (B, T, 30)
        hidden, new_state = self.lstm(mixed, state)  # (B, T, hidden); state None: zeros
        per_frame = self.linear2(self.linear1(torch.cat([mixed, hidden], dim=2)))  # (B, T, D)
        return per_frame, new_state

    def _window_frames(self, x: torch.Tensor) -> torch.Tensor:
        return self._per_frame(x, None)[0]  # (B, L, D), zero initial state per window

    def forward_stream(
        self, x: torch.Tensor, state: tuple[torch.Tensor, torch.Tensor] | None = None
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor]]:
        """``(B, 6, T)``, LSTM ``(h, c)`` or None -> per-frame velocity ``(B, T, D)``, new ``(h, c)``."""
        return self._per_frame(x, state)


@register_sequence_model("ronin_lstm", RoninLSTMConfig, "ronin_position_full", label="RoNIN LSTM")
def ronin_lstm(**cfg) -> RoninLSTM:
    return RoninLSTM(make_config(RoninLSTMConfig, "ronin_lstm", cfg))


# ---------------------------------------------------------------------------------------------- TCN
@dataclass(frozen=True)
class RoninTCNConfig:
    out_dim: int = 2
    channels: tuple[int, ...] = (32, 64, 128, 256, 72, 36)
    kernel_size: int = 3
    dropout: float = 0.2

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", tuple(int(c) for c in self.channels))
        require_ranges(self, "ronin_tcn", {"out_dim": 1, "kernel_size": 2}, ("dropout",))
        require(
            len(self.channels) >= 1 and min(self.channels) >= 1,
            "ronin_tcn",
            f"channels needs at least one positive width, got {self.channels}",
        )


class RoninTCN(PerFrameModel):
    """RoNIN TCN: per-frame velocity from a causal TCN (sequence to sequence)."""

    train_loss = "ronin_position_part"

    def __init__(self, config: RoninTCNConfig) -> None:
        super().__init__(**asdict(config))
        self.tcn = TemporalConvNet(IN_CHANNELS, config.channels, config.kernel_size, config.dropout)
        self.output_dropout = nn.Dropout(config.dropout)
        self.output_layer = nn.Conv1d(self.tcn.out_channels, config.out_dim, 1)
        nn.init.normal_(self.output_layer.weight, 0.0, 0.01)
        nn.init.normal_(self.output_layer.bias, 0.0, 0.001)

    @property
    def receptive_field(self) -> int:
        return self.tcn.receptive_field

    def _per_frame(self, x: torch.Tensor) -> torch.Tensor:
        check_input(x, "ronin_tcn")
        return self.output_layer(self.output_dropout(self.tcn(x))).transpose(1, 2)  # (B, L, D)

    def _window_frames(self, x: torch.Tensor) -> torch.Tensor:
        return self._per_frame(x)  # (B, L, D)

    def forward_stream(
        self, x: torch.Tensor, state: torch.Tensor | None = None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """``(B, 6, T)``, the previous ``<= receptive_field - 1`` input frames ``(B, 6, H)`` or None
        -> per-frame velocity ``(B, T, D)``, the new history."""
        length = check_input(x, "ronin_tcn")
        full = x if state is None else torch.cat([state, x], dim=2)  # (B, 6, H + T)
        per_frame = self._per_frame(full)[:, full.shape[2] - length :]  # (B, T, D): the chunk's frames
        keep = self.receptive_field - 1
        history = full[:, :, max(full.shape[2] - keep, 0) :].contiguous()  # (B, 6, <= keep)
        return per_frame, history


@register_sequence_model("ronin_tcn", RoninTCNConfig, "ronin_position_part", label="RoNIN TCN")
def ronin_tcn(**cfg) -> RoninTCN:
    return RoninTCN(make_config(RoninTCNConfig, "ronin_tcn", cfg))
