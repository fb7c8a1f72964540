"""End to end in a real browser (Debian's chromium driven by Playwright): upload a CSV on the page,
see the trajectory plot, the metrics and the links; API errors in plain words; the 3D scene renders.

Without chromium or the playwright package these tests skip with the reason, except when
``FTIN_REQUIRE_BROWSER=1`` (CI sets it): then they fail, so a broken CI image cannot pass silently.
Set ``FTIN_SCREENSHOT_DIR`` (e.g. ``docs/screenshots``) to save screenshots of the page and scene.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.utils.recordings import still_phone_csv

CHROMIUM = Path(os.environ.get("FTIN_CHROMIUM", "/usr/bin/chromium"))
REQUIRE_BROWSER_ENV = "FTIN_REQUIRE_BROWSER"


def browser_missing(reason: str) -> None:
    """Skip with ``reason``, or fail when ``FTIN_REQUIRE_BROWSER=1`` says the browser must be there."""
    if os.environ.get(REQUIRE_BROWSER_ENV, "").strip() == "1":
        pytest.fail(f"{reason} ({REQUIRE_BROWSER_ENV}=1: the browser tests must run)", pytrace=False)
    pytest.skip(reason)


def browser_problem(chromium: Path) -> str | None:
    """Why the browser tests cannot run here, or None."""
    if importlib.util.find_spec("playwright") is None:
        return "the playwright package is not installed (pip install playwright)"
    if not chromium.exists():
        return (
            f"no chromium at {chromium}: install Debian's (apt-get install -y chromium) or set FTIN_CHROMIUM"
        )
    return None


DEFAULT_MODEL = "ftin-oxiod"
DEFAULT_SHOWN = "FTIN · OxIOD"  # its display name


def open_upload_page(page, live_server) -> None:
    """Open the upload page and wait for its first screen: the bundled sample's result."""
    open_page_at(page, live_server.base_url)


def open_page_at(page, base_url: str) -> None:
    page.goto(base_url)
    page.wait_for_selector(f"#model-select option[value='{DEFAULT_MODEL}']", state="attached")
    wait_for_result(page, "walk_gt (bundled)")


def wait_for_result(page, caption_start: str) -> None:
    """Wait until the result shown is the one of ``caption_start`` (a file or sample name)."""
    page.wait_for_function(
        "(start) => !document.getElementById('result').hidden && "
        "document.getElementById('result-caption').textContent.startsWith(start)",
        arg=caption_start,
        timeout=60_000,
    )


def run_file(page, path: str) -> None:
    """Pick ``path`` in the file input and press Run."""
    page.set_input_files("#file-input", path)
    page.click("#run-button")


# No sandbox (containers, root), no GPU, and nothing that phones home: the test runs offline.
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--enable-unsafe-swiftshader",  # software WebGL for the 3D scene
]
SCREENSHOT_DIR = os.environ.get("FTIN_SCREENSHOT_DIR")


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    problem = browser_problem(CHROMIUM)
    if problem is not None:
        browser_missing(problem)
    from playwright import sync_api

    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()


@pytest.fixture
def page(browser) -> Iterator[object]:
    context = browser.new_context(viewport={"width": 1360, "height": 860})
    page = context.new_page()
    external: list[str] = []
    page.on(
        "request",
        lambda r: (
            external.append(r.url) if not r.url.startswith(("http://127.0.0.1", "data:", "blob:")) else None
        ),
    )
    try:
        yield page
    finally:
        context.close()
    assert external == [], f"the page fetched from outside: {external}"


def screenshot(page, name: str) -> None:
    if SCREENSHOT_DIR:
        Path(SCREENSHOT_DIR).mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(Path(SCREENSHOT_DIR) / name))


