"""Take the README's pictures of how sure a path is: the upload page's plot with the 2-sigma band and the
95 % end circle, and the 3D scene with the ellipses along the path and the sigma plot in the Timeline.

    .venv/bin/python docs/screenshots/screenshot_uncertainty.py [--csv ftin/sim/samples/sim_handheld.csv]
                                                       [--out docs/screenshots]  # from the repo root

Starts the app on free ports with the default settings (the shipped checkpoints in ``checkpoints/``,
the bundled samples; runs kept in a temporary folder), uploads ``--csv`` on the page with the default
model (``ronin_resnet-walking``, whose uncertainty is calibrated), and saves ``uncertainty_page.png``
(the plot and its legend) and ``uncertainty_scene.png`` (the scene). Images are reduced to a
256-colour palette so that each stays well under 300 KB.

Needs Playwright and Debian's chromium (``/usr/bin/chromium``).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from PIL import Image
from playwright.sync_api import sync_playwright

from app.main import create_app
from app.serve import serve_in_thread
from app.settings import BUNDLED_SAMPLES_DIR, Settings

ROOT = Path(__file__).resolve().parents[2]

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--enable-unsafe-swiftshader",
]
SCENE_FADE_MS = 12_000  # viser fades the scene in; software WebGL is slow
RESULT_TIMEOUT_MS = 300_000
MODEL = "ronin_resnet-walking"  # the default model: its uncertainty is calibrated, not borrowed


def _small_png(path: Path) -> None:
    """Rewrite ``path`` with a 256-colour palette (screenshots of flat colours lose nothing visible)."""
    with Image.open(path) as image:
        reduced = image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    reduced.save(path, optimize=True)
    print(f"{path}: {path.stat().st_size // 1024} KB")


def _hide_notifications(page) -> None:
    page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--csv", type=Path, default=BUNDLED_SAMPLES_DIR / "sim_handheld.csv")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "screenshots")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as runs:
        app = create_app(Settings(viser_port=0, runs_dir=Path(runs)))
        server = serve_in_thread(app)
        try:
            _shoot(app, server.base_url, args.csv, args.out)
        finally:
            server.stop()


def _shoot(app, base_url: str, csv: Path, out: Path) -> None:
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1360, "height": 900}, device_scale_factor=2)
            page.goto(base_url)
            page.wait_for_selector(f"#model-select option[value='{MODEL}']", state="attached")
            page.select_option(
                "#model-select", MODEL
            )  # the calibrated one (ftin/uncertainty/calibration.json)
            page.set_input_files("#file-input", str(csv))
            page.click("#run-button")
            page.wait_for_function(
                "(name) => !document.getElementById('result').hidden && "
                "document.getElementById('result-caption').textContent.startsWith(name)",
                arg=csv.name,
                timeout=RESULT_TIMEOUT_MS,
            )
            page.wait_for_selector("#plot g.uncertainty-band ellipse", state="attached")
            page.locator(".plot-column").screenshot(path=str(out / "uncertainty_page.png"))
            _small_png(out / "uncertainty_page.png")

            scene = app.state.scene
            scene.flush(120)
            if scene.timeline.gui_time.max > 1.0:  # the marker and cursor part-way, as when scrubbing
                scene.timeline.gui_time.value = round(0.6 * scene.timeline.gui_time.max, 2)
                scene.timeline.update()
            scene_page = browser.new_page(viewport={"width": 1600, "height": 900})
            scene_page.goto(scene.url)
            scene_page.wait_for_selector("canvas")
            _hide_notifications(scene_page)
            scene_page.wait_for_timeout(SCENE_FADE_MS)
            _hide_notifications(scene_page)
            scene_page.screenshot(path=str(out / "uncertainty_scene.png"))
            _small_png(out / "uncertainty_scene.png")
        finally:
            browser.close()


if __name__ == "__main__":
    main()
