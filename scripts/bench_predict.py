"""Time ``POST /predict`` on a one-minute 100 Hz simulated walk with the dashboard's default model.

    .venv/bin/python scripts/bench_predict.py                # real uvicorn + viser, in-process
    .venv/bin/python scripts/bench_predict.py --runs 30 --testclient --no-viser
    .venv/bin/python scripts/bench_predict.py --duration-s 1200 --runs 3 --warmup 1   # a 20 min recording

Starts nothing external: the app runs in this process (uvicorn on a free 127.0.0.1 port, or
FastAPI's TestClient), on the checkpoint folder the app would use (``FTIN_CHECKPOINT_DIR`` or
``checkpoints/``) and its default model (``ftin-oxiod``); when that checkpoint is missing, the
app's own fallback (the first FTIN checkpoint, else the first one) is timed and the script says so.
The scene is on by default, as in ``uvicorn app.main:app``, because a finished run is drawn before
the response leaves. Three uploads are timed: the simulated CSV as is (device orientation and
ground truth, so metrics too), the same without ground truth, and its IMU columns only (orientation
estimated by the VQF filter), side by side, with the ratio of the medians of the same recording without
and with orientation (the cost of estimating orientation).
Each upload is a multipart form in the field ``file``, as the upload page sends it; the time is
the full round trip including the JSON response.
"""

from __future__ import annotations

import argparse
import io
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import httpx
import numpy as np
import torch
from load_test import add_walk_options  # this folder's sibling script (its options are the same)

from app.main import create_app
from app.serve import ServerStartError, serve_in_thread
from app.settings import Settings
from ftin.data import preprocess
from ftin.data.preprocess import AhrsMethod
from ftin.data.readers.generic_csv import write_csv
from ftin.sim.config import CarryMode, SimConfig
from ftin.sim.simulator import simulate

Post = Callable[[bytes], httpx.Response]


def simulated_csvs(
    duration_s: float, rate_hz: float, seed: int, filter_name: str = "vqf"
) -> dict[str, bytes]:
    """The simulated walk as CSV: full (orientation + ground truth) and IMU columns only."""
    seq = simulate(SimConfig(duration_s=duration_s, rate_hz=rate_hz, carry=CarryMode.HANDHELD, seed=seed))
    oriented, imu_only, full = io.StringIO(), io.StringIO(), io.StringIO()
    write_csv(seq.with_(gt=None), oriented)
    write_csv(seq.with_(q_world_device_wxyz=None, gt=None), imu_only)
    write_csv(seq, full)
    return {  # the first two are the same recording with and without orientation (the ratio)
        "with orientation": oriented.getvalue().encode(),
        f"IMU only ({filter_name} estimates orientation)": imu_only.getvalue().encode(),
        "orientation + ground truth (metrics)": full.getvalue().encode(),
    }


@contextmanager
def uvicorn_poster(settings: Settings) -> Iterator[tuple[Post, object]]:
    app = create_app(settings)
    try:
        served = serve_in_thread(app, name="bench-uvicorn")
    except ServerStartError as exc:
        raise SystemExit(f"the app did not start: {exc}") from None
    try:
        with httpx.Client(base_url=served.base_url, timeout=600) as client:
            yield (lambda data: client.post("/predict", files={"file": ("walk.csv", data, "text/csv")})), app
    finally:
        served.stop()


@contextmanager
def testclient_poster(settings: Settings) -> Iterator[tuple[Post, object]]:
    from fastapi.testclient import TestClient

    app = create_app(settings)
    with TestClient(app) as client:
        yield (lambda data: client.post("/predict", files={"file": ("walk.csv", data, "text/csv")})), app


