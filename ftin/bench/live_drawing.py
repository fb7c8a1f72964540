"""What one live update costs the 3D scene at minute 1 and at minute 30 of a walk
(``ftin bench live-drawing``).

The caller starts the app with its scene and hands over ``grown(t_s)``: the live run and its figures
as the live service publishes them when the walk has reached ``t_s`` seconds. At each minute mark a
fresh live run grows by ``every_s`` per update, ``warmup`` untimed updates first (the scene draws a
walk it already holds, as it would after following it from the start), then ``updates`` timed ones:
from handing the update to the scene until its drawing thread has drawn everything the update caused.
The model and integration are not in it (the live service's, flat in the walk's length). Prints
numbers, asserts nothing; the target is the minute-30 median at most 1.2x the minute-1 median.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any

from ftin.bench.options import LiveDrawingOptions


def time_updates(
    scene: Any, grown: Callable[[float, str], Any], options: LiveDrawingOptions
) -> dict[float, list[float]]:
    """Seconds per timed update at each minute mark; ``grown(t_s, run_id)``: the update at ``t_s``."""
    seconds: dict[float, list[float]] = {}
    for minute in options.minutes:
        run_id = f"bench-live-{minute:g}"
        end_s = 60.0 * minute
        first_s = end_s - options.every_s * (options.warmup + options.updates)
        times = []
        for k in range(options.warmup + options.updates):
            update = grown(max(first_s, 5.0) + k * options.every_s, run_id)
            t0 = time.perf_counter()
            scene.live_updated(update)
            scene.drawing.flush()  # the update's drawing ...
            scene.drawing.flush()  # ... and what it queued in turn (the timeline's time)
            if k >= options.warmup:
                times.append(time.perf_counter() - t0)
        seconds[minute] = times
    return seconds


def describe(seconds: dict[float, list[float]], options: LiveDrawingOptions) -> list[str]:
    lines = [
        f"live drawing: {options.updates} timed updates at each mark after {options.warmup} untimed, "
        f"one every {options.every_s:g} s of recording",
        "",
        "| minute | median (ms) | p90 (ms) | max (ms) | median / first mark's |",
        "|--:|--:|--:|--:|--:|",
    ]
    base = statistics.median(next(iter(seconds.values())))
    for minute, times in seconds.items():
        ordered = sorted(times)
        p90 = ordered[min(len(ordered) - 1, int(0.9 * len(ordered)))]
        median = statistics.median(times)
        milliseconds = (f"{1e3 * v:.1f}" for v in (median, p90, max(times)))
        cells = [f"{minute:g}", *milliseconds, f"{median / base:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines
