"""In a real browser (as ``test_browser``; skips without chromium or playwright): the page's
*Orientation* select reaches the API, the page says in words which orientation source ran and why,
which model ran and by which rule, and an orientation the file cannot give is refused in words."""

from __future__ import annotations

from pathlib import Path

from tests.app.test_browser import (  # noqa: F401 (fixtures)
    browser,
    open_upload_page,
    page,
    run_file,
    wait_for_result,
)

RESULT = "#result:not([hidden]) #plot svg polyline.series >> nth=1"


def test_the_orientation_select_and_the_source_shown(live_server, page, sample_csv_path: Path) -> None:  # noqa: F811
    open_upload_page(page, live_server)
    assert page.input_value("#orientation-select") == "auto"
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")  # not the first screen's bundled result
    text = page.inner_text("#choice-text")
    assert "Orientation: the phone's own attitude (chosen automatically: no magnetometer" in text
    assert "Model: ftin-oxiod (" in text  # the page names none: the server says which rule chose

    page.select_option("#orientation-select", "vqf6d")
    assert page.is_hidden("#result")  # another input: the shown result is stale
    page.click("#run-button")
    page.wait_for_selector(RESULT, timeout=60_000)  # hidden when the select changed: this run's
    assert "Orientation: the VQF filter without the magnetometer (6-D) (as asked)." in page.inner_text(
        "#choice-text"
    )

    page.select_option("#orientation-select", "ground_truth")
    page.click("#run-button")
    page.wait_for_selector("#error:not([hidden])", timeout=30_000)
    message = page.inner_text("#error")
    assert "no reference orientation" in message and "choose one of auto, device, vqf, vqf6d" in message


def test_a_listed_recording_says_which_rule_chose_its_model(live_server, page) -> None:  # noqa: F811
    open_upload_page(page, live_server)
    page.wait_for_selector("#samples:not([hidden])", timeout=30_000)
    page.click("#sample-button")
    page.wait_for_selector(RESULT, timeout=60_000)
    text = page.inner_text("#choice-text")
    assert "Orientation: " in text and "Model: " in text and "(as chosen)" not in text
