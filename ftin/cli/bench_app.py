"""The benchmarks that run the product (``ftin bench predict|live|scene|load``): the app is started here,
in the command line's layer above it, and handed to ``ftin.bench``, which measures it.

``ftin.cli.bench`` imports this module only when one of these runs: it loads the app (FastAPI and its
services, seconds no other command should pay) and the ``test`` extra (httpx, Playwright).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import torch
from fastapi import FastAPI
from fastapi.testclient import TestClient

from app.main import create_app
from app.serve import serve_in_thread
from app.services.features import ModelInput
from app.services.live import LiveUpdate
from app.services.runs import Run
from app.settings import Settings
from ftin.bench import hour, live, live_drawing, load, predict, scene
from ftin.bench.options import (
    SCENE_SETTINGS,
    HourOptions,
    LiveDrawingOptions,
    LiveOptions,
    LoadOptions,
    PredictOptions,
    SceneOptions,
)
from ftin.checkpoint import DEFAULT_MODEL, load_model, read_default_choice
from ftin.data.types import Trajectory
from ftin.infer import predict_trajectory
from ftin.sim.config import SimConfig
from ftin.sim.simulator import simulate

Echo = Callable[[str], None]


@contextmanager
def served(settings: Settings) -> Iterator[tuple[str, FastAPI]]:
    """The app of ``settings`` under uvicorn on a free 127.0.0.1 port, in this process: its URL and app
    (``ServerStartError`` when it does not start). Its runs go to a folder of its own, removed after."""
    with _runs_elsewhere(settings) as settings:
        app = create_app(settings)
        server = serve_in_thread(app, name="bench-uvicorn")
        try:
            yield server.base_url, app
        finally:
            server.stop()


@contextmanager
def _runs_elsewhere(settings: Settings) -> Iterator[Settings]:
    """``settings`` with a temporary runs folder: a benchmark's runs never fill the user's."""
    with tempfile.TemporaryDirectory(prefix="ftin-bench-runs-") as runs:
        yield settings.model_copy(update={"runs_dir": Path(runs)})


@contextmanager
def _client(settings: Settings, testclient: bool) -> Iterator[tuple[httpx.Client, FastAPI]]:
    """A client of the app: FastAPI's TestClient, or an HTTP client of it served by uvicorn."""
    if testclient:
        with _runs_elsewhere(settings) as settings:
            app = create_app(settings)
            # Host 127.0.0.1: TestClient's own name, testserver, is on no allow-list (app.access)
            with TestClient(app, base_url="http://127.0.0.1") as client:
                yield client, app
        return
    with served(settings) as (base_url, app), httpx.Client(base_url=base_url, timeout=600) as client:
        yield client, app


def run_predict(options: PredictOptions, echo: Echo) -> None:
    settings = Settings(**options.settings_overrides())
    predict.use_filter(options.filter)
    csvs = predict.simulated_csvs(options.duration_s, options.rate_hz, options.seed, options.filter.value)
    with _client(settings, options.testclient) as (client, app):
        services = app.state.services
        if services.models.default_name is None:
            raise RuntimeError(f"no model to time: {'; '.join(services.notes)}")
        entry = services.models.get(None)
        size = f"{entry.architecture}, {entry.n_parameters:,} parameters"
        echo(f"model     {entry.name} ({size}) from {entry.path}")
        if services.models.default_name.casefold() != settings.default_model.casefold():
            missing = settings.checkpoint_dir / f"{settings.default_model}.safetensors"
            echo(f"          FALLBACK: the default model's checkpoint {missing} is missing")
        samples = int(options.duration_s * options.rate_hz)
        echo(
            f"input     {options.duration_s:g} s at {options.rate_hz:g} Hz ({samples} samples), "
            f"window {entry.loaded.window}, stride {entry.loaded.stride}"
        )
        echo(
            f"server    {'TestClient' if options.testclient else 'uvicorn 127.0.0.1'}, viser "
            f"{'off' if options.no_viser else 'on'}, torch threads {torch.get_num_threads()}, "
            f"{options.runs} runs after {options.warmup} warm-up"
        )
        echo(f"orientation filter for the IMU-only upload: {options.filter.value}")

        def post(data: bytes) -> Any:
            return client.post("/predict", files={"file": ("walk.csv", data, "text/csv")})

        timings = predict.time_uploads(post, csvs, options.runs, options.warmup)
    for line in predict.describe_timings(csvs, timings):
        echo(line)


