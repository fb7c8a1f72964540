"""Live latency and memory: phones replaying a Sensor Logger export into the real app over HTTP
(``ftin bench live``).

The caller starts the app in this process (the shipped checkpoints, the default model, the viser scene
unless turned off) and hands over its URL and its live service; for each phone count the export
(looped to ``minutes`` of recording) is replayed from that many threads at once, each as its own
phone, at ``speed`` times real time. Reported per phone count: median and p95 latency from a sample's
arrival (its message's) to the published trajectory covering it (``app.services.live``; the scene
draws what is published), messages, dropped, and the process's resident memory over time. Asserts
nothing: the targets (median <= 0.5 s, p95 <= 1 s for one phone at 100 Hz, p95 < 2 s for four, flat
memory) are read off the output. A quick run: ``--minutes 2 --speed 5`` (faster than real time:
latencies then include the backlog a 2-core machine builds at 5x).
"""

from __future__ import annotations

import math
import resource
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ftin.bench.options import LiveOptions
from ftin.live import session as live_session
from ftin.live.replay import export_messages, send


def keep_every_latency() -> None:
    """Keep every latency of the benchmark in each session, not the last 2048."""
    live_session.LATENCIES_KEPT = 10**7


def rss_mb() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def run_round(
    phones: int, options: LiveOptions, base_url: str, live: Any, echo: Callable[[str], None]
) -> None:
    """One round of ``phones`` phones against the app at ``base_url``; ``live``: its live service
    (``app.state.services.live``), read for the sessions' latencies."""
    loop_s = export_messages(options.export, options.batch_s)[-1].at_s
    repeat = max(1, math.ceil(options.minutes * 60.0 / loop_s))
    streams = [
        export_messages(options.export, options.batch_s, f"bench-{phones}-{i}", f"phone-{i}", repeat)
        for i in range(phones)
    ]
    url = f"{base_url}/live/sensorlogger"
    threads = [threading.Thread(target=send, args=(m, url, options.speed), daemon=True) for m in streams]
    memory = [(0.0, rss_mb())]
    t0 = time.monotonic()
    for thread in threads:
        thread.start()
    while any(t.is_alive() for t in threads):
        time.sleep(1.0)
        elapsed = time.monotonic() - t0
        if elapsed - memory[-1][0] >= options.memory_every_s:
            memory.append((elapsed, rss_mb()))
    memory.append((time.monotonic() - t0, rss_mb()))
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
    echo(
        f"\n{phones} phone(s), {options.minutes:g} min of recording each ({repeat} loops of {loop_s:.1f} s), "
        f"{options.speed:g}x real time, batch {options.batch_s:g} s: {wall:.0f} s wall"
    )
    if pairs:
        values, weights = np.asarray(pairs).T
        median, p95 = (live_session.weighted_quantile(values, weights, q) for q in (0.5, 0.95))
        echo(
            f"  latency per sample: median {median:.3f} s, p95 {p95:.3f} s, max {values.max():.3f} s "
            f"over {int(weights.sum())} gyroscope samples"
        )
    echo(f"  messages {messages}, dropped {dropped}, samples per session {samples}")
    echo("  memory (RSS, MB) over time: " + ", ".join(f"{t:.0f}s {m:.0f}" for t, m in memory))
