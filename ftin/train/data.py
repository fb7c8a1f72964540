"""The windows one training process works on (``ftin.train.loop``).

``training_data(config, train_sequences, val_sequences, ...)``: without validation sequences a seeded
``val_fraction`` of whole training sequences is held out (``ftin.data.loading.split_validation``); every
sequence is prepared for the config's rate (walks whose truth is waypoints apart: their chunks,
``ftin.train.sparse_truth``, join each step's batch) (``ftin.data.prepare.prepare``, as inference prepares it)
and cut into ``WindowDataset``s with per-part targets (the training windows with the config's
augmentations, ``ftin.train.augment``); the input normalisation is fitted on the
training windows; each of N processes takes ``ceil(batch_size / N)`` windows per step, in the order
of a ``DistributedSampler`` (also with one process) seeded by ``config.seed`` and the epoch.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch.utils.data.distributed import DistributedSampler

from ftin.data.loading import split_validation
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence
from ftin.data.windows import InputNormalization, WindowDataset, fit_normalization
from ftin.models.base import VelocityModel
from ftin.train.augment import WindowAugmenter
from ftin.train.config import TrainConfig
from ftin.train.distributed import Distributed
from ftin.train.losses import block_means, validation_blocks
from ftin.train.provenance import training_data_record
from ftin.train.sparse_truth import SparseBatch, SparseChunks, split_sparse, step_generator


@dataclass
class TrainData:
    train: WindowDataset
    val: WindowDataset | None
    normalization: InputNormalization
    sampler: DistributedSampler
    batch: int  # windows per step in this process
    val_per_block: int  # parts per ~1 s validation block (ftin.train.losses.validation_blocks)
    info: dict[str, Any]  # training data and split, for the checkpoint's JSON
    sparse: SparseChunks | None = None  # walks whose truth is waypoints (ftin.train.sparse_truth)

    def sparse_batch(self, config: TrainConfig, step: int) -> SparseBatch | None:
        """This step's sparse-truth chunks (None without sparse walks); drawn as a resumed run would."""
        if self.sparse is None:
            return None
        return self.sparse.batch(step_generator(config.seed, step), config.sparse_chunks)

    def validation_sums(
        self,
        model: VelocityModel,
        device: torch.device,
        ddp: Distributed,
        log_std_range: tuple[float, float] = (-5.0, 3.0),
    ) -> tuple[float, float, int]:
        """Squared-error sum, Gaussian NLL sum (0 without a log-std) and element count of ~1 s mean
        velocities over this rank's share of the validation windows: per window for K = 1 models, per
        block of parts otherwise (``ftin.train.losses.validation_blocks``; a block's log-std is its
        parts' mean, exact for K = 1)."""
        model.eval()
        indices = np.arange(len(self.val))[ddp.rank :: ddp.world]
        sq_sum, nll_sum, count = 0.0, 0.0, 0
        with torch.inference_mode():
            for i in range(0, len(indices), self.batch):
                x, v = self.val.get_batch(indices[i : i + self.batch])
                out = model.forward_parts(self.normalization.apply(x.to(device)))  # (B, K, D)
                pred = block_means(out.velocity, self.val_per_block)  # (B, blocks, D)
                target = block_means(v.to(device), self.val_per_block)
                error2 = (pred - target) ** 2
                sq_sum += float(error2.sum())
                if out.log_std is not None:
                    log_std = block_means(out.log_std, self.val_per_block).clamp(*log_std_range)
                    nll_sum += float((0.5 * error2 * torch.exp(-2.0 * log_std) + log_std).sum())
                count += target.numel()
        return sq_sum, nll_sum, count


def training_data(
    config: TrainConfig,
    train_sequences: Sequence[ImuSequence],
    val_sequences: Sequence[ImuSequence],
    *,
    parts: int,
    out_dim: int,
    ddp: Distributed,
) -> TrainData:
    """The windows of ``config`` (rate and window resolved) for a model predicting ``parts`` parts of
    ``out_dim`` velocities per window (module docstring)."""
    rate_hz, window = float(config.imu_rate_hz), config.resolved_window
    train_sequences, sparse_sequences = split_sparse(train_sequences)
    val_sequences, _ = split_sparse(val_sequences)  # the validation loss is a velocity MSE
    if sparse_sequences and config.sparse_chunks < 1:
        names = ", ".join(s.name for s in sparse_sequences[:3])
        raise ValueError(f"walks with waypoints only ({names}, ...) need sparse_chunks >= 1 to train on")
    val_source = "paths" if val_sequences else "none"
    if not val_sequences:
        train_sequences, val_sequences = split_validation(train_sequences, config.val_fraction, config.seed)
        val_source = "held_out" if val_sequences else "none"
    prepared_train = [prepare(s, rate_hz, orientation=config.orientation).seq for s in train_sequences]
    train = WindowDataset(
        prepared_train,
        window,
        config.stride,
        out_dim,
        parts=parts,
        augment_yaw=config.augment_yaw,
        seed=config.seed,
        augmenter=WindowAugmenter(config.augment, config.stride, config.seed),
    )
    val, prepared_val = None, []
    if val_sequences:
        prepared_val = [prepare(s, rate_hz, orientation=config.orientation).seq for s in val_sequences]
        val = WindowDataset(prepared_val, window, config.stride, out_dim, parts=parts, augment_yaw=False)
    split = {
        "train": train.names,
        "val": [] if val is None else val.names,
        "val_source": val_source,
        # recordings whose reference orientation does not belong to their IMU (ftin.data.reference_check)
        "reference_disagrees": [
            s.name
            for s in (*prepared_train, *prepared_val)
            if s.meta.get("reference_check", {}).get("disagrees")
        ],
    }
    sparse = SparseChunks(sparse_sequences, rate_hz, window, config.orientation) if sparse_sequences else None
    if sparse is not None:
        split["sparse"] = sparse.names
    return TrainData(
        sparse=sparse,
        train=train,
        val=val,
        normalization=fit_normalization(train.imu_per_sequence, config.normalization),
        sampler=DistributedSampler(train, ddp.world, ddp.rank, shuffle=True, seed=config.seed),
        batch=math.ceil(config.batch_size / ddp.world),
        val_per_block=validation_blocks(window, parts, rate_hz),
        # datasets by name, recordings relative to the data folder (ftin.train.provenance)
        info={
            "training_data": training_data_record(
                config.data,
                [*train_sequences, *sparse_sequences],
                [*train.names, *([] if sparse is None else sparse.names)],
            ),
            "split": split,
        },
    )
