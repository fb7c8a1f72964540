"""Time ``POST /predict`` on a one-minute 100 Hz simulated walk with the dashboard's default model
(``ftin bench predict``).

The app runs in this process (uvicorn on a free 127.0.0.1 port, or FastAPI's TestClient: the caller
starts it and hands over ``post``), on the checkpoint folder the app would use (``FTIN_CHECKPOINT_DIR``
or ``checkpoints/``) and its default model; when that checkpoint is missing, the app's own fallback
(the first FTIN checkpoint, else the first one) is timed and the report says so. The scene is on by
default, as in ``uvicorn app.main:app``, because a finished run is drawn before the response leaves.
Three uploads are timed: the simulated CSV as is (device orientation and ground truth, so metrics
too), the same without ground truth, and its IMU columns only (orientation estimated by the filter),
side by side, with the ratio of the medians of the same recording without and with orientation (the
cost of estimating orientation). Each upload is a multipart form in the field ``file``, as the upload
page sends it; the time is the full round trip including the JSON response.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ftin.bench.load import csv_bytes, simulated_walk
from ftin.data import preprocess
from ftin.data.preprocess import AhrsMethod

Post = Callable[[bytes], Any]  # one upload of a CSV; returns the HTTP response


def use_filter(name: str) -> None:
    """Make ``name`` the orientation filter of every IMU-only upload. The app always uses
    ``ensure_orientation``'s default filter; a benchmark may swap it for before/after timings."""
    preprocess.ensure_orientation.__defaults__ = (AhrsMethod(name),)


def simulated_csvs(
    duration_s: float, rate_hz: float, seed: int, filter_name: str = "vqf"
) -> dict[str, bytes]:
    """The simulated walk as CSV: with orientation, IMU columns only, and with ground truth too."""
    seq = simulated_walk(duration_s, rate_hz, seed)
    return {  # the first two are the same recording with and without orientation (the ratio)
        "with orientation": csv_bytes(seq.with_(gt=None)),
        f"IMU only ({filter_name} estimates orientation)": csv_bytes(
            seq.with_(q_world_device_wxyz=None, gt=None)
        ),
        "orientation + ground truth (metrics)": csv_bytes(seq),
    }


def time_requests(post: Post, data: bytes, runs: int, warmup: int) -> list[float]:
    for _ in range(warmup):
        post(data).raise_for_status()
    seconds = []
    for _ in range(runs):
        start = time.perf_counter()
        response = post(data)
        seconds.append(time.perf_counter() - start)
        if response.status_code != 200:
            raise RuntimeError(f"POST /predict answered {response.status_code}: {response.text}")
    return seconds


def time_uploads(post: Post, csvs: dict[str, bytes], runs: int, warmup: int) -> dict[str, list[float]]:
    """Seconds per upload and CSV. Interleaved (one request of each upload per round), so that a
    machine whose load drifts during the benchmark weighs on every upload alike."""
    for data in csvs.values():
        time_requests(post, data, 0, warmup)
    timings: dict[str, list[float]] = {label: [] for label in csvs}
    for _ in range(runs):
        for label, data in csvs.items():
            timings[label] += time_requests(post, data, 1, 0)
    return timings


def describe_timings(csvs: dict[str, bytes], timings: dict[str, list[float]]) -> list[str]:
    """One row per CSV (size, median, p90, max) and the without / with orientation ratio."""
    lines = [f"{'CSV':<40} {'size':>8} {'median':>9} {'p90':>9} {'max':>9}"]
    medians = []
    for label, data in csvs.items():
        seconds = timings[label]
        medians.append(statistics.median(seconds))
        p90 = float(np.percentile(seconds, 90))
        lines.append(
            f"{label:<40} {len(data) / 2**20:>6.2f}MB {statistics.median(seconds):>8.3f}s "
            f"{p90:>8.3f}s {max(seconds):>8.3f}s"
        )
    ratio = medians[1] / medians[0]
    lines.append(f"ratio     IMU only / with orientation, same recording (medians): {ratio:.2f}")
    return lines