def test_upload_shows_the_trajectory_plot(live_server, page, sample_csv_path: Path) -> None:
    open_upload_page(page, live_server)
    assert page.input_value("#model-select") == ""  # "default: ..." is preselected: the server chooses
    assert page.is_disabled("#run-button")
    page.set_input_files("#file-input", str(sample_csv_path))
    assert "walk.csv" in page.inner_text("#drop-text")
    page.click("#run-button")
    wait_for_result(page, "walk.csv")

    labels = page.eval_on_selector_all("#plot polyline.series", "els => els.map(e => e.dataset.label)")
    assert labels == ["ground truth", DEFAULT_SHOWN]
    points = page.get_attribute("#plot polyline.series >> nth=1", "points")
    assert len(points.split()) == 2000  # every sample of the 20 s walk
    metrics = page.inner_text("#metrics")
    assert "ATE" in metrics and "RTE" in metrics and "PDE" in metrics and " m" in metrics
    assert "ATE evo" in metrics  # both ATE conventions, each labelled (the headline one plain "ATE")
    assert "Path" in metrics and " %" in metrics  # the path ratio beside them; PDE in %
    assert "No alignment" in page.inner_text("#convention")  # the convention is stated
    assert page.inner_text("#result-caption") == f"walk.csv · {DEFAULT_SHOWN}"
    assert page.is_hidden("#error")

    # Information in the quiet list (folded), never among the warnings.
    assert "t detected as" in page.text_content("#notes") and "t detected" not in page.inner_text("#warnings")
    words = page.inner_text("#result-meta") + page.inner_text("#metrics")
    assert "frame:" not in words and "ground_truth" not in words  # in words, not enum values
    run_id = page.get_attribute("#scene-link", "data-run-id")
    assert page.get_attribute("#download-link", "href") == f"/runs/{run_id}/trajectory.csv"
    download = httpx.get(f"{live_server.base_url}/runs/{run_id}/trajectory.csv", timeout=10)
    header = "\nt_s,x_m,y_m,z_m,sigma_x_m,sigma_y_m\n"
    assert download.text.startswith("# z is constant") and header in download.text
    scene_href = page.get_attribute("#scene-link", "href")
    assert scene_href.rstrip("/") == live_server.scene.url
    live_server.scene.flush()
    assert run_id in live_server.scene.shown_run_ids()  # the same run is in the 3D scene
    screenshot(page, "upload_page.png")


def test_dropping_a_file_selects_it(live_server, page, csv_with_gt: bytes) -> None:
    open_upload_page(page, live_server)
    transfer = page.evaluate_handle(
        "(text) => { const dt = new DataTransfer();"
        " dt.items.add(new File([text], 'dropped.csv', {type: 'text/csv'})); return dt; }",
        csv_with_gt.decode(),
    )
    page.dispatch_event("#drop-zone", "drop", {"dataTransfer": transfer})
    assert "dropped.csv" in page.inner_text("#drop-text")
    assert page.is_enabled("#run-button")


def test_api_errors_are_shown_in_plain_words(live_server, page, tmp_path: Path) -> None:
    bad = tmp_path / "notes.csv"
    bad.write_text("time,comment\n0,hello\n")
    open_upload_page(page, live_server)
    run_file(page, str(bad))
    page.wait_for_selector("#error:not([hidden])", timeout=30_000)
    message = page.inner_text("#error")
    assert "notes.csv" in message and "gyro" in message
    assert "{" not in message  # the detail text, not raw JSON
    assert page.is_hidden("#result")


def test_a_file_above_the_upload_limit_is_refused_before_sending(
    make_settings, server_control, page, tmp_path: Path
) -> None:
    big = tmp_path / "big.csv"
    big.write_bytes(b"t,gyro_x\n" + b"0" * (200 * 1024))
    live = server_control.start(make_settings(max_upload_mb=0.1, viser_enabled=False))
    try:
        open_page_at(page, live.base_url)
        page.set_input_files("#file-input", str(big))
        message = page.inner_text("#error")
        assert "big.csv is 0.2 MB" in message and "0.1 MB" in message and "FTIN_MAX_UPLOAD_MB" in message
        assert page.is_disabled("#run-button")
    finally:
        server_control.stop(live)


