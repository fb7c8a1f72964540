"""Averaging a network over turned copies of its world-frame input: every inference path's model call.

A walk's velocity turns with its world: turn the gravity-aligned input by a yaw and the true velocity
turns by the same yaw. The networks learn that only approximately (random yaw in training); what they
do not learn is a part of the output fixed to the input's axes, a drift in one world direction that is
largest where the model is least sure of the motion. Running the model on ``copies`` copies of the
input turned by 360/``copies`` degree steps, turning each velocity back and taking the mean keeps
exactly the part that turns (the mean is equivariant to those turns by construction) and removes the
rest. Measured on walkers and carry modes the models never trained on, phone only
(docs/results/probes/yaw_ensemble.md): four quarter turns beat a single copy at an arbitrary heading on
OxIOD, RIDI and Inria (mean ATE -4 to -59 %); eight add nothing. ``copies=1`` is the network alone.

The same cancellation from one look per window (``cyclic_angles``): windows overlap (a 1 s window every
0.2 s: five cover each sample) and the trajectory integrates the mean of the windows covering each
interval, so turning window k by ``k mod 4`` quarter turns and its velocity back points the fixed part
in four directions over any four neighbouring windows, and it cancels in the path as in the four-copy
mean, at a quarter of the cost (docs/results/probes/single_look.md: the same ATE within 1 % on 64
walker-held-out walks, where turning each window into a yaw of its own motion cost 2-9 %).

Inputs are ``(B, 6, L)`` world-frame windows or stream chunks, channels gyro xyz then acc xyz
(``ftin.data.windows``), turned before normalisation, as the raw world-frame data would be; outputs
are velocities ``(..., D)`` with x, y first (D = 2 or 3; z does not turn). Copies are stacked along the
batch axis, copy k in rows ``k * B ... (k + 1) * B``, so one model call runs them all.
"""

from __future__ import annotations

import math

import numpy as np
import torch

YAW_COPIES = 4  # the default where windows do not cycle through the turns (the probe above)
# Registry names of the window-model families whose walking checkpoints read walker-held-out walks as
# well with one look per window, cycling through the quarter turns, as with four turned copies of every
# window (docs/results/probes/single_look.md: mean ATE over standing still's +0.1 % RoNIN ResNet, +1.0 %
# FTIN, the same walks within 0.8-1.2); every other family keeps the four copies.
CYCLIC_FAMILIES = frozenset({"ronin_resnet", "ftin"})
_TURNED_CHANNELS = ((0, 1), (3, 4))  # gyro x, y and acc x, y


def _angles(copies: int) -> list[float]:
    if copies < 1:
        raise ValueError(f"yaw copies must be >= 1, got {copies}")
    return [2.0 * math.pi * k / copies for k in range(copies)]


def turned_copies(x: torch.Tensor, copies: int) -> torch.Tensor:
    """``(copies * B, 6, L)``: ``x`` turned about the vertical by each copy's angle (copy 0 is ``x``)."""
    if copies == 1:
        return x
    return torch.cat([turn_windows(x, torch.full((len(x),), angle)) for angle in _angles(copies)], dim=0)


def mean_turned_back(velocity: np.ndarray, copies: int) -> np.ndarray:
    """The mean over copies of each copy's velocity turned back by its angle: ``(copies * B, ..., D)``
    stacked as ``turned_copies`` stacks them -> ``(B, ..., D)``."""
    if copies == 1:
        return velocity
    per_copy = np.asarray(velocity, dtype=np.float64).reshape(copies, -1, *velocity.shape[1:])
    back = [
        turn_velocities(v, np.full(len(v), -angle))
        for v, angle in zip(per_copy, _angles(copies), strict=True)
    ]
    return np.mean(back, axis=0)


def turn_windows(x: torch.Tensor, angles: torch.Tensor) -> torch.Tensor:
    """``(B, 6, L)`` windows each turned about the vertical by its own angle ``(B,)`` (radians); cos and
    sin rounded to 12 decimals, so that a quarter turn only swaps and negates channels, exactly."""
    c = torch.round(torch.cos(angles.double()), decimals=12).to(x.dtype)[:, None]
    s = torch.round(torch.sin(angles.double()), decimals=12).to(x.dtype)[:, None]
    y = x.clone()
    for i, j in _TURNED_CHANNELS:
        y[:, i] = c * x[:, i] - s * x[:, j]
        y[:, j] = s * x[:, i] + c * x[:, j]
    return y


def turn_velocities(velocity: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``(B, ..., D)`` velocities, x and y of row b turned by ``angles[b]``; z as it is."""
    v = np.array(velocity, dtype=np.float64, copy=True)
    shape = (len(angles),) + (1,) * (v.ndim - 2)
    c, s = np.round(np.cos(angles), 12).reshape(shape), np.round(np.sin(angles), 12).reshape(shape)
    x, y = v[..., 0].copy(), v[..., 1].copy()
    v[..., 0], v[..., 1] = c * x - s * y, s * x + c * y
    return v


def cyclic_angles(starts: np.ndarray, stride: int) -> np.ndarray:
    """``(M,)`` the turn of each window (radians): window k of the recording (``start // stride``) is
    turned by ``k mod 4`` quarter turns, whichever batch or live chunk it comes in."""
    return (np.asarray(starts, dtype=np.int64) // stride % 4) * (math.pi / 2.0)


def uses_cyclic_turns(family: str, streams: bool) -> bool:
    """Whether a model of registry name ``family`` runs one look per window, cycling through the quarter
    turns, by default (``CYCLIC_FAMILIES``; a streaming model has no window to turn)."""
    return family in CYCLIC_FAMILIES and not streams


def default_copies(cyclic: bool) -> int:
    """Turned copies to average by default: one look where windows cycle through the turns, else
    ``YAW_COPIES``."""
    return 1 if cyclic else YAW_COPIES


def turn_log_std(log_std: torch.Tensor, angles: torch.Tensor) -> torch.Tensor:
    """Per-axis log-std ``(B, ..., D)`` of a diagonal covariance turned by ``angles`` ``(B,)``: the
    diagonal of R diag(var) R^T for x and y (the cross term dropped); z as it is."""
    var = torch.exp(2.0 * log_std.double())
    shape = (len(angles),) + (1,) * (var.ndim - 2)
    c2 = (torch.round(torch.cos(angles.double()), decimals=12) ** 2).reshape(shape)
    s2 = 1.0 - c2
    out = var.clone()
    out[..., 0] = c2 * var[..., 0] + s2 * var[..., 1]
    out[..., 1] = s2 * var[..., 0] + c2 * var[..., 1]
    return (0.5 * torch.log(out)).to(log_std.dtype)
