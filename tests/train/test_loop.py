from __future__ import annotations

import json
import os
import signal
import threading

import numpy as np
import pytest
import torch

from ftin.interrupts import stop_on_signals
from ftin.models import VelocityOutput
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.train import ConfigError, TrainConfig, load_model, train
from ftin.train.losses import velocity_loss
from tests.utils.checkpoints import tiny_train_config

RATE_HZ = 50.0  # the sim_sequences fixture's rate
WINDOW = 25


def _config(tmp_path, **changes) -> TrainConfig:
    return tiny_train_config(tmp_path / "run", **changes)


def _weights(run_dir, name="ronin_tcn"):
    return {k: v.clone() for k, v in load_model(run_dir / name).model.state_dict().items()}


# The TCN is a sequence model (per-frame parts, its reference's position loss); FTIN a window model.
RESUME_MODELS = {
    "ronin_tcn": {},
    "ftin": {"model": "ftin", "model_kwargs": {**TINY_FTIN_KWARGS, "window": WINDOW}},
}


def test_training_writes_a_run_folder(tmp_path, sim_sequences):
    config = _config(tmp_path, max_epochs=3)
    result = train(config, sim_sequences, progress=False)
    run = tmp_path / "run"
    assert result.stop_reason == "max_epochs" and result.finished and result.epochs_done == 3
    assert {p.name for p in run.iterdir()} == {
        "config.json",
        "history.json",
        "resume.safetensors",
        "ronin_tcn.safetensors",
        "ronin_tcn.json",
    }
    saved = TrainConfig.load(run / "config.json")
    assert saved.imu_rate_hz == RATE_HZ and saved.window == WINDOW and saved.out_dim == 2
    history = json.loads((run / "history.json").read_text())
    assert [h["epoch"] for h in history] == [1, 2, 3]
    assert history[-1]["train_loss"] < history[0]["train_loss"]  # it learns something
    loaded = load_model(result.checkpoint)
    assert loaded.imu_rate_hz == RATE_HZ and loaded.window == WINDOW and loaded.stride == 5
    meta = loaded.meta
    assert meta["split"]["val_source"] == "held_out" and len(meta["split"]["val"]) == 1
    assert sorted(meta["split"]["train"] + meta["split"]["val"]) == sorted(s.name for s in sim_sequences)
    best = min(history, key=lambda h: h["val_mse"])
    assert meta["metrics"]["epoch"] == best["epoch"] and meta["metrics"]["val_mse"] == pytest.approx(
        best["val_mse"]
    )
    assert meta["epochs"] == best["epoch"] and meta["train_config"]["lr"] == 1e-3
    assert meta["wall_time_s"] > 0 and not meta["metrics"]["partial"]


@pytest.mark.parametrize("name", sorted(RESUME_MODELS))
def test_stopped_and_resumed_run_matches_an_uninterrupted_one(tmp_path, sim_sequences, name):
    model = RESUME_MODELS[name]
    whole = train(_config(tmp_path / "a", **model), sim_sequences, progress=False)
    assert whole.steps > 6
    stopped = train(_config(tmp_path / "b", max_steps=5, **model), sim_sequences, progress=False)
    assert stopped.stop_reason == "max_steps" and stopped.steps == 5 and not stopped.finished
    partial = load_model(tmp_path / "b" / "run" / name)  # something to load even mid-epoch
    assert partial.meta["metrics"]["partial"]
    # Another budget stop in the second epoch, then run to the end.
    budget = _config(tmp_path / "b", max_steps=whole.steps - 2, **model)
    again = train(budget, sim_sequences, resume=True, progress=False)
    assert again.steps == whole.steps - 2 and again.epochs_done == 1
    resumed = train(_config(tmp_path / "b", **model), sim_sequences, resume=True, progress=False)
    assert resumed.stop_reason == "max_epochs" and resumed.steps == whole.steps
    a, b = _weights(tmp_path / "a" / "run", name), _weights(tmp_path / "b" / "run", name)
    for key in a:
        torch.testing.assert_close(b[key], a[key], rtol=0, atol=0)
    assert [h["val_mse"] for h in resumed.history] == [h["val_mse"] for h in whole.history]
    # A finished run resumed with a larger epoch budget continues.
    more = train(_config(tmp_path / "b", max_epochs=3, **model), sim_sequences, resume=True, progress=False)
    assert more.epochs_done == 3


