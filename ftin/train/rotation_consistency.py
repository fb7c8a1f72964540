"""The rotation-consistency term (RIO, Cao et al., CVPR 2022): a walk turned is the same walk, turned.

Turn a gravity-aligned window about the vertical by R and its true velocity turns by R. Random yaw in
training teaches that only through the labels; the network may still keep a part of its output fixed
to the input's axes, which shows at inference as the quarter-turn looks of one window disagreeing
(``experiments/probe_ilc_direction.py``: 15-28 deg on the ILC mall walks against <= 5 deg on OxIOD and
RIDI). The term asks for it directly: each dense window of a step is also run turned by a random
quarter turn (1-3 of them: the turns the inference's look cycling uses, ``ftin.yaw_average``), and the
mean squared difference between the turned window's velocity and the unturned one's velocity turned
by the same angle is added to the loss with weight ``TrainConfig.rotation_consistency_weight``. It needs
no label, so both copies get its gradient; the turned copies ride in the same forward as the rest of
the batch (one call, batch norm sees both). Velocities are ``(B, K, D)`` part velocities: x and y turn,
z does not.
"""

from __future__ import annotations

import math

import torch

from ftin.yaw_average import turn_windows


def quarter_turns(count: int, generator: torch.Generator | None = None) -> torch.Tensor:
    """``(count,)`` angles (radians): 1, 2 or 3 quarter turns, uniformly (never the identity). ``count`` 0
    draws nothing, so a run without the term keeps its random stream as before."""
    if count == 0:
        return torch.zeros(0, dtype=torch.float64)
    k = torch.randint(1, 4, (count,), generator=generator)
    return k.double() * (math.pi / 2.0)


def turned_inputs(x: torch.Tensor, angles: torch.Tensor) -> torch.Tensor:
    """``(B, 6, L)`` raw world-frame windows turned by ``angles`` (before normalisation, as at inference)."""
    return turn_windows(x, angles)


def turn_velocity(velocity: torch.Tensor, angles: torch.Tensor) -> torch.Tensor:
    """``(B, ..., D)`` velocities with x and y of row b turned by ``angles[b]``; z as it is."""
    shape = (len(angles),) + (1,) * (velocity.ndim - 2)
    c = torch.round(torch.cos(angles), decimals=12).to(velocity.dtype).reshape(shape)
    s = torch.round(torch.sin(angles), decimals=12).to(velocity.dtype).reshape(shape)
    x, y = velocity[..., 0], velocity[..., 1]
    turned = torch.stack([c * x - s * y, s * x + c * y], dim=-1)
    return torch.cat([turned, velocity[..., 2:]], dim=-1)


def consistency_loss(
    velocity: torch.Tensor, turned_velocity: torch.Tensor, angles: torch.Tensor
) -> torch.Tensor:
    """Mean squared difference between the turned windows' velocities and ``velocity`` turned by ``angles``:
    zero exactly when the network is equivariant to those turns."""
    return torch.mean((turned_velocity.float() - turn_velocity(velocity.float(), angles)) ** 2)
