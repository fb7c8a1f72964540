from __future__ import annotations

import math

import pytest
import torch

from ftin.train import ConfigError, TrainConfig, load_model, train
from ftin.train.rotation_consistency import consistency_loss, quarter_turns, turn_velocity, turned_inputs
from tests.utils.checkpoints import tiny_train_config


def equivariant(x: torch.Tensor) -> torch.Tensor:
    """Velocity = mean horizontal specific force plus a gyro-z-scaled copy of it turned by 90 deg: turns
    with the input exactly."""
    a = x[:, 3:5].mean(-1)  # (B, 2)
    wz = x[:, 2].mean(-1, keepdim=True)
    return (a + wz * torch.stack([-a[:, 1], a[:, 0]], dim=-1))[:, None, :]  # (B, 1, 2)


def fixed_axis(x: torch.Tensor) -> torch.Tensor:
    """The same plus a part fixed to the input's x axis (what the look cycling cancels at inference)."""
    v = equivariant(x)
    return v + torch.tensor([0.3, 0.0]) * x[:, 3:6].abs().mean((1, 2))[:, None, None]


@pytest.mark.parametrize("model, zero", [(equivariant, True), (fixed_axis, False)])
def test_the_term_is_zero_exactly_for_an_equivariant_model(model, zero):
    torch.manual_seed(0)
    x = torch.randn(16, 6, 20)
    turns = quarter_turns(len(x))
    assert set(torch.round(turns / (math.pi / 2)).tolist()) <= {1.0, 2.0, 3.0}
    term = consistency_loss(model(x), model(turned_inputs(x, turns)), turns)
    assert (term.item() < 1e-12) if zero else (term.item() > 1e-3)


def test_turn_velocity_turns_x_y_and_keeps_z():
    v = torch.tensor([[[1.0, 0.0, 0.5]]])
    out = turn_velocity(v, torch.tensor([math.pi / 2], dtype=torch.float64))
    assert torch.allclose(out, torch.tensor([[[0.0, 1.0, 0.5]]]))
    assert quarter_turns(0).numel() == 0


def test_the_loop_trains_with_the_term(tmp_path, sim_sequences):
    base = tiny_train_config(tmp_path / "off", max_steps=2)
    with_term = tiny_train_config(tmp_path / "on", max_steps=2, rotation_consistency_weight=1.0)
    off = train(base, sim_sequences, progress=False)
    on = train(with_term, sim_sequences, progress=False)
    assert off.steps == on.steps == 2
    a = load_model(off.checkpoint).model.state_dict()
    b = load_model(on.checkpoint).model.state_dict()
    assert any(not torch.equal(a[k], b[k]) for k in a)  # the term changed the gradient
    assert TrainConfig.load(tmp_path / "on" / "config.json").rotation_consistency_weight == 1.0
    with pytest.raises(ConfigError, match="rotation_consistency_weight"):
        TrainConfig(model="ftin", data=("x",), out_dir="o", rotation_consistency_weight=-1.0)
