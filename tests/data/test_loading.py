"""``ftin.data.loading``: reading paths into sequences, the validation hold-out, preparation."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.data.errors import DataFormatError
from ftin.data.loading import data_rate_hz, load_sequences, split_validation
from ftin.data.prepare import prepare
from ftin.data.readers.generic_csv import write_csv
from ftin.sim import SimConfig, simulate


@pytest.fixture(scope="module")
def walks():
    return [simulate(SimConfig(duration_s=5.0, rate_hz=50.0, seed=seed)) for seed in (1, 2, 3)]


def test_split_validation_holds_out_whole_sequences(walks):
    train_seqs, val_seqs = split_validation(walks, 0.1, seed=0)
    assert len(val_seqs) == 1 and len(train_seqs) == 2
    assert {s.name for s in train_seqs}.isdisjoint(s.name for s in val_seqs)
    assert split_validation(walks[:1], 0.5, seed=0) == (walks[:1], [])
    assert split_validation(walks, 0.0, seed=0)[1] == []


def test_load_sequences_reads_files_and_folders_and_names_the_option(walks, tmp_path):
    for seq in walks:
        write_csv(seq, tmp_path / "data" / f"{seq.name}.csv")
    folder = load_sequences([tmp_path / "data"])
    assert len(folder) == 3
    assert len(load_sequences([tmp_path / "data" / f"{walks[0].name}.csv"])) == 1
    with pytest.raises(DataFormatError, match="--val .*no such file"):
        load_sequences([tmp_path / "missing"], "--val")
    with pytest.raises(DataFormatError, match="--data: no sequences given"):
        load_sequences([])
    assert data_rate_hz(folder) == 50.0


def test_prepare_puts_the_sequence_on_the_rate_grid(walks):
    prepared = prepare(walks[0].with_(q_world_device_wxyz=None), 25.0, window=10, stride=5)
    assert prepared.seq.q_world_device_wxyz is not None
    assert any("orientation estimated by" in note for note in prepared.seq.meta["notes"])  # said once
    np.testing.assert_allclose(np.diff(prepared.seq.t_s), 1 / 25.0, rtol=1e-6)
    assert prepared.imu_world.shape == (len(prepared), 6) and prepared.imu_world.dtype == np.float32
    np.testing.assert_array_equal(prepared.starts, np.arange(0, len(prepared) - 10, 5))


def test_prepare_keeps_a_sequence_already_on_the_grid(walks):
    seq = walks[0]
    prepared = prepare(seq, seq.rate_hz)
    assert prepared.seq is seq and prepared.notes == [] and prepared.starts is None