def run_live(options: LiveOptions, echo: Echo) -> None:
    live.keep_every_latency()
    settings = Settings(**options.settings_overrides())
    with served(settings) as (base_url, app):
        echo(
            f"app at {base_url} (pid {os.getpid()}, scene {'off' if options.no_scene else 'on'}, "
            f"model {settings.live_model or settings.default_model}, {os.cpu_count()} CPUs)"
        )
        for phones in options.phones:
            live.run_round(phones, options, base_url, app.state.services.live, echo)


def run_scene(options: SceneOptions, echo: Echo) -> None:
    with served(Settings(**SCENE_SETTINGS)) as (base_url, app):
        scene.time_scene(base_url, app.state.scene, options, echo)


def run_hour(options: HourOptions, echo: Echo) -> None:
    choice = read_default_choice(options.checkpoint_dir)
    name = DEFAULT_MODEL if choice is None else choice[0]
    loaded = load_model(options.checkpoint_dir / f"{name}.safetensors")
    report = hour.measure(loaded, options.minutes, options.rate_hz, options.seed, echo)
    for line in hour.describe(report):
        echo(line)


def run_live_drawing(options: LiveDrawingOptions, echo: Echo) -> None:
    """A simulated walk as long as the last minute mark, predicted once by the live model; each
    update is that prediction cut where the walk has got to, as the live service publishes it."""
    with served(Settings(**SCENE_SETTINGS)) as (_, app):
        entry = app.state.services.models.get(None)
        loaded = entry.loaded
        seq = simulate(SimConfig(duration_s=60.0 * max(options.minutes) + 10.0, seed=5))
        whole = predict_trajectory(loaded, seq, yaw_copies=1)
        echo(f"model {entry.name}, a {seq.duration_s / 60:.1f}-minute simulated walk at {seq.rate_hz:.0f} Hz")

        def grown(t_s: float, run_id: str) -> LiveUpdate:
            return _live_update(run_id, entry.name, whole, loaded.window, t_s)

        seconds = live_drawing.time_updates(app.state.scene, grown, options)
    for line in live_drawing.describe(seconds, options):
        echo(line)


def _live_update(run_id: str, model_name: str, whole: Any, window: int, t_s: float) -> LiveUpdate:
    """``whole`` (a prediction of the entire walk) as a live session has it at ``t_s`` seconds."""
    t = whole.trajectory.t_s
    n = int(np.searchsorted(t, t[0] + t_s, side="right"))
    m = int(np.searchsorted(whole.span_t_s[:, 1], t[n - 1], side="right"))
    trajectory = Trajectory(t[:n], whole.trajectory.p_world_m[:n], whole.trajectory.q_world_body_wxyz[:n])
    prediction = replace(
        whole,
        trajectory=trajectory,
        window_t_s=whole.window_t_s[:m],
        velocity_m_s=whole.velocity_m_s[:m],
        span_t_s=whole.span_t_s[:m],
        prepared=None,
        truth=None,
        imu_world=whole.imu_world[:n],
        starts=whole.starts[:m],
    )
    model_input = ModelInput(whole.imu_world[:n], whole.starts[:m], window, whole.turn_stride)
    sequence = whole.prepared.seq.slice(0, n).with_(gt=None)  # a phone streaming: no ground truth
    run = Run(run_id, model_name, sequence, prediction, "live", None, model_input)
    session = {
        "device_id": "bench-phone",
        "state": "live",
        "model": model_name,
        "rate_hz": 100.0,
        "latest_latency_s": 0.2,
        "dropped_messages": 0,
        "distance_m": trajectory.path_length_m,
        "steps": int(t_s * 1.8),
    }
    return LiveUpdate(run, session)


def run_load(options: LoadOptions, echo: Echo) -> int:
    """The load test, reported; its exit status: 0 passed, 1 failed or the server died, 2 the server
    did not start (its log's tail on stderr)."""
    try:
        report = load.load_test(options, echo)
    except load.ServerError as exc:
        print(f"error: {exc}\n--- server log (tail) ---\n{exc.log_tail}", file=sys.stderr)
        return 2 if exc.starting else 1
    for line in load.describe(report):
        echo(line)
    if options.json_out is not None:
        options.json_out.write_text(json.dumps(asdict(report), indent=2) + "\n")
    failures = load.failures(report, options)
    for line in failures:
        echo(line)
    return 1 if failures else 0
