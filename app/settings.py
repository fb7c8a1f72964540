"""All dashboard settings in one pydantic-settings object, read from ``FTIN_*`` environment variables.

Decisions:
- Both servers bind 127.0.0.1 unless told otherwise (``uvicorn --host`` for the REST API,
  ``FTIN_VISER_HOST`` for the scene): the dashboard runs models on files users upload.
- ``FTIN_DATA_DIRS`` is an ``os.pathsep``-separated list (``:`` on Linux), like ``PATH``, not JSON.
- CORS is closed (no origins) unless ``FTIN_CORS_ORIGINS`` lists some (comma-separated): the upload
  page is served by the API itself, so it never needs CORS.
- ``FTIN_VISER_PORT=0`` lets the OS pick a free port (tests); viser moves to the next free port
  when the configured one is taken, so the real URL is read back from the running server.
- Model names are checkpoint file stems (``checkpoints/ftin-oxiod.safetensors`` is ``ftin-oxiod``)
  and are matched case-insensitively, so the paper's spelling ``FTIN-OxIOD`` names the same model.
- The default model (``FTIN_DEFAULT_MODEL``) is ``ftin-pedestrian``, trained on real walks; when
  that checkpoint is absent the first FTIN checkpoint stands in (``ModelStore``). The 3D scene ticks,
  per sequence, the checkpoint trained on that kind of data (``app.services.kinds``).
- Limits: one prediction reads at most ``FTIN_MAX_SAMPLES`` samples (default one hour at
  200 Hz) and is stopped after ``FTIN_INFERENCE_TIMEOUT_S`` without progress (waiting for a free slot
  included; a long recording that keeps making progress is never cut: ``app.services.limits``);
  at most ``FTIN_MAX_CONCURRENT_INFERENCES`` run at once (default 1: on a small CPU two runs only
  slow each other down, and each holds its windows in memory), and at most ``FTIN_MAX_PENDING_UPLOADS``
  are read, parsed, waiting or running (429 with ``Retry-After`` beyond); finished runs are kept while they
  hold at most ``FTIN_MAX_KEPT_SAMPLES`` samples in all (and at most ``FTIN_MAX_RUNS`` runs) in memory.
- Access (``app.access``): one token, ``FTIN_TOKEN`` (``FTIN_LIVE_TOKEN``, its old name, still read),
  needed by every route but ``/health`` from a client on another machine; without one a token is
  generated at each start. ``FTIN_ALLOWED_HOSTS`` adds names to the ``Host`` allow-list (loopback and
  this machine's own names and addresses are always on it; ``*`` allows any).
- Live pushes (``FTIN_LIVE_*``): bounded body, sessions, session length, idle time and queue.
- ``FTIN_MAP_TILES`` (OpenStreetMap's tiles by default): the only thing the page fetches from outside,
  in the user's browser, for the map under a walk with GPS; offline the page says so and keeps the plot.
- ``FTIN_TORCH_THREADS`` (default 1) sets torch's intra-op threads for the whole process while the
  app runs. One thread, because the app shares its CPU with the event loop, viser and the drawing
  thread (and, on a workstation, with everything else): on a busy 2-core machine a one-minute
  prediction took 0.6 s with one thread and 4.9 s with two, whose threads wait for each other.
  ``0`` keeps torch's own choice (one per core), for a dedicated machine.
- Runs persist (``app.services.run_archive``): every finished run is written under ``FTIN_RUNS_DIR``
  (default: the user's data folder, ``$XDG_DATA_HOME/ftin-studio/runs``, else
  ``~/.local/share/ftin-studio/runs``; ``%LOCALAPPDATA%`` on Windows, ``~/Library/Application Support``
  on macOS) with a SQLite index, and removed only to keep that folder under
  ``FTIN_RUNS_DISK_BUDGET_MB`` (default 2000), oldest first. ``FTIN_MAX_RUNS`` and
  ``FTIN_MAX_KEPT_SAMPLES`` bound only the runs also held in memory.
- ``FTIN_PRECISION`` (default ``auto``): bf16 autocast where this CPU does bf16 natively and the
  model's family kept its accuracy under it, fp32 elsewhere (``ftin.precision``), chosen at start-up
  and named in ``GET /health``; ``fp32`` / ``bf16`` force one.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated

from pydantic import AliasChoices, Field, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

import ftin
from ftin.checkpoint import DEFAULT_MODEL
from ftin.files import DEFAULT_CHECKPOINT_DIR
from ftin.precision import PrecisionSetting

REPO_ROOT = Path(__file__).resolve().parents[1]
BUNDLED_SAMPLES_DIR = Path(ftin.__file__).resolve().parent / "sim" / "samples"
DEFAULT_MAP_TILES = "https://tile.openstreetmap.org/{z}/{x}/{y}.png"
DEFAULT_MAP_ATTRIBUTION = (
    '&copy; <a href="https://www.openstreetmap.org/copyright">OpenStreetMap</a> contributors'
)


def default_runs_dir() -> Path:
    """Where runs are kept unless ``FTIN_RUNS_DIR`` says: the user's data folder, by platform."""
    home = Path.home()
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or home / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = home / "Library" / "Application Support"
    else:
        base = Path(os.environ.get("XDG_DATA_HOME") or home / ".local" / "share")
    return base / "ftin-studio" / "runs"


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="FTIN_", extra="ignore", populate_by_name=True)

    data_dirs: Annotated[list[Path], NoDecode] = Field(
        default_factory=lambda: [BUNDLED_SAMPLES_DIR],
        description="Folders whose sequences GET /sequences lists (os.pathsep-separated).",
    )
    checkpoint_dir: Path = Field(DEFAULT_CHECKPOINT_DIR, description="Folder of *.safetensors checkpoints.")
    default_model: str = Field(DEFAULT_MODEL, description="Model used when a request names none.")
    # 200 MiB: FTIN_MAX_SAMPLES (720 000) rows of the generic CSV with orientation and ground truth at
    # full float precision (~270 bytes a row) fit; a gzip or ZIP body may unpack to no more than this.
    max_upload_mb: float = Field(200.0, gt=0, description="Largest request body accepted, in MiB.")
    max_uncompressed_mb: float = Field(
        1024.0,
        gt=0,
        description="Most a gzip or ZIP upload may unpack to, in MiB, and never above FTIN_MAX_UPLOAD_MB.",
    )
    viser_enabled: bool = Field(True, description="Start the viser 3D scene with the app.")
    scene_first_run: bool = Field(
        True, description="At start-up, run the suggested model on the first sequence for the 3D scene."
    )
    viser_host: str = "127.0.0.1"
    viser_port: int = Field(8080, ge=0, le=65535)
    cors_origins: Annotated[list[str], NoDecode] = Field(default_factory=list)
    # Access (app.access): the token other machines must show, and the Host names besides this machine's.
    token: str | None = Field(
        None,
        min_length=8,
        validation_alias=AliasChoices("FTIN_TOKEN", "FTIN_LIVE_TOKEN", "token"),
        description="Token clients on other machines must show (FTIN_TOKEN; FTIN_LIVE_TOKEN is its old "
        "name); generated at each start when unset.",
    )
    allowed_hosts: Annotated[list[str], NoDecode] = Field(
        default_factory=list,
        description="Host names the API answers to besides loopback and this machine's (comma-separated; "
        "* for any).",
    )
    max_runs: int = Field(
        20, ge=1, description="Finished runs also held in memory (the rest are read from FTIN_RUNS_DIR)."
    )
    runs_dir: Path = Field(
        default_factory=default_runs_dir, description="Folder where finished runs are stored (SQLite index)."
    )
    runs_disk_budget_mb: float = Field(
        2000.0, gt=0, description="Most the runs folder may hold, in MiB (the oldest runs removed first)."
    )
    max_kept_samples: int = Field(
        3_000_000, ge=1, description="Samples all kept runs may hold together (oldest dropped first)."
    )
    max_samples: int = Field(
        720_000, ge=1, description="Most IMU samples one prediction may read (default: 1 h at 200 Hz)."
    )
    inference_timeout_s: float = Field(
        120.0,
        gt=0,
        description="Longest a prediction may go without progress, waiting for a slot included (504 after).",
    )
    max_concurrent_inferences: int = Field(1, ge=1, description="Predictions that may run at once.")
    max_pending_uploads: int = Field(
        4,
        ge=1,
        description="Predictions read, parsed, waiting or running at once (429 with Retry-After beyond).",
    )
    torch_threads: int = Field(1, ge=0, description="torch intra-op threads (0: torch's default).")
    precision: PrecisionSetting = Field(
        PrecisionSetting.AUTO, description="Inference precision: auto (bf16 where free), fp32 or bf16."
    )
    # Live phone streams (POST /live/sensorlogger; app.services.live has the decisions).
    live_model: str | None = Field(None, description="Model for live sessions (default: the default model).")
    live_max_sessions: int = Field(4, ge=1, description="Live sessions running at once.")
    live_max_session_s: float = Field(3600.0, gt=0, description="Longest live session, in seconds of data.")
    live_idle_s: float = Field(30.0, gt=0, description="A live session without messages this long ends.")
    live_max_body_kb: float = Field(2048.0, gt=0, description="Largest push message, in KiB.")
    live_queue_messages: int = Field(256, ge=1, description="Push messages waiting to be used (429 beyond).")
    # The upload page's map under a walk with GPS: the browser fetches these tiles (nothing else leaves).
    map_tiles: str = Field(
        DEFAULT_MAP_TILES,
        description="Map tile URL template with {z}, {x}, {y} (empty: no map, the plot alone).",
    )
    map_attribution: str = Field(
        DEFAULT_MAP_ATTRIBUTION, description="Credit shown on the map (HTML allowed)."
    )

    @field_validator("data_dirs", mode="before")
    @classmethod
    def _split_data_dirs(cls, value: object) -> object:
        if isinstance(value, str):
            return [Path(part).expanduser() for part in value.split(os.pathsep) if part.strip()]
        return value

    @field_validator("cors_origins", "allowed_hosts", mode="before")
    @classmethod
    def _split_commas(cls, value: object) -> object:
        if isinstance(value, str):
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @field_validator("map_tiles", mode="after")
    @classmethod
    def _tile_template(cls, value: str) -> str:
        missing = [part for part in ("{z}", "{x}", "{y}") if part not in value]
        if value.strip() and missing:
            raise ValueError(f"FTIN_MAP_TILES needs {', '.join(missing)} in its URL template; got {value!r}")
        return value.strip()

    @field_validator("checkpoint_dir", "runs_dir", mode="after")
    @classmethod
    def _expand_checkpoint_dir(cls, value: Path) -> Path:
        return value.expanduser()

    @property
    def max_upload_bytes(self) -> int:
        return int(self.max_upload_mb * 1024 * 1024)

    @property
    def runs_disk_budget_bytes(self) -> int:
        return int(self.runs_disk_budget_mb * 1024 * 1024)

    @property
    def max_uncompressed_bytes(self) -> int:
        """What an upload may unpack to: a compressed body holds no more than a plain one may."""
        return min(int(self.max_uncompressed_mb * 1024 * 1024), self.max_upload_bytes)

    @property
    def default_model_is_explicit(self) -> bool:
        """True when the user set FTIN_DEFAULT_MODEL (then a missing model is a start-up error)."""
        return "default_model" in self.model_fields_set
