"""Tiny simulated data and a tiny model configuration shared by the training tests."""

from __future__ import annotations

import pytest
import torch

from ftin.sim import SimConfig, simulate

RATE_HZ = 50.0


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """One torch thread: the CI machine has 2 shared cores, where more threads only contend."""
    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)


@pytest.fixture(scope="session")
def sim_sequences():
    """Three 20 s walks at 50 Hz, with orientation and ground truth."""
    return [simulate(SimConfig(duration_s=20.0, rate_hz=RATE_HZ, seed=seed)) for seed in (1, 2, 3)]
