"""What ``GET /models`` and ``GET /sequences`` list: the models and the recordings to choose from."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, Field

from app.services.catalog import SequenceEntry, SequenceSummary
from app.services.checkpoint_store import ModelEntry


class ModelInfo(BaseModel):
    name: str = Field(description="The API name (the checkpoint's file stem): use it in ?model=.")
    display_name: str = Field(description="The name people know, for menus: 'RNIN · OxIOD'.")
    summary: str = Field("", description="The model in at most 25 plain words, for the page.")
    architecture: str
    trained_on: str | None = Field(description="Training data recorded in the checkpoint.")
    imu_rate_hz: float
    window: int = Field(description="Window length in samples at imu_rate_hz.")
    stride: int
    out_dim: int
    parameters: int
    metrics: dict[str, Any] | None = Field(description="Evaluation metrics recorded in the checkpoint.")
    default: bool

    @classmethod
    def from_entry(cls, entry: ModelEntry, default_name: str | None) -> ModelInfo:
        loaded, meta = entry.loaded, entry.meta
        return cls(
            name=entry.name,
            display_name=entry.display_name,
            summary=entry.summary(entry.name == default_name),
            architecture=entry.architecture,
            trained_on=entry.trained_on,
            imu_rate_hz=float(loaded.imu_rate_hz),
            window=int(loaded.window),
            stride=int(loaded.stride),
            out_dim=int(loaded.out_dim),
            parameters=entry.n_parameters,
            metrics=meta.get("metrics"),
            default=entry.name == default_name,
        )


# What a sequence's summary tells (None where it cannot be read).
_SUMMARY_FIELDS = ("duration_s", "rate_hz", "samples", "has_ground_truth")


class SequenceInfo(BaseModel):
    id: str = Field(description="Use in POST /sequences/{id}/predict.")
    name: str
    dataset: str
    duration_s: float | None
    rate_hz: float | None
    samples: int | None
    has_ground_truth: bool | None
    error: str | None = Field(None, description="Why the sequence cannot be read, if it cannot.")
    dataset_label: str | None = Field(None, description="The data folder in words, for menus.")
    suggested_model: str | None = Field(
        None, description="The model trained on this kind of data (else the default model)."
    )

    @classmethod
    def from_entry(
        cls, entry: SequenceEntry, summary: SequenceSummary | str, suggested_model: str | None = None
    ) -> SequenceInfo:
        listed = {
            "id": entry.id,
            "name": entry.name,
            "dataset": entry.dataset,
            "dataset_label": entry.dataset_label or None,
            "suggested_model": suggested_model,
        }
        if isinstance(summary, str):  # unreadable: the summary is why, and nothing was measured
            return cls(**listed, **dict.fromkeys(_SUMMARY_FIELDS), error=summary)
        return cls(
            **listed,
            duration_s=round(summary.duration_s, 3),
            rate_hz=round(summary.rate_hz, 3),
            samples=summary.n_samples,
            has_ground_truth=summary.has_ground_truth,
        )
