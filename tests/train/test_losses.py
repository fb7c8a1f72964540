"""Each family's loss against a hand computation of its reference formula, and tiny sequence models
training with them (ftin.train.losses)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ftin.data.windows import WindowDataset
from ftin.models import VelocityOutput, create_model
from ftin.train import TrainConfig, load_model, train
from ftin.train.config import ConfigError
from ftin.train.losses import (
    block_means,
    make_loss,
    part_history,
    rnin_displacement_loss,
    ronin_position_loss,
    validation_blocks,
    velocity_loss,
)
from tests.utils.checkpoints import tiny_train_config

RATE_HZ = 50.0  # the sim_sequences fixture's rate
PRED = torch.tensor([[[1.0, -2.0], [0.5, 0.0], [3.0, 1.0]]])  # (B=1, K=3, D=2)
TARG = torch.tensor([[[0.0, -1.0], [1.5, 2.0], [2.0, 1.0]]])


def test_rnin_loss_is_the_references():
    """mean(cat((d - d*)^2, 8 (cumsum(d) - cumsum(d*))[:, 1:]^2)) on displacements d = v x duration."""
    err = [[1.0, -1.0], [-1.0, -2.0], [1.0, 0.0]]  # d - d* per part (1 s parts: d = v)
    cum = [[0.0, -3.0], [1.0, -3.0]]  # cumulative error after parts 2 and 3
    terms = [e**2 for row in err for e in row] + [8.0 * c**2 for row in cum for c in row]
    assert rnin_displacement_loss(PRED, TARG, part_s=1.0).item() == pytest.approx(sum(terms) / len(terms))
    # Half-second parts: displacements are half the velocities, every term a quarter.
    half = rnin_displacement_loss(PRED, TARG, part_s=0.5).item()
    assert half == pytest.approx(0.25 * sum(terms) / len(terms))


def test_ronin_position_loss_full_and_part():
    v = torch.tensor([[[1.0], [2.0], [-1.0], [4.0]]])  # (1, L=4, 1)
    t = torch.tensor([[[0.0], [1.0], [1.0], [1.0]]])
    # full: cumsum of frames 1.. : pred 2, 1, 5; target 1, 2, 3
    assert ronin_position_loss(v, t, None).item() == pytest.approx((1 + 1 + 4) / 3)
    # part, h = 1: displacements over one frame are frames 2 and 3 themselves
    assert ronin_position_loss(v, t, 1).item() == pytest.approx(((-1 - 1) ** 2 + (4 - 1) ** 2) / 2)
    # part, h = 2: one displacement, frames 2 + 3
    assert ronin_position_loss(v, t, 2).item() == pytest.approx((3 - 2) ** 2)
    with pytest.raises(ValueError, match="history 3"):
        ronin_position_loss(v, t, 3)


def test_make_loss_follows_the_model_family():
    out = VelocityOutput(PRED, torch.zeros_like(PRED))
    tlio = create_model("tlio", window=50, fc_dim=8, trans_channels=8)
    nll = make_loss(tlio, 50, RATE_HZ, use_nll=True, log_std_range=(-5.0, 3.0))
    assert nll(out, TARG, False).item() == velocity_loss(out, TARG, True, False, (-5.0, 3.0)).item()
    window_mse = make_loss(tlio, 50, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0))
    assert window_mse(out, TARG, False).item() == pytest.approx(torch.mean((PRED - TARG) ** 2).item())
    rnin = create_model("rnin", sub_window=25)
    loss = make_loss(rnin, 75, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0))  # 3 parts of 0.5 s
    assert loss(out, TARG, False).item() == pytest.approx(rnin_displacement_loss(PRED, TARG, 0.5).item())
    with pytest.raises(ValueError, match="nll"):
        make_loss(rnin, 75, RATE_HZ, use_nll=True, log_std_range=(-5.0, 3.0))
    lstm = make_loss(create_model("ronin_lstm"), 3, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0))
    assert lstm(out, TARG, False).item() == pytest.approx(ronin_position_loss(PRED, TARG, None).item())
    tcn = create_model("ronin_tcn")
    assert part_history(tcn.receptive_field, 400) == 253  # the reference: window 400, history 253
    assert part_history(tcn.receptive_field, 25) == 23  # capped: one displacement per chunk
    with pytest.raises(ValueError, match="at least 3 frames"):
        make_loss(tcn, 2, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0))


def test_validation_blocks_are_about_one_second():
    assert validation_blocks(1000, 10, 100.0) == 1  # RNIN: its 1 s sub-windows
    assert validation_blocks(400, 400, 200.0) == 200  # RoNIN LSTM / TCN chunk: two 1 s blocks
    assert validation_blocks(25, 25, 50.0) == 25  # a window shorter than 1 s is one block
    assert validation_blocks(200, 1, 200.0) == 1  # window models: the window itself
    v = torch.arange(10.0).reshape(1, 5, 2)
    torch.testing.assert_close(block_means(v, 2), torch.tensor([[[1.0, 2.0], [5.0, 6.0]]]))  # 5th dropped


TINY_SEQUENCE_MODELS = {
    "rnin": ({"sub_window": 5, "out_dim": 2, "fc_dim": 16, "lstm_size": 16}, 25),  # 5 parts of 0.1 s
    "ronin_lstm": ({"hidden_size": 16, "num_layers": 2}, 25),
    "ronin_tcn": ({"channels": (8, 8)}, 25),
}


@pytest.mark.parametrize("name", sorted(TINY_SEQUENCE_MODELS))
def test_tiny_sequence_models_learn_with_their_reference_loss(name, sim_sequences):
    kwargs, window = TINY_SEQUENCE_MODELS[name]
    torch.manual_seed(0)
    model = create_model(name, **kwargs)
    parts = model.target_parts(window)
    dataset = WindowDataset(sim_sequences[:1], window, 5, model.out_dim, parts=parts, augment_yaw=False)
    x, v = dataset.get_batch(np.arange(10, len(dataset), 4)[:32])  # a fixed batch, mostly walking
    x = (x - x.mean(dim=(0, 2), keepdim=True)) / (x.std(dim=(0, 2), keepdim=True) + 1e-6)
    loss_fn = make_loss(model, window, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0))

    def batch_loss() -> float:
        torch.manual_seed(123)  # same dropout masks before and after
        with torch.no_grad():
            return loss_fn(model.forward_parts(x), v, False).item()

    before = batch_loss()
    optimizer = torch.optim.Adam(model.parameters(), lr=3e-3)
    model.train()
    for _ in range(15):
        optimizer.zero_grad()
        loss_fn(model.forward_parts(x), v, False).backward()
        optimizer.step()
    after = batch_loss()
    assert np.isfinite(after) and after < 0.8 * before, f"{name}: {before:.4f} -> {after:.4f}"


def _config(tmp_path, name: str, **changes) -> TrainConfig:
    kwargs, window = TINY_SEQUENCE_MODELS[name]
    return tiny_train_config(tmp_path / "run", model=name, model_kwargs=kwargs, window=window, **changes)


def test_lstm_run_resumes_exactly(tmp_path, sim_sequences):
    """A sequence model stopped mid-epoch and resumed reaches the uninterrupted run's weights."""
    whole = train(_config(tmp_path / "a", "ronin_lstm"), sim_sequences, progress=False)
    train(_config(tmp_path / "b", "ronin_lstm", max_steps=whole.steps - 3), sim_sequences, progress=False)
    resumed = train(_config(tmp_path / "b", "ronin_lstm"), sim_sequences, resume=True, progress=False)
    assert resumed.steps == whole.steps and resumed.stop_reason == "max_epochs"
    a = load_model(tmp_path / "a" / "run" / "ronin_lstm").model.state_dict()
    b = load_model(tmp_path / "b" / "run" / "ronin_lstm").model.state_dict()
    for key in a:
        torch.testing.assert_close(b[key], a[key], rtol=0, atol=0)
    assert [h["val_mse"] for h in resumed.history] == [h["val_mse"] for h in whole.history]


