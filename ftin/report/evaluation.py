"""Evaluation for the report: every checkpoint of a folder on every dataset, once each.

``evaluate_checkpoints`` runs each (checkpoint, sequence) pair exactly once through the inference
path users get and keeps, besides the metrics, the trajectories the figures need.

Decisions:
- Two checkpoints for one column are an error (which one would the table show?): a folder holding
  e.g. ``ftin-oxiod`` and ``ftin-sim`` is narrowed with name globs (``find_checkpoints(patterns=...)``,
  ``ftin table --pattern '*-oxiod'``). Checkpoints of models outside the layout (e.g. ``resnet1d``)
  are evaluated too: they appear in the metric chart and ``results.json`` and are named in a note.
- The representative sequence of a dataset (trajectory figure) is the one whose FTIN ATE is the
  median (lower middle for an even count; RoNIN ResNet's ATE without an FTIN checkpoint): neither the
  best nor the worst case, so the figure does not cherry-pick.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from fnmatch import fnmatchcase
from pathlib import Path

from ftin.checkpoint import META_SUFFIX, WEIGHTS_SUFFIX, LoadedModel, load_model
from ftin.data.errors import DataFormatError
from ftin.data.loading import load_sequences
from ftin.data.types import Trajectory
from ftin.evaluate import EvaluationReport, SequenceResult, score, uncertainty_coverage
from ftin.infer import predict_trajectory
from ftin.metrics import Convention, evaluate_trajectory, mean_metrics, stand_still
from ftin.report.results import (
    FIGURE_MODELS,
    TABLE_MODELS,
    CheckpointResult,
    DatasetSpec,
    LoadedDataset,
    ReportError,
    ReportResults,
)


def load_datasets(specs: Sequence[DatasetSpec], orientation: str | None = None) -> list[LoadedDataset]:
    """Read every sequence of every dataset (folders searched with the readers' discovery), as the
    ``orientation`` choice needs them read (``ftin.data.loading.reader_options``)."""
    loaded = []
    for spec in specs:
        sequences = load_sequences(spec.paths, f"--dataset {spec.name}", orientation)
        no_truth = [seq.name for seq in sequences if seq.gt is None]
        if no_truth:
            raise DataFormatError(
                f"--dataset {spec.name}: sequence(s) {', '.join(no_truth)} lack ground truth to score against"
            )
        names = [seq.name for seq in sequences]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise DataFormatError(
                f"--dataset {spec.name}: sequence name(s) {', '.join(duplicates)} occur more than once; "
                "give each path once (or files with different names)"
            )
        loaded.append(LoadedDataset(spec, sequences))
    return loaded


def find_checkpoints(
    directory: str | Path,
    patterns: Sequence[str] = (),
    option: str = "--checkpoints",
    pattern_option: str = "--pattern",
) -> list[Path]:
    """Every ``<stem>.json`` with a ``<stem>.safetensors`` beside it under ``directory`` (recursive,
    sorted); a run folder's ``config.json`` or ``resume.safetensors`` have no partner and are skipped.

    ``patterns`` (shell globs, case-sensitive) keep the checkpoints whose name (the file stem, e.g.
    ``ftin-oxiod``) matches any of them: a folder holding ``ftin-oxiod`` and ``ftin-sim`` gives the
    OxIOD table with ``*-oxiod``. A pattern matching nothing is an error naming what is there.
    """
    directory = Path(directory).expanduser()
    if not directory.is_dir():
        raise ReportError(f"{option} {directory}: no such folder")
    stems = sorted(
        p.with_suffix("")
        for p in directory.rglob(f"*{META_SUFFIX}")
        if p.with_suffix(WEIGHTS_SUFFIX).is_file()
    )
    if not stems:
        pair = f"<name>{WEIGHTS_SUFFIX} + <name>{META_SUFFIX}"
        raise ReportError(f"{option} {directory}: no checkpoints there (pairs of {pair})")
    for pattern in patterns:
        if not any(fnmatchcase(stem.name, pattern) for stem in stems):
            available = ", ".join(stem.name for stem in stems)
            raise ReportError(
                f"{pattern_option} {pattern!r} matches no checkpoint in {directory} (there: {available})"
            )
    if patterns:
        stems = [stem for stem in stems if any(fnmatchcase(stem.name, p) for p in patterns)]
    return stems


def load_checkpoints(stems: Sequence[Path]) -> list[LoadedModel]:
    """``load_model`` for each stem, in the paper's column order (other models after, by name);
    ``ReportError`` when two fill the same table column."""
    loaded = [load_model(stem) for stem in stems]
    by_model: dict[str, list[str]] = {}
    for stem, model in zip(stems, loaded, strict=True):
        by_model.setdefault(model.model_name, []).append(str(stem) + META_SUFFIX)
    for model_name, files in by_model.items():
        if model_name in TABLE_MODELS and len(files) > 1:
            raise ReportError(
                f"{len(files)} checkpoints of model {model_name!r} ({', '.join(files)}); the table has one "
                "column per model: choose with --pattern (a glob on the checkpoint name, e.g. '*-oxiod')"
            )
    rank = {name: i for i, name in enumerate(TABLE_MODELS)}
    return sorted(loaded, key=lambda m: (rank.get(m.model_name, len(rank)), m.name))


# --- evaluation -------------------------------------------------------------------------------------


def evaluate_checkpoints(
    checkpoints: Sequence[LoadedModel],
    datasets: Sequence[LoadedDataset],
    convention: Convention = Convention.RONIN,
    *,
    rte_window_s: float = 60.0,
    stride: int | None = None,
    on_evaluation: Callable[[str, str, str], None] | None = None,
    orientation: str | None = None,
    yaw_copies: int | None = None,
    cyclic_turns: bool | None = None,
) -> ReportResults:
    """Score every checkpoint on every sequence of every dataset, once each, with the ``orientation``
    choice applied (``ftin.data.orientation_option``; ``None``: each sequence's own).

    ``on_evaluation(checkpoint, dataset, sequence)`` is called before each of the
    ``len(checkpoints) x total sequences`` evaluations (progress bars).
    """
    convention = Convention(convention)
    if not checkpoints:
        raise ReportError("no checkpoints to evaluate")
    if not datasets:
        raise ReportError("no datasets to evaluate on")
    ground_truth: dict[str, dict[str, Trajectory]] = {d.name: {} for d in datasets}
    results = []
    for loaded in checkpoints:
        result = CheckpointResult(loaded.name, loaded.model_name, loaded.meta)
        for dataset in datasets:
            sequences: list[SequenceResult] = []
            for seq in dataset.sequences:
                if on_evaluation is not None:
                    on_evaluation(loaded.name, dataset.name, seq.name)
                prediction = predict_trajectory(
                    loaded,
                    seq,
                    stride=stride,
                    keep_prepared=False,
                    orientation=orientation,
                    yaw_copies=yaw_copies,
                    cyclic_turns=cyclic_turns,
                )
                scored = score(prediction, None, convention, rte_window_s, default_alignment_rule=False)
                if scored.metrics is None:
                    reason = "; ".join(scored.warnings[-1:])
                    raise DataFormatError(f"--dataset {dataset.name}, sequence {seq.name!r}: {reason}")
                warnings = [*prediction.warnings, *scored.warnings]
                duration_s = prediction.trajectory.duration_s
                choice = prediction.orientation_choice
                coverage = uncertainty_coverage(prediction, loaded.name, seq)  # the uncertainty vs the truth
                sequences.append(
                    SequenceResult(seq.name, scored.metrics, duration_s, warnings, None, choice, coverage)
                )
                ground_truth[dataset.name].setdefault(seq.name, prediction.truth)
                if loaded.model_name in FIGURE_MODELS:
                    result.trajectories.setdefault(dataset.name, {})[seq.name] = prediction.trajectory
            result.reports[dataset.name] = EvaluationReport(
                checkpoint=loaded.name,
                convention=convention,
                rte_window_s=float(rte_window_s),
                sequences=sequences,
                mean=mean_metrics([s.metrics for s in sequences]),
            )
        results.append(result)
    return ReportResults(
        datasets=[d.spec for d in datasets],
        sequence_names={d.name: [seq.name for seq in d.sequences] for d in datasets},
        convention=convention,
        rte_window_s=float(rte_window_s),
        checkpoints=results,
        ground_truth=ground_truth,
        stand_still={
            name: mean_metrics(
                [evaluate_trajectory(stand_still(gt), gt, convention, rte_window_s) for gt in truths.values()]
            )
            for name, truths in ground_truth.items()
        },
        orientation=orientation,
    )


def representative_sequence(results: ReportResults, dataset: str) -> str:
    """The sequence with the median ATE of FTIN (else RoNIN ResNet, else the first checkpoint)."""
    reference = next((c for m in FIGURE_MODELS if (c := results.by_model(m)) is not None), None)
    reference = reference or results.checkpoints[0]
    ranked = sorted(reference.reports[dataset].sequences, key=lambda r: (r.metrics.ate, r.name))
    return ranked[(len(ranked) - 1) // 2].name
