"""Take the dashboard screenshots in this folder: the upload page and the 3D scene.

    .venv/bin/python docs/screenshots/take_screenshots.py [--csv ftin/sim/samples/sim_stops_turns.csv]

Starts the app as ``uvicorn app.main:app`` would (the same settings: ``FTIN_*`` variables or the
defaults, i.e. the shipped checkpoints in ``checkpoints/`` and the bundled samples; only the viser
port is picked free), uploads the CSV on the page with the default model, runs every other loaded
model on the same recording for the 3D scene, moves the timeline to ``--time`` seconds and saves
``upload_page.png``, ``scene_3d.png`` and ``scene_error.png`` here. Needs Playwright and Debian's
chromium (``/usr/bin/chromium``).
"""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path

import httpx
import uvicorn
from playwright.sync_api import sync_playwright

from app.main import create_app
from app.settings import BUNDLED_SAMPLES_DIR, Settings

HERE = Path(__file__).resolve().parent
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--enable-unsafe-swiftshader",
]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--csv", type=Path, default=BUNDLED_SAMPLES_DIR / "sim_stops_turns.csv")
    parser.add_argument("--time", type=float, default=35.0, help="timeline position in seconds")
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args()

    app = create_app(Settings(viser_port=0))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)
    base = f"http://127.0.0.1:{server.servers[0].sockets[0].getsockname()[1]}"
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 860})
            page.goto(base)
            page.wait_for_selector("#model-select option:checked", state="attached")
            print("default model:", page.input_value("#model-select"))
            page.set_input_files("#file-input", str(args.csv))
            page.click("#run-button")
            page.wait_for_selector("#result:not([hidden]) #plot svg polyline.series", timeout=120_000)
            page.screenshot(path=str(HERE / "upload_page.png"), full_page=True)

            # Every other model on the same recording, so the scene overlays them all.
            models = [m["name"] for m in httpx.get(f"{base}/models").json() if not m["default"]]
            for model in models:
                with args.csv.open("rb") as handle:
                    httpx.post(
                        f"{base}/predict", params={"model": model}, files={"file": handle}, timeout=300
                    ).raise_for_status()
            scene = app.state.scene
            scene.gui_time.value = args.time
            scene._update_time()
            page = browser.new_page(viewport={"width": 1600, "height": 900})
            page.goto(scene.url)
            page.wait_for_selector("canvas")
            for close in page.query_selector_all("button.mantine-Notification-closeButton"):
                close.click()
            page.wait_for_timeout(15_000)  # viser fades the scene in; software WebGL is slow
            page.screenshot(path=str(HERE / "scene_3d.png"))
            page.get_by_text("Error", exact=True).click()
            page.wait_for_timeout(2_000)
            page.screenshot(path=str(HERE / "scene_error.png"))
            browser.close()
    finally:
        server.should_exit = True
        thread.join(30)


if __name__ == "__main__":
    main()
