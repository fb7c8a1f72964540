"""The one interface every model implements (``docs/design.md``, "Models").

``forward(x, features=None) -> VelocityOutput``

* ``x``: ``(B, 6, L)`` gravity-aligned world-frame IMU window, channels gyro xyz then acc xyz,
  already normalised by the caller.
* returns ``VelocityOutput(velocity (B, D), log_std (B, D) or None)``: the mean world-frame
  velocity over the window in m/s (D = ``out_dim``, 2 for horizontal or 3). Models with an
  uncertainty head (``has_uncertainty = True``) fill ``log_std`` (natural log of the standard
  deviation of the velocity, per axis); all others return ``None``.
* ``features``: when a dict is passed, the model stores named intermediate tensors in it (feature
  taps for the dashboard) during the same forward pass; when ``None`` nothing extra is kept.

``forward`` is what the dashboard, the benchmark and every generic caller use. Training and
inference use two finer interfaces, so that the sequence-to-sequence baselines train and run as
their reference code does:

* Parts. ``target_parts(L) -> K`` (default 1) and ``forward_parts(x) -> VelocityOutput`` with
  velocity ``(B, K, D)`` (log_std ``(B, K, D)`` or None): the mean velocity of each of K equal,
  consecutive parts of the window, part k spanning samples ``[k L/K, (k+1) L/K]``. The default is
  ``forward`` with K = 1. RNIN has one part per sub-window, RoNIN's LSTM and TCN one per frame.
  ``forward`` of a multi-part model returns the mean over its parts, which is the window's velocity.
* Streaming (``streams = True``, the sequence-to-sequence RoNIN LSTM and TCN):
  ``forward_stream(x (B, 6, T), state) -> (velocity (B, T, D), new_state)`` gives one velocity per
  frame (frame t: the velocity over ``[t[t], t[t+1]]``) and carries what the next chunk needs
  (``state = None`` at the start of a sequence). Feeding a sequence in chunks gives the same
  per-frame output as one pass over the whole sequence; inference runs the whole recording this way.
* ``train_loss``: the name of the loss in ``ftin.train.losses`` this family trains with, as its
  reference does (losses live outside ``forward``): ``"velocity"`` (window MSE / NLL),
  ``"rnin_displacement"``, ``"ronin_position_full"`` or ``"ronin_position_part"``.

Window lengths: a model accepts any ``L`` with ``L >= min_window`` and ``L % window_multiple == 0``;
models whose head size depends on ``L`` take ``window`` in their config. Which of these a registered
model is, with its default window, rate and outputs, is its input contract in the registry
(``ftin.models.registry.model_contract``), known without building it; the attributes here agree with
it (tests/models/test_all_models.py checks every model).
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import torch
from torch import nn


class VelocityOutput(NamedTuple):
    velocity: torch.Tensor  # (B, D); (B, K, D) from forward_parts
    log_std: torch.Tensor | None = None  # (B, D); (B, K, D) from forward_parts


class VelocityModel(nn.Module):
    """Base class: holds the config that rebuilds the model, and the interface attributes."""

    has_uncertainty: bool = False
    min_window: int = 1
    window_multiple: int = 1
    streams: ClassVar[bool] = False  # implements forward_stream (sequence-to-sequence inference)
    train_loss: ClassVar[str] = "velocity"  # a loss name in ftin.train.losses

    def __init__(self, **config) -> None:
        super().__init__()
        # Everything create_model(name, **config) needs to rebuild this model (saved in checkpoints).
        self.config = dict(config)

    @property
    def out_dim(self) -> int:
        return int(self.config.get("out_dim", 2))

    def forward(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:  # pragma: no cover
        raise NotImplementedError

    def target_parts(self, window: int) -> int:
        """How many equal consecutive parts of a ``window``-sample input ``forward_parts`` predicts."""
        return 1

    def check_parts(self, window: int) -> int:
        """Run ``forward_parts`` once on zeros (eval mode) so that a window the model cannot take fails
        before any data work; returns K = ``target_parts(window)``. Raises ``ValueError``."""
        self.eval()
        parts = self.target_parts(window)
        with torch.inference_mode():
            shape = tuple(self.forward_parts(torch.zeros(2, 6, window)).velocity.shape)
        if shape != (2, parts, self.out_dim) or window % parts:
            raise ValueError(
                f"{type(self).__name__} returned part velocities of shape {shape}, expected "
                f"(B, {parts}, {self.out_dim}) for {parts} equal parts of {window} samples"
            )
        return parts

    def forward_parts(self, x: torch.Tensor, features: dict | None = None) -> VelocityOutput:
        """``(B, 6, L) -> velocity (B, K, D)``, K = ``target_parts(L)``; here K = 1 (``forward``)."""
        out = self(x, features=features)
        log_std = None if out.log_std is None else out.log_std[:, None]
        return VelocityOutput(out.velocity[:, None], log_std)  # (B, 1, D)

    def forward_stream(self, x: torch.Tensor, state: Any = None) -> tuple[torch.Tensor, Any]:
        """``(B, 6, T), state -> (velocity (B, T, D), new_state)``; only for ``streams`` models."""
        raise NotImplementedError(f"{type(self).__name__} does not stream (streams = False)")