def test_resume_guards(tmp_path, sim_sequences):
    with pytest.raises(ConfigError, match="no resume.safetensors"):
        train(_config(tmp_path), sim_sequences, resume=True, progress=False)
    train(_config(tmp_path, max_steps=1), sim_sequences, progress=False)
    with pytest.raises(ConfigError, match="already holds a run"):
        train(_config(tmp_path), sim_sequences, progress=False)
    with pytest.raises(ConfigError, match=r"lr: 0\.001 -> 0\.01"):
        train(_config(tmp_path, lr=1e-2), sim_sequences, resume=True, progress=False)


def test_stops_when_the_learning_rate_falls_below_min_lr(tmp_path, sim_sequences):
    # A learning rate too small to change the loss: the second epoch does not improve, the plateau
    # schedule (patience 0) cuts the rate below min_lr and training ends.
    config = _config(tmp_path, lr=1e-6, min_lr=5e-7, plateau_patience=0, max_epochs=10)
    result = train(config, sim_sequences, progress=False)
    assert result.stop_reason == "min_lr" and result.epochs_done == 2
    assert result.history[-1]["lr"] == pytest.approx(1e-7)


def test_explicit_validation_and_progress_output(tmp_path, sim_sequences, capsys):
    result = train(_config(tmp_path, max_epochs=1), sim_sequences[:2], sim_sequences[2:], progress=True)
    meta = load_model(result.checkpoint).meta
    assert meta["split"] == {
        "train": [s.name for s in sim_sequences[:2]],
        "val": [sim_sequences[2].name],
        "val_source": "paths",
        "reference_disagrees": [],
    }
    assert "epoch 1/1: train" in capsys.readouterr().err


def test_the_card_names_the_recordings_whose_reference_is_not_their_imus(tmp_path, sim_sequences):
    """Markers on another body (the reference tilted 15 deg from the phone) are named in the split."""
    from dataclasses import replace

    from scipy.spatial.transform import Rotation

    from ftin.data import frames

    good, other, val = sim_sequences
    tilted = frames.wxyz_from_rotation(
        frames.rotation_from_wxyz(other.gt.q_world_body_wxyz) * Rotation.from_euler("y", 15, degrees=True)
    )
    bad = other.with_(q_world_device_wxyz=tilted, gt=replace(other.gt, q_world_body_wxyz=tilted))
    config = _config(tmp_path, max_epochs=1, orientation="ground_truth")
    result = train(config, [good, bad], [val], progress=False)
    assert load_model(result.checkpoint).meta["split"]["reference_disagrees"] == [bad.name]


def test_uncertainty_model_trains_with_nll(tmp_path, sim_sequences):
    config = _config(
        tmp_path,
        model="tlio",
        model_kwargs={"fc_dim": 16, "trans_channels": 8},
        max_steps=2,
        nll_warmup_epochs=0,
    )
    result = train(config, sim_sequences[:1], progress=False)
    loaded = load_model(result.checkpoint)
    assert loaded.out_dim == 3 and loaded.model_name == "tlio" and loaded.window == WINDOW


def test_config_errors(tmp_path, sim_sequences):
    with pytest.raises(ConfigError, match="batch_size must be > 0"):
        _config(tmp_path, batch_size=0)
    with pytest.raises(ConfigError, match="out_dim"):
        _config(tmp_path, out_dim=4)
    with pytest.raises(ConfigError, match="normalization must be one of none, channel_stats, got 'bogus'"):
        _config(tmp_path, normalization="bogus")
    with pytest.raises(ConfigError, match="needs a model with an uncertainty head"):
        train(_config(tmp_path, loss="nll"), sim_sequences, progress=False)
    with pytest.raises(ConfigError, match="unknown config key"):
        train(_config(tmp_path, model_kwargs={"nope": 1}), sim_sequences, progress=False)
    with pytest.raises(ConfigError, match="--window 30"):
        train(_config(tmp_path, model="rnin", model_kwargs={"sub_window": 25}, window=30), sim_sequences)
    with pytest.raises(ConfigError, match="unknown training option"):
        TrainConfig.from_json({**_config(tmp_path).to_json(), "extra": 1})
    as_json = json.loads(json.dumps(_config(tmp_path).to_json()))
    assert TrainConfig.from_json(as_json).to_json() == as_json


def test_the_model_gets_window_and_out_dim_only_where_taken(tmp_path, sim_sequences):
    lstm = {"hidden_size": 4, "num_layers": 1}
    config = _config(tmp_path, model="ronin_lstm", model_kwargs=lstm, out_dim=3, max_steps=1)
    result = train(config, sim_sequences, progress=False)
    meta = load_model(result.checkpoint).meta
    assert "window" not in meta["model_kwargs"] and meta["model_kwargs"]["out_dim"] == 3
    assert meta["window"] == WINDOW


