"""The options of the benchmarks that run the app (``ftin bench predict|live|scene|load``), apart from
them: the command line makes one option per field (``option``: its default and help) and builds them
before it loads the app and the ``test`` extra those benchmarks need."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ftin.data.preprocess import AhrsMethod
from ftin.files import DEFAULT_CHECKPOINT_DIR, DEFAULT_DATA_ROOT

DEFAULT_EXPORT = DEFAULT_DATA_ROOT / "phone" / "sensorlogger" / "inhand-20-steps-Zyf"


def option(default: Any, help: str) -> Any:
    """A field that is a command-line option: its default, and its ``--help`` line."""
    return field(default=default, metadata={"help": help})


@dataclass(frozen=True)
class WalkOptions:
    """The simulated walk that is uploaded and the checkpoint folder of the app under test (``predict``
    and ``load``)."""

    rate_hz: float = option(100.0, "IMU rate of the uploaded walk (Hz).")
    seed: int = option(7, "Seed of the simulated walk.")
    checkpoint_dir: Path | None = option(
        None, "The app's checkpoint folder (default: FTIN_CHECKPOINT_DIR's)."
    )


@dataclass(frozen=True)
class LoadOptions(WalkOptions):
    """Load test of the real dashboard: concurrent POST /predict while GET /health is polled. Exits 1
    on a failed request or poll, a slow /health or a dead server; 2 when the server does not start."""

    clients: int = option(16, "Concurrent clients.")
    duration_s: float = option(60.0, "How long new requests start (s).")
    max_requests: int = option(10_000, "Cap on requests sent.")
    request_timeout_s: float = option(300.0, "Client timeout (s).")
    health_interval_s: float = option(0.2, "/health poll period (s).")
    max_health_p99_s: float = option(1.0, "Fail above this /health p99 (s).")
    walk_s: float = option(60.0, "Length of the uploaded walk (s).")
    tiny: bool = option(False, "Serve a tiny untrained FTIN checkpoint.")
    startup_timeout_s: float = option(180.0, "Seconds the server may take to answer /health.")
    json_out: Path | None = option(None, "Also write the report here as JSON.")

    def __post_init__(self) -> None:
        if self.clients < 1 or self.duration_s <= 0 or self.max_requests < 1:
            raise ValueError("--clients and --max-requests must be >= 1 and --duration-s > 0")


@dataclass(frozen=True)
class PredictOptions(WalkOptions):
    """Time POST /predict on a simulated walk with the app's default model, three uploads side by side."""

    runs: int = option(20, "Timed requests per CSV.")
    warmup: int = option(2, "Untimed requests first.")
    duration_s: float = option(60.0, "Length of the uploaded walk (s).")
    threads: int | None = option(None, "torch threads (default: the app's, 1; 0: one per core).")
    testclient: bool = option(False, "FastAPI TestClient instead of uvicorn.")
    no_viser: bool = option(False, "Without the 3D scene.")
    filter: AhrsMethod = option(AhrsMethod.VQF, "Orientation filter for the IMU-only upload.")

    def __post_init__(self) -> None:
        if self.runs < 1 or self.warmup < 0:
            raise ValueError("--runs must be >= 1 and --warmup >= 0")

    def settings_overrides(self) -> dict[str, Any]:
        """The app's settings for this benchmark (``app.settings.Settings`` fields)."""
        overrides: dict[str, Any] = {"viser_enabled": not self.no_viser, "viser_port": 0}
        if self.threads is not None:
            overrides["torch_threads"] = self.threads
        if self.checkpoint_dir is not None:
            overrides["checkpoint_dir"] = self.checkpoint_dir
        return overrides


@dataclass(frozen=True)
class LiveOptions:
    """Live latency and memory: phones replaying a Sensor Logger export into the app over HTTP."""

    phones: tuple[int, ...] = option((1, 4), "Phones at once, one round each (repeatable).")
    minutes: float = option(20.0, "Recording per phone (the export looped).")
    speed: float = option(1.0, "Times real time.")
    batch_s: float = option(1.0, "Sensor Logger's batch period.")
    export: Path = option(DEFAULT_EXPORT, "The Sensor Logger export replayed.")
    memory_every_s: float = option(60.0, "Memory sampled every so often (s).")
    no_scene: bool = option(False, "Without the 3D scene.")

    def settings_overrides(self) -> dict[str, Any]:
        """The app's settings for this benchmark (``app.settings.Settings`` fields)."""
        return {
            "viser_enabled": not self.no_scene,
            "viser_port": 0,
            "scene_first_run": False,
            "live_max_sessions": max(self.phones),
        }


# The app's settings for this benchmark (``app.settings.Settings`` fields): a free port, no first run.
SCENE_SETTINGS = {"viser_port": 0, "scene_first_run": False}


@dataclass(frozen=True)
class SceneOptions:
    """Time the 3D scene with many runs: drawing, slider moves, the REST call meanwhile."""

    minutes: float = option(4.0, "Length of the simulated walk (min).")
    repeats: int = option(2, "Runs of each model (repeats pile up or replace).")
    moves: int = option(20, "Slider moves in the dragged-slider test.")
    models: int = option(0, "Only the first N checkpoints (0: all).")
    chromium: str = option("/usr/bin/chromium", "'' to time without a browser.")


@dataclass(frozen=True)
class LiveDrawingOptions:
    """What one live update costs the 3D scene as the walk grows: the same updates at each minute mark."""

    minutes: tuple[float, ...] = option((1.0, 30.0), "Minute marks of the walk to time (repeatable).")
    updates: int = option(40, "Timed updates at each mark.")
    warmup: int = option(10, "Untimed updates before them.")
    every_s: float = option(0.5, "Recording between two updates (s): the live service's publishing period.")

    def __post_init__(self) -> None:
        if (
            not self.minutes
            or min(self.minutes) <= 0
            or self.updates < 1
            or self.warmup < 0
            or self.every_s <= 0
        ):
            raise ValueError("--minutes must be > 0, --updates >= 1, --warmup >= 0 and --every-s > 0")


@dataclass(frozen=True)
class HourOptions:
    """An hour of phone data through POST /predict beside one plain forward pass of the default model over
    its windows: the upload's stages, looks per sample, bf16 against fp32, the server's peak memory."""

    minutes: float = option(60.0, "Length of the uploaded walk (min).")
    rate_hz: float = option(200.0, "IMU rate of the uploaded walk (Hz).")
    seed: int = option(7, "Seed of the simulated walk.")
    checkpoint_dir: Path = option(DEFAULT_CHECKPOINT_DIR, "Where the default checkpoint is read from.")

    def __post_init__(self) -> None:
        if self.minutes <= 0 or self.rate_hz <= 0:
            raise ValueError("--minutes and --rate-hz must be > 0")


# The benchmarks that run the app, in `ftin bench --help`'s order: each is `ftin bench <name>`, its
# options the fields of its type, run by ``run_<name>`` (dashes as underscores) of ``ftin.cli.bench_app``.
PRODUCT_BENCHMARKS: dict[str, type] = {
    "predict": PredictOptions,
    "live": LiveOptions,
    "scene": SceneOptions,
    "hour": HourOptions,
    "live-drawing": LiveDrawingOptions,
    "load": LoadOptions,
}
