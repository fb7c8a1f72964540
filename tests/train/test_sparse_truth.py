"""Training on sparse truth (ftin/train/sparse_truth.py): the segment loss is zero where the predicted
displacements are the waypoints', grows with a scale error and a wrong turn, and a run whose data holds
an ILC walk trains on its chunks (in bf16 too) and records them."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from ftin.data.discovery import read_sequence
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.train import TrainConfig, load_model, train
from ftin.train.sparse_truth import TURN_WEIGHT, SparseChunks, segment_loss, split_sparse
from tests.utils.checkpoints import tiny_train_config
from tests.utils.ilc import write_trace

# Three marks: 6 m east in 5 s, then 4 m north in 4 s (a left turn of 90 degrees).
MARKS = np.array([[0.0, 0.0, 10.0], [6.0, 0.0, 15.0], [6.0, 4.0, 19.0]])


def _velocity(
    first: tuple[float, float], second: tuple[float, float], n1: int = 10, n2: int = 8
) -> torch.Tensor:
    return torch.tensor([first] * n1 + [second] * n2, dtype=torch.float32)


def test_the_segment_loss_reads_scale_and_turn_and_not_the_map_heading():
    layout = [(10, 8, MARKS)]
    exact = segment_loss(_velocity((1.2, 0.0), (0.0, 1.0)), layout)
    assert float(exact) == pytest.approx(0.0, abs=1e-3)
    turned = segment_loss(_velocity((0.0, 1.2), (-1.0, 0.0)), layout)  # the same walk, heading 90 deg off
    assert float(turned) == pytest.approx(0.0, abs=1e-3)
    short = segment_loss(_velocity((0.6, 0.0), (0.0, 0.5)), layout)  # every segment read at half length
    assert float(short) == pytest.approx(math.log(0.5) ** 2, abs=1e-2)
    straight = segment_loss(_velocity((1.2, 0.0), (1.0, 0.0)), layout)  # the turn missed
    assert float(straight) == pytest.approx(TURN_WEIGHT * (1 - math.cos(math.pi / 2)), abs=1e-3)


def test_chunks_of_a_trace_and_training_on_them(tmp_path, sim_sequences):
    trace = read_sequence(write_trace(tmp_path / "ilc", seconds=40.0))
    dense, sparse = split_sparse([*sim_sequences, trace])
    assert sparse == [trace] and len(dense) == len(sim_sequences)
    chunks = SparseChunks(sparse, 50.0, 25)
    assert len(chunks) >= 1 and chunks.names == [trace.name]
    batch = chunks.batch(np.random.default_rng(0), 3)
    assert batch.x.shape[1:] == (6, 25) and len(batch.layout) == 3
    assert batch.x.shape[0] == sum(n1 + n2 for n1, n2, _ in batch.layout)

    model = {"model": "ftin", "model_kwargs": {**TINY_FTIN_KWARGS, "window": 25}}
    config: TrainConfig = tiny_train_config(tmp_path / "run", max_steps=3, precision="bf16", **model)
    result = train(config, [*sim_sequences, trace], progress=False)
    meta = load_model(result.checkpoint).meta
    assert result.steps == 3 and meta["split"]["sparse"] == [trace.name]
    assert "ilc" in meta["training_data"]["datasets"] and trace.name in meta["training_data"]["sequences"]
    assert trace.name not in meta["split"]["train"] + meta["split"]["val"]
    with pytest.raises(ValueError, match="sparse_chunks >= 1"):
        train(
            config.with_(sparse_chunks=0, out_dir=str(tmp_path / "refused")),
            [*sim_sequences, trace],
            progress=False,
        )
