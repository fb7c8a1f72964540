"""The benchmarks that run the product (``ftin bench predict|live|scene|load``): the app is started here,
in the command line's layer above it, and handed to ``ftin.bench``, which measures it.

``ftin.cli.bench`` imports this module only when one of these runs: it loads the app (FastAPI and its
services, seconds no other command should pay) and the ``test`` extra (httpx, Playwright).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict
from typing import Any

import httpx
import torch
from fastapi import FastAPI
from fastapi.testclient import TestClient

from app.main import create_app
from app.serve import serve_in_thread
from app.settings import Settings
from ftin.bench import live, load, predict, scene
from ftin.bench.options import SCENE_SETTINGS, LiveOptions, LoadOptions, PredictOptions, SceneOptions

Echo = Callable[[str], None]


@contextmanager
def served(settings: Settings) -> Iterator[tuple[str, FastAPI]]:
    """The app of ``settings`` under uvicorn on a free 127.0.0.1 port, in this process: its URL and app
    (``ServerStartError`` when it does not start)."""
    app = create_app(settings)
    server = serve_in_thread(app, name="bench-uvicorn")
    try:
        yield server.base_url, app
    finally:
        server.stop()


@contextmanager
def _client(settings: Settings, testclient: bool) -> Iterator[tuple[httpx.Client, FastAPI]]:
    """A client of the app: FastAPI's TestClient, or an HTTP client of it served by uvicorn."""
    if testclient:
        app = create_app(settings)
        with TestClient(app) as client:
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
