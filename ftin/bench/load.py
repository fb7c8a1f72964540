"""Load test of the real dashboard: concurrent ``POST /predict`` while ``GET /health`` is polled
(``ftin bench load``).

Starts ``uvicorn app.main:app`` as a subprocess on a free 127.0.0.1 port (the viser scene on another
free port, as in production), on the app's checkpoint folder (``checkpoints/``, or
``checkpoint_dir``; ``tiny`` writes a tiny untrained FTIN checkpoint to a temporary folder instead).
This process is the client: ``clients`` threads upload a simulated one-minute 100 Hz walk
(orientation and ground truth included) as the upload page does (multipart, field ``file``), one
request after another, until ``duration_s`` has passed or ``max_requests`` were sent; requests in
flight then finish (bounded by ``request_timeout_s``). A separate thread polls ``GET /health`` every
``health_interval_s``: /health runs on the event loop, so its latency under load shows whether
predictions block the loop.

The report: throughput, latency p50/p99, errors and the /health latency; it fails on any failed
request, any failed /health poll, a /health p99 above ``max_health_p99_s``, or a server that died
(``ServerError`` when the server does not start or dies). Not part of the test suite (it takes
minutes and loads the machine). Needs the ``test`` extra (httpx).
"""

from __future__ import annotations

import io
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import numpy as np
import torch

from ftin.bench.options import LoadOptions
from ftin.checkpoint import save_checkpoint
from ftin.data.readers.generic_csv import write_csv
from ftin.data.types import ImuSequence
from ftin.files import REPO_ROOT
from ftin.models import create_model
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.sim.config import CarryMode, SimConfig
from ftin.sim.simulator import simulate

TINY_MODEL = "tiny-ftin"
TINY_WINDOW = 50


class ServerError(RuntimeError):
    """The server under test did not start (``starting``) or died during the load."""

    def __init__(self, message: str, starting: bool, log_tail: str = "") -> None:
        super().__init__(message)
        self.starting = starting
        self.log_tail = log_tail


@dataclass
class Outcome:
    """What one request or poll gave: when it started (s after the load began), how long it took."""

    started_s: float
    latency_s: float
    status: int  # HTTP status; 0 when no response came (connection error, timeout)
    error: str = ""


@dataclass
class Report:
    clients: int
    duration_s: float
    model: str
    requests: int
    ok: int
    errors: int
    wall_s: float
    throughput_req_s: float
    latency_p50_s: float
    latency_p99_s: float
    latency_max_s: float
    health_polls: int
    health_errors: int
    health_p50_s: float
    health_p99_s: float
    health_max_s: float
    error_samples: list[str] = field(default_factory=list)


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def write_tiny_checkpoint(folder: Path) -> str:
    torch.manual_seed(0)
    model = create_model("ftin", **TINY_FTIN_KWARGS, window=TINY_WINDOW)
    meta = {
        "model_name": "ftin",
        "imu_rate_hz": 100.0,
        "window": TINY_WINDOW,
        "stride": TINY_WINDOW // 2,
        "training_data": "untrained (load test)",
    }
    save_checkpoint(folder / TINY_MODEL, model, meta)
    return TINY_MODEL


def simulated_walk(duration_s: float, rate_hz: float, seed: int) -> ImuSequence:
    """The uploaded walk: simulated, hand-held, with orientation and ground truth."""
    return simulate(SimConfig(duration_s=duration_s, rate_hz=rate_hz, carry=CarryMode.HANDHELD, seed=seed))


def csv_bytes(seq: ImuSequence) -> bytes:
    """``seq`` as the generic CSV an upload sends."""
    buffer = io.StringIO()
    write_csv(seq, buffer)
    return buffer.getvalue().encode()


