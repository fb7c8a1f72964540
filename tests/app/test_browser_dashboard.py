"""The dashboard in a real browser (fixtures of ``test_browser``): the first screen, every download,
verdicts in words, the plausibility panel and the GPS track, every upload kept and listed in the
scene with menus that show what is on screen."""

from __future__ import annotations

from pathlib import Path

import httpx

from tests.app.test_browser import (  # noqa: F401  (browser and page are fixtures)
    DEFAULT_MODEL,
    DEFAULT_SHOWN,
    browser,
    open_upload_page,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)
from tests.utils.phone_walk import sensorlogger_walk_zip


def test_the_page_opens_on_the_bundled_samples_result(live_server, page) -> None:
    open_upload_page(page, live_server)  # waits for "walk_gt (bundled)" without any click
    assert page.inner_text("#result-caption") == f"walk_gt (bundled) · {DEFAULT_SHOWN}"
    assert page.eval_on_selector_all("#plot polyline.series", "els => els.length") == 2
    assert "standing still" in page.inner_text("#verdict")
    # one banner: the walk's verdict says how it compares with standing still, once on the card
    shown = page.inner_text("#result").split("Compare models on this recording")[0]
    assert page.is_visible("#walk-verdict") and page.is_hidden("#verdict")
    assert shown.count("than standing still") <= 1, shown
    # Models under the names people know, with the API name beside them.
    option = page.inner_text(f"#model-select option[value='{DEFAULT_MODEL}']")
    assert option == f"{DEFAULT_SHOWN} ({DEFAULT_MODEL})"
    assert page.get_attribute("link[rel=icon]", "href") == "/favicon.ico"
    assert page.request.get(f"{live_server.base_url}/favicon.ico").status == 200  # no 404 in the console


def test_the_page_links_all_four_downloads_and_metrics_json_matches_predict(
    live_server, page, sample_csv_path: Path
) -> None:
    open_upload_page(page, live_server)
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")
    result = page.evaluate("state.result")  # what POST /predict answered the page
    run = f"/runs/{result['run_id']}"
    links = {
        "#download-link": f"{run}/trajectory.csv",
        "#download-tum": f"{run}/trajectory.tum",
        "#download-gt": f"{run}/ground_truth.tum",
        "#download-metrics": f"{run}/metrics.json",
    }
    for selector, href in links.items():
        assert page.is_visible(selector) and page.get_attribute(selector, "href") == href
    assert "evo_ape tum ground_truth.tum trajectory.tum" in page.inner_text("#evo-line")
    with page.expect_download() as download:
        page.click("#download-tum")
    assert download.value.suggested_filename == f"walk_{DEFAULT_MODEL}_trajectory.tum"
    saved = httpx.get(f"{live_server.base_url}{run}/metrics.json", timeout=10).json()
    assert saved["metrics"] == result["metrics"] and saved["plausibility"] == result["plausibility"]
    for name in ("predicted_path_m", "true_path_m", "stand_still", "duration_s", "worse_than_standing_still"):
        assert name in saved["metrics"]
    assert "z is constant" in page.inner_text("#result-meta")  # a 2-D model: said on the page too


def test_compare_all_flags_every_model_worse_than_standing_still(live_server, page) -> None:
    open_upload_page(page, live_server)
    page.click("#compare-button")
    page.wait_for_function(
        "() => document.querySelectorAll('#compare-table tbody tr.done').length === 2", timeout=60_000
    )
    page.wait_for_selector("#compare-button:not([disabled])")
    results = page.evaluate("[state.result, ...state.compared]")
    rows = page.eval_on_selector_all(
        "#compare-table tbody tr.done", "rows => rows.map((r) => [r.dataset.model, r.className, r.innerText])"
    )
    for result, (model, classes, text) in zip(results, rows, strict=True):
        assert model == result["model"]
        worse = result["metrics"]["worse_than_standing_still"]
        assert ("worse" in classes.split()) is worse
        assert ("worse than standing still" in text) is worse and (("⚠" in text) if worse else True)
    assert "standing still" in page.inner_text("#compare-table tr.baseline")
    legend = page.inner_text("#compare-legend")
    assert "worse than standing still" in legend and "never moves" in legend  # the ⚠ in words
    worse = sum(r["metrics"]["worse_than_standing_still"] for r in results)
    assert f"{worse} of 2 models are worse than standing still" in page.inner_text("#compare-summary")


def test_a_phone_walk_shows_its_plausibility_and_gps_track(live_server, page, tmp_path: Path) -> None:
    export = tmp_path / "phone_walk.zip"
    export.write_bytes(sensorlogger_walk_zip())
    open_upload_page(page, live_server)
    run_file(page, str(export))
    wait_for_result(page, "phone_walk.zip")
    panel = page.inner_text("#plausibility")
    for figure in ("Path length", "Step count", "Cadence", "Step length", "GPS fixes", "GPS distance rms"):
        assert figure in panel, figure
    assert " steps" in panel and " m" in panel and " steps/min" in panel  # figures with units
    assert page.eval_on_selector_all("#plot g.gps circle.gps-fix", "els => els.length") == 20
    assert "GPS fixes (aligned at the start, median accuracy ±5 m)" in page.inner_text("#plot-legend")
    assert "no ground truth" in page.inner_text("#metrics")
    # The iOS sign is a routine conversion: information, folded away, not a warning.
    assert "iOS" in page.text_content("#notes") and "iOS" not in page.inner_text("#warnings")
    screenshot(page, "upload_phone_walk.png")


def test_three_uploads_are_kept_and_listed_in_the_scene_with_the_right_menus(
    live_server, page, csv_with_gt: bytes, tmp_path: Path
) -> None:
    names = ["hall.csv", "stairs.csv", "garden.csv"]
    open_upload_page(page, live_server)
    page.select_option("#align-select", "se2")
    for name in names:
        path = tmp_path / name
        path.write_bytes(csv_with_gt)
        run_file(page, str(path))
        wait_for_result(page, name)
        # se2 moves the prediction's start off the true start: one green start, the other in its colour.
        assert page.eval_on_selector_all("#plot circle.start", "els => els.length") == 1
    page.wait_for_function(
        "() => document.getElementById('kept-list').innerText.includes('garden ·')", timeout=10_000
    )
    kept = page.inner_text("#kept-list")
    for name in names:  # the page lists each with its downloads
        assert f"{name[:-4]} · {DEFAULT_SHOWN}" in kept
    assert kept.count("metrics JSON") >= 3 and kept.count("ground truth TUM") >= 3
    scene = live_server.scene
    scene.flush()
    page.goto(scene.url)
    page.wait_for_function("() => document.body.innerText.includes('Clear scene')", timeout=30_000)
    values = "() => [...document.querySelectorAll('input')].map((i) => i.value)"
    page.wait_for_function(f"() => ({values})().includes('garden (uploaded)')", timeout=30_000)
    inputs = page.evaluate(values)
    assert "Uploaded recordings" in inputs and "se2" in inputs  # the Dataset and Alignment menus
    assert scene.controls.checked_models() == [DEFAULT_MODEL]
    page.click("input[value='garden (uploaded)']")  # open the Sequence menu: all three are there
    page.wait_for_function("() => document.body.innerText.includes('hall (uploaded)')", timeout=10_000)
    listed = page.inner_text("body")
    assert all(f"{name[:-4]} (uploaded)" in listed for name in names)
