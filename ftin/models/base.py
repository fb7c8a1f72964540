"""The one interface every model implements (design §3).

``forward(x, features=None) -> VelocityOutput``

* ``x``: ``(B, 6, L)`` gravity-aligned world-frame IMU window, channels gyro xyz then acc xyz,
  already normalised by the caller.
* returns ``VelocityOutput(velocity (B, D), log_std (B, D) or None)``: the mean world-frame
  velocity over the window in m/s (D = ``out_dim``, 2 for horizontal or 3). Models with an
  uncertainty head (``has_uncertainty = True``) fill ``log_std`` (natural log of the standard
  deviation of the velocity, per axis); all others return ``None``.
* ``features``: when a dict is passed, the model stores named intermediate tensors in it (feature
  taps for the dashboard) during the same forward pass; when ``None`` nothing extra is kept.

Sequence-to-sequence models (RoNIN LSTM/TCN, RNIN) predict per-frame or per-sub-window velocity
internally and return its mean over the window, which is exactly the window's velocity target, so
the same training loop and inference code serve every model.

Window lengths: a model accepts any ``L`` with ``L >= min_window`` and ``L % window_multiple == 0``;
models whose head size depends on ``L`` take ``window`` in their config.
"""

from __future__ import annotations

from typing import NamedTuple

import torch
from torch import nn


class VelocityOutput(NamedTuple):
    velocity: torch.Tensor  # (B, D)
    log_std: torch.Tensor | None = None  # (B, D)


class VelocityModel(nn.Module):
    """Base class: holds the config that rebuilds the model, and the interface attributes."""

    has_uncertainty: bool = False
    min_window: int = 1
    window_multiple: int = 1

    def __init__(self, **config) -> None:
        super().__init__()
        # Everything create_model(name, **config) needs to rebuild this model (saved in checkpoints).
        self.config = dict(config)

    @property
    def out_dim(self) -> int:
        return int(self.config.get("out_dim", 2))

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:  # pragma: no cover
        raise NotImplementedError
