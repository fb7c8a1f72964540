"""Training on sparse truth: the segments between waypoints (ILC walks) beside the dense windows.

A walk whose truth is waypoints (``ImuSequence.waypoints``; ``ftin.data.readers.ilc``) has no velocity
per window, but each segment between two marks has a length and each pair of segments a turn; neither
needs the map frame's heading. ``experiments/probe_sparse_truth.py`` measured this loss first.

Decisions:

* A **chunk** is two consecutive segments of at least ``MIN_SEGMENT_M`` between three marks. Its windows
  are centred every ``STEP_S`` along each segment (oriented as every training walk is, by the config's
  ``orientation``; a walk without any attitude, as ILC's, by ``auto``: VQF), and turned by one random yaw
  per chunk (the loss does not depend on it; the network must not either).
* A segment's predicted displacement is its windows' mean velocity times its duration. Loss per chunk:
  the mean over its two segments of ``(log |d_pred| - log L)^2`` (a scale error, the same for a short
  and a long segment) plus ``TURN_WEIGHT * (1 - cos(turn_pred - turn_true))``; the batch's mean times
  ``TrainConfig.sparse_weight`` is added to the dense loss.
* The chunks of a step are drawn by a generator seeded by ``(seed, step)``, so a resumed run draws what
  an uninterrupted one would have.
* Sparse walks take no part in the validation loss (it is a velocity MSE): they are scored at their
  waypoints by ``ftin.evaluate_sparse`` after training.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence
from ftin.models.base import VelocityOutput

MIN_SEGMENT_M = 2.0
STEP_S = 0.5
TURN_WEIGHT = 0.5
EDGE_S = 0.5  # marks this close to the recording's ends have no full window around them


def split_sparse(sequences: Sequence[ImuSequence]) -> tuple[list[ImuSequence], list[ImuSequence]]:
    """``(dense, sparse)``: the walks with a dense path, and those whose truth is waypoints only."""
    dense = [s for s in sequences if not (s.gt is None and s.waypoints is not None)]
    sparse = [s for s in sequences if s.gt is None and s.waypoints is not None]
    return dense, sparse


@dataclass(frozen=True)
class Chunk:
    walk: int  # index into SparseChunks.imu
    starts: tuple[np.ndarray, np.ndarray]  # window starts along each of the two segments
    marks: np.ndarray  # (3, 3): x, y (map frame, m), t (s)


@dataclass(frozen=True)
class SparseBatch:
    x: torch.Tensor  # (W, 6, L) float32, world frame, each chunk turned by its own yaw
    layout: list[tuple[int, int, np.ndarray]]  # per chunk: windows of segment 1, of segment 2, marks


class SparseChunks:
    """Every chunk of ``sequences`` (module docstring), prepared at ``rate_hz`` for ``window`` samples."""

    def __init__(
        self, sequences: Sequence[ImuSequence], rate_hz: float, window: int, orientation: str | None = None
    ) -> None:
        self.window = window
        self.imu: list[np.ndarray] = []
        self.names: list[str] = []
        self.chunks: list[Chunk] = []
        for seq in sequences:
            if seq.waypoints is None:
                raise ValueError(f"{seq.name!r} has no waypoints: not a sparse-truth walk")
            choice = orientation if seq.q_world_device_wxyz is not None else None  # none: VQF
            prepared = prepare(seq, rate_hz, window, window, orientation=choice)
            imu, t = prepared.imu_world.astype(np.float32), prepared.seq.t_s
            if len(imu) <= window:
                continue
            marks = seq.waypoints.within(t[0] + EDGE_S, t[-1] - EDGE_S)
            walk = len(self.imu)
            found = [c for c in _chunks(marks.t_s, marks.xy_map_m, t, window, len(imu), walk)]
            if found:
                self.imu.append(imu)
                self.names.append(seq.name)
                self.chunks += found

    def __len__(self) -> int:
        return len(self.chunks)

    def batch(self, rng: np.random.Generator, count: int) -> SparseBatch:
        """The windows of ``count`` chunks drawn by ``rng``, each chunk turned by one random yaw."""
        xs, layout = [], []
        for i in rng.integers(0, len(self.chunks), count):
            chunk = self.chunks[i]
            rows = np.concatenate(chunk.starts)[:, None] + np.arange(self.window)[None, :]
            x = self.imu[chunk.walk][rows].transpose(0, 2, 1).copy()  # (W, 6, L)
            c, s = math.cos(yaw := rng.uniform(-math.pi, math.pi)), math.sin(yaw)
            for j in (0, 3):  # gyro and specific force: turn x, y about the vertical
                x0, x1 = x[:, j].copy(), x[:, j + 1].copy()
                x[:, j], x[:, j + 1] = c * x0 - s * x1, s * x0 + c * x1
            xs.append(x)
            layout.append((len(chunk.starts[0]), len(chunk.starts[1]), chunk.marks))
        return SparseBatch(torch.from_numpy(np.concatenate(xs)), layout)


def _chunks(mark_t: np.ndarray, xy: np.ndarray, t: np.ndarray, window: int, n: int, walk: int) -> list[Chunk]:
    found = []
    for k in range(len(mark_t) - 2):
        if min(np.linalg.norm(np.diff(xy[k : k + 3], axis=0), axis=1)) < MIN_SEGMENT_M:
            continue
        starts = []
        for a, b in ((mark_t[k], mark_t[k + 1]), (mark_t[k + 1], mark_t[k + 2])):
            centres = np.arange(a + STEP_S / 2, b, STEP_S)
            starts.append(np.clip(np.searchsorted(t, centres) - window // 2, 0, n - window))
        marks = np.column_stack([xy[k : k + 3], mark_t[k : k + 3]])
        found.append(Chunk(walk, (starts[0], starts[1]), marks))
    return found


def segment_loss(velocity: torch.Tensor, layout: list[tuple[int, int, np.ndarray]]) -> torch.Tensor:
    """Mean over chunks of the two segments' squared log length ratios and the turn term;
    ``velocity`` ``(W, D)`` (or ``(W, K, D)``: parts averaged) in the order of the batch's windows."""
    if velocity.dim() == 3:
        velocity = velocity.mean(dim=1)
    losses, at = [], 0
    for n1, n2, marks in layout:
        v1, v2 = velocity[at : at + n1, :2], velocity[at + n1 : at + n1 + n2, :2]
        at += n1 + n2
        d1 = v1.mean(0) * float(marks[1, 2] - marks[0, 2])
        d2 = v2.mean(0) * float(marks[2, 2] - marks[1, 2])
        true = np.diff(marks[:, :2], axis=0)
        length = sum(
            (torch.log(torch.linalg.norm(d) + 1e-3) - math.log(float(np.linalg.norm(tr)))) ** 2
            for d, tr in zip((d1, d2), true, strict=True)
        )
        turn_pred = torch.atan2(d1[0] * d2[1] - d1[1] * d2[0], (d1 * d2).sum())
        turn_true = math.atan2(true[0, 0] * true[1, 1] - true[0, 1] * true[1, 0], float(true[0] @ true[1]))
        losses.append(length / 2 + TURN_WEIGHT * (1 - torch.cos(turn_pred - turn_true)))
    return torch.stack(losses).mean()


def step_generator(seed: int, step: int) -> np.random.Generator:
    """The chunks' generator of one optimizer step (module docstring: resumable)."""
    return np.random.default_rng((seed, step))


def split_output(output: VelocityOutput, dense: int) -> tuple[VelocityOutput, torch.Tensor]:
    """The dense windows' output (float32) and the sparse windows' velocity, from one joined forward."""
    velocity = output.velocity.float()
    log_std = None if output.log_std is None else output.log_std.float()[:dense]
    return VelocityOutput(velocity[:dense], log_std), velocity[dense:]
