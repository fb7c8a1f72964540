"""``TrainConfig.train_only``: a shipped RoNIN ResNet gains a variance head, its velocities unchanged."""

from __future__ import annotations

import pytest
import torch

from ftin.checkpoint import load_model
from ftin.train import ConfigError, train
from tests.utils.checkpoints import head_train_config, tiny_model_kwargs, tiny_train_config, write_checkpoint

KWARGS = tiny_model_kwargs("ronin_resnet")


def test_only_the_new_head_trains(tmp_path, sim_sequences):
    source = write_checkpoint(tmp_path / "source", "ronin_resnet", seed=3, model_kwargs=KWARGS)
    config = head_train_config(tmp_path / "run", source, max_epochs=2)
    result = train(config, sim_sequences, progress=False)
    assert result.steps > 0
    trained = load_model(result.checkpoint)
    before = load_model(source).model.state_dict()
    after = trained.model.state_dict()
    # every weight and batch-norm statistic of the shipped model is as it was
    assert all(torch.equal(after[k], before[k]) for k in before), [
        k for k in before if not torch.equal(after[k], before[k])
    ]
    new = [k for k in after if k.startswith("log_std_head")]
    assert new and trained.model.has_uncertainty
    # the head learnt: the validation NLL is what the run monitored, and it is recorded per epoch
    assert all("val_nll" in epoch for epoch in result.history)
    x = torch.randn(4, 6, KWARGS["window"])
    trained.model.eval()
    with torch.no_grad():
        out = trained.model(x)
        plain = load_model(source).model.eval()(x)
    assert out.log_std is not None and out.log_std.shape == out.velocity.shape
    assert torch.allclose(out.velocity, plain.velocity)


def test_a_prefix_that_names_nothing_is_refused(tmp_path, sim_sequences):
    config = tiny_train_config(
        tmp_path / "run", model="ronin_resnet", model_kwargs=KWARGS, train_only=("no_such_head",)
    )
    with pytest.raises(ConfigError, match="no parameter of this model"):
        train(config, sim_sequences, progress=False)


def test_a_checkpoint_missing_more_than_the_trained_head_is_refused(tmp_path, sim_sequences):
    source = write_checkpoint(tmp_path / "source", "ronin_resnet", model_kwargs=KWARGS)
    config = tiny_train_config(
        tmp_path / "run",
        model="ronin_resnet",
        model_kwargs={**KWARGS, "uncertainty_head": True},
        init_from=str(source),
        train_only=(
            "head",
        ),  # the velocity head is in the checkpoint; the log-std head is not and does not train
    )
    with pytest.raises(ConfigError, match="weights missing"):
        train(config, sim_sequences, progress=False)
