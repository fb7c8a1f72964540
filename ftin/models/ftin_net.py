"""FTIN (Frequency-Time Integration Network) and its ablations, from one class with two switches.

``(B, 6, L) -> ResNet-1D encoder -> (B, C_res, L_res) -> FDL -> (B, C_fre, L_fre) -> sLSTM -> MLP -> (B, D)``
(``L_fre = L_res`` with ``fdl_output = "ordered"``, see Decisions)

| registered name | FDL | sLSTM (TDL) | paper's ablation column |
|---|---|---|---|
| ``resnet1d``   | -   | -   | the ResNet-1D baseline (= RoNIN ResNet's structure) |
| ``resnet_fdl`` | yes | -   | +FDL |
| ``resnet_tdl`` | -   | yes | +TDL |
| ``ftin``       | yes | yes | +FDL&TDL (FTIN) |

A missing stage is simply skipped: without FDL the sLSTM / head see the encoder output
``(B, C_res, L_res)`` (a sequence of L_res steps with C_res features).

Decisions (paper Sec. 2 leaves them open; all are ``FTINConfig`` fields, kept in ``self.config``):

* Encoder = the shared ``ResNet1DBackbone`` (64..512, [2,2,2,2]) + RoNIN's output-block transition
  ``conv1x1 512 -> res_channels (128) + BN``, so ``C_res = 128``. FDL's tensors are
  ``B x d x C_res x L_res``: on all 512 backbone channels FDL alone cost about as much as the whole
  backbone on 2 CPU cores; with 128 (the width RoNIN itself hands its FC head) FTIN stays well above
  half of RoNIN ResNet's throughput. ``res_channels = 0`` feeds FDL the raw 512 channels.
* ``window`` is in the config (default 100: 1 s at 100 Hz, the paper's window = rate): FDL's FC
  flattens ``L_res x d`` and the head flattens the sequence, so sizes depend on
  ``L_res = backbone.output_length(window)``; forward rejects other lengths with the fix.
* FDL: ``embed_dim`` d = 8, one complex layer per axis (``fdl_layers``), ReLU as in FreTS
  (``fdl_activation``, also the FC's), residual on (``fdl_residual``), output ``fre_channels``
  C_fre = 64 x ``fre_length`` L_fre = 8 (``fdl_output = "mixed"``). FDL's cost is linear in d
  (FFTs, copies) plus d^2 (the complex GEMMs); d = 16 measured only 0.60-0.69 of ``ronin_resnet``'s
  speed, too close to the 0.5 floor on a loaded 2-core machine, so d = 8.
* ``fdl_output`` picks the structure of FDL's output FC + activation (``ftin.models.layers.fdl``):

  - ``"mixed"`` (default; every checkpoint saved before the option existed has no key and gets it):
    flatten ``(L_res x d)`` per channel and one FC with the Kronecker-structured weight
    ``kron(fc_channel, fc_time)`` -> ``(B, C_fre, L_fre)``. Its L_fre = 8 "time" slots are learned
    mixtures of all L_res encoder steps, so they have **no time order**: the sLSTM then scans 8
    unordered slots, a learned set more than a sequence.
  - ``"ordered"``: keep the encoder's time axis: each of the L_res steps' ``(C_res x d)`` features go
    through one dense FC ``C_res d -> C_fre`` + activation -> ``(B, C_fre, L_res)``; the sLSTM scans
    the L_res steps in the ResNet encoder's time order (4 at window 100, 7 at 200) and the head
    flattens ``C_fre x L_res``. ``fre_length`` is **unused** in this mode: it is kept in the config
    (so configs round-trip and switching modes needs one key) but ignored, and nothing about it is
    rejected; the effective length is ``self.seq_shape[1]`` / ``self.fdl.out_length``.

  The paper leaves the sLSTM's sequence axis open; which of the two trains better is for validation
  to decide (a checkpoint records the mode in its ``model_kwargs``). Sizes at the defaults, window
  100: FDL's FC 8.5 k (mixed) vs 65.6 k (ordered) weights, the head's first layer 512 vs 256 inputs
  (whole model 4,484,892 vs 4,410,900; window 200: 4,485,084 vs 4,509,204). Like every FDL key,
  ``fdl_output`` has no effect on ``resnet_tdl`` / ``resnet1d``.
* The sLSTM scans **time** (``slstm_axis = "time"``: L_fre steps of C_fre = 64 features). Time is
  the axis of "time-domain learning" and the only one that can be ordered (with ``fdl_output =
  "ordered"``): after FDL's channel FC the channel index has no order, so scanning it would invent
  one; and 4-8 steps keep the unavoidable loop short. ``"channel"`` (C_fre steps of L_fre features)
  is there for experiments.
* sLSTM: ``slstm_blocks`` = 1 residual block, ``slstm_heads`` = 4, gated FFN with projection factor
  4/3, sigmoid forget gate, residuals on, ``slstm_dropout`` 0. The final state is dropped: each
  window is independent, as for every other model behind the same interface.
* Head: RoNIN's FC layout ``(L_seq x C_seq) -> 512 -> 512 -> D``, dropout 0.5, RoNIN's init.
* No uncertainty head by default (``log_std`` is None): the paper trains FTIN with MSE on velocity.
  ``uncertainty_head`` adds a second MLP head on the same sequence (log-std per axis, TLIO's), which a
  shipped checkpoint gains on its frozen network (``TrainConfig.train_only``).

Speed target: at least half of ``ronin_resnet``'s windows/s (``torch.inference_mode``, eval, batch
512, window 100, 2 threads). Measured with these defaults: 0.77-0.81 (FDL ~ +25%, sLSTM ~ +10% on
top of the shared backbone, which dominates). ``fdl_output = "ordered"`` measured the same within
noise (1 thread, best of 10 interleaved rounds: 0.81 vs mixed 0.83): its dense FC costs FDL ~3 ms
more per batch of 512, its sLSTM scans 4 steps instead of 8 (~7 ms less).

Feature taps (``features`` dict; detached; nothing is computed when it is None): ``resnet``
(B, C_res, L_res), the encoder output; with FDL ``fdl_channel_spectrum`` (B, C_res//2+1, L_res, d),
``fdl_temporal_spectrum`` (B, C_res, L_res//2+1, d) (|rfft| right before each complex MLP, d kept)
and ``fdl`` (B, C_fre, L_fre) (L_fre = L_res when ordered); with the sLSTM ``slstm`` (B, steps,
features), the stack's output.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from enum import Enum

import torch
from torch import nn

from ftin.models.base import VelocityModel, VelocityOutput
from ftin.models.layers.fdl import FDLOutput, FrequencyDomainLearning, parse_activation, parse_fdl_output
from ftin.models.layers.heads import MLPHead
from ftin.models.layers.resnet1d import ResNet1DBackbone, init_resnet_weights
from ftin.models.layers.slstm import ForgetGate, SLSTMStack
from ftin.models.registry import ModelCfg, register_model


class ScanAxis(str, Enum):
    TIME = "time"  # sequence of L steps, C features
    CHANNEL = "channel"  # sequence of C steps, L features


# FTIN's full structure (ResNet -> FDL -> sLSTM -> head) at a few thousand parameters: for tests, the
# load test's --tiny mode and quick experiments. Add a ``window``; 25-100 samples work.
TINY_FTIN_KWARGS: dict[str, object] = {
    "resnet_channels": (8, 16),
    "resnet_blocks": (1, 1),
    "res_channels": 16,
    "embed_dim": 4,
    "fre_channels": 8,
    "fre_length": 4,
    "slstm_heads": 2,
    "head_hidden": (16,),
}


@dataclass
class FTINConfig:
    window: int = 100
    out_dim: int = 2
    resnet_channels: tuple[int, ...] = (64, 128, 256, 512)
    resnet_blocks: tuple[int, ...] = (2, 2, 2, 2)
    res_channels: int = 128
    embed_dim: int = 8
    fdl_layers: int = 1
    fdl_activation: str = "relu"
    fdl_residual: bool = True
    fdl_output: str = "mixed"  # FDLOutput: "mixed" (L_fre unordered slots) or "ordered" (L_res steps)
    fre_channels: int = 64
    fre_length: int = 8  # L_fre with fdl_output "mixed"; unused with "ordered" (L_fre = L_res)
    slstm_axis: str = "time"
    slstm_blocks: int = 1
    slstm_heads: int = 4
    slstm_proj_factor: float = 4 / 3
    slstm_forget_gate: str = "sigmoid"
    slstm_residual: bool = True
    slstm_dropout: float = 0.0
    head_hidden: tuple[int, ...] = (512, 512)
    head_dropout: float = 0.5
    uncertainty_head: bool = False  # a log-std head beside the velocity head (module docstring)

    def __post_init__(self) -> None:
        # JSON checkpoints hand back lists; keep tuples so configs compare equal and stay immutable.
        self.resnet_channels = tuple(int(c) for c in self.resnet_channels)
        self.resnet_blocks = tuple(int(b) for b in self.resnet_blocks)
        self.head_hidden = tuple(int(h) for h in self.head_hidden)
        if self.res_channels < 0:
            raise ValueError(f"res_channels must be >= 0 (0: no transition conv), got {self.res_channels}")
        if self.window < 1:
            raise ValueError(f"window must be >= 1 samples, got {self.window}")
        if self.out_dim not in (2, 3):
            raise ValueError(f"out_dim must be 2 (horizontal) or 3, got {self.out_dim}")
        if len(self.resnet_channels) != len(self.resnet_blocks):
            raise ValueError(
                f"resnet_channels {self.resnet_channels} and resnet_blocks {self.resnet_blocks} "
                "need the same length"
            )
        parse_activation(self.fdl_activation, "fdl_activation")
        parse_fdl_output(self.fdl_output, "fdl_output")
        try:
            ScanAxis(self.slstm_axis)
            ForgetGate(self.slstm_forget_gate)
        except ValueError as error:
            raise ValueError(
                f"{error}; slstm_axis must be 'time' or 'channel', slstm_forget_gate 'sigmoid' or 'exp'"
            ) from None


# window 100: 1 s at 100 Hz (the paper's window = rate); built for it, see the module docstring.
FTIN_CFG = ModelCfg(FTINConfig, window=100, rate_hz=100.0)


@register_model("ftin", FTIN_CFG, label="FTIN")
class FTIN(VelocityModel):
    """FTIN: ResNet-1D -> FDL -> sLSTM -> MLP head; subclasses switch ``use_fdl`` / ``use_tdl`` off."""

    use_fdl: bool = True
    use_tdl: bool = True

    def __init__(self, **config) -> None:
        names = {f.name for f in fields(FTINConfig)}
        unknown = sorted(set(config) - names)
        if unknown:
            raise TypeError(f"unknown {type(self).__name__} config {unknown}; valid keys: {sorted(names)}")
        cfg = FTINConfig(**config)
        super().__init__(**{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(cfg).items()})
        self.cfg = cfg
        strides = (1,) + (2,) * (len(cfg.resnet_channels) - 1)  # RoNIN: stride 2 from the second group
        self.backbone = ResNet1DBackbone(6, cfg.resnet_channels, cfg.resnet_blocks, strides)
        self.res_length = self.backbone.output_length(cfg.window)
        self.transition: nn.Module = nn.Identity()
        c_res = self.backbone.out_channels
        if cfg.res_channels:
            # RoNIN's output-block conv (512 -> 128 + BN): the encoder output FDL works on.
            self.transition = nn.Sequential(
                nn.Conv1d(c_res, cfg.res_channels, 1, bias=False), nn.BatchNorm1d(cfg.res_channels)
            )
            init_resnet_weights(self.transition)
            c_res = cfg.res_channels

        self.fdl: FrequencyDomainLearning | None = None
        seq_channels, seq_length = c_res, self.res_length
        if self.use_fdl:
            self.fdl = FrequencyDomainLearning(
                c_res,
                self.res_length,
                cfg.embed_dim,
                cfg.fre_channels,
                cfg.fre_length,
                cfg.fdl_layers,
                cfg.fdl_activation,
                cfg.fdl_residual,
                output=FDLOutput(cfg.fdl_output),  # "ordered" ignores fre_length: L_fre = L_res
            )
            seq_channels, seq_length = cfg.fre_channels, self.fdl.out_length
        self.seq_shape = (seq_channels, seq_length)  # (C, L) of the sequence the sLSTM / head see

        self.scan_axis = ScanAxis(cfg.slstm_axis)
        self.slstm: SLSTMStack | None = None
        if self.use_tdl:
            dim = seq_channels if self.scan_axis is ScanAxis.TIME else seq_length
            if dim % cfg.slstm_heads != 0:
                raise ValueError(
                    f"slstm_heads ({cfg.slstm_heads}) must divide the sLSTM feature size {dim} "
                    f"({'fre_channels' if self.scan_axis is ScanAxis.TIME else 'the sequence length'})"
                )
            self.slstm = SLSTMStack(
                dim,
                cfg.slstm_blocks,
                heads=cfg.slstm_heads,
                proj_factor=cfg.slstm_proj_factor,
                dropout=cfg.slstm_dropout,
                forget_gate=cfg.slstm_forget_gate,
                residual=cfg.slstm_residual,
            )
        self.head = MLPHead(seq_channels * seq_length, cfg.out_dim, cfg.head_hidden, cfg.head_dropout)
        init_resnet_weights(self.head)
        self.has_uncertainty = cfg.uncertainty_head
        if cfg.uncertainty_head:
            self.log_std_head = MLPHead(
                seq_channels * seq_length, cfg.out_dim, cfg.head_hidden, cfg.head_dropout
            )
            init_resnet_weights(self.log_std_head)

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        if x.dim() != 3 or x.shape[1] != 6:
            raise ValueError(f"{type(self).__name__} input must be (B, 6, L), got {tuple(x.shape)}")
        window = x.shape[-1]
        if self.backbone.output_length(window) != self.res_length:  # lengths with the same L_res are fine
            raise ValueError(
                f"{type(self).__name__} was built for window {self.cfg.window} (L_res {self.res_length}), "
                f"got L = {window} (L_res {self.backbone.output_length(window)}); "
                f"rebuild it with window={window}"
            )
        seq = self.transition(self.backbone(x))  # (B, 512, L_res) -> (B, C_res, L_res)
        if features is not None:
            features["resnet"] = seq.detach()
        if self.fdl is not None:
            seq = self.fdl(seq, features)  # (B, C_fre, L_fre); L_fre = L_res when ordered
            if features is not None:
                features["fdl"] = seq.detach()
        if self.slstm is not None:
            time_major = self.scan_axis is ScanAxis.TIME
            seq = seq.transpose(1, 2) if time_major else seq  # (B, steps, features)
            seq, _ = self.slstm(seq)  # (B, steps, features); one window, so a fresh state each call
            if features is not None:
                features["slstm"] = seq.detach()
        log_std = self.log_std_head(seq) if self.has_uncertainty else None
        return VelocityOutput(self.head(seq), log_std)  # heads flatten (B, ...) -> (B, D)


@register_model("resnet_fdl", FTIN_CFG, label="ResNet + FDL")
class ResNetFDL(FTIN):
    """Ablation +FDL: ResNet-1D encoder -> FDL -> MLP head."""

    use_tdl = False


@register_model("resnet_tdl", FTIN_CFG, label="ResNet + TDL")
class ResNetTDL(FTIN):
    """Ablation +TDL: ResNet-1D encoder -> sLSTM over its L_res steps -> MLP head."""

    use_fdl = False


@register_model("resnet1d", FTIN_CFG, label="ResNet-1D")
class ResNet1D(FTIN):
    """Ablation baseline: ResNet-1D encoder -> MLP head (RoNIN ResNet's structure)."""

    use_fdl = False
    use_tdl = False