def test_the_3d_scene_renders_the_run(live_server, page, csv_with_gt: bytes) -> None:
    response = httpx.post(
        f"{live_server.base_url}/predict", files={"file": ("walk.csv", csv_with_gt, "text/csv")}, timeout=60
    )
    run_id = response.json()["run_id"]
    live_server.scene.flush()
    page.goto(live_server.scene.url)
    page.wait_for_selector("canvas", timeout=30_000)
    live_server.scene.timeline.gui_time.value = 12.0  # move the timeline: markers and spectra follow
    live_server.scene.timeline.update()
    page.wait_for_function("() => document.body.innerText.includes('Spectra')", timeout=30_000)
    page.wait_for_function("() => document.body.innerText.includes('ATE [m]')", timeout=30_000)
    body = page.inner_text("body")
    assert "FTIN Studio" in body and "ATE [m]" in body and "PDE [%]" in body and "path" in body
    assert "ATE evo [m]" in body  # the scene's table shows both ATE conventions too
    assert "On walk:" in body and DEFAULT_SHOWN in body
    assert run_id in live_server.scene.shown_run_ids()
    if SCREENSHOT_DIR:
        for close in page.query_selector_all("button.mantine-Notification-closeButton"):
            close.click()  # the "software WebGL" notice
        page.wait_for_timeout(12_000)  # viser fades the scene in; software WebGL is slow
        screenshot(page, "scene_3d.png")


def test_api_docs_render_offline(live_server, page) -> None:
    page.goto(f"{live_server.base_url}/docs")
    page.wait_for_selector(".swagger-ui .opblock", timeout=30_000)
    assert "/predict" in page.inner_text(".swagger-ui")


