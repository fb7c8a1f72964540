"""The body of ``GET /compare``: the "compare all models" table of one recording
(``app.services.compare_table``), beside ``app.schemas``, which holds the bodies of single runs."""

from __future__ import annotations

from pydantic import BaseModel, Field

from app.services.compare_table import CompareTable


class CompareColumnPayload(BaseModel):
    key: str = Field(description="The key of this column's value in every row's values.")
    label: str
    unit: str = Field(description="Unit of the value as shown (after scale); '' for a count or ratio.")
    digits: int = Field(description="Decimals shown.")
    scale: float = Field(description="Shown as value * scale (a ratio as a percentage).")
    better: str = Field(description="lower, higher, closer to 1, or neither (a figure, not a score).")
    description: str


class CompareRowPayload(BaseModel):
    run_id: str
    model: str
    values: dict[str, float | None] = Field(description="Column key -> value (None: undefined here).")
    flags: list[str] = Field(description="Why the row is flagged, a few words each (empty: not flagged).")
    warnings: list[str] = Field(description="The run's warnings in full.")
    worse_than_standing_still: bool | None = Field(description="None without ground truth.")
    verdict: str | None = Field(None, description="The walk's verdict: ok, check or implausible.")
    verdict_says: str | None = Field(None, description="The verdict in one line.")
    levels: dict[str, str] = Field(
        default_factory=dict,
        description="Each reason of the verdict by its code: ok, check or implausible.",
    )


class CompareResponse(BaseModel):
    sequence: str
    columns: list[CompareColumnPayload]
    rows: list[CompareRowPayload] = Field(description="One per run, in the order of ids.")
    stand_still: dict[str, float | None] | None = Field(
        description="The metric columns of a predictor that never moves (None without ground truth)."
    )
    summary: str = Field(description="The table in one sentence.")
    csv_url: str = Field(description="The same table as CSV.")
    zip_url: str = Field(description="Every model's trajectory in TUM format, and the CSV, in one ZIP.")

    @classmethod
    def from_table(cls, table: CompareTable, ids: str) -> CompareResponse:
        return cls(
            sequence=table.sequence,
            columns=[CompareColumnPayload(**vars(c)) for c in table.columns],
            rows=[CompareRowPayload(**vars(r)) for r in table.rows],
            stand_still=table.baseline,
            summary=table.summary,
            csv_url=f"/compare.csv?ids={ids}",
            zip_url=f"/compare.zip?ids={ids}",
        )
