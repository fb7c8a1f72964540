"""In a real browser (as ``test_browser``; skips without chromium or playwright, fails instead with
``FTIN_REQUIRE_BROWSER=1``): the page's *Filter* select sends ``filter=ekf`` only when the EKF is
picked, and the result says that the EKF ran (docs/filter.md, "At every door")."""

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


def test_the_filter_select_runs_the_ekf_and_the_result_says_so(
    live_server,
    page,  # noqa: F811
    sample_csv_path: Path,
) -> None:
    open_upload_page(page, live_server)
    assert page.input_value("#filter-select") == "none"
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")
    assert page.is_hidden("#filter-text")  # no filter asked, none said
    assert page.evaluate("'filter' in state.result") is False  # not sent: the answer as before

    page.select_option("#filter-select", "ekf")
    assert page.is_hidden("#result")  # another estimate: the shown result is stale
    page.click("#run-button")
    page.wait_for_selector(RESULT, timeout=60_000)
    page.wait_for_selector("#filter-text:not([hidden])", timeout=10_000)
    assert "Filter: EKF" in page.inner_text("#filter-text")
    # The answer says which orientation the model read (the filter's, or why not: ftin.filter.levelled).
    assert page.evaluate("state.result.filter") == "ekf"
    assert any("EKF's orientation" in note for note in page.evaluate("state.result.notes"))

    page.select_option("#filter-select", "none")
    page.click("#run-button")
    page.wait_for_selector(RESULT, timeout=60_000)
    assert page.is_hidden("#filter-text")
