"""``ftin table`` and ``ftin evaluate`` on Ray (``--workers N`` / ``--address``): the same evaluation
(``ftin.report.evaluation``, ``ftin.evaluate``), one task per checkpoint or per recording, merged into
the result a serial run gives (same order, same means, same stand-still row).

A task loads its checkpoint from the file (a model with weight-norm parametrizations does not
pickle; on a cluster the checkpoints must be where every node sees them, as the data) and copies
the recordings it gets from Ray's object store (read-only there; inference writes in place)."""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch

from ftin.campaign import engine
from ftin.checkpoint import load_model
from ftin.data.types import ImuSequence
from ftin.evaluate import EvaluationReport, evaluate_checkpoint
from ftin.metrics import mean_metrics
from ftin.report.evaluation import evaluate_checkpoints
from ftin.report.results import LoadedDataset, ReportResults


def _one_checkpoint(stem: Path, datasets: Sequence[LoadedDataset], options: dict[str, Any]) -> Any:
    torch.set_num_threads(1)
    return evaluate_checkpoints([load_model(stem)], copy.deepcopy(datasets), **options)


def _one_sequence(seq: ImuSequence, checkpoint: Path, options: dict[str, Any]) -> EvaluationReport:
    torch.set_num_threads(1)
    return evaluate_checkpoint(load_model(checkpoint), [copy.deepcopy(seq)], **options)


def evaluate_checkpoints_on_ray(
    checkpoints: Sequence[Path],
    datasets: Sequence[LoadedDataset],
    *,
    workers: int | None = None,
    address: str | None = None,
    on_done: Callable[[int], None] | None = None,
    **options: Any,
) -> ReportResults:
    """``evaluate_checkpoints`` with one Ray task per checkpoint (stems, in the table's column order);
    ``options`` are its keywords."""
    parts = engine.map_tasks(
        _one_checkpoint, checkpoints, datasets, options, workers=workers, address=address, on_done=on_done
    )
    # The ground truth and stand-still row come from the first checkpoint's preparation, as serially.
    return dataclasses.replace(parts[0], checkpoints=[c for part in parts for c in part.checkpoints])


def evaluate_checkpoint_on_ray(
    checkpoint: Path,
    sequences: Sequence[ImuSequence],
    *,
    workers: int | None = None,
    address: str | None = None,
    on_done: Callable[[int], None] | None = None,
    **options: Any,
) -> EvaluationReport:
    """``evaluate_checkpoint`` with one Ray task per sequence; ``options`` are its keywords."""
    parts = engine.map_tasks(
        _one_sequence, sequences, checkpoint, options, workers=workers, address=address, on_done=on_done
    )
    results = [r for part in parts for r in part.sequences]
    return dataclasses.replace(
        parts[0],
        sequences=results,
        mean=mean_metrics([r.metrics for r in results]),
        stand_still=mean_metrics([r.stand_still for r in results]),
    )
