"""Take the dashboard screenshots in this folder: every view of the upload page and the 3D scene.

    PYTHONPATH=. .venv/bin/python docs/screenshots/take_screenshots.py \
        [--csv ftin/sim/samples/sim_stops_turns.csv] [--out docs/screenshots]

Starts the app as ``uvicorn app.main:app`` would (the same settings: ``FTIN_*`` variables or the
defaults, i.e. the shipped checkpoints in ``checkpoints/`` and the bundled samples; only the viser
port is picked free, and the runs folder is a new empty one: the pages as a new user first sees
them) and saves, in ``--out``:

- ``scene_start.png``: the 3D scene as it opens, before anything was asked of it;
- ``upload_first_screen.png``: the upload page as it opens: the bundled sample's result;
- ``upload_page.png``: the CSV uploaded on the page with the default model, every loaded model
  compared below it (flags in words, the standing-still row), its four downloads;
- ``scene_3d.png``: every loaded model on the same recording (the upload page's own run repeated
  three times on top), the timeline at ``--time`` seconds;
- ``scene_error.png``: the Error tab (all models' per-window errors, heading drift);
- ``scene_spectra_other_model.png``: the Spectra tab following a model without FDL;
- ``scene_cleared.png``: the scene after "Clear scene";
- ``upload_expired.png``: the upload page after its run was dropped from memory and the user
  pressed "Download trajectory (CSV)";
- ``upload_failed.png``: the upload page after a second upload that the server refused;
- ``upload_path_warning.png``: a recording where the phone lies still while the ground truth
  walks: the path ratio and the warning naming the path;
- ``upload_phone_walk.png`` and ``scene_phone_walk.png``: a phone walk without ground truth, its
  plausibility panel and its GPS track beside the prediction, on the page also the map under the plot
  (tiles from ``FTIN_MAP_TILES``; on a machine without internet the page says they could not load).
  The export is synthetic (Sensor Logger's layout, as ``tests/utils/phone_walk.py`` builds it): the
  real exports with GPS in the shared data have an empty Location.csv.

Needs Playwright and Debian's chromium (``/usr/bin/chromium``).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import httpx
import pandas as pd
from playwright.sync_api import sync_playwright

from app.main import create_app
from app.serve import serve_in_thread
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from tests.utils.phone_walk import sensorlogger_walk_zip

HERE = Path(__file__).resolve().parent
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--enable-unsafe-swiftshader",
]
SCENE_FADE_MS = 12_000  # viser fades the scene in; software WebGL is slow


def _close_notifications(page) -> None:
    """Hide viser's notices (the "software WebGL" one comes back after every reload)."""
    page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")


def _wait_for_result(page, caption_start: str, timeout_ms: int = 300_000) -> None:
    """Wait until the page shows the result of ``caption_start`` (a file or sample name)."""
    page.wait_for_function(
        "(start) => !document.getElementById('result').hidden && "
        "document.getElementById('result-caption').textContent.startsWith(start)",
        arg=caption_start,
        timeout=timeout_ms,
    )


