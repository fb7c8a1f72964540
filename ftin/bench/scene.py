"""Time the 3D scene with many runs: drawing a run, one slider move, a dragged slider, and the REST
call made while the scene holds the runs (the scene must stay responsive with 10 models on a
4-minute recording; slow spots seen before: 7.6 s per API call, 2-4 s of spectra per slider move)
(``ftin bench scene``).

The caller starts the app in this process with a real viser server on a free port and hands over its
URL and scene; every checkpoint it serves runs ``repeats`` times on the same simulated walk of
``minutes``. Prints numbers and asserts nothing. With chromium (Playwright, the ``test`` extra) a
browser shows the scene while the runs arrive, and a slider move is timed until the browser shows the
new window's spectra.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import httpx
from playwright.sync_api import Page, sync_playwright

from ftin.bench.load import csv_bytes
from ftin.bench.options import SceneOptions
from ftin.sim.config import SimConfig
from ftin.sim.simulator import simulate


@contextmanager
def browser_page(chromium: str, url: str) -> Iterator[Page | None]:
    """A chromium page showing the scene at ``url``; ``None`` without a chromium."""
    if not chromium:
        yield None
        return
    playwright = sync_playwright().start()
    browser = playwright.chromium.launch(
        executable_path=chromium, args=["--no-sandbox", "--enable-unsafe-swiftshader"]
    )
    try:
        page = browser.new_page(viewport={"width": 1600, "height": 900})
        page.goto(url)
        page.wait_for_selector("canvas")
        yield page
    finally:
        browser.close()
        playwright.stop()


def _median_max(seconds: list[float], unit: float = 1.0, fmt: str = ".2f", suffix: str = " s") -> str:
    return (
        f"median {statistics.median(seconds) * unit:{fmt}}{suffix}, max {max(seconds) * unit:{fmt}}{suffix}"
    )


def time_scene(base_url: str, scene: Any, options: SceneOptions, echo: Callable[[str], None]) -> None:
    """Upload every model's run, then move the slider; ``scene``: the app's (``app.state.scene``)."""
    data = csv_bytes(simulate(SimConfig(duration_s=60.0 * options.minutes, seed=11)))
    with browser_page(options.chromium, scene.url) as page:
        models = [m["name"] for m in httpx.get(f"{base_url}/models").json()]
        models = models[: options.models] if options.models else models
        api_s, draw_s = [], []
        for _ in range(options.repeats):
            for model in models:
                start = time.perf_counter()
                httpx.post(
                    f"{base_url}/predict",
                    params={"model": model},
                    files={"file": ("walk.csv", data, "text/csv")},
                    timeout=600,
                ).raise_for_status()
                api_s.append(time.perf_counter() - start)
                start = time.perf_counter()
                scene.flush(300)
                draw_s.append(time.perf_counter() - start)
        shown = len(scene.shown_run_ids())
        walk = f"a {options.minutes:g}-minute walk"
        echo(f"{len(models)} models x {options.repeats} runs on {walk}: {shown} shown")
        last = f"last {api_s[-1]:.2f} s"
        echo(f"POST /predict: median {statistics.median(api_s):.2f} s, {last}, max {max(api_s):.2f} s")
        echo(f"drawing after the response: {_median_max(draw_s)}")

        # One slider move, redrawn synchronously (markers, windows, spectra, error plots).
        timeline = scene.timeline
        moves = []
        for k in range(10):
            timeline.gui_time.value = 10.0 + 7.3 * k
            scene.flush(120)
            start = time.perf_counter()
            timeline.update()
            moves.append(time.perf_counter() - start)
        echo(f"one slider move (server): {_median_max(moves, 1000, '.0f', ' ms')}")

        # A dragged slider: ``moves`` updates in quick succession, until the scene is up to date.
        scene.flush(120)
        start = time.perf_counter()
        for k in range(options.moves):
            timeline.gui_time.value = 30.0 + 0.5 * k
        scene.flush(300)
        echo(f"{options.moves} slider moves in a row, until settled: {time.perf_counter() - start:.2f} s")
        if page is not None:
            _time_browser(page, scene, echo)


def _time_browser(page: Page, scene: Any, echo: Callable[[str], None]) -> None:
    """Slider moves until the browser shows the spectra of the new window ("window k/M" in the Spectra
    tab), and one screenshot."""
    seen = []
    for k in range(8):
        scene.flush(120)
        t_s = 40.0 + 11.1 * k
        start = time.perf_counter()
        scene.timeline.gui_time.value = t_s
        view = scene.plots.plotted(list(scene.overlay.views.values()))
        index = view.window_at(view.t0_s + t_s) if view is not None else 0
        page.wait_for_function(
            f"() => document.body.innerText.includes('window {index + 1}/')", timeout=120_000
        )
        seen.append(time.perf_counter() - start)
    echo(f"slider move until the browser shows the window: {_median_max(seen)}")
    start = time.perf_counter()
    page.screenshot(path="/tmp/bench_scene.png")
    echo(f"a screenshot of the scene: {time.perf_counter() - start:.2f} s")
