"""Training losses, one per model family, chosen by the model's ``train_loss`` (``ftin.models.base``).

Every loss compares part velocities: the model's ``forward_parts`` output ``(B, K, D)`` with the
dataset's part targets ``(B, K, D)`` (``ftin.data.windows.part_velocity_targets``). Which one a model
trains with is how its reference trains it:

- ``"velocity"`` (window models, K = 1): ``velocity_loss``, MSE on the window's velocity, or a
  Gaussian NLL for models with uncertainty (the paper's training); optionally plus a speed term
  (``TrainConfig.speed_weight``).
- ``"rnin_displacement"`` (RNIN, K sub-windows): the reference's
  ``mean(cat((d - d*)^2, 8 (cumsum(d)[:, 1:] - cumsum(d*)[:, 1:])^2))`` on per-sub-window
  displacements ``d = v * part duration`` (on the uniform grid a part lasts ``window / K / rate``
  seconds; for 1 s sub-windows d = v numerically, exactly the reference). Its default configuration
  never switches to the NLL (``start_cov_epochs`` exceeds its epochs), so neither does this one.
- ``"ronin_position_full"`` (RoNIN LSTM, K = frames): RoNIN's ``GlobalPosLoss`` "full",
  ``mse(cumsum(v[:, 1:]), cumsum(v*[:, 1:]))`` over the chunk. As the reference, the cumulative sum
  is of velocities, not of velocity x dt (positions in units of m/s x frames).
- ``"ronin_position_part"`` (RoNIN TCN): ``GlobalPosLoss`` "part": the same cumulative sums ``c``,
  compared as displacements over ``h`` frames, ``c[:, h:] - c[:, :-h]``, with ``h`` = the receptive
  field (253 for the reference's TCN), capped at ``window - 2`` so that a chunk shorter than the
  reference's 400 frames still has at least one displacement (``c`` has ``window - 1`` entries).
  Needs a window of at least 3 frames.

The NLL exists only for ``"velocity"``; the other families train with their own (MSE-based) loss
under ``loss = "auto"`` or ``"mse"`` alike, and ``"nll"`` is a config error for them
(``uses_nll``).

Validation stays comparable across every model: the MSE of ~1 s mean velocities
(``validation_blocks``, ``block_means``). K = 1 models are compared on their window's velocity;
multi-part models average predicted and target part velocities over blocks of ``round(imu_rate_hz)``
frames (RNIN's 1 s sub-windows are blocks of one part, a per-frame model's 400-frame chunk at 200 Hz
two blocks).
"""

from __future__ import annotations

from collections.abc import Callable

import torch
import torch.nn.functional as F

from ftin.models.base import VelocityModel, VelocityOutput
from ftin.train.config import ConfigError, LossKind

# (output with velocity (B, K, D), part targets (B, K, D), warm-up epoch?) -> scalar loss
LossFn = Callable[[VelocityOutput, torch.Tensor, bool], torch.Tensor]

LOSS_NAMES = ("velocity", "rnin_displacement", "ronin_position_full", "ronin_position_part")
RNIN_CUMULATIVE_WEIGHT = 8.0  # the reference's weight of the cumulative-displacement term


def velocity_loss(
    output: VelocityOutput,
    target: torch.Tensor,
    use_nll: bool,
    warmup: bool,
    log_std_range: tuple[float, float],
    speed_weight: float = 0.0,
) -> torch.Tensor:
    """MSE, or Gaussian NLL (per element, constant dropped) with a clamped log-std; plus
    ``speed_weight`` x the speed's squared error (``TrainConfig.speed_weight``).

    Shapes only need to agree (``(B, D)`` or ``(B, K, D)``): every term is a mean over elements.
    During ``warmup`` the velocity gets the MSE gradient and the log-std learns from the detached
    error, so a bad early uncertainty cannot slow down the mean (TLIO's motivation for MSE first).
    """
    speed = speed_weight * speed_loss(output.velocity, target) if speed_weight else 0.0
    if not use_nll:
        return F.mse_loss(output.velocity, target) + speed
    log_std = output.log_std.clamp(*log_std_range)
    error = output.velocity - target
    if warmup:
        nll = 0.5 * error.detach() ** 2 * torch.exp(-2.0 * log_std) + log_std
        return F.mse_loss(output.velocity, target) + nll.mean() + speed
    return (0.5 * error**2 * torch.exp(-2.0 * log_std) + log_std).mean() + speed


