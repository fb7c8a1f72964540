"""The body of ``GET /health``: the server's own state (what it loaded, its limits, its precision),
beside ``app.schemas``, which holds the bodies about recordings, models and runs."""

from __future__ import annotations

from pydantic import BaseModel, Field


class PrecisionPayload(BaseModel):
    """What predictions run in (``ftin.precision``), chosen at start-up."""

    setting: str = Field(description="FTIN_PRECISION: auto, fp32 or bf16.")
    precision: str = Field(description="What the models run in on this CPU: fp32 or bf16.")
    reason: str = Field(description="Why, in words (for auto: what the CPU has).")
    exceptions: dict[str, str] = Field(
        default_factory=dict,
        description="Models that run otherwise (auto keeps fp32 for a family whose bf16 accuracy was not "
        "shown within 1 % of fp32's): model name -> its precision and why.",
    )


class HealthResponse(BaseModel):
    status: str = "ok"
    version: str
    models: list[str]
    default_model: str | None
    default_model_why: str | None = Field(
        None, description="Why the default model is the default (the checkpoint folder's default.json)."
    )
    sequences: int
    scene_url: str | None = Field(description="URL of the viser 3D scene, when it runs.")
    notes: list[str] = Field(description="Configuration problems worth knowing (empty folders, fallbacks).")
    inferences_running: int = Field(0, description="Predictions running right now.")
    max_upload_mb: float = Field(description="Largest upload accepted (FTIN_MAX_UPLOAD_MB), MiB.")
    max_samples: int = Field(description="Most IMU samples one prediction reads (FTIN_MAX_SAMPLES).")
    inference_timeout_s: float = Field(
        description="Longest a prediction may go without progress (FTIN_INFERENCE_TIMEOUT_S)."
    )
    precision: PrecisionPayload
    map_tiles: str = Field(
        "", description="Tile URL template of the page's map (FTIN_MAP_TILES; empty: no map)."
    )
    map_attribution: str = Field("", description="The map tiles' credit (FTIN_MAP_ATTRIBUTION), HTML.")
