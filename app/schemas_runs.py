"""The bodies of GET /runs: the stored runs, newest first, each with its downloads and its group (the
compare-all it belongs to), beside ``app.schemas``, which holds the prediction answers."""

from __future__ import annotations

from pydantic import BaseModel, Field

from app.services.run_archive import RunRecord


class RunSummary(BaseModel):
    """A finished run kept on the server (GET /runs): what it is and where its files are."""

    run_id: str
    model: str
    sequence: str
    sequence_id: str | None = Field(
        None, description="The GET /sequences id it ran on (a bundled or listed recording); None for uploads."
    )
    source: str = Field(description="upload, json, sequence, viser or live: the door it came in through.")
    created_s: float = Field(description="When it finished, seconds since the epoch.")
    group: str | None = Field(
        None,
        description="The run_id of the run a compare-all started from, for each run that compare made "
        "(the page lists them beneath it); None for a run of its own.",
    )
    has_ground_truth: bool
    worse_than_standing_still: bool | None
    page_url: str = Field(description="The upload page with this run loaded: /runs/{run_id} (text/html).")
    csv_url: str
    tum_url: str
    ground_truth_tum_url: str | None
    metrics_url: str
    result_url: str = Field(description="The whole POST /predict answer again: GET /runs/{run_id}/result.")

    @classmethod
    def from_record(cls, record: RunRecord) -> RunSummary:
        base = f"/runs/{record.run_id}"
        return cls(
            run_id=record.run_id,
            model=record.model,
            sequence=record.sequence,
            sequence_id=record.sequence_id,
            source=record.source,
            created_s=record.created_s,
            group=record.group_id,
            has_ground_truth=record.has_ground_truth,
            worse_than_standing_still=record.worse_than_standing_still,
            page_url=base,
            csv_url=f"{base}/trajectory.csv",
            tum_url=f"{base}/trajectory.tum",
            ground_truth_tum_url=f"{base}/ground_truth.tum" if record.has_ground_truth else None,
            metrics_url=f"{base}/metrics.json",
            result_url=f"{base}/result",
        )
