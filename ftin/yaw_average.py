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

Inputs are ``(B, 6, L)`` world-frame windows or stream chunks, channels gyro xyz then acc xyz
(``ftin.data.windows``), turned before normalisation, as the raw world-frame data would be; outputs
are velocities ``(..., D)`` with x, y first (D = 2 or 3; z does not turn). Copies are stacked along the
batch axis, copy k in rows ``k * B ... (k + 1) * B``, so one model call runs them all.
"""

from __future__ import annotations

import math

import numpy as np
import torch

YAW_COPIES = 4  # the default of every inference path (the probe above)
_TURNED_CHANNELS = ((0, 1), (3, 4))  # gyro x, y and acc x, y


def _angles(copies: int) -> list[float]:
    if copies < 1:
        raise ValueError(f"yaw copies must be >= 1, got {copies}")
    return [2.0 * math.pi * k / copies for k in range(copies)]


def turned_copies(x: torch.Tensor, copies: int) -> torch.Tensor:
    """``(copies * B, 6, L)``: ``x`` turned about the vertical by each copy's angle (copy 0 is ``x``)."""
    if copies == 1:
        return x
    turned = []
    for angle in _angles(copies):
        c, s = math.cos(angle), math.sin(angle)
        y = x.clone()
        for i, j in _TURNED_CHANNELS:
            y[:, i] = c * x[:, i] - s * x[:, j]
            y[:, j] = s * x[:, i] + c * x[:, j]
        turned.append(y)
    return torch.cat(turned, dim=0)


def mean_turned_back(velocity: np.ndarray, copies: int) -> np.ndarray:
    """The mean over copies of each copy's velocity turned back by its angle: ``(copies * B, ..., D)``
    stacked as ``turned_copies`` stacks them -> ``(B, ..., D)``."""
    if copies == 1:
        return velocity
    per_copy = np.asarray(velocity, dtype=np.float64).reshape(copies, -1, *velocity.shape[1:])
    total = np.zeros_like(per_copy[0])
    for k, angle in enumerate(_angles(copies)):
        c, s = math.cos(angle), math.sin(angle)
        v = per_copy[k]
        total[..., 0] += c * v[..., 0] + s * v[..., 1]  # turned by -angle
        total[..., 1] += -s * v[..., 0] + c * v[..., 1]
        total[..., 2:] += v[..., 2:]
    return total / copies
