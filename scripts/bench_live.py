"""Live latency and memory: phones replaying a Sensor Logger export into the real app over HTTP.

    .venv/bin/python scripts/bench_live.py [--phones 1 4] [--minutes 20] [--speed 1] [--batch-s 1.0]
        [--export ../shared/data/phone/sensorlogger/inhand-20-steps-Zyf] [--no-scene]

Starts the app under uvicorn in this process (the shipped checkpoints, the default model, the viser
scene unless ``--no-scene``), then for each phone count replays the export (looped to ``--minutes``
of recording) from that many threads at once, each as its own phone, at ``--speed`` times real time.
Prints, per phone count: median and p95 latency from a sample's arrival (its message's) to the drawn
trajectory covering it (``app.services.live``: to the scene's drawing when it runs), messages,
dropped, and the process's resident memory over time. Asserts nothing: the targets (median <= 0.5 s,
p95 <= 1 s for one phone at 100 Hz, p95 < 2 s for four, flat memory) are read off the output.
A quick run: ``--minutes 2 --speed 5`` (faster than real time: latencies then include the backlog a
2-core machine builds at 5x).
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import threading
import time
from pathlib import Path

import numpy as np
import torch

import ftin.live.session as live_session
from app.main import create_app
from app.serve import serve_in_thread
from app.settings import Settings
from ftin.live.replay import export_messages, send

DEFAULT_EXPORT = (
    Path(__file__).resolve().parents[1].parent / "shared/data/phone/sensorlogger/inhand-20-steps-Zyf"
)


def rss_mb() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run(phones: int, args: argparse.Namespace, base_url: str, app) -> None:
    loop_s = export_messages(args.export, args.batch_s)[-1].at_s
    repeat = max(1, math.ceil(args.minutes * 60.0 / loop_s))
    streams = [
        export_messages(args.export, args.batch_s, f"bench-{phones}-{i}", f"phone-{i}", repeat)
        for i in range(phones)
    ]
    url = f"{base_url}/live/sensorlogger"
    threads = [threading.Thread(target=send, args=(m, url, args.speed), daemon=True) for m in streams]
    memory = [(0.0, rss_mb())]
    t0 = time.monotonic()
    for thread in threads:
        thread.start()
    while any(t.is_alive() for t in threads):
        time.sleep(1.0)
        elapsed = time.monotonic() - t0
        if elapsed - memory[-1][0] >= args.memory_every_s:
            memory.append((elapsed, rss_mb()))
    memory.append((time.monotonic() - t0, rss_mb()))
    live = app.state.services.live
    live.wait_idle(60)
    time.sleep(1.0)
    with live._lock:  # every latency of every session of this round, before they end
        sessions = [v.session for k, v in live._sessions.items() if k[0].startswith(f"bench-{phones}-")]
        pairs = [pair for s in sessions for pair in s.latencies_s]
        messages = sum(s.messages for s in sessions)
        dropped = sum(s.dropped_messages for s in sessions)
        samples = [s.n_samples for s in sessions]
    live.end_all("benchmark round over")
    wall = time.monotonic() - t0
    print(
        f"\n{phones} phone(s), {args.minutes:g} min of recording each ({repeat} loops of {loop_s:.1f} s), "
        f"{args.speed:g}x real time, batch {args.batch_s:g} s: {wall:.0f} s wall"
    )
    if pairs:
        values, weights = np.asarray(pairs).T
        median, p95 = (live_session.weighted_quantile(values, weights, q) for q in (0.5, 0.95))
        print(
            f"  latency per sample: median {median:.3f} s, p95 {p95:.3f} s, max {values.max():.3f} s "
            f"over {int(weights.sum())} gyroscope samples"
        )
    print(f"  messages {messages}, dropped {dropped}, samples per session {samples}")
    print("  memory (RSS, MB) over time: " + ", ".join(f"{t:.0f}s {m:.0f}" for t, m in memory))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--phones", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--minutes", type=float, default=20.0)
    parser.add_argument("--speed", type=float, default=1.0)
    parser.add_argument("--batch-s", type=float, default=1.0, help="Sensor Logger's batch period")
    parser.add_argument("--export", type=Path, default=DEFAULT_EXPORT)
    parser.add_argument("--memory-every-s", type=float, default=60.0)
    parser.add_argument("--no-scene", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(1)
    live_session.LATENCIES_KEPT = 10**7  # keep every latency of the benchmark, not the last 2048
    settings = Settings(
        viser_enabled=not args.no_scene,
        viser_port=0,
        scene_first_run=False,
        live_max_sessions=max(args.phones),
    )
    server = serve_in_thread(create_app(settings))
    print(
        f"app at {server.base_url} (pid {os.getpid()}, scene {'off' if args.no_scene else 'on'}, "
        f"model {settings.live_model or settings.default_model}, {os.cpu_count()} CPUs)"
    )
    try:
        for phones in args.phones:
            run(phones, args, server.base_url, server.app)
    finally:
        server.stop()


if __name__ == "__main__":
    main()
