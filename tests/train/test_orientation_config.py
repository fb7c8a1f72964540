"""``TrainConfig.orientation``: every choice of ``ftin.data.orientation_option``, saved and loaded; configs
written before (``ground_truth``, ``device``, none) still load; training applies the choice as inference."""

from __future__ import annotations

import json

import pytest

from ftin.data.orientation_option import CHOICES
from ftin.train.config import ConfigError, TrainConfig
from ftin.train.data import training_data
from ftin.train.distributed import Distributed
from tests.utils.checkpoints import tiny_train_config


@pytest.mark.parametrize("orientation", [*CHOICES, None])
def test_every_choice_round_trips(tmp_path, orientation):
    config = tiny_train_config(tmp_path / "run", orientation=orientation)
    config.save(tmp_path / "config.json")
    assert TrainConfig.load(tmp_path / "config.json").orientation == orientation


def test_an_older_config_still_loads(tmp_path):
    data = tiny_train_config(tmp_path / "run").to_json()
    for old in ("ground_truth", "device"):
        (tmp_path / "old.json").write_text(json.dumps({**data, "orientation": old}))
        assert TrainConfig.load(tmp_path / "old.json").orientation == old


def test_a_bad_choice_names_the_choices(tmp_path):
    with pytest.raises(ConfigError, match="auto, device, vqf, vqf6d, ground_truth, got 'compass'"):
        tiny_train_config(tmp_path / "run", orientation="compass")


def test_training_prepares_with_the_chosen_orientation(tmp_path, sim_sequences, monkeypatch):
    from ftin.train import data as train_data

    applied = []

    def prepare(seq, rate_hz, *args, orientation=None, **kwargs):
        out = real_prepare(seq, rate_hz, *args, orientation=orientation, **kwargs)
        applied.append(out.seq.meta["orientation_choice"]["source"])
        return out

    real_prepare = train_data.prepare
    monkeypatch.setattr(train_data, "prepare", prepare)
    config = tiny_train_config(tmp_path / "run", orientation="vqf6d", imu_rate_hz=50.0)
    data = training_data(config, sim_sequences[:2], sim_sequences[2:], parts=1, out_dim=2, ddp=Distributed())
    assert data.val is not None and applied == ["vqf6d"] * len(sim_sequences)