def test_rnin_trains_on_sequences_of_sub_windows(tmp_path, sim_sequences):
    """``--window 5*part --model-kwargs '{"sub_window": part}'``: RNIN's sequences through ``train``."""
    result = train(_config(tmp_path, "rnin", max_epochs=1), sim_sequences, progress=False)
    loaded = load_model(result.checkpoint)
    assert loaded.model.target_parts(loaded.window) == 5 and loaded.out_dim == 2
    assert result.history[0]["val_mse"] is not None and np.isfinite(result.history[0]["train_loss"])
    with pytest.raises(ValueError, match="nll"):
        train(_config(tmp_path / "nll", "rnin", loss="nll"), sim_sequences, progress=False)


def test_the_speed_term_pays_for_the_distance_a_shrunken_velocity_loses():
    """Two windows of the same speed whose directions the model cannot tell apart: their mean (zero) is
    the least MSE; with the speed term, a vector of the right length costs less than a shrunken one."""
    target = torch.tensor([[[1.0, 0.0]], [[-1.0, 0.0]]])  # (B=2, K=1, D=2)
    shrunk = VelocityOutput(torch.zeros_like(target), None)
    full = VelocityOutput(torch.tensor([[[0.0, 1.0]], [[0.0, 1.0]]]), None)  # right speed, direction unknown
    plain = [velocity_loss(out, target, False, False, (-5.0, 3.0)).item() for out in (shrunk, full)]
    assert plain[0] < plain[1]  # MSE alone walks short
    speed = [velocity_loss(out, target, False, False, (-5.0, 3.0), 3.0).item() for out in (shrunk, full)]
    assert speed == pytest.approx([plain[0] + 3.0 * 1.0, plain[1]])  # |0| - 1 squared, weighted; none
    assert speed[1] < speed[0]
    resnet = create_model("ronin_resnet", window=50)
    with_speed = make_loss(resnet, 50, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0), speed_weight=3.0)
    assert with_speed(shrunk, target, False).item() == pytest.approx(speed[0])
    with pytest.raises(ValueError, match="only the 'velocity' loss has a speed term"):
        make_loss(
            create_model("ronin_lstm"), 3, RATE_HZ, use_nll=False, log_std_range=(-5.0, 3.0), speed_weight=1.0
        )
    with pytest.raises(ConfigError, match="speed_weight"):
        TrainConfig(model="ftin", data=("x",), out_dir="o", speed_weight=-1.0)