def test_missing_browser_skips_or_fails_as_the_environment_says(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Runs everywhere (no browser needed): the skip-or-fail rule itself."""
    problem = browser_problem(tmp_path / "no-chromium")
    assert problem is not None
    monkeypatch.delenv(REQUIRE_BROWSER_ENV, raising=False)
    with pytest.raises(pytest.skip.Exception, match="chromium|playwright"):
        browser_missing(problem)
    monkeypatch.setenv(REQUIRE_BROWSER_ENV, "1")
    with pytest.raises(pytest.fail.Exception, match="FTIN_REQUIRE_BROWSER=1"):
        browser_missing(problem)
    monkeypatch.setenv(REQUIRE_BROWSER_ENV, "0")
    with pytest.raises(pytest.skip.Exception):
        browser_missing(problem)


# --- results that tell the truth, in the browser ----------------------------------------------------


def test_item1_a_model_that_barely_moves_is_flagged_on_the_page(
    live_server, page, sample_frame, tmp_path: Path
) -> None:
    still = tmp_path / "still.csv"
    still.write_bytes(still_phone_csv(sample_frame))
    open_upload_page(page, live_server)
    run_file(page, str(still))
    wait_for_result(page, "still.csv")
    flagged = page.eval_on_selector_all("#metrics tr.flagged", "rows => rows.map((r) => r.innerText)")
    path_row = next(row for row in flagged if row.startswith("Path"))
    assert "m of" in path_row
    warnings = page.inner_text("#warnings")
    assert "path" in warnings and "barely moves" in warnings
    assert "No alignment" in page.inner_text("#convention")
    assert "Standing still" in page.inner_text("#metrics")
    screenshot(page, "upload_still_phone.png")


def test_item2_a_failed_second_upload_leaves_no_stale_result(
    live_server, page, sample_csv_path: Path, tmp_path: Path
) -> None:
    open_upload_page(page, live_server)
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")
    assert page.inner_text("#result-caption") == f"walk.csv · {DEFAULT_SHOWN}"
    bad = tmp_path / "notes.csv"
    bad.write_text("time,comment\n0,hello\n")
    run_file(page, str(bad))
    page.wait_for_selector("#error:not([hidden])", timeout=30_000)
    assert page.is_hidden("#result")  # the first file's plot and metrics are gone with the error


def test_item2_and_3_the_scene_shows_one_row_per_model_and_clears_everything(
    live_server, page, csv_with_gt: bytes
) -> None:
    for _ in range(4):  # the same model on the same recording, again and again
        response = httpx.post(
            f"{live_server.base_url}/predict",
            files={"file": ("walk.csv", csv_with_gt, "text/csv")},
            timeout=60,
        )
        assert response.status_code == 200
    live_server.scene.flush()
    assert len(live_server.scene.shown_run_ids()) == 1
    page.goto(live_server.scene.url)
    page.wait_for_function("() => document.body.innerText.includes('Clear scene')", timeout=30_000)
    page.wait_for_function("() => document.body.innerText.includes('On walk:')", timeout=30_000)
    inputs = "() => [...document.querySelectorAll('input')].map((i) => i.value)"
    body = page.inner_text("body")
    assert body.count(f"| {DEFAULT_MODEL} |") == 0  # the table is rendered, not raw markdown
    lines = body.splitlines()
    table_rows = [line for line in lines if line.startswith(DEFAULT_SHOWN) and "\t" in line]
    assert len(table_rows) == 1, table_rows  # one table row for four identical runs
    # The Models checkbox and one legend row (flagged in words when the tiny model barely moves).
    names = [line for line in lines if line == DEFAULT_SHOWN or line.startswith(f"{DEFAULT_SHOWN} ⚠ ")]
    assert len(names) == 2, names
    page.wait_for_function(f"() => ({inputs})().includes('walk (uploaded)')", timeout=10_000)
    page.get_by_text("Clear scene", exact=True).click()
    page.wait_for_function("() => document.body.innerText.includes('Scene cleared')", timeout=30_000)
    assert "Nothing shown yet" in page.inner_text("body")
    page.wait_for_function(f"() => !({inputs})().includes('walk (uploaded)')", timeout=10_000)
    assert live_server.scene.shown_run_ids() == [] and live_server.scene.timeline.gui_time.disabled


def test_item4_an_expired_run_says_so_on_the_page(
    make_settings, server_control, page, sample_csv_path: Path, csv_with_gt: bytes
) -> None:
    # A disk budget below one run: the runs folder keeps only the newest run.
    live = server_control.start(make_settings(max_runs=1, runs_disk_budget_mb=0.001, viser_enabled=True))
    try:
        open_page_at(page, live.base_url)
        page.set_input_files("#file-input", str(sample_csv_path))
        page.click("#run-button")
        wait_for_result(page, "walk.csv")
        httpx.post(  # another prediction pushes the page's run out of the runs folder
            f"{live.base_url}/predict", files={"file": ("w.csv", csv_with_gt, "text/csv")}, timeout=60
        ).raise_for_status()
        page.click("#download-link")
        page.wait_for_selector("#expired:not([hidden])", timeout=10_000)
        message = page.inner_text("#expired")
        assert "expired" in message and "Predict again" in message
        pages_before = len(page.context.pages)
        page.evaluate("document.getElementById('expired').hidden = true")
        page.click("#scene-link")
        page.wait_for_selector("#expired:not([hidden])", timeout=10_000)
        page.wait_for_timeout(300)
        assert len(page.context.pages) == pages_before  # no scene tab opened on another run
        screenshot(page, "upload_expired.png")
    finally:
        server_control.stop(live)


def test_item10_the_scene_opens_on_a_run_of_the_model_trained_for_the_data(
    make_settings, server_control, page
) -> None:
    live = server_control.start(make_settings(viser_enabled=True, scene_first_run=True))
    try:
        scene = live.scene
        suggested = scene.controls.checked_models()
        assert suggested == [scene.services.models.for_kind(scene.controls.selected_entry().kind)]
        page.goto(scene.url)
        page.wait_for_function(
            "() => document.body.innerText.includes('Showing')", timeout=60_000
        )  # nobody pressed Run
        body = page.inner_text("body")
        shown = scene.shown_name(suggested[0])
        assert f"Showing {shown} on walk_gt" in body and "ground truth" in body
    finally:
        server_control.stop(live)
