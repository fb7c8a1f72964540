"""``TrainConfig.init_from``: a run starts from a checkpoint's weights, or refuses another architecture."""

from __future__ import annotations

import pytest
import torch

from ftin.checkpoint import load_model
from ftin.cli import app
from ftin.data.readers.generic_csv import write_csv
from ftin.train import ConfigError, train
from tests.utils.checkpoints import RATE_HZ, tiny_train_config, write_checkpoint
from tests.utils.cli import FAST, TINY, fails_cleanly, runner

TCN_KWARGS = {"channels": (8, 8), "kernel_size": 3}  # tiny_train_config's model


def test_a_run_starts_from_the_checkpoint_weights(tmp_path, sim_sequences):
    source = write_checkpoint(tmp_path / "source", "ronin_tcn", seed=123, model_kwargs=TCN_KWARGS)
    # a budget spent before the first step: the checkpoint written is the weights the run started with
    config = tiny_train_config(tmp_path / "run", init_from=str(source), max_minutes=1e-9, seed=7)
    result = train(config, sim_sequences, progress=False)
    assert result.steps == 0
    started = load_model(result.checkpoint).model.state_dict()
    expected = load_model(source).model.state_dict()
    assert started.keys() == expected.keys()
    assert all(torch.equal(started[k], expected[k]) for k in expected)
    assert load_model(result.checkpoint).meta["train_config"]["init_from"] == str(source)


def test_another_architecture_is_refused(tmp_path, sim_sequences):
    source = write_checkpoint(tmp_path / "source", "ronin_tcn", model_kwargs={"channels": (4, 4)})
    config = tiny_train_config(tmp_path / "run", init_from=str(source))
    with pytest.raises(ValueError, match=r"init_from .*ronin_tcn.*cannot start") as error:
        train(config, sim_sequences, progress=False)
    assert isinstance(error.value, ConfigError)
    assert "[4, 4]" in str(error.value) and "[8, 8]" in str(error.value)  # both architectures named


def test_another_rate_is_refused(tmp_path, sim_sequences):
    source = write_checkpoint(tmp_path / "source", "ronin_tcn", model_kwargs=TCN_KWARGS, rate_hz=2 * RATE_HZ)
    config = tiny_train_config(tmp_path / "run", init_from=str(source))
    with pytest.raises(ConfigError, match="100 Hz cannot start"):
        train(config, sim_sequences, progress=False)


def test_the_cli_option_reaches_the_run(tmp_path, sim_sequences):
    (tmp_path / "data").mkdir()
    for seq in sim_sequences:
        write_csv(seq, tmp_path / "data" / f"{seq.name}.csv")
    source = write_checkpoint(tmp_path / "source", "ronin_tcn", model_kwargs={"channels": (4, 4)})
    args = ["train", *TINY, *FAST, "--data", str(tmp_path / "data"), "--out", str(tmp_path / "run")]
    fails_cleanly(runner.invoke(app, [*args, "--init-from", str(source)]), "init_from", "cannot start")