@contextmanager
def running_server(
    env: dict[str, str], startup_timeout_s: float, log_path: Path
) -> Iterator[tuple[str, int]]:
    """``uvicorn app.main:app`` in a subprocess; yields its base URL and process id once /health answers.
    Its runs go beside ``log_path`` unless ``env`` names a runs folder."""
    env = {"FTIN_RUNS_DIR": str(log_path.parent / "runs"), **env}
    port = free_port()
    command = [sys.executable, "-m", "uvicorn", "app.main:app", "--host", "127.0.0.1", "--port", str(port)]
    command += ["--log-level", "warning", "--no-access-log"]
    base_url = f"http://127.0.0.1:{port}"
    with open(log_path, "wb") as log:
        process = subprocess.Popen(command, cwd=REPO_ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            deadline = time.monotonic() + startup_timeout_s
            while True:
                if process.poll() is not None:
                    raise RuntimeError(f"the server exited with {process.returncode} during start-up")
                try:
                    if httpx.get(f"{base_url}/health", timeout=2.0).status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if time.monotonic() > deadline:
                    raise RuntimeError(f"the server did not answer /health within {startup_timeout_s:g} s")
                time.sleep(0.25)
            yield base_url, process.pid
            if process.poll() is not None:
                raise RuntimeError(f"the server died during the load (exit {process.returncode})")
        finally:
            if process.poll() is None:
                process.terminate()  # uvicorn shuts down gracefully on SIGTERM
                try:
                    process.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait()


def _client_loop(
    base_url: str,
    body: bytes,
    t0: float,
    stop_at: float,
    budget: Iterator[int],
    out: list[Outcome],
    lock: threading.Lock,
    timeout_s: float,
) -> None:
    with httpx.Client(base_url=base_url, timeout=timeout_s) as client:
        while time.monotonic() < stop_at and next(budget, None) is not None:
            start = time.monotonic()
            try:
                response = client.post("/predict", files={"file": ("walk.csv", body, "text/csv")})
                status, error = response.status_code, ""
                if status == 200:
                    if len(response.json()["trajectory"]["t"]) < 2:
                        status, error = 0, "200 without a trajectory"
                else:
                    error = f"{status}: {response.text[:200]}"
            except (httpx.HTTPError, ValueError, KeyError) as exc:
                status, error = 0, f"{type(exc).__name__}: {exc}"
            outcome = Outcome(start - t0, time.monotonic() - start, status, error)
            with lock:
                out.append(outcome)


def _health_loop(
    base_url: str, t0: float, stop: threading.Event, interval_s: float, out: list[Outcome]
) -> None:
    with httpx.Client(base_url=base_url, timeout=30.0) as client:
        while not stop.is_set():
            start = time.monotonic()
            try:
                response = client.get("/health")
                status, error = (
                    response.status_code,
                    "" if response.status_code == 200 else response.text[:200],
                )
            except httpx.HTTPError as exc:
                status, error = 0, f"{type(exc).__name__}: {exc}"
            out.append(Outcome(start - t0, time.monotonic() - start, status, error))
            stop.wait(interval_s)


def _percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def run_load(base_url: str, body: bytes, options: LoadOptions) -> tuple[list[Outcome], list[Outcome], float]:
    requests: list[Outcome] = []
    polls: list[Outcome] = []
    lock = threading.Lock()
    budget = iter(range(options.max_requests))  # next() on a range iterator is atomic under the GIL
    stop_health = threading.Event()
    t0 = time.monotonic()
    health = threading.Thread(
        target=_health_loop, args=(base_url, t0, stop_health, options.health_interval_s, polls), daemon=True
    )
    health.start()
    stop_at = t0 + options.duration_s
    workers = [
        threading.Thread(
            target=_client_loop,
            args=(base_url, body, t0, stop_at, budget, requests, lock, options.request_timeout_s),
            name=f"client-{i}",
            daemon=True,
        )
        for i in range(options.clients)
    ]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    wall_s = time.monotonic() - t0
    stop_health.set()
    health.join()
    return requests, polls, wall_s


def summarize(
    requests: list[Outcome], polls: list[Outcome], wall_s: float, options: LoadOptions, model: str
) -> Report:
    ok = [r for r in requests if r.status == 200 and not r.error]
    failed = [r for r in requests if not (r.status == 200 and not r.error)]
    # Polls while requests were running: the ones that show whether the loop is blocked.
    busy_polls = [p for p in polls if p.started_s <= wall_s]
    health_ok = [p.latency_s for p in busy_polls if p.status == 200]
    health_failed = [p for p in busy_polls if p.status != 200]
    latencies = [r.latency_s for r in ok]
    return Report(
        clients=options.clients,
        duration_s=options.duration_s,
        model=model,
        requests=len(requests),
        ok=len(ok),
        errors=len(failed),
        wall_s=round(wall_s, 2),
        throughput_req_s=round(len(ok) / wall_s, 3) if wall_s > 0 else 0.0,
        latency_p50_s=round(_percentile(latencies, 50), 3),
        latency_p99_s=round(_percentile(latencies, 99), 3),
        latency_max_s=round(max(latencies, default=float("nan")), 3),
        health_polls=len(busy_polls),
        health_errors=len(health_failed),
        health_p50_s=round(_percentile(health_ok, 50), 4),
        health_p99_s=round(_percentile(health_ok, 99), 4),
        health_max_s=round(max(health_ok, default=float("nan")), 4),
        error_samples=[r.error for r in failed[:5]] + [f"/health {p.error}" for p in health_failed[:5]],
    )


def load_test(options: LoadOptions, echo=print) -> Report:
    """Start the server, load it, and report; ``ServerError`` when it does not start or dies."""
    with tempfile.TemporaryDirectory(prefix="ftin-load-") as tmp:
        tmp_dir = Path(tmp)
        env = {**os.environ, "FTIN_VISER_PORT": str(free_port()), "PYTHONUNBUFFERED": "1"}
        if options.tiny:
            env["FTIN_CHECKPOINT_DIR"] = str(tmp_dir)
            env["FTIN_DEFAULT_MODEL"] = write_tiny_checkpoint(tmp_dir)
        elif options.checkpoint_dir is not None:
            env["FTIN_CHECKPOINT_DIR"] = str(options.checkpoint_dir.resolve())
        body = csv_bytes(simulated_walk(options.walk_s, options.rate_hz, options.seed))
        log_path = tmp_dir / "server.log"
        try:
            with running_server(env, options.startup_timeout_s, log_path) as (base_url, _):
                model = httpx.get(f"{base_url}/health", timeout=10).json().get("default_model") or "?"
                walk = f"{options.walk_s:g} s at {options.rate_hz:g} Hz"
                echo(
                    f"server {base_url} ({model}); {options.clients} clients for {options.duration_s:g} s, "
                    f"{len(body) / 1e6:.2f} MB CSV ({walk}) per request"
                )
                requests, polls, wall_s = run_load(base_url, body, options)
        except RuntimeError as exc:
            log_tail = log_path.read_text(errors="replace")[-3000:] if log_path.exists() else ""
            raise ServerError(str(exc), "start" in str(exc), log_tail) from None
    return summarize(requests, polls, wall_s, options, model)


def describe(report: Report) -> list[str]:
    lines = [
        f"requests: {report.requests} ({report.ok} ok, {report.errors} errors) in {report.wall_s:.1f} s: "
        f"{report.throughput_req_s:.2f} req/s",
        f"latency:  p50 {report.latency_p50_s:.2f} s, p99 {report.latency_p99_s:.2f} s, "
        f"max {report.latency_max_s:.2f} s",
        f"/health under load: {report.health_polls} polls, {report.health_errors} errors, "
        f"p50 {report.health_p50_s * 1000:.1f} ms, p99 {report.health_p99_s * 1000:.1f} ms, "
        f"max {report.health_max_s * 1000:.1f} ms",
    ]
    lines += [f"  error: {sample}" for sample in report.error_samples]
    return lines


def failures(report: Report, options: LoadOptions) -> list[str]:
    """Why the load test failed (empty when it passed)."""
    found = []
    if report.errors > 0 or report.health_errors > 0 or report.ok == 0:
        found.append(f"{report.errors} failed requests, {report.health_errors} failed /health polls")
    if not report.health_p99_s <= options.max_health_p99_s:
        limit = options.max_health_p99_s
        found.append(f"/health p99 {report.health_p99_s:.3f} s is above --max-health-p99-s {limit:g}")
    return found
