from __future__ import annotations

import random

import numpy as np
import pytest
import torch

from ftin.models import create_model
from ftin.train.checkpoint import CheckpointError
from ftin.train.state import load_training_state, save_training_state


def _setup(seed: int):
    torch.manual_seed(seed)
    model = create_model("ronin_tcn", channels=(8, 8))
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(optimizer, factor=0.5, patience=1)
    return model, optimizer, scheduler


def _steps(model, optimizer, n: int):
    model.train()
    for _ in range(n):
        x = torch.randn(4, 6, 20)
        loss = model(x).velocity.pow(2).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()


def test_round_trip_continues_identically(tmp_path):
    model, optimizer, scheduler = _setup(0)
    _steps(model, optimizer, 3)
    scheduler.step(1.0)
    scheduler.step(2.0)  # one bad epoch recorded
    np.random.seed(5)
    random.seed(5)
    progress = {"epoch": 2, "best": None, "history": [{"loss": float("inf")}], "ids": (1, 2)}
    path = tmp_path / "resume.safetensors"
    save_training_state(path, model=model, optimizer=optimizer, scheduler=scheduler, progress=progress)
    assert [p.name for p in tmp_path.iterdir()] == ["resume.safetensors"]  # one file, nothing else
    _steps(model, optimizer, 2)
    expected = {k: v.clone() for k, v in model.state_dict().items()}
    expected_draws = (np.random.rand(), random.random())

    fresh, fresh_opt, fresh_sched = _setup(1)  # different init: everything must come from the file
    loaded_progress, rng = load_training_state(path, model=fresh, optimizer=fresh_opt, scheduler=fresh_sched)
    assert loaded_progress == progress
    assert fresh_sched.state_dict() == scheduler.state_dict()
    assert fresh_sched.num_bad_epochs == 1 and fresh_sched.best == 1.0
    from ftin.train.state import restore_rng

    restore_rng(rng)
    _steps(fresh, fresh_opt, 2)
    for key, value in fresh.state_dict().items():
        assert torch.equal(value, expected[key]), key
    assert (np.random.rand(), random.random()) == expected_draws


def test_bad_files(tmp_path):
    model, optimizer, scheduler = _setup(0)
    with pytest.raises(CheckpointError, match="no resume state"):
        load_training_state(
            tmp_path / "none.safetensors", model=model, optimizer=optimizer, scheduler=scheduler
        )
    path = tmp_path / "resume.safetensors"
    save_training_state(path, model=model, optimizer=optimizer, scheduler=scheduler, progress={})
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="unreadable resume state"):
        load_training_state(path, model=model, optimizer=optimizer, scheduler=scheduler)
    path.write_bytes(data)
    other = create_model("ronin_tcn", channels=(8, 16))
    with pytest.raises(CheckpointError, match="does not fit"):
        load_training_state(path, model=other, optimizer=optimizer, scheduler=scheduler)
