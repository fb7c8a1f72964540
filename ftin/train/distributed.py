"""The processes of one training run: ranks under ``torchrun`` (DistributedDataParallel on gloo for
CPU) and the module DDP wraps (stopping on SIGINT/SIGTERM: ``ftin.interrupts``).

Decisions (see also ``ftin.train.loop``):
- One process without ``WORLD_SIZE`` (or ``WORLD_SIZE=1``): ``Distributed()`` with rank 0, and the
  collective helpers return their inputs unchanged.
- Every rank starts from the same weights (seeded before the model is built); the other ranks then
  reseed so that their dropout differs. An uncertainty head trained with plain MSE gets no gradient,
  which DDP must be told (``find_unused_parameters``).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import torch
import torch.distributed as dist

from ftin.models.base import VelocityModel, VelocityOutput


@dataclass(frozen=True)
class Distributed:
    rank: int = 0
    world: int = 1
    owns_group: bool = False  # this process created the process group (and destroys it)

    @property
    def main(self) -> bool:
        return self.rank == 0

    def sum(self, *values: float) -> list[float]:
        """The sum over every rank of each value."""
        if self.world == 1:
            return list(values)
        tensor = torch.tensor(values, dtype=torch.float64)
        dist.all_reduce(tensor, op=dist.ReduceOp.SUM)
        return tensor.tolist()

    def any(self, flag: bool) -> bool:
        """Whether ``flag`` is set on any rank."""
        if self.world == 1:
            return flag
        tensor = torch.tensor([1 if flag else 0], dtype=torch.int64)
        dist.all_reduce(tensor, op=dist.ReduceOp.MAX)
        return bool(tensor.item())


@contextmanager
def distributed() -> Iterator[Distributed]:
    """Join the process group ``torchrun`` describes (if any) for the duration of the block."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        yield Distributed()
        return
    owns = not dist.is_initialized()
    if owns:
        dist.init_process_group(backend="gloo")
    try:
        yield Distributed(rank=dist.get_rank(), world=dist.get_world_size(), owns_group=owns)
        if owns:  # every rank is done before the group goes: gloo aborts a rank still talking to it
            dist.barrier()
    finally:
        if owns:
            dist.destroy_process_group()


class PartsForward(torch.nn.Module):
    """``model.forward_parts`` as a module's ``forward``, so that DistributedDataParallel (which
    synchronises gradients only for calls of the module it wraps) can wrap it."""

    def __init__(self, model: VelocityModel) -> None:
        super().__init__()
        self.model = model

    def forward(self, x: torch.Tensor) -> VelocityOutput:
        return self.model.forward_parts(x)  # velocity (B, K, D)


def parts_module(
    model: VelocityModel, ddp: Distributed, *, seed: int, step: int, unused_parameters: bool
) -> torch.nn.Module:
    """The module the loop trains: ``PartsForward(model)``, wrapped in DDP under several ranks."""
    net: torch.nn.Module = PartsForward(model)
    if ddp.world > 1:
        if not ddp.main:  # same initial weights on every rank (seeded before), then distinct dropout
            torch.manual_seed(seed * 1000 + ddp.rank + step)
        net = torch.nn.parallel.DistributedDataParallel(net, find_unused_parameters=unused_parameters)
    return net
