"""Runs that persist, in a real browser (fixtures of ``test_browser``): a run's own address, the
kept list with a compare-all grouped under its upload, the same page and the same downloads after
a restart of the server on the same runs folder, and a run the disk budget removed saying so."""

from __future__ import annotations

from pathlib import Path

from tests.app.test_browser import (  # noqa: F401  (browser and page are fixtures)
    browser,
    open_page_at,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)

OTHER_SHOWN = "resnet-tiny"  # the second fixture model (no display name: its API name)


def kept_names(page) -> list[str]:
    """The kept list's run names, nested ones prefixed with "> " (a compare's runs)."""
    return page.eval_on_selector_all(
        "#kept-list .kept-name",
        "els => els.map(e => (e.closest('.kept-group') ? '> ' : '') + e.textContent)",
    )


def test_a_run_has_its_own_address_and_outlives_a_restart(
    make_settings, server_control, page, sample_csv_path: Path, tmp_path: Path
) -> None:
    settings = make_settings(runs_dir=tmp_path / "runs")
    live = server_control.start(settings)
    try:
        open_page_at(page, live.base_url)
        assert page.url == f"{live.base_url}/"  # the first screen moves nowhere
        run_file(page, str(sample_csv_path))
        wait_for_result(page, "walk.csv")
        page.wait_for_function("() => location.pathname.startsWith('/runs/')")
        run_id = page.url.rsplit("/", 1)[1]
        assert page.evaluate("state.result.run_id") == run_id

        page.click("#compare-button")  # the other model, stored in this run's group
        page.wait_for_function("() => state.compared.length === 1 && !state.comparing", timeout=60_000)
        page.wait_for_function("() => document.querySelectorAll('#kept-list .kept-group li').length === 1")
        names = kept_names(page)
        assert names[:2] == ["walk · FTIN · OxIOD", f"> walk · {OTHER_SHOWN}"], names
        before = page.request.get(f"{live.base_url}/runs/{run_id}/trajectory.csv").body()

        # Another run shown from the list moves the address; Back returns to the upload's.
        page.click("#kept-list > li:not(.kept-compare) .kept-name")
        page.wait_for_function(f"() => location.pathname !== '/runs/{run_id}'")
        page.go_back()
        page.wait_for_function(f"() => state.result && state.result.run_id === '{run_id}'")
        assert page.url.endswith(f"/runs/{run_id}")
    finally:
        server_control.stop(live)

    again = server_control.start(settings)  # a restart: a new server on the same folder
    try:
        page.goto(f"{again.base_url}/runs/{run_id}")  # a bookmark of the run
        wait_for_result(page, "walk")
        assert page.evaluate("state.result.run_id") == run_id
        page.wait_for_function("() => document.querySelectorAll('#kept-list .kept-group li').length === 1")
        assert kept_names(page)[:2] == names[:2]
        assert page.request.get(f"{again.base_url}/runs/{run_id}/trajectory.csv").body() == before
        with page.expect_download() as download:
            page.click("#download-link")
        assert Path(download.value.path()).read_bytes() == before
        screenshot(page, "upload_run_page.png")
    finally:
        server_control.stop(again)

    tight = server_control.start(make_settings(runs_dir=tmp_path / "runs", runs_disk_budget_mb=0.001))
    try:  # a budget below one run: only the newest stays, the upload's address says why
        page.goto(f"{tight.base_url}/runs/{run_id}")
        page.wait_for_selector("#error:not([hidden])", timeout=30_000)
        message = page.inner_text("#error")
        assert "removed" in message and "disk budget" in message and "Predict again" in message
        assert page.is_hidden("#result")
    finally:
        server_control.stop(tight)
