from __future__ import annotations

import json
import random

import numpy as np
import pytest
import torch
from safetensors import safe_open

from ftin.checkpoint import CheckpointError
from ftin.models import create_model
from ftin.train.state import (
    _META_KEY,
    TrainProgress,
    load_training_state,
    restore_rng,
    save_training_state,
)

# The ``progress`` entry of a resume file written by the code of 2026-11-23 (commit 33cc844, a dict
# in the loop), read from its safetensors metadata: a ronin_tcn run stopped by max_steps mid-epoch 2.
PROGRESS_2026_11_23 = json.loads(
    '{"epoch": 1, "step_in_epoch": 5, "global_step": 12, "epoch_loss_sum": 23168.064208984375, '
    '"epoch_count": 320, "best_val_loss": 0.41739298215722487, "best_epoch": 1, '
    '"elapsed_s": 11.902740335999624, "history": [{"epoch": 1, "train_loss": 71.38644311366937, '
    '"val_mse": 0.41739298215722487, "lr": 0.001, "steps": 7, "elapsed_s": 11.19236321299968, '
    '"best": true}], "stop_reason": "max_steps"}'
)


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


def test_progress_in_the_format_of_existing_resume_files_round_trips_exactly(tmp_path):
    progress = TrainProgress.from_dict(PROGRESS_2026_11_23)
    assert (progress.epoch, progress.global_step, progress.best_epoch) == (1, 12, 1)
    assert progress.to_dict() == PROGRESS_2026_11_23
    assert list(progress.to_dict()) == list(PROGRESS_2026_11_23)  # same keys, same order
    assert list(TrainProgress().to_dict()) == list(PROGRESS_2026_11_23)
    # Written and read back through the resume file: the stored JSON is the old one, byte for byte.
    model, optimizer, scheduler = _setup(0)
    path = tmp_path / "resume.safetensors"
    state = {"model": model, "optimizer": optimizer, "scheduler": scheduler}
    save_training_state(path, **state, progress=progress.to_dict())
    with safe_open(str(path), framework="pt") as handle:
        stored = json.loads(handle.metadata()[_META_KEY])["progress"]
    assert json.dumps(stored) == json.dumps(PROGRESS_2026_11_23)
    loaded, _ = load_training_state(path, **state)
    assert TrainProgress.from_dict(loaded) == progress
    with pytest.raises(CheckpointError, match="unknown key"):
        TrainProgress.from_dict({**PROGRESS_2026_11_23, "extra": 1})


@pytest.mark.parametrize(
    ("name", "tag"), [("ftin-oxiod", "oxiod"), (None, None), ("ftin", None), ("my_walks", None)]
)
def test_the_card_says_which_weights_of_its_model_it_holds(name, tag):
    """``tag`` is written once, from the run's name, so the card says it from then on (a renamed file
    keeps it); a run named as its model, or not after it, writes none."""
    from ftin.train.config import TrainConfig
    from ftin.train.state import TrainProgress, checkpoint_meta

    config = TrainConfig(model="ftin", data=("x",), out_dir="out", name=name)
    meta = checkpoint_meta(config, TrainProgress(), None, {}, False, processes=1, wall_time_s=0.0)
    assert meta.get("tag") == tag
