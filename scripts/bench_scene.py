"""Time the 3D scene with many runs: drawing a run, one slider move, a dragged slider, and the REST
call made while the scene holds the runs (the scene must stay responsive with 10 models on a
4-minute recording; slow spots seen before: 7.6 s per API call, 2-4 s of spectra per slider move).

    .venv/bin/python scripts/bench_scene.py [--minutes 4] [--repeats 2] [--chromium /usr/bin/chromium]

Uses the checkpoints in ``checkpoints/`` (every one of them, each run ``--repeats`` times on the
same simulated walk of ``--minutes``) and a real viser server on a free port; prints numbers and
asserts nothing. With chromium (Playwright) a browser shows the scene while the runs arrive, and
a slider move is timed until the browser shows the new window's spectra.
"""

from __future__ import annotations

import argparse
import io
import statistics
import time

import httpx

from ftin.sim.config import SimConfig
from ftin.sim.simulator import simulate


def walk_csv(minutes: float) -> bytes:
    from ftin.data.readers.generic_csv import write_csv

    seq = simulate(SimConfig(duration_s=60.0 * minutes, seed=11))
    buffer = io.StringIO()
    write_csv(seq, buffer)
    return buffer.getvalue().encode()


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--minutes", type=float, default=4.0)
    parser.add_argument(
        "--repeats", type=int, default=2, help="runs of each model (repeats pile up or replace)"
    )
    parser.add_argument("--moves", type=int, default=20, help="slider moves in the dragged-slider test")
    parser.add_argument("--models", type=int, default=0, help="only the first N checkpoints (0: all)")
    parser.add_argument("--chromium", default="/usr/bin/chromium", help="'' to time without a browser")
    args = parser.parse_args()

    from app.main import create_app
    from app.serve import serve_in_thread
    from app.settings import Settings

    data = walk_csv(args.minutes)
    app = create_app(Settings(viser_port=0, scene_first_run=False))
    served = serve_in_thread(app)
    base = served.base_url
    playwright = browser = page = None
    try:
        scene = app.state.scene
        if args.chromium:
            from playwright.sync_api import sync_playwright

            playwright = sync_playwright().start()
            browser = playwright.chromium.launch(
                executable_path=args.chromium, args=["--no-sandbox", "--enable-unsafe-swiftshader"]
            )
            page = browser.new_page(viewport={"width": 1600, "height": 900})
            page.goto(scene.url)
            page.wait_for_selector("canvas")
        models = [m["name"] for m in httpx.get(f"{base}/models").json()]
        models = models[: args.models] if args.models else models
        api_s, draw_s = [], []
        for _ in range(args.repeats):
            for model in models:
                start = time.perf_counter()
                httpx.post(
                    f"{base}/predict",
                    params={"model": model},
                    files={"file": ("walk.csv", data, "text/csv")},
                    timeout=600,
                ).raise_for_status()
                api_s.append(time.perf_counter() - start)
                start = time.perf_counter()
                scene.flush(300)
                draw_s.append(time.perf_counter() - start)
        shown = len(scene.shown_run_ids())
        print(f"{len(models)} models x {args.repeats} runs on a {args.minutes:g}-minute walk: {shown} shown")
        print(
            f"POST /predict: median {statistics.median(api_s):.2f} s, last {api_s[-1]:.2f} s, "
            f"max {max(api_s):.2f} s"
        )
        print(
            f"drawing after the response: median {statistics.median(draw_s):.2f} s, max {max(draw_s):.2f} s"
        )

        # One slider move, redrawn synchronously (markers, windows, spectra, error plots).
        moves = []
        for k in range(10):
            scene.gui_time.value = 10.0 + 7.3 * k
            scene.flush(120)
            start = time.perf_counter()
            scene._update_time()
            moves.append(time.perf_counter() - start)
        print(
            f"one slider move (server): median {statistics.median(moves) * 1000:.0f} ms, "
            f"max {max(moves) * 1000:.0f} ms"
        )

        # A dragged slider: ``--moves`` updates in quick succession, until the scene is up to date.
        scene.flush(120)
        start = time.perf_counter()
        for k in range(args.moves):
            scene.gui_time.value = 30.0 + 0.5 * k
        scene.flush(300)
        print(f"{args.moves} slider moves in a row, until settled: {time.perf_counter() - start:.2f} s")

        if page is not None:
            # Until the browser shows the spectra of the new window ("window k/M" in the Spectra tab).
            seen = []
            for k in range(8):
                scene.flush(120)
                t_s = 40.0 + 11.1 * k
                start = time.perf_counter()
                scene.gui_time.value = t_s
                view = scene._plotted_view() if hasattr(scene, "_plotted_view") else None
                index = view.window_at(view.t0_s + t_s) if view is not None else 0
                page.wait_for_function(
                    f"() => document.body.innerText.includes('window {index + 1}/')", timeout=120_000
                )
                seen.append(time.perf_counter() - start)
            print(
                f"slider move until the browser shows the window: median {statistics.median(seen):.2f} s, "
                f"max {max(seen):.2f} s"
            )
            start = time.perf_counter()
            page.screenshot(path="/tmp/bench_scene.png")
            print(f"a screenshot of the scene: {time.perf_counter() - start:.2f} s")
    finally:
        if browser is not None:
            browser.close()
            playwright.stop()
        served.stop()


if __name__ == "__main__":
    main()
