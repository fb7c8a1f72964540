"""Compare-all on a phone walk in a real browser (fixtures of ``test_browser``): figures instead of
dashes, sorting by a column header, the table as CSV, every model's TUM in one ZIP, and the map
downloads (GPX / GeoJSON) and the phone's clock for a walk with GPS.

The walk is the shared 20-step Sensor Logger export with GPS fixes written beside it (its own
Location.csv is empty; ``tests.utils.gps``)."""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path

import httpx

from tests.app.test_browser import (  # noqa: F401  (browser is a fixture)
    browser,
    open_upload_page,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.utils.gps import northward_fixes, twenty_steps_export

PHONE_HEADERS = ["Path m", "Steps steps", "Step (path / steps) m", "End-to-start gap m", "GPS distance RMS m"]


def column_values(page, index: int) -> list[str]:
    return page.eval_on_selector_all(
        "#compare-table tbody tr.done", f"rows => rows.map((r) => r.cells[{index}].innerText)"
    )


def shown_ids(page) -> list[str]:
    return page.eval_on_selector_all(
        "#compare-table tbody tr.done", "rows => rows.map((r) => r.dataset.runId)"
    )


def ids_in_run_order(page) -> str:
    return page.evaluate("[state.result, ...state.compared].map((r) => r.run_id).join(',')")


def saved(download) -> bytes:
    return Path(download.path()).read_bytes()


def test_compare_all_on_a_phone_walk(live_server, page, shared_data: Path, tmp_path: Path) -> None:
    export = twenty_steps_export(shared_data)
    walk = tmp_path / "walk.zip"
    walk.write_bytes(sensorlogger_zip(export, northward_fixes(export, seconds=21, speed_m_s=0.6)))
    open_upload_page(page, live_server)
    run_file(page, str(walk))
    wait_for_result(page, "walk.zip")

    # the map downloads of a walk with GPS, and the phone's clock for CSV and TUM
    run_id = page.evaluate("state.result.run_id")
    assert page.get_attribute("#download-gpx", "href") == f"/runs/{run_id}/trajectory.gpx"
    assert page.is_visible("#download-geojson")
    with page.expect_download() as gpx:
        page.click("#download-gpx")
    assert gpx.value.suggested_filename == f"walk_{page.evaluate('state.result.model')}_trajectory.gpx"
    assert b'<gpx version="1.1"' in saved(gpx.value) and b"<trkpt lat=" in saved(gpx.value)
    page.check("#epoch-clock")
    assert page.get_attribute("#download-link", "href") == f"/runs/{run_id}/trajectory.csv?clock=epoch"
    with page.expect_download() as epoch_csv:
        page.click("#download-link")
    assert b"t_unix_s,x_m,y_m,z_m" in saved(epoch_csv.value)
    page.uncheck("#epoch-clock")
    assert page.get_attribute("#download-tum", "href") == f"/runs/{run_id}/trajectory.tum"

    page.click("#compare-button")
    page.wait_for_function(
        "() => document.querySelectorAll('#compare-table tbody tr.done').length === 2", timeout=60_000
    )
    page.wait_for_selector("#compare-downloads:not([hidden])", timeout=30_000)
    headers = page.eval_on_selector_all("#compare-table thead th", "ths => ths.map((th) => th.innerText)")
    assert headers[1 : 1 + len(PHONE_HEADERS)] == PHONE_HEADERS and "ATE m" not in headers
    for index in range(1, 1 + len(PHONE_HEADERS)):  # figures, not dashes
        assert all(v not in ("", "–") for v in column_values(page, index)), headers[index]
    assert "steps in the accelerometer" in page.inner_text("#compare-summary")

    # sorted by a column, one way then the other: the rows follow the table's own values (the page
    # shows them rounded; the tiny test models walk millimetres, in a different order per column)
    table = httpx.get(
        f"{live_server.base_url}/compare", params={"ids": ids_in_run_order(page)}, timeout=10
    ).json()
    values = {
        key: {r["run_id"]: r["values"][key] for r in table["rows"]} for key in ("path_length", "start_to_end")
    }
    assert all(len(set(v.values())) == 2 for v in values.values())  # distinct, so the order means something
    for key, direction in (
        ("path_length", "ascending"),
        ("path_length", "descending"),
        ("start_to_end", "ascending"),
    ):
        if page.get_attribute(f"#compare-table th[data-key='{key}']", "aria-sort") != direction:
            page.click(f"#compare-table thead th[data-key='{key}']")
        assert page.get_attribute(f"#compare-table th[data-key='{key}']", "aria-sort") == direction
        expected = sorted(values[key], key=values[key].get, reverse=direction == "descending")
        assert shown_ids(page) == expected, (key, direction)
    shown = shown_ids(page)

    # the CSV is the table as shown, in the order shown
    with page.expect_download() as table:
        page.click("#compare-csv")
    assert table.value.suggested_filename == "walk_compare.csv"
    rows = list(csv.reader(io.StringIO(saved(table.value).decode())))
    assert rows[0][2 : 2 + len(PHONE_HEADERS)] == [
        "Path (m)",
        "Steps (steps)",
        "Step (path / steps) (m)",
        "End-to-start gap (m)",
        "GPS distance RMS (m)",
    ]
    assert [r[1] for r in rows[1:]] == shown
    with page.expect_download() as bundle:
        page.click("#compare-zip")
    names = zipfile.ZipFile(io.BytesIO(saved(bundle.value))).namelist()
    models = page.evaluate("[state.result, ...state.compared].map((r) => r.model)")
    assert sorted(names) == sorted([*(f"{m}.tum" for m in models), "compare.csv"])
    tum = httpx.get(f"{live_server.base_url}/runs/{shown[0]}/trajectory.tum", timeout=10).text
    model = page.evaluate(f"[state.result, ...state.compared].find((r) => r.run_id === '{shown[0]}').model")
    assert zipfile.ZipFile(io.BytesIO(saved(bundle.value))).read(f"{model}.tum").decode() == tum
    screenshot(page, "compare_phone_walk.png")