def speed_loss(velocity: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Mean squared error of the speeds ``|v|`` (norm over the last axis) of ``(..., D)`` velocities."""
    return F.mse_loss(torch.linalg.vector_norm(velocity, dim=-1), torch.linalg.vector_norm(target, dim=-1))


def rnin_displacement_loss(velocity: torch.Tensor, target: torch.Tensor, part_s: float) -> torch.Tensor:
    """RNIN's loss on per-part displacements ``velocity * part_s``, ``(B, K, D)`` each."""
    pred, targ = velocity * part_s, target * part_s  # (B, K, D) displacements in m
    cumulative_error = torch.cumsum(pred, dim=1)[:, 1:] - torch.cumsum(targ, dim=1)[:, 1:]  # (B, K-1, D)
    terms = torch.cat([(pred - targ) ** 2, RNIN_CUMULATIVE_WEIGHT * cumulative_error**2], dim=1)
    return terms.mean()


def ronin_position_loss(velocity: torch.Tensor, target: torch.Tensor, history: int | None) -> torch.Tensor:
    """RoNIN's ``GlobalPosLoss`` on per-frame velocities ``(B, L, D)``: "full" when ``history`` is
    None, else "part" (displacements over ``history`` frames)."""
    pred_pos = torch.cumsum(velocity[:, 1:], dim=1)  # (B, L-1, D)
    targ_pos = torch.cumsum(target[:, 1:], dim=1)
    if history is not None:
        if not 1 <= history < pred_pos.shape[1]:
            raise ValueError(
                f"history {history} needs chunks of more than {history + 1} frames, got {velocity.shape[1]}"
            )
        pred_pos = pred_pos[:, history:] - pred_pos[:, :-history]  # (B, L-1-h, D)
        targ_pos = targ_pos[:, history:] - targ_pos[:, :-history]
    return F.mse_loss(pred_pos, targ_pos)


def part_history(receptive_field: int, window: int) -> int:
    """The TCN's "part" history: its receptive field, capped so a ``window`` chunk keeps one term."""
    if window < 3:
        raise ValueError(f"the TCN's position loss needs a window of at least 3 frames, got {window}")
    return min(int(receptive_field), window - 2)


def make_loss(
    model: VelocityModel,
    window: int,
    rate_hz: float,
    *,
    use_nll: bool,
    log_std_range: tuple[float, float],
    speed_weight: float = 0.0,
) -> LossFn:
    """The loss ``model`` trains with on ``window``-sample chunks at ``rate_hz`` (module docstring).

    Raises ``ValueError`` when the family's loss does not fit (unknown name, NLL outside
    ``"velocity"``, a window too short for the TCN's history).
    """
    name = model.train_loss
    if name not in LOSS_NAMES:
        raise ValueError(f"unknown train_loss {name!r}; known: {', '.join(LOSS_NAMES)}")
    if use_nll and name != "velocity":
        raise ValueError(f"loss 'nll' is not how this model trains: it uses its reference's {name!r} loss")
    if speed_weight and name != "velocity":
        raise ValueError(
            f"speed_weight: only the 'velocity' loss has a speed term; this model trains with {name!r}"
        )
    if name == "velocity":
        return lambda output, target, warmup: velocity_loss(
            output, target, use_nll, warmup, log_std_range, speed_weight
        )
    if name == "rnin_displacement":
        part_s = window / model.target_parts(window) / rate_hz
        return lambda output, target, warmup: rnin_displacement_loss(output.velocity, target, part_s)
    if name == "ronin_position_full":
        return lambda output, target, warmup: ronin_position_loss(output.velocity, target, None)
    history = part_history(model.receptive_field, window)
    return lambda output, target, warmup: ronin_position_loss(output.velocity, target, history)


def uses_nll(loss: LossKind, model: VelocityModel, model_name: str) -> bool:
    """Whether the ``"velocity"`` loss is the NLL. Families with their own reference loss (RNIN,
    RoNIN LSTM / TCN) train with it under ``auto``; ``nll`` is a ``ConfigError`` for them."""
    if loss is LossKind.NLL and not model.has_uncertainty:
        raise ConfigError(f"loss 'nll' needs a model with an uncertainty head; {model_name!r} has none")
    if loss is LossKind.NLL and model.train_loss != "velocity":
        raise ConfigError(
            f"loss 'nll': {model_name!r} trains with its reference's {model.train_loss!r} loss "
            "(ftin.train.losses); use loss 'auto'"
        )
    if loss is LossKind.MSE or model.train_loss != "velocity":
        return False
    return bool(model.has_uncertainty)


def validation_blocks(window: int, parts: int, rate_hz: float) -> int:
    """How many consecutive parts make one ~1 s validation block (module docstring).

    A part lasts ``window / parts`` frames; a block is ``round(rate_hz)`` frames, rounded to whole
    parts, at least one part and at most the whole window (a window shorter than 1 s is one block).
    Parts left over after the last whole block are not scored.
    """
    part_frames = window // parts
    return int(min(parts, max(1, round(round(rate_hz) / part_frames))))


def block_means(velocity: torch.Tensor, per_block: int) -> torch.Tensor:
    """``(B, K, D) -> (B, K // per_block, D)``: mean over consecutive blocks of ``per_block`` parts."""
    batch, parts, dim = velocity.shape
    blocks = parts // per_block
    return velocity[:, : blocks * per_block].reshape(batch, blocks, per_block, dim).mean(dim=2)
