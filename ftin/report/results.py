"""What a Table 1 report is made of: the paper's column layout and the result types.

Decisions (the layout):
- Columns follow the paper: RoNIN ResNet, RoNIN LSTM, RoNIN TCN, RNIN, IMUNet, TLIO, FTIN, then
  "FTIN vs RoNIN ResNet" = ``(resnet - ftin) / resnet`` in percent (positive: FTIN is better), then
  the ablation +FDL (``resnet_fdl``), +TDL (``resnet_tdl``) and +FDL&TDL (``ftin`` again). A
  checkpoint fills the column of its ``model_name``; a column without a checkpoint shows "—" and is
  named in a note, never filled in.
- Before them stands "Stand still": the predictor that never moves, scored on the same recordings
  (in a motion-capture room it scores metres of ATE). Every dataset has one row per registered table
  metric (``ftin.metrics.list_metrics``): both ATE conventions, RTE, PDE and the path ratio
  (predicted / true horizontal path length): a model that barely moves can have a low ATE, never a
  path ratio near 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any

from ftin.data.types import ImuSequence, Trajectory
from ftin.evaluate import EvaluationReport
from ftin.metrics import Convention, TrajectoryMetrics, describe
from ftin.models import model_label
from ftin.protocol import COMPARED

MISSING = "—"
FTIN_MODEL = "ftin"
RESNET_MODEL = "ronin_resnet"
FIGURE_MODELS = (FTIN_MODEL, RESNET_MODEL)  # the paper's Fig. 4 compares these two
FIGURE_METRIC = "pde"  # the paper's Fig. 3 charts the position drift error per dataset and model


class ReportError(ValueError):
    """Bad report input (options, checkpoint folder); the message names the option or file."""


class ColumnGroup(str, Enum):
    BASELINE = "baseline"  # the predictor that never moves: the bar every model must clear
    COMPARED = "compared"
    IMPROVEMENT = "improvement"
    ABLATION = "ablation"
    PEDESTRIAN = "pedestrian"  # one checkpoint trained on several datasets together (as the app's default)


@dataclass(frozen=True)
class Column:
    label: str
    model_name: str | None  # None for the percentage column
    group: ColumnGroup


IMPROVEMENT_LABEL = f"{model_label(FTIN_MODEL)} vs {model_label(RESNET_MODEL)}"
STAND_STILL_LABEL = "Stand still"
# The compared models are headed by their registry label; the ablations by what they add to ResNet-1D,
# as the paper's columns are named.
PAPER_COLUMNS: tuple[Column, ...] = (
    Column(STAND_STILL_LABEL, None, ColumnGroup.BASELINE),
    *(Column(model_label(model), model, ColumnGroup.COMPARED) for model in COMPARED),
    Column(IMPROVEMENT_LABEL, None, ColumnGroup.IMPROVEMENT),
    Column("+FDL", "resnet_fdl", ColumnGroup.ABLATION),
    Column("+TDL", "resnet_tdl", ColumnGroup.ABLATION),
    Column("+FDL&TDL", FTIN_MODEL, ColumnGroup.ABLATION),
)
TABLE_MODELS = tuple(dict.fromkeys(c.model_name for c in PAPER_COLUMNS if c.model_name is not None))
MODEL_LABELS = {model: model_label(model) for model in TABLE_MODELS}  # names for figures
CONVENTION_LABELS = {
    Convention.RONIN: "RoNIN",
    Convention.EUCLIDEAN: "Euclidean",
    Convention.SE2: "SE(2)-aligned",
    Convention.SE3: "SE(3)-aligned",
}


# --- result types -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class DatasetSpec:
    """One table dataset: a display name and the files/folders its sequences come from."""

    name: str
    paths: tuple[Path, ...]


@dataclass(frozen=True)
class LoadedDataset:
    spec: DatasetSpec
    sequences: list[ImuSequence]

    @property
    def name(self) -> str:
        return self.spec.name


@dataclass
class CheckpointResult:
    name: str  # checkpoint stem
    model_name: str
    meta: dict[str, Any]
    reports: dict[str, EvaluationReport] = field(default_factory=dict)  # dataset -> report
    # dataset -> sequence -> predicted trajectory; kept only for FIGURE_MODELS
    trajectories: dict[str, dict[str, Trajectory]] = field(default_factory=dict)


@dataclass
class ReportResults:
    datasets: list[DatasetSpec]
    sequence_names: dict[str, list[str]]  # dataset -> sequence names, in reading order
    convention: Convention
    rte_window_s: float
    checkpoints: list[CheckpointResult]
    ground_truth: dict[str, dict[str, Trajectory]]  # dataset -> sequence -> ground truth
    stand_still: dict[str, TrajectoryMetrics] = field(default_factory=dict)  # dataset -> mean
    orientation: str | None = None  # the orientation choice applied (ftin.data.orientation_option)

    def describe(self) -> str:
        return describe(self.convention, self.rte_window_s)

    def by_model(self, model_name: str) -> CheckpointResult | None:
        return next((c for c in self.checkpoints if c.model_name == model_name), None)
