"""Tiny simulated data and a tiny model configuration shared by the training tests."""

from __future__ import annotations

import pytest

from ftin.sim import SimConfig, simulate

RATE_HZ = 50.0



@pytest.fixture(scope="session")
def sim_sequences():
    """Three 20 s walks at 50 Hz, with orientation and ground truth."""
    return [simulate(SimConfig(duration_s=20.0, rate_hz=RATE_HZ, seed=seed)) for seed in (1, 2, 3)]