def _timed(what: str, start: float) -> None:
    print(f"{what}: {time.perf_counter() - start:.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--csv", type=Path, default=BUNDLED_SAMPLES_DIR / "sim_stops_turns.csv")
    parser.add_argument("--time", type=float, default=35.0, help="timeline position in seconds")
    parser.add_argument("--out", type=Path, default=HERE, help="folder for the PNG files")
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)

    app = create_app(Settings(viser_port=0, runs_dir=Path(tempfile.mkdtemp(prefix="ftin-screenshots-"))))
    served = serve_in_thread(app)
    base = served.base_url
    scene = app.state.scene
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
            scene.flush()
            scene_page = browser.new_page(viewport={"width": 1600, "height": 900})
            scene_page.goto(scene.url)
            scene_page.wait_for_selector("canvas")
            _close_notifications(scene_page)
            scene_page.wait_for_timeout(SCENE_FADE_MS)
            _close_notifications(scene_page)
            scene_page.screenshot(path=str(out / "scene_start.png"))

            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.goto(base)
            page.wait_for_selector("#model-select option:checked", state="attached")
            print("default model:", page.input_value("#model-select"))
            page.wait_for_selector("#result:not([hidden]) #plot svg polyline.series", timeout=300_000)
            page.wait_for_timeout(500)
            page.screenshot(path=str(out / "upload_first_screen.png"), full_page=True)
            page.set_input_files("#file-input", str(args.csv))
            page.click("#run-button")
            _wait_for_result(page, args.csv.name)
            if page.query_selector("#compare-button"):
                page.click("#compare-button")
                page.wait_for_selector("#compare-table tr.done >> nth=-1", timeout=600_000)
                page.wait_for_function(
                    "() => !document.querySelector('#compare-button').disabled", timeout=600_000
                )
            page.screenshot(path=str(out / "upload_page.png"), full_page=True)

            # Every other model on the same recording (when the page did not compare them already),
            # then the default model three more times: repeats must not pile up.
            models = httpx.get(f"{base}/models").json()
            default = next(m["name"] for m in models if m["default"])
            shown = {r.model_name for r in app.state.services.runs.list()}
            timings = []
            for model in [m["name"] for m in models if m["name"] not in shown] + [default] * 3:
                start = time.perf_counter()
                with args.csv.open("rb") as handle:
                    httpx.post(
                        f"{base}/predict", params={"model": model}, files={"file": handle}, timeout=600
                    ).raise_for_status()
                timings.append(time.perf_counter() - start)
            print("POST /predict, s:", " ".join(f"{t:.2f}" for t in timings))
            start = time.perf_counter()
            scene.flush(120)
            _timed("scene drew every run", start)
            scene.timeline.gui_time.value = args.time
            scene.timeline.update()
            scene_page.reload()
            scene_page.wait_for_selector("canvas")
            _close_notifications(scene_page)
            scene_page.wait_for_timeout(SCENE_FADE_MS)
            _close_notifications(scene_page)
            start = time.perf_counter()
            scene_page.screenshot(path=str(out / "scene_3d.png"))
            _timed("screenshot of the scene", start)
            scene_page.get_by_text("Error", exact=True).click()
            scene_page.wait_for_timeout(2_000)
            _close_notifications(scene_page)
            scene_page.screenshot(path=str(out / "scene_error.png"))

            # The Spectra tab following a model without FDL.
            other = next((label for label in scene.plots.spectra.gui_run.options if "tlio" in label), None)
            if other is not None:
                scene.plots.spectra.gui_run.value = other
            scene_page.get_by_text("Spectra", exact=True).click()
            scene_page.wait_for_timeout(2_000)
            _close_notifications(scene_page)
            scene_page.screenshot(path=str(out / "scene_spectra_other_model.png"))

            scene_page.get_by_text("Clear scene", exact=True).click()
            scene_page.wait_for_timeout(2_000)
            _close_notifications(scene_page)
            scene_page.screenshot(path=str(out / "scene_cleared.png"))

            # Drop every kept run but the newest one: the page's run has expired.
            runs = app.state.services.runs
            runs.max_runs = 1
            with args.csv.open("rb") as handle:
                httpx.post(f"{base}/predict", params={"model": default}, files={"file": handle}, timeout=600)
            page.evaluate("window.scrollTo(0, 0)")
            page.click("#download-link")
            page.wait_for_timeout(1_500)
            page.screenshot(path=str(out / "upload_expired.png"), full_page=True)

            bad = out / "notes.csv"
            bad.write_text("time,comment\n0,hello\n")
            try:
                page.set_input_files("#file-input", str(bad))
                page.click("#run-button")
                page.wait_for_selector("#error:not([hidden])", timeout=60_000)
                page.wait_for_timeout(500)
                page.screenshot(path=str(out / "upload_failed.png"), full_page=True)
            finally:
                bad.unlink()

            # The phone lies still on a table while the ground truth walks: the path warning.
            still = out / "still_phone.csv"
            frame = pd.read_csv(args.csv)
            for column in ("gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y"):
                frame[column] = 0.0
            frame["acc_z"] = 9.81
            frame["q_w"], frame["q_x"], frame["q_y"], frame["q_z"] = 1.0, 0.0, 0.0, 0.0
            frame.to_csv(still, index=False)
            try:
                page.set_input_files("#file-input", str(still))
                page.click("#run-button")
                _wait_for_result(page, still.name)
                page.screenshot(path=str(out / "upload_path_warning.png"), full_page=True)
            finally:
                still.unlink()

            # A phone walk without ground truth: plausibility figures and the GPS track (synthetic export).
            runs.max_runs = 20
            walk = out / "phone_walk.zip"
            walk.write_bytes(sensorlogger_walk_zip(duration_s=60.0))
            try:
                page.set_input_files("#file-input", str(walk))
                page.click("#run-button")
                _wait_for_result(page, walk.name)
                page.wait_for_timeout(500)
                page.screenshot(path=str(out / "upload_phone_walk.png"), full_page=True)
            finally:
                walk.unlink()
            scene.flush(120)
            scene_page.reload()
            scene_page.wait_for_selector("canvas")
            _close_notifications(scene_page)
            scene_page.wait_for_timeout(SCENE_FADE_MS)
            _close_notifications(scene_page)
            for folder in ("Models", "Run", "Timeline"):  # folded: the Runs folder's figures show
                scene_page.get_by_text(folder, exact=True).first.click()
            scene_page.wait_for_timeout(1_500)
            scene_page.screenshot(path=str(out / "scene_phone_walk.png"))
            browser.close()
    finally:
        served.stop()


if __name__ == "__main__":
    main()