def time_requests(post: Post, data: bytes, runs: int, warmup: int) -> list[float]:
    for _ in range(warmup):
        post(data).raise_for_status()
    seconds = []
    for _ in range(runs):
        start = time.perf_counter()
        response = post(data)
        seconds.append(time.perf_counter() - start)
        if response.status_code != 200:
            raise SystemExit(f"POST /predict answered {response.status_code}: {response.text}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=20, help="timed requests per CSV (default 20)")
    parser.add_argument("--warmup", type=int, default=2, help="untimed requests first (default 2)")
    add_walk_options(parser, "--duration-s")
    parser.add_argument(
        "--threads",
        type=int,
        help="torch threads: FTIN_TORCH_THREADS (default: the app's, 1; 0: one per core)",
    )
    parser.add_argument("--testclient", action="store_true", help="FastAPI TestClient instead of uvicorn")
    parser.add_argument("--no-viser", action="store_true", help="without the 3D scene")
    parser.add_argument(
        "--filter",
        choices=[m.value for m in AhrsMethod],
        default=AhrsMethod.VQF.value,
        help="orientation filter for the IMU-only upload (default vqf; madgwick: the previous one, for "
        "before/after timings)",
    )
    args = parser.parse_args()
    if args.runs < 1 or args.warmup < 0:
        parser.error("--runs must be >= 1 and --warmup >= 0")
    overrides: dict[str, object] = {"viser_enabled": not args.no_viser, "viser_port": 0}
    if args.threads is not None:
        overrides["torch_threads"] = args.threads
    if args.checkpoint_dir is not None:
        overrides["checkpoint_dir"] = args.checkpoint_dir
    settings = Settings(**overrides)
    # The app always uses ensure_orientation's default filter; a benchmark may swap it for comparison.
    preprocess.ensure_orientation.__defaults__ = (AhrsMethod(args.filter),)
    csvs = simulated_csvs(args.duration_s, args.rate_hz, args.seed, args.filter)
    poster = testclient_poster if args.testclient else uvicorn_poster
    with poster(settings) as (post, app):
        services = app.state.services
        if services.models.default_name is None:
            raise SystemExit(f"no model to time: {'; '.join(services.notes)}")
        entry = services.models.get(None)
        fallback = services.models.default_name.casefold() != settings.default_model.casefold()
        size = f"{entry.architecture}, {entry.n_parameters:,} parameters"
        print(f"model     {entry.name} ({size}) from {entry.path}")
        if fallback:
            missing = settings.checkpoint_dir / f"{settings.default_model}.safetensors"
            print(f"          FALLBACK: the default model's checkpoint {missing} is missing")
        print(
            f"input     {args.duration_s:g} s at {args.rate_hz:g} Hz ({int(args.duration_s * args.rate_hz)} "
            f"samples), window {entry.loaded.window}, stride {entry.loaded.stride}"
        )
        print(
            f"server    {'TestClient' if args.testclient else 'uvicorn 127.0.0.1'}, viser "
            f"{'off' if args.no_viser else 'on'}, torch threads {torch.get_num_threads()}, "
            f"{args.runs} runs after {args.warmup} warm-up"
        )
        print(f"orientation filter for the IMU-only upload: {args.filter}")
        print(f"{'CSV':<40} {'size':>8} {'median':>9} {'p90':>9} {'max':>9}")
        # Interleaved (one request of each upload per round), so that a machine whose load drifts
        # during the benchmark weighs on every upload alike.
        for data in csvs.values():
            time_requests(post, data, 0, args.warmup)
        timings: dict[str, list[float]] = {label: [] for label in csvs}
        for _ in range(args.runs):
            for label, data in csvs.items():
                timings[label] += time_requests(post, data, 1, 0)
        medians = []
        for label, data in csvs.items():
            seconds = timings[label]
            medians.append(statistics.median(seconds))
            p90 = float(np.percentile(seconds, 90))
            print(
                f"{label:<40} {len(data) / 2**20:>6.2f}MB {statistics.median(seconds):>8.3f}s "
                f"{p90:>8.3f}s {max(seconds):>8.3f}s"
            )
        ratio = medians[1] / medians[0]
        print(f"ratio     IMU only / with orientation, same recording (medians): {ratio:.2f}")


if __name__ == "__main__":
    main()
