"""An hour of phone data end to end, side by side with what the network alone costs (``ftin bench hour``).

One simulated hand-held walk of ``minutes`` at ``rate_hz``, uploaded as a phone alone gives it (IMU
columns only: no orientation, no ground truth, no model named) to a real server (``uvicorn
app.main:app`` in a subprocess, its default settings, the scene on). Measured in the same run:

* **reference**: one plain fp32 forward pass of the default checkpoint over that hour's windows at
  its stride, one copy, one torch thread, in this process: the floor a prediction is held to;
* **upload**: ``POST /predict`` from sending the file to the whole JSON answer, and the server's peak
  resident memory during it over its resident memory before it (the kernel's high-water mark, reset
  first through ``/proc/<pid>/clear_refs``);
* **stages**, in this process as the server runs them: reading the CSV, orientation (``auto``),
  preparing the model's input (resampling, world frame), the network as the app runs it (its looks
  per window, its precision), the figures without ground truth given the steps (path); the step
  detection apart: the app runs it on another thread while the model runs (``PredictionService``);
* **looks per sample** (windows covering a sample x looks per window) and **bf16 against fp32** on the
  same windows (where the CPU has no bf16 instructions the ratio says what emulation costs).

Prints numbers, asserts nothing. The target: the upload at most the reference, the memory growth at
most 400 MB.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import numpy as np
import torch

from ftin.bench.load import csv_bytes, running_server, simulated_walk
from ftin.checkpoint import LoadedModel
from ftin.data.from_bytes import read_bytes
from ftin.data.orientation_option import orient
from ftin.data.prepare import prepare
from ftin.infer import predict_trajectory, run_windows
from ftin.metrics.plausibility import assess
from ftin.metrics.steps import detect_steps
from ftin.precision import Precision, choose, cpu_bf16
from ftin.yaw_average import default_copies, uses_cyclic_turns

Echo = Callable[[str], None]


@dataclass
class HourReport:
    minutes: float
    rate_hz: float
    csv_mb: float
    model: str
    looks: str
    looks_per_sample: float
    reference_s: float = 0.0  # the mean of the two below
    references_s: tuple[float, float] = (0.0, 0.0)  # just before and just after the upload
    upload_s: float = 0.0
    server_growth_mb: float = 0.0
    stages_s: dict[str, float] = field(default_factory=dict)
    fp32_s: float = 0.0
    bf16_s: float = 0.0
    bf16_note: str = ""
    beside_s: float = 0.0  # step detection: the app runs it on another thread while the model runs


def _seconds(call: Callable[[], object]) -> tuple[float, object]:
    t0 = time.perf_counter()
    out = call()
    return time.perf_counter() - t0, out


def measure(loaded: LoadedModel, minutes: float, rate_hz: float, seed: int, echo: Echo) -> HourReport:
    torch.set_num_threads(1)
    echo(f"simulating {minutes:g} min at {rate_hz:g} Hz ...")
    data = csv_bytes(simulated_walk(60.0 * minutes, rate_hz, seed).with_(q_world_device_wxyz=None, gt=None))
    cyclic = uses_cyclic_turns(loaded.model_name, loaded.model.streams)
    copies = default_copies(cyclic)
    how = ", window k turned by k mod 4 quarter turns" if cyclic else " (turned copies)"
    looks = f"{copies} per window{how}"
    per_sample = copies * loaded.window / loaded.stride
    report = HourReport(minutes, rate_hz, len(data) / 2**20, loaded.name, looks, per_sample)
    echo("stages, in this process ...")
    stages = report.stages_s
    stages["read the CSV"], seq = _seconds(lambda: read_bytes(data, "hour.csv"))
    stages["orientation (auto)"], oriented = _seconds(lambda: orient(seq, "auto"))
    stages["prepare (resample, world frame)"], prepared = _seconds(
        lambda: prepare(oriented, loaded.imu_rate_hz, loaded.window, loaded.stride)
    )
    imu, starts = prepared.imu_world, prepared.starts

    def network(rows: np.ndarray, copies: int, precision: Precision, cyclic: bool) -> float:
        window, turns = loaded.window, loaded.stride if cyclic else None
        return _seconds(
            lambda: run_windows(loaded, imu, rows, window, 1, 1024, None, False, copies, precision, turns)
        )[0]

    precision = choose("auto", loaded.model_name).precision
    stages[f"network ({precision.value}, as the app runs it)"] = network(starts, copies, precision, cyclic)
    prediction = predict_trajectory(loaded, oriented, keep_prepared=False)
    report.beside_s, steps = _seconds(
        lambda: detect_steps(oriented.t_s, oriented.acc_m_s2, oriented.gyro_rad_s)
    )
    stages["figures without ground truth (path, given the steps)"], _ = _seconds(
        lambda: assess(prediction.trajectory, oriented, steps)
    )
    report.fp32_s = network(starts[:4000], 1, Precision.FP32, False)
    report.bf16_s = network(starts[:4000], 1, Precision.BF16, False)
    report.bf16_note = cpu_bf16()[1]
    # The reference just before and just after the upload, and their mean: a machine whose load moves
    # during the benchmark weighs on both sides of the ratio alike.
    echo("reference: one plain fp32 forward pass, one copy, one thread ...")
    before = network(starts, 1, Precision.FP32, False)
    echo("upload to a server in a subprocess ...")
    report.upload_s, report.server_growth_mb = _upload(data)
    echo("reference again ...")
    report.references_s = (before, network(starts, 1, Precision.FP32, False))
    report.reference_s = sum(report.references_s) / 2.0
    return report


def _upload(data: bytes) -> tuple[float, float]:
    with tempfile.TemporaryDirectory() as tmp:
        with running_server(dict(os.environ), 180.0, Path(tmp) / "server.log") as (base_url, pid):
            with httpx.Client(base_url=base_url, timeout=900.0) as client:
                client.get("/health").raise_for_status()
                Path(f"/proc/{pid}/clear_refs").write_text("5")  # the high-water mark back to now
                before = _status_kb(pid, "VmRSS")
                t0 = time.perf_counter()
                response = client.post("/predict", files={"file": ("hour.csv", data, "text/csv")})
                seconds = time.perf_counter() - t0
                if response.status_code != 200:
                    answer = response.text[:500]
                    raise RuntimeError(f"POST /predict answered {response.status_code}: {answer}")
                growth = (_status_kb(pid, "VmHWM") - before) / 1024.0
    return seconds, growth


def _status_kb(pid: int, key: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(f"{key}:"):
            return int(line.split()[1])
    raise RuntimeError(f"/proc/{pid}/status has no {key}")


def describe(report: HourReport) -> list[str]:
    r = report
    lines = [
        f"{r.minutes:g} min at {r.rate_hz:g} Hz, IMU only ({r.csv_mb:.0f} MB CSV), default model {r.model}",
        f"looks: {r.looks}, {r.looks_per_sample:g} looks per sample (windows covering it x looks per window)",
        "",
        "| what | seconds | / reference |",
        "|---|--:|--:|",
        f"| reference: one fp32 forward pass, one copy, one thread (mean of {r.references_s[0]:.1f} before "
        f"and {r.references_s[1]:.1f} after the upload) | {r.reference_s:.1f} | 1.00 |",
        f"| **POST /predict, whole round trip** | {r.upload_s:.1f} | {r.upload_s / r.reference_s:.2f} |",
    ]
    for stage, seconds in r.stages_s.items():
        lines.append(f"| stage: {stage} | {seconds:.1f} | {seconds / r.reference_s:.2f} |")
    rest = r.upload_s - sum(r.stages_s.values())
    if rest >= 0:
        lines.append(
            f"| the rest (HTTP, JSON, scoring, the scene) | {rest:.1f} | {rest / r.reference_s:.2f} |"
        )
    else:  # the stages ran apart from the upload, on a machine whose load moved meanwhile
        lines.append(
            "| the rest (HTTP, JSON, scoring, the scene) | (the stages summed to more: load moved) | |"
        )
    lines.append(
        f"| beside the network: step detection (on another thread while it runs) | {r.beside_s:.1f} | "
        f"{r.beside_s / r.reference_s:.2f} |"
    )
    lines += [
        "",
        f"server peak memory growth during the upload: {r.server_growth_mb:.0f} MB (target <= 400)",
        f"bf16 / fp32 on the same 4,000 windows: {r.bf16_s / r.fp32_s:.2f} ({r.bf16_note})",
    ]
    return lines