def test_velocity_loss():
    target = torch.tensor([[1.0, -1.0]])
    mean = torch.tensor([[2.0, 1.0]], requires_grad=True)
    log_std = torch.tensor([[0.0, np.log(2.0)]], requires_grad=True)
    out = VelocityOutput(mean, log_std)
    mse = velocity_loss(out, target, use_nll=False, warmup=False, log_std_range=(-5, 3))
    assert mse.item() == pytest.approx(2.5)
    nll = velocity_loss(out, target, use_nll=True, warmup=False, log_std_range=(-5, 3))
    assert nll.item() == pytest.approx((0.5 * 1 + 0.0 + 0.5 * 4 / 4 + np.log(2.0)) / 2)
    # Warm-up: the velocity's gradient is exactly the MSE gradient.
    warm = velocity_loss(out, target, use_nll=True, warmup=True, log_std_range=(-5, 3))
    (grad_warm,) = torch.autograd.grad(warm, mean)
    (grad_mse,) = torch.autograd.grad(velocity_loss(out, target, False, False, (-5, 3)), mean)
    torch.testing.assert_close(grad_warm, grad_mse)
    clamped = velocity_loss(
        VelocityOutput(mean, torch.full((1, 2), -50.0)), target, True, False, log_std_range=(-1, 3)
    )
    assert np.isfinite(clamped.item())


def test_max_minutes_stops_and_leaves_a_partial_checkpoint(tmp_path, sim_sequences):
    result = train(_config(tmp_path, max_minutes=1e-9), sim_sequences, progress=False)
    assert result.stop_reason == "max_minutes" and result.steps == 0 and not result.finished
    assert load_model(result.checkpoint).meta["metrics"]["partial"]


def test_ctrl_c_asks_for_a_clean_stop_and_a_second_one_interrupts():
    before = signal.getsignal(signal.SIGINT)
    stop = threading.Event()
    with stop_on_signals(stop):
        os.kill(os.getpid(), signal.SIGTERM)
        assert stop.is_set()  # stop at the next step boundary, after saving the resume state
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is before


def test_early_stopping_after_patience_epochs_without_a_new_best(tmp_path, sim_sequences, monkeypatch):
    from ftin.train import loop

    scores = iter([1.0, 0.5, 0.6, 0.7, 0.8, 0.9])  # best at epoch 2, then worse every epoch
    monkeypatch.setattr(loop._Run, "validation_mse", lambda self: next(scores))
    config = _config(tmp_path, max_epochs=6, early_stop_patience=2)
    result = train(config, sim_sequences[:2], sim_sequences[2:], progress=False)
    assert result.stop_reason == "early_stop" and result.finished
    assert result.epochs_done == 4 and result.best_val_loss == 0.5
    # Derived from the saved progress, so a resumed run that had stopped early stays stopped.
    again = train(config, sim_sequences[:2], sim_sequences[2:], resume=True, progress=False)
    assert again.stop_reason == "early_stop" and again.epochs_done == 4


def test_after_the_switch_to_nll_patience_and_plateau_start_again(tmp_path, sim_sequences, monkeypatch):
    """TLIO: the NLL phase first raises the validation MSE; it gets its own patience and plateau."""
    from ftin.train import loop

    scores = iter([1.0, 0.5, 2.0, 1.8, 1.6, 1.7, 1.9, 1.5])  # MSE: epochs 1-2; NLL: best at 5 until 8
    monkeypatch.setattr(loop._Run, "validation_mse", lambda self: next(scores))
    tlio = {"model": "tlio", "model_kwargs": {"window": 20}, "window": 20, "stride": 20, "max_epochs": 8}
    config = _config(tmp_path, **tlio, nll_warmup_epochs=2, early_stop_patience=2, plateau_patience=3)
    result = train(config, sim_sequences[:2], sim_sequences[2:], progress=False)
    # Counted from the overall best (epoch 2) it would stop after epoch 4; from the phase's, after 7.
    assert result.stop_reason == "early_stop" and result.epochs_done == 7
    assert result.best_val_loss == 0.5  # the checkpoint is still the best validation MSE overall
    assert [h["lr"] for h in result.history] == [1e-3] * 7  # 5 epochs above 0.5: no decay after a reset


def test_early_stop_patience_must_be_positive(tmp_path):
    with pytest.raises(ConfigError, match="early_stop_patience"):
        _config(tmp_path, early_stop_patience=0)
    with pytest.raises(ConfigError, match="orientation"):
        _config(tmp_path, orientation="compass")
